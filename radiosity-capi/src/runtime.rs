//! The runtime through C: analytic lights ([`RadLight`]), per-patch direct light with shadow
//! rays against the file's mesh ([`rad_scene_direct`]) and the total irradiance at points
//! ([`rad_scene_point_irradiance`]), both `radiosity_runtime`'s, as `radiosity solve` runs
//! them.

use crate::error::{Failure, slice, slice_mut, status as run_status};
use crate::scene::scene_ref;
use crate::{RAD_ERR_LENGTH, RAD_ERR_NO_MESH, RAD_ERR_VALUE, RadRgb, RadScene};
use glam::{DVec3, Vec3};
use radiosity_core::{Light, Rgb};
use radiosity_runtime::points::{Answer, Point};

/// A point light: `position`, `value` = intensity in W/sr.
pub const RAD_LIGHT_POINT: u32 = 0;
/// A spot light: `position`, `direction` (the cone's axis), `cone_deg` (the cone's
/// half-angle in degrees, in (0, 180]), `value` = intensity in W/sr.
pub const RAD_LIGHT_SPOT: u32 = 1;
/// A directional light (a sun): `direction` (the way the light travels), `value` =
/// irradiance in W/m^2 on a surface facing it.
pub const RAD_LIGHT_DIRECTIONAL: u32 = 2;
/// A uniform sky: `value` = radiance in W/(m^2 sr), the same from every direction of the
/// sphere; it reaches each patch and point through the file's sky visibility (a file baked
/// with `--sky off` refuses it with RAD_ERR_VALUE). Position, direction and cone unused.
pub const RAD_LIGHT_SKY: u32 = 3;

/// Point status of rad_scene_point_irradiance: the point is answered.
pub const RAD_POINT_OK: i32 = 0;
/// Point status of rad_scene_point_irradiance: the point lies inside an object (most of its
/// rays meet the backs of faces); its irradiance is zero.
pub const RAD_POINT_INSIDE: i32 = 1;
/// Point status of rad_scene_point_irradiance: the point lies outside the scene; its
/// irradiance is zero.
pub const RAD_POINT_OUTSIDE: i32 = 2;

/// An analytic light, as the lights file of the command line gives one.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RadLight {
    /// RAD_LIGHT_POINT, RAD_LIGHT_SPOT, RAD_LIGHT_DIRECTIONAL or RAD_LIGHT_SKY.
    pub kind: u32,
    /// Point, spot: where the light is, in scene units.
    pub position: [f32; 3],
    /// Spot: the cone's axis; directional: the direction the light travels. Need not be unit
    /// length; not zero.
    pub direction: [f32; 3],
    /// Spot: the cone's half-angle in degrees, in (0, 180].
    pub cone_deg: f32,
    /// Point, spot: intensity in W/sr; directional: irradiance in W/m^2; sky: radiance in
    /// W/(m^2 sr). Finite, not negative.
    pub value: RadRgb,
}

/// The core's light for `l`, the `i`th of the host's, checked (RAD_ERR_VALUE: an unknown kind,
/// a negative, NaN or infinite value, a zero direction, a cone outside (0, 180]).
fn light(i: usize, l: &RadLight) -> Result<Light, Failure> {
    let value = Rgb::new(l.value.r, l.value.g, l.value.b);
    let light = match l.kind {
        RAD_LIGHT_POINT => Light::Point {
            position: Vec3::from(l.position),
            intensity: value,
        },
        RAD_LIGHT_SPOT => Light::Spot {
            position: Vec3::from(l.position),
            direction: Vec3::from(l.direction),
            cone_deg: l.cone_deg,
            intensity: value,
        },
        RAD_LIGHT_DIRECTIONAL => Light::Directional {
            direction: Vec3::from(l.direction),
            irradiance: value,
        },
        RAD_LIGHT_SKY => Light::Sky { radiance: value },
        k => {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!(
                    "light {i}: unknown kind {k} (RAD_LIGHT_POINT 0, RAD_LIGHT_SPOT 1, RAD_LIGHT_DIRECTIONAL 2, RAD_LIGHT_SKY 3)"
                ),
            ));
        }
    };
    light
        .validate()
        .map_err(|why| Failure::new(RAD_ERR_VALUE, format!("light {i}: {why}")))?;
    Ok(light)
}

/// The host's `count` lights at `lights` (NULL allowed for none), checked.
///
/// # Safety
///
/// A non-NULL `lights` points to `count` readable lights.
unsafe fn lights_in(lights: *const RadLight, count: usize) -> Result<Vec<Light>, Failure> {
    if count == 0 {
        return Ok(Vec::new());
    }
    // SAFETY: the caller promises `count` readable lights at a non-NULL `lights`.
    let given = unsafe { slice(lights, count, "lights") }?;
    given.iter().enumerate().map(|(i, l)| light(i, l)).collect()
}

/// Refuses `n` unless it is the scene's patch count.
fn check_n(scene: &RadScene, n: usize, what: &str) -> Result<(), Failure> {
    let patches = scene.rt.file.n();
    if n != patches {
        return Err(Failure::new(
            RAD_ERR_LENGTH,
            format!("{what}: n = {n}, the scene has {patches} patches"),
        ));
    }
    Ok(())
}

/// The runtime's error as a C status.
fn runtime_failure(e: radiosity_runtime::Error) -> Failure {
    let code = match e {
        radiosity_runtime::Error::NoMesh(_) => RAD_ERR_NO_MESH,
        radiosity_runtime::Error::Gather(_) => crate::RAD_ERR_GATHER,
        _ => RAD_ERR_VALUE,
    };
    Failure::new(code, e.to_string())
}

