//! The lights file (`docs/contract.md`; an example with every field:
//! `docs/examples/lights.json`):
//!
//! ```json
//! {"lights":[{"type":"point","position":[x,y,z],"intensity":[r,g,b]},
//!            {"type":"spot","position":[..],"direction":[..],"cone_deg":a,"intensity":[..]},
//!            {"type":"directional","direction":[..],"irradiance":[r,g,b]},
//!            {"type":"sky","radiance":[r,g,b]},
//!            {"type":"environment","path":"sky.hdr","intensity":1.0,"rotation_deg":0}]}
//! ```
//!
//! A sky is uniform radiance (W·sr⁻¹·m⁻²) from every direction; an environment an
//! equirectangular Radiance `.hdr` or OpenEXR image of radiance (`radiosity_core::EnvMap` has
//! its direction convention), its path relative to the lights file, scaled by `intensity` and
//! turned `rotation_deg` about +Y.
//!
//! Every field is required; none has a default. Positions in scene units; intensity in W/sr,
//! irradiance in W/m² on a surface facing the light, all finite and non-negative; directions
//! non-zero, need not be unit length: a spot's is the axis of its cone (from the light
//! outwards), a directional light's the way its light travels. `cone_deg` is the cone's
//! half-angle in degrees, in (0, 180], with a hard edge. Unknown fields are refused (a
//! misspelt `"intensty"` must not silently become a black light).

use glam::Vec3;
use radiosity_core::{EnvMap, Light, Rgb};
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightsFile {
    lights: Vec<LightEntry>,
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum LightEntry {
    Point {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    Spot {
        position: [f32; 3],
        direction: [f32; 3],
        cone_deg: f32,
        intensity: [f32; 3],
    },
    Directional {
        direction: [f32; 3],
        irradiance: [f32; 3],
    },
    Sky {
        radiance: [f32; 3],
    },
    Environment {
        path: String,
        intensity: f32,
        rotation_deg: f32,
    },
}

impl LightEntry {
    /// The light, an environment's image read from its path (relative to `base`).
    fn light(&self, base: &Path) -> crate::Result<Light> {
        let rgb = |c: [f32; 3]| Rgb::new(c[0], c[1], c[2]);
        Ok(match *self {
            LightEntry::Point {
                position,
                intensity,
            } => Light::Point {
                position: Vec3::from(position),
                intensity: rgb(intensity),
            },
            LightEntry::Spot {
                position,
                direction,
                cone_deg,
                intensity,
            } => Light::Spot {
                position: Vec3::from(position),
                direction: Vec3::from(direction),
                cone_deg,
                intensity: rgb(intensity),
            },
            LightEntry::Directional {
                direction,
                irradiance,
            } => Light::Directional {
                direction: Vec3::from(direction),
                irradiance: rgb(irradiance),
            },
            LightEntry::Sky { radiance } => Light::Sky {
                radiance: rgb(radiance),
            },
            LightEntry::Environment {
                ref path,
                intensity,
                rotation_deg,
            } => Light::Environment(Arc::new(environment(
                &base.join(path),
                intensity,
                rotation_deg,
            )?)),
        })
    }
}

/// Reads an equirectangular environment image: Radiance `.hdr` or OpenEXR (linear radiance;
/// an 8-bit PNG or JPEG holds display values, not radiance, and is refused), scaled by
/// `intensity` and turned `rotation_deg` about +Y.
pub fn environment(path: &Path, intensity: f32, rotation_deg: f32) -> crate::Result<EnvMap> {
    let shown = path.display();
    let reader = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| crate::Error::Invalid(format!("cannot read environment {shown}: {e}")))?;
    match reader.format() {
        Some(image::ImageFormat::Hdr | image::ImageFormat::OpenExr) => {}
        other => invalid!(
            "environment {shown} is {}, not a Radiance .hdr or OpenEXR image of radiance",
            other.map_or("not an image format known here".to_owned(), |f| format!(
                "{f:?}"
            ))
        ),
    }
    let img = reader
        .decode()
        .map_err(|e| crate::Error::Invalid(format!("cannot decode environment {shown}: {e}")))?
        .to_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let texels = img
        .pixels()
        .map(|p| Rgb::new(p.0[0], p.0[1], p.0[2]))
        .collect();
    EnvMap::new(w, h, texels, intensity, rotation_deg)
        .map_err(|why| crate::Error::Invalid(format!("environment {shown}: {why}")))
}

/// serde_json's message on one line (it carries the line and column), with the types it
/// expected said as the file's shapes instead of the Rust names.
pub fn json_error(e: &serde_json::Error) -> crate::Error {
    let text = e
        .to_string()
        .replace('\n', " ")
        .replace(
            "expected struct LightsFile",
            r#"expected an object {"lights": [...]} (see docs/examples/lights.json)"#,
        )
        .replace(
            "expected internally tagged enum LightEntry",
            r#"expected a light object {"type": "point", "spot", "directional", "sky" or "environment", ...}"#,
        )
        .replace(
            "expected struct CameraFile",
            r#"expected an object {"position": [x, y, z], "look_at": [x, y, z], ...} (see docs/examples/camera.json)"#,
        );
    crate::Error::Invalid(text)
}

/// Refuses a file that is a bare JSON array where an object is expected (serde would read
/// the array as the object's fields in order and complain about the first one instead).
pub fn refuse_bare_array(text: &str, expected: &str) -> crate::Result<()> {
    if text.trim_start().starts_with('[') {
        invalid!("expected an object {expected} at the top level, not a bare array");
    }
    Ok(())
}

/// Reads, parses and validates a lights file (an environment's path relative to it).
pub fn load(path: &Path) -> crate::Result<Vec<Light>> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        crate::Error::Invalid(format!("cannot read lights file {}: {e}", path.display()))
    })?;
    parse_in(&text, path.parent().unwrap_or(Path::new("")))
}

