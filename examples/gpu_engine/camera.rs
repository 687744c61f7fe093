//! The scene's side of a frame on the CPU: `radiosity render`'s camera, the moving light and
//! its direct irradiance per patch.

use super::Result;
use glam::{Mat4, Vec3};
use radiosity_bake::geometry::Occluders;
use radiosity_core::{Light, Mesh, Rgb};
use std::path::Path;

/// `radiosity render`'s pinhole camera, from its camera file.
pub(crate) struct Camera {
    pub(crate) position: Vec3,
    pub(crate) look_at: Vec3,
    pub(crate) up: Vec3,
    pub(crate) fov_deg: f32,
    pub(crate) width: u32,
    pub(crate) height: u32,
}

impl Camera {
    pub(crate) fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read camera file {}: {e}", path.display()))?;
        let v: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| format!("bad camera file {}: {e}", path.display()))?;
        let vec = |k: &str, default: Option<Vec3>| -> Result<Vec3> {
            match v.get(k) {
                None => default.ok_or_else(|| format!("camera file needs {k}").into()),
                Some(a) => {
                    let a: [f32; 3] = serde_json::from_value(a.clone())
                        .map_err(|e| format!("camera {k}: {e}"))?;
                    Ok(Vec3::from(a))
                }
            }
        };
        let num = |k: &str, default: f64| v.get(k).and_then(|x| x.as_f64()).unwrap_or(default);
        let cam = Camera {
            position: vec("position", None)?,
            look_at: vec("look_at", None)?,
            up: vec("up", Some(Vec3::Y))?,
            fov_deg: num("fov_deg", 40.0) as f32,
            width: num("width", 512.0) as u32,
            height: num("height", 512.0) as u32,
        };
        let view = cam.look_at - cam.position;
        let valid = view.length() > 0.0
            && view.normalize().cross(cam.up.normalize()).length() >= 1e-6
            && cam.fov_deg > 0.0
            && cam.fov_deg < 180.0
            && (1..=8192).contains(&cam.width)
            && (1..=8192).contains(&cam.height);
        if !valid {
            return Err(format!("bad camera file {}", path.display()).into());
        }
        Ok(cam)
    }

    /// View-projection with `Camera::ray`'s conventions (vertical field of view, up made
    /// perpendicular to the view, pixel rows from the top) and depth in [0, 1].
    pub(crate) fn view_proj(&self, near: f32, far: f32) -> Mat4 {
        let aspect = self.width as f32 / self.height as f32;
        glam::camera::rh::proj::directx::perspective(self.fov_deg.to_radians(), aspect, near, far)
            * glam::camera::rh::view::look_at_mat4(self.position, self.look_at, self.up)
    }
}

/// The light of frame `f` of `frames`.
pub(crate) fn light_at(lo: Vec3, hi: Vec3, f: u32, frames: u32) -> Light {
    let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let a = std::f32::consts::TAU * f as f32 / frames as f32;
    let position = Vec3::new(
        c.x + h.x / 3.0 * a.cos(),
        c.y + 0.6 * h.y,
        c.z + h.z / 3.0 * a.sin(),
    );
    // About 1 W/m² at the scale of the scene: the exposure is automatic anyway.
    Light::Point {
        position,
        intensity: Rgb::splat(h.length_squared()),
    }
}

/// The per-patch direct irradiance of `light`: the area-weighted mean over each patch's
/// samples, one shadow ray each (`radiosity render`'s runtime, for one light).
pub(crate) fn direct_per_patch(
    mesh: &Mesh<'_>,
    occ: &Occluders,
    light: &Light,
    n: usize,
) -> Vec<Rgb> {
    (0..n)
        .map(|p| {
            let (mut acc, mut area) = (Rgb::ZERO, 0.0f32);
            for s in mesh.samples_of(p) {
                let (pos, nrm) = (Vec3::from(s.position), Vec3::from(s.normal));
                if let Some((e, ray)) = light.irradiance_at(pos, nrm) {
                    let a = pos.as_dvec3();
                    let b = a + ray.direction.as_dvec3() * f64::from(ray.distance);
                    if occ.segment_visible(a, b) {
                        acc += e * s.area;
                    }
                }
                area += s.area;
            }
            if area > 0.0 { acc * (1.0 / area) } else { acc }
        })
        .collect()
}
