//! The scene's light probes through the C ABI: each frame's probe SH from the patches'
//! irradiance, and the irradiance at any point and normal interpolated from them, with the
//! host's own ray caster saying which probes the point sees.

use crate::error::{Failure, guard, slice, slice_mut, status};
use crate::scene::{RadScene, check_n, read_input, scene_ref};
use crate::{RAD_ERR_LENGTH, RAD_ERR_NO_PROBES, RAD_ERR_VALUE, RadRgb};
use radiosity_core::{Rgb, SH_COEFFICIENTS, sh_irradiance};
use std::ffi::c_void;

/// The host's visibility test for rad_probe_irradiance: whether the segment from `from`
/// to `to` (3 floats each, scene units) is clear of the scene. `user` is the pointer the host
/// passed along. NULL in its place: every probe is in sight.
pub type RadProbeVisible =
    Option<unsafe extern "C" fn(user: *mut c_void, from: *const f32, to: *const f32) -> bool>;

fn probes(scene: &RadScene) -> Result<&radiosity_core::DecodedProbes, Failure> {
    scene.rt.decoded_probes().ok_or_else(|| {
        Failure::new(
            RAD_ERR_NO_PROBES,
            "the scene has no light probes (it was baked with --probes none)",
        )
    })
}

/// `sh_len` must be nine coefficients for each of the scene's `probes`.
fn check_sh_len(sh_len: usize, probes: usize) -> Result<(), Failure> {
    if sh_len == SH_COEFFICIENTS * probes {
        return Ok(());
    }
    Err(Failure::new(
        RAD_ERR_LENGTH,
        format!(
            "sh_len = {sh_len}, the scene's {probes} probes take {}",
            SH_COEFFICIENTS * probes
        ),
    ))
}

/// Light probes in the scene (0 without, or for a NULL scene, which sets the last error).
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_probe_count(scene: *const RadScene) -> usize {
    guard("rad_scene_probe_count", 0, || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        Ok(scene.rt.file.probes.as_ref().map_or(0, |p| p.len()))
    })
}

/// The probes' positions: `3 · rad_scene_probe_count` floats (x, y, z per probe, scene
/// units), owned by the scene; NULL without probes or for a NULL scene.
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_probe_positions(scene: *const RadScene) -> *const f32 {
    guard("rad_scene_probe_positions", std::ptr::null(), || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        Ok(scene
            .rt
            .file
            .probes
            .as_ref()
            .filter(|p| !p.is_empty())
            .map_or(std::ptr::null(), |p| p.positions.as_ptr().cast()))
    })
}

/// The frame's probe SH from the patches' total irradiance `irradiance` (direct plus
/// gathered, W/m², `n` = patch count): `sh` gets nine RGB coefficients a probe of the
/// radiance their reflected light `ρ·H` sends it (`sh_len` = 9 × probe count), in the order
/// Y00, Y1−1, Y10, Y11, Y2−2, Y2−1, Y20, Y21, Y22. RAD_ERR_NO_PROBES without probes,
/// RAD_ERR_VALUE for a non-finite irradiance.
///
/// # Safety
///
/// `scene` is NULL or a live scene; `irradiance` is NULL or `n` readable values; `sh` is NULL
/// or `sh_len` writable values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_probes_frame(
    scene: *const RadScene,
    irradiance: *const RadRgb,
    n: usize,
    sh: *mut RadRgb,
    sh_len: usize,
) -> i32 {
    status("rad_scene_probes_frame", || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        let probes = probes(scene)?;
        check_n(scene, n, "irradiance")?;
        check_sh_len(sh_len, probes.len())?;
        // SAFETY: the caller promises `n` readable values at `irradiance`; an overlap with
        // `sh` is copied away.
        let h = unsafe { read_input(irradiance, n, sh.cast_const(), sh_len, "irradiance") }?;
        if let Some(i) = h.iter().position(|v| !v.is_finite()) {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("irradiance of patch {i} is not finite"),
            ));
        }
        let reflected: Vec<Rgb> = h
            .iter()
            .zip(scene.rt.file.patches.iter())
            .map(|(h, p)| p.reflectance * *h)
            .collect();
        // SAFETY: the caller promises `sh_len` writable values at a non-NULL `sh`; `h` no
        // longer borrows them if they overlapped.
        let out = unsafe { slice_mut(sh, sh_len, "sh") }?;
        let out: &mut [Rgb] = bytemuck::cast_slice_mut(out);
        let modes = probes.modes(&reflected);
        for (p, o) in out.chunks_exact_mut(SH_COEFFICIENTS).enumerate() {
            o.copy_from_slice(&probes.gather_probe_with(p, &reflected, &modes));
        }
        Ok(())
    })
}