/// Parses and validates a lights file's text (an environment's path relative to the working
/// directory).
pub fn parse(text: &str) -> crate::Result<Vec<Light>> {
    parse_in(text, Path::new(""))
}

/// Parses and validates a lights file's text, an environment's path relative to `base`.
pub fn parse_in(text: &str, base: &Path) -> crate::Result<Vec<Light>> {
    refuse_bare_array(text, r#"{"lights": [...]} (see docs/examples/lights.json)"#)?;
    // A light given as an array would be read as its fields in order (the first one its
    // type): say what a light is instead.
    if let Ok(serde_json::Value::Object(top)) = serde_json::from_str::<serde_json::Value>(text)
        && let Some(serde_json::Value::Array(lights)) = top.get("lights")
        && let Some(i) = lights.iter().position(|l| !l.is_object())
    {
        invalid!(
            r#"light {i}: expected a light object {{"type": "point", "spot", "directional", "sky" or "environment", ...}}, not {}"#,
            lights[i]
        );
    }
    let file: LightsFile = serde_json::from_str(text).map_err(|e| json_error(&e))?;
    let mut lights = Vec::with_capacity(file.lights.len());
    for (i, e) in file.lights.iter().enumerate() {
        let light = e
            .light(base)
            .map_err(|why| crate::Error::Invalid(format!("light {i}: {why}")))?;
        // f32 fields of huge JSON numbers (1e39) become infinite here; validate catches them.
        if let Err(why) = light.validate() {
            invalid!("light {i}: {why}");
        }
        lights.push(light);
    }
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_kind() {
        let l = parse(
            r#"{"lights":[
                {"type":"point","position":[0,1,2],"intensity":[1,2,3]},
                {"type":"spot","position":[0,1,2],"direction":[0,-1,0],"cone_deg":30,"intensity":[4,4,4]},
                {"type":"directional","direction":[0,-1,0.5],"irradiance":[5,5,5]}]}"#,
        )
        .unwrap();
        assert_eq!(l.len(), 3);
        assert!(matches!(l[1], Light::Spot { cone_deg, .. } if cone_deg == 30.0));
        assert!(
            matches!(l[2], Light::Directional { irradiance, .. } if irradiance == Rgb::splat(5.0))
        );
    }

    #[test]
    fn refuses_bad_files_with_the_reason() {
        for (text, needle) in [
            (
                r#"{"lights":[{"type":"point","position":[0,0,0],"intensity":[-1,0,0]}]}"#,
                "negative",
            ),
            (
                r#"{"lights":[{"type":"spot","position":[0,0,0],"direction":[0,0,0],"cone_deg":10,"intensity":[1,1,1]}]}"#,
                "direction is zero",
            ),
            (
                r#"{"lights":[{"type":"spot","position":[0,0,0],"direction":[0,1,0],"cone_deg":0,"intensity":[1,1,1]}]}"#,
                "cone_deg",
            ),
            (
                r#"{"lights":[{"type":"point","position":[0,0,1e39],"intensity":[1,1,1]}]}"#,
                "infinite",
            ),
            (
                r#"{"lights":[{"type":"point","position":[0,0,0],"intensty":[1,1,1]}]}"#,
                "unknown field",
            ),
            (
                r#"{"lights":[{"type":"area","position":[0,0,0]}]}"#,
                "unknown variant",
            ),
            (
                r#"{"lights":[{"type":"point","position":[0,0],"intensity":[1,1,1]}]}"#,
                "length",
            ),
            (r#"{"lights": NaN}"#, "expected value"),
            (
                r#"[{"type":"point","position":[0,0,0],"intensity":[1,1,1]}]"#,
                r#"expected an object {"lights": [...]}"#,
            ),
            (
                r#"{"lights":[[0,0,0]]}"#,
                r#"expected a light object {"type""#,
            ),
            ("", "EOF"),
        ] {
            let err = format!("{:#}", parse(text).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
            assert!(!err.contains('\n'), "{err}");
        }
    }

    /// Writes a `w × h` Radiance `.hdr` whose texel (x, y) is `f(x, y)` in every channel.
    fn write_hdr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> f32) {
        let img = image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb([f(x, y); 3]));
        img.save(path).unwrap();
    }

    #[test]
    fn parses_a_sky_and_an_environment_relative_to_the_file() {
        let dir = tempfile::tempdir().unwrap();
        // Left half of the image 1, right half 3: u < 0.5 is the −Z..+X..+Z side.
        write_hdr(&dir.path().join("sky.hdr"), 8, 4, |x, _| {
            if x < 4 { 1.0 } else { 3.0 }
        });
        let lights_path = dir.path().join("lights.json");
        std::fs::write(
            &lights_path,
            r#"{"lights":[{"type":"sky","radiance":[0.5,1,2]},
                {"type":"environment","path":"sky.hdr","intensity":2.0,"rotation_deg":0}]}"#,
        )
        .unwrap();
        let l = load(&lights_path).unwrap();
        assert!(matches!(l[0], Light::Sky { radiance } if radiance == Rgb::new(0.5, 1.0, 2.0)));
        let Light::Environment(env) = &l[1] else {
            panic!("an environment light")
        };
        assert_eq!(env.size(), (8, 4));
        // +X is at u = 0.25 (left half), −X at u = 0.75 (right half); intensity 2 scales both.
        assert!((env.radiance(Vec3::X).r - 2.0).abs() < 1e-5);
        assert!((env.radiance(-Vec3::X).r - 6.0).abs() < 1e-5);
    }

    #[test]
    fn refuses_bad_skies_and_environments() {
        let dir = tempfile::tempdir().unwrap();
        image::RgbImage::new(4, 2)
            .save(dir.path().join("sky.png"))
            .unwrap();
        write_hdr(&dir.path().join("neg.hdr"), 4, 2, |_, _| 1.0);
        for (text, needle) in [
            (
                r#"{"lights":[{"type":"sky","radiance":[-1,0,0]}]}"#,
                "negative",
            ),
            (
                r#"{"lights":[{"type":"environment","path":"none.hdr","intensity":1,"rotation_deg":0}]}"#,
                "cannot read environment",
            ),
            (
                r#"{"lights":[{"type":"environment","path":"sky.png","intensity":1,"rotation_deg":0}]}"#,
                "not a Radiance .hdr or OpenEXR",
            ),
            (
                r#"{"lights":[{"type":"environment","path":"neg.hdr","intensity":-1,"rotation_deg":0}]}"#,
                "intensity",
            ),
            (
                r#"{"lights":[{"type":"environment","path":"neg.hdr","intensity":1}]}"#,
                "rotation_deg",
            ),
        ] {
            let err = format!("{:#}", parse_in(text, dir.path()).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
            assert!(!err.contains('\n'), "{err}");
        }
    }
}
