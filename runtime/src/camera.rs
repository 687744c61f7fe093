//! The pinhole camera of `render` (and of the reference path tracer's images).
//!
//! Camera file (JSON; an example with every field: `docs/examples/camera.json`), every field
//! but `position` and `look_at` optional:
//!
//! ```json
//! {"position":[x,y,z], "look_at":[x,y,z], "up":[0,1,0], "fov_deg":40, "width":512, "height":512}
//! ```
//!
//! Positions in scene units; `up` need only not be along the view (the image's up is made
//! perpendicular to it); `fov_deg` is the full vertical field of view in degrees, in (0, 180);
//! `width` and `height` the image size in pixels, 1 to [`MAX_SIDE`]. Without a file,
//! [`Camera::frame`] chooses one from the geometry.

use glam::DVec3;
use radiosity_geometry::Occluders;
use serde::Deserialize;

/// Largest image side accepted (a typo of 51200 should not allocate gigabytes).
pub const MAX_SIDE: u32 = 8192;

/// A pinhole camera with its image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Where the pinhole is.
    pub position: DVec3,
    /// The point it looks at.
    pub look_at: DVec3,
    /// The up direction (need not be unit or orthogonal to the view).
    pub up: DVec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub fov_deg: f64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraFile {
    position: [f64; 3],
    look_at: [f64; 3],
    #[serde(default = "default_up")]
    up: [f64; 3],
    #[serde(default = "default_fov")]
    fov_deg: f64,
    #[serde(default = "default_side")]
    width: u32,
    #[serde(default = "default_side")]
    height: u32,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_side() -> u32 {
    512
}

/// Which optional fields a (valid) camera file leaves out, and the defaults they take:
/// `"no up, fov_deg given: up [0, 1, 0], fov_deg 40 used"`. `None` when it gives them all.
fn defaulted(text: &str) -> Option<String> {
    let v: serde_json::Value = serde_json::from_str(text).ok()?;
    let given = v.as_object()?;
    let defaults = [
        ("up", "[0, 1, 0]".to_owned()),
        ("fov_deg", format!("{}", default_fov())),
        ("width", format!("{}", default_side())),
        ("height", format!("{}", default_side())),
    ];
    let missing: Vec<&(&str, String)> = defaults
        .iter()
        .filter(|(k, _)| !given.contains_key(*k))
        .collect();
    if missing.is_empty() {
        return None;
    }
    let names: Vec<&str> = missing.iter().map(|(k, _)| *k).collect();
    let values: Vec<String> = missing.iter().map(|(k, d)| format!("{k} {d}")).collect();
    Some(format!(
        "no {} given: {} used",
        names.join(", "),
        values.join(", ")
    ))
}

/// A camera's orthonormal frame: right, up, and forward (the viewing direction).
#[derive(Clone, Copy, Debug)]
pub struct Basis {
    right: DVec3,
    up: DVec3,
    forward: DVec3,
    /// tan(fov/2): half the image height at unit distance.
    half_h: f64,
}

impl Camera {
    /// Parses and validates a camera file's text.
    pub fn parse(text: &str) -> crate::Result<Self> {
        crate::lights::refuse_bare_array(
            text,
            r#"{"position": [x, y, z], "look_at": [x, y, z], ...} (see docs/examples/camera.json)"#,
        )?;
        let f: CameraFile =
            serde_json::from_str(text).map_err(|e| crate::lights::json_error(&e))?;
        let cam = Camera {
            position: DVec3::from(f.position),
            look_at: DVec3::from(f.look_at),
            up: DVec3::from(f.up),
            fov_deg: f.fov_deg,
            width: f.width,
            height: f.height,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// The note a caller prints for a camera file's text that leaves fields out: which, and
    /// the defaults they took (`"no up given: up [0, 1, 0] used"`); `None` when it gives them
    /// all.
    pub fn defaults_note(text: &str) -> Option<String> {
        defaulted(text)
    }

    /// Checks the values: finite, a viewing direction, an up vector not along it, a field of
    /// view in (0, 180) degrees and an image of 1 to [`MAX_SIDE`] pixels a side.
    pub fn validate(&self) -> crate::Result<()> {
        if ![self.position, self.look_at, self.up]
            .iter()
            .all(|v| v.is_finite())
            || !self.fov_deg.is_finite()
        {
            invalid!("camera has a NaN or infinite value");
        }
        let view = self.look_at - self.position;
        if !(view.length() > 0.0) {
            invalid!("camera look_at equals its position");
        }
        if !(self.up.length() > 0.0) || view.normalize().cross(self.up.normalize()).length() < 1e-6
        {
            invalid!("camera up is zero or along the viewing direction");
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            invalid!("camera fov_deg must be in (0, 180), got {}", self.fov_deg);
        }
        for (name, side) in [("width", self.width), ("height", self.height)] {
            if side == 0 || side > MAX_SIDE {
                invalid!("camera {name} must be 1 to {MAX_SIDE} pixels, got {side}");
            }
        }
        Ok(())
    }

    /// The camera's frame. Call on a validated camera.
    pub fn basis(&self) -> Basis {
        let forward = (self.look_at - self.position).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        Basis {
            right,
            up,
            forward,
            half_h: (self.fov_deg.to_radians() * 0.5).tan(),
        }
    }

    /// The unit direction through image point `(x, y)` in pixels from the top-left corner
    /// (pixel `(i, j)` spans `[i, i+1) × [j, j+1)`; its centre is `(i + 0.5, j + 0.5)`).
    pub fn ray(&self, b: &Basis, x: f64, y: f64) -> DVec3 {
        let aspect = f64::from(self.width) / f64::from(self.height);
        let sx = (2.0 * x / f64::from(self.width) - 1.0) * b.half_h * aspect;
        let sy = (1.0 - 2.0 * y / f64::from(self.height)) * b.half_h;
        (b.forward + b.right * sx + b.up * sy).normalize()
    }

    /// Frames a scene automatically, y up: looks horizontally along the axis (±x or ±z) whose
    /// view meets the most front-facing area, from far enough out that the scene's bounds fill
    /// the image. A closed room would show only the backs of its walls from outside, so when
    /// the first thing the camera sees is a back face, the camera moves inside, near the wall,
    /// with a wider lens.
    pub fn frame(triangles: &[[DVec3; 3]], occ: &Occluders, width: u32, height: u32) -> Self {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in triangles {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        if triangles.is_empty() || !lo.is_finite() || !hi.is_finite() {
            (lo, hi) = (DVec3::splat(-1.0), DVec3::splat(1.0));
        }
        let centre = (lo + hi) * 0.5;
        let half = ((hi - lo) * 0.5).max(DVec3::splat(1e-9 * (hi - lo).length().max(1e-30)));
        let fov_deg: f64 = 40.0;
        let aspect = f64::from(width) / f64::from(height);
        let tan_v = (fov_deg.to_radians() * 0.5).tan();
        // The camera sits at +d outside the bounds and looks along -d.
        let outside = |d: DVec3| -> Camera {
            // Half-extents across the view: vertical is y, horizontal the other axis.
            let (across_h, depth) = if d.z != 0.0 {
                (half.x, half.z)
            } else {
                (half.z, half.x)
            };
            let dist = (half.y / tan_v).max(across_h / (tan_v * aspect)) * 1.05 + depth;
            Camera {
                position: centre + d * dist,
                look_at: centre,
                up: DVec3::Y,
                fov_deg,
                width,
                height,
            }
        };
        // How much of the view from side d shows the fronts of surfaces: 9×9 rays, +1 for a
        // front face, -1 for a back face (a wall seen from outside), 0 for a miss.
        let score = |d: DVec3| -> i32 {
            let cam = outside(d);
            let b = cam.basis();
            let mut s = 0;
            for i in 0..9 {
                for j in 0..9 {
                    let x = (f64::from(i) + 0.5) / 9.0 * f64::from(width);
                    let y = (f64::from(j) + 0.5) / 9.0 * f64::from(height);
                    let dir = cam.ray(&b, x, y);
                    if let Some((_, front)) =
                        occ.first_surface(cam.position, dir, 0.0, f64::INFINITY)
                    {
                        s += if front { 1 } else { -1 };
                    }
                }
            }
            s
        };
        let sides = [DVec3::Z, DVec3::NEG_Z, DVec3::X, DVec3::NEG_X];
        let (best, best_score) = sides
            .into_iter()
            .map(|d| (d, score(d)))
            .fold((DVec3::Z, i32::MIN), |a, b| if b.1 > a.1 { b } else { a });
        if best_score > 0 {
            return outside(best);
        }
        // A closed room shows only the backs of its walls from outside: stand inside, near
        // the wall on the +z side, with a wider lens.
        Camera {
            position: centre + DVec3::Z * half.z * 0.9,
            look_at: centre,
            up: DVec3::Y,
            fov_deg: 70.0,
            width,
            height,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    #[test]
    fn centre_ray_looks_at_the_target_and_corners_span_the_fov() {
        let c = Camera::parse(
            r#"{"position":[0,0,5],"look_at":[0,0,0],"fov_deg":90,"width":200,"height":100}"#,
        )
        .unwrap();
        let b = c.basis();
        assert!((c.ray(&b, 100.0, 50.0) - dvec3(0.0, 0.0, -1.0)).length() < 1e-12);
        // Top edge centre: 45° up for a 90° vertical field of view.
        let top = c.ray(&b, 100.0, 0.0);
        assert!(
            (top.y - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12,
            "{top}"
        );
        // Right edge centre: tan = aspect · tan(45°) = 2.
        let right = c.ray(&b, 200.0, 50.0);
        assert!((right.x / -right.z - 2.0).abs() < 1e-12, "{right}");
    }

    #[test]
    fn bad_cameras_are_refused() {
        for (text, needle) in [
            (
                r#"{"position":[0,0,0],"look_at":[0,0,0]}"#,
                "equals its position",
            ),
            (
                r#"{"position":[0,0,1],"look_at":[0,0,0],"up":[0,0,1]}"#,
                "along the viewing",
            ),
            (
                r#"{"position":[0,0,1],"look_at":[0,0,0],"fov_deg":180}"#,
                "fov_deg",
            ),
            (
                r#"{"position":[0,0,1],"look_at":[0,0,0],"width":0}"#,
                "width",
            ),
            (
                r#"{"position":[0,0,1],"look_at":[0,0,0],"height":100000}"#,
                "height",
            ),
            (
                r#"{"position":[0,0,1e400],"look_at":[0,0,0]}"#,
                "number out of range",
            ),
            (r#"{"position":[0,0,1]}"#, "look_at"),
            (
                r#"{"position":[0,0,1],"look_at":[0,0,0],"zoom":2}"#,
                "unknown field",
            ),
        ] {
            let err = format!("{:#}", Camera::parse(text).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
        }
    }

    #[test]
    fn left_out_fields_are_named_with_their_defaults() {
        let d = defaulted(r#"{"position":[0,0,1],"look_at":[0,0,0],"width":64}"#).unwrap();
        assert_eq!(
            d,
            "no up, fov_deg, height given: up [0, 1, 0], fov_deg 40, height 512 used"
        );
        let all = r#"{"position":[0,0,1],"look_at":[0,0,0],"up":[0,1,0],"fov_deg":30,"width":8,"height":8}"#;
        assert_eq!(defaulted(all), None);
        let err = format!("{:#}", Camera::parse("[1, 2]").unwrap_err());
        assert!(err.contains(r#"expected an object {"position""#), "{err}");
    }

    #[test]
    fn framing_an_open_box_looks_in_through_the_open_side() {
        // Floor (y=0, up) and back wall (z=0, facing +z) of a unit box open at +z.
        let tris = vec![
            [dvec3(0., 0., 0.), dvec3(0., 0., 1.), dvec3(1., 0., 1.)],
            [dvec3(0., 0., 0.), dvec3(1., 0., 1.), dvec3(1., 0., 0.)],
            [dvec3(0., 0., 0.), dvec3(1., 0., 0.), dvec3(1., 1., 0.)],
            [dvec3(0., 0., 0.), dvec3(1., 1., 0.), dvec3(0., 1., 0.)],
        ];
        let occ = Occluders::from_triangles(&tris);
        let c = Camera::frame(&tris, &occ, 64, 64);
        c.validate().unwrap();
        assert!(c.position.z > 1.0, "{c:?}");
        assert!((c.look_at - dvec3(0.5, 0.5, 0.5)).length() < 1e-12);
    }
}