/// The reflected irradiance (W/m²) at `point` on a small surface facing unit `normal` (3
/// floats each) from the frame's probe SH `sh` (as rad_scene_probes_frame wrote it, `sh_len`
/// values): the probes of the point's lattice cell that `visible(user, point, probe)` says it
/// sees, trilinear weights times a facing term, a cell twice as wide where none is in sight
/// (`docs/contract.md`, "The points file"). Add the direct light from the emitters and the
/// host's lights at the point for the total. Writes `*out`; RAD_ERR_NO_PROBES without probes
/// or when no probe is in sight, RAD_ERR_VALUE for a non-finite point or a normal not of
/// unit length (within 1e-3).
///
/// # Safety
///
/// `scene` is NULL or a live scene; `sh` is NULL or `sh_len` readable values; `point` and
/// `normal` are NULL or 3 readable floats; `out` is NULL or writable; `visible`, when not NULL,
/// is safe to call with `user` and two 3-float arrays.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_probe_irradiance(
    scene: *const RadScene,
    sh: *const RadRgb,
    sh_len: usize,
    point: *const f32,
    normal: *const f32,
    visible: RadProbeVisible,
    user: *mut c_void,
    out: *mut RadRgb,
) -> i32 {
    status("rad_probe_irradiance", || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        let file_probes = match &scene.rt.file.probes {
            Some(p) => p,
            None => return probes(scene).map(|_| ()),
        };
        check_sh_len(sh_len, file_probes.len())?;
        // SAFETY: the caller promises `sh_len` readable values at `sh`, 3 at `point` and
        // `normal` (each checked for NULL and alignment).
        let (sh, p, n) = unsafe {
            (
                slice(sh, sh_len, "sh")?,
                slice(point, 3, "point")?,
                slice(normal, 3, "normal")?,
            )
        };
        let (p, n) = ([p[0], p[1], p[2]], [n[0], n[1], n[2]]);
        if !p.iter().all(|v| v.is_finite()) {
            return Err(Failure::new(RAD_ERR_VALUE, "point is not finite"));
        }
        let len = n.iter().map(|v| v * v).sum::<f32>().sqrt();
        if !((len - 1.0).abs() <= 1e-3) {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("normal has length {len}, not 1"),
            ));
        }
        let mut weights = Vec::new();
        let sees = |i: usize| match visible {
            // SAFETY: the caller promises `visible` is safe to call with `user` and two
            // 3-float arrays; both live for the call.
            Some(f) => unsafe { f(user, p.as_ptr(), file_probes.positions[i].as_ptr()) },
            None => true,
        };
        if !file_probes.interpolation_weights(p, Some(n), sees, &mut weights) {
            return Err(Failure::new(
                RAD_ERR_NO_PROBES,
                "no probe around the point is in sight (outside the probe grid)",
            ));
        }
        let sh: &[Rgb] = bytemuck::cast_slice(sh);
        let mut e = Rgb::ZERO;
        for (i, w) in weights {
            let c: &[Rgb; SH_COEFFICIENTS] = sh[SH_COEFFICIENTS * i..SH_COEFFICIENTS * (i + 1)]
                .try_into()
                .expect("nine coefficients");
            e += sh_irradiance(c, n) * w;
        }
        // SAFETY: the caller promises `out` is writable (checked for NULL and alignment).
        let out = unsafe { slice_mut(out, 1, "out") }?;
        out[0] = bytemuck::cast(e);
        Ok(())
    })
}