/// Per-patch direct irradiance from `lights`, with shadow rays against the file's full-detail
/// mesh at its direct-light points (each patch the area-weighted mean over its points): what
/// `radiosity solve --lights` feeds its gather, less the correction of each patch's first
/// bounce for where its rays land on its senders (the file's BOUNCE rows), which can make an
/// exitance negative and so is not in the C frame. `n` = the patch count; `lights` may be NULL
/// when `light_count` is 0 (all zeros). Feed the result to rad_first_exitance.
/// RAD_ERR_VALUE for a bad light (nothing written), RAD_ERR_NO_MESH for a file without a mesh
/// when lights are given.
///
/// # Safety
///
/// `scene` is NULL or a live scene; `lights` is NULL or `light_count` readable lights;
/// `direct` is NULL or `n` writable values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_direct(
    scene: *const RadScene,
    lights: *const RadLight,
    light_count: usize,
    direct: *mut RadRgb,
    n: usize,
) -> i32 {
    run_status("rad_scene_direct", || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        check_n(scene, n, "direct")?;
        // SAFETY: the caller promises `light_count` readable lights at `lights`.
        let lights = unsafe { lights_in(lights, light_count) }?;
        // The direct light alone: the C frame sends each patch's mean (its exitance is never
        // negative), without the first bounce's correction (`BakedScene::direct`).
        let h = scene
            .rt
            .direct_with_samples(&lights)
            .map_err(runtime_failure)?
            .0;
        // SAFETY: the caller promises `n` writable values at a non-NULL `direct`.
        let out = unsafe { slice_mut(direct, n, "direct") }?;
        out.copy_from_slice(bytemuck::cast_slice(&h));
        Ok(())
    })
}

/// Total irradiance at `count` points, as `radiosity solve --points` answers them: `y` is this
/// frame's gather result (`n` entries, rad_gather_run's output) for the same `lights`;
/// `points` and `normals` are 3 floats each per point (normals need not be unit length, not
/// zero). `out[i]` receives the irradiance in W/m^2 and `status[i]` RAD_POINT_OK,
/// RAD_POINT_INSIDE or RAD_POINT_OUTSIDE (`out[i]` is then zero). RAD_ERR_VALUE for a bad
/// light, a non-finite or negative `y`, a non-finite point or a zero normal (nothing
/// written); RAD_ERR_NO_MESH for a file without a mesh.
///
/// # Safety
///
/// `scene` is NULL or a live scene; `lights` is NULL or `light_count` readable lights; `y` is
/// NULL or `n` readable values; `points` and `normals` are NULL or `3 * count` readable floats;
/// `out` is NULL or `count` writable values; `status` is NULL or `count` writable values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_point_irradiance(
    scene: *const RadScene,
    lights: *const RadLight,
    light_count: usize,
    y: *const RadRgb,
    n: usize,
    points: *const f32,
    normals: *const f32,
    count: usize,
    out: *mut RadRgb,
    status: *mut i32,
) -> i32 {
    run_status("rad_scene_point_irradiance", || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        check_n(scene, n, "y")?;
        // SAFETY: the caller promises `light_count` readable lights at `lights`.
        let lights = unsafe { lights_in(lights, light_count) }?;
        // SAFETY: the caller promises `n` readable values at `y`.
        let y: Vec<Rgb> = bytemuck::cast_slice(unsafe { slice(y, n, "y") }?).to_vec();
        if let Some(i) = y
            .iter()
            .position(|v| !(v.is_finite() && v.to_array().iter().all(|c| *c >= 0.0)))
        {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("y of patch {i} is negative or not finite"),
            ));
        }
        let three = count
            .checked_mul(3)
            .ok_or_else(|| Failure::new(RAD_ERR_LENGTH, format!("count {count} is too large")))?;
        // SAFETY: the caller promises `3 * count` readable floats at each.
        let (p, nrm) = unsafe {
            (
                slice(points, three, "points")?,
                slice(normals, three, "normals")?,
            )
        };
        let mut queries = Vec::with_capacity(count);
        for i in 0..count {
            let at =
                |v: &[f32]| DVec3::new(v[3 * i].into(), v[3 * i + 1].into(), v[3 * i + 2].into());
            let (position, normal) = (at(p), at(nrm));
            if !position.is_finite() || !normal.is_finite() {
                return Err(Failure::new(
                    RAD_ERR_VALUE,
                    format!("point {i}: position and normal must be finite"),
                ));
            }
            let len = normal.length();
            if !(len > 1e-12) {
                return Err(Failure::new(
                    RAD_ERR_VALUE,
                    format!("point {i}: normal has zero length"),
                ));
            }
            queries.push(Point {
                position,
                normal: normal / len,
                given_normal: normal,
            });
        }
        // The frame's totals H = H_d + y, as the C frame has them (rad_scene_direct's H_d).
        let direct = scene
            .rt
            .direct_with_samples(&lights)
            .map_err(runtime_failure)?
            .0;
        let h: Vec<Rgb> = direct.iter().zip(&y).map(|(d, y)| *d + *y).collect();
        let answers = radiosity_runtime::points::answer(&scene.rt, &y, &h, &lights, &queries)
            .map_err(runtime_failure)?;
        // SAFETY: the caller promises `count` writable values at each, non-NULL (checked).
        let (out, st) = unsafe {
            (
                slice_mut(out, count, "out")?,
                slice_mut(status, count, "status")?,
            )
        };
        for ((o, s), a) in out.iter_mut().zip(st.iter_mut()).zip(answers) {
            (*o, *s) = match a {
                Answer::Irradiance { total, .. } => (bytemuck::cast(total), RAD_POINT_OK),
                Answer::Inside => (RadRgb::default(), RAD_POINT_INSIDE),
                Answer::Outside => (RadRgb::default(), RAD_POINT_OUTSIDE),
            };
        }
        Ok(())
    })
}
