//! The materials file (`solve --materials`, `docs/contract.md`): reflectance edits of named
//! objects at run time, without a re-bake.
//!
//! ```json
//! {"materials":[{"object":"leftWall","reflectance":[r,g,b]}]}
//! ```
//!
//! Every field is required; unknown fields are refused; each reflectance channel finite and in
//! [0, 1); an object named twice or not in the `.rad` is an error. The edit replaces the
//! object's diffuse reflectance everywhere on it (textures included) with the one value.
//!
//! Each matrix patch takes the new reflectance of its object. A patch shared by several
//! objects' parts (the bake report's `shared_patches`) keeps its area-weighted mean: the edited
//! object's share of the patch moves from that object's old mean reflectance (over its
//! full-detail triangles, or its patches without a mesh) to the new one.

use crate::ObjectShares;
use radiosity_core::{RadFile, Rgb};
use serde::Deserialize;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialsFile {
    materials: Vec<Entry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    object: String,
    reflectance: [f32; 3],
}

/// One object's new reflectance.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialEdit {
    /// The object's name in the file.
    pub object: String,
    /// Its new diffuse reflectance, each channel in [0, 1).
    pub reflectance: Rgb,
}

/// Parses a materials file's text (names are checked against a scene by [`patch_edits`]).
pub fn parse(text: &str) -> crate::Result<Vec<MaterialEdit>> {
    let file: MaterialsFile = serde_json::from_str(text)
        .map_err(|e| crate::Error::Invalid(format!("not a materials file: {e}")))?;
    let mut seen = std::collections::HashSet::new();
    file.materials
        .iter()
        .enumerate()
        .map(|(i, e)| {
            if !seen.insert(e.object.as_str()) {
                invalid!("material {i}: object `{}` is edited twice", e.object);
            }
            let [r, g, b] = e.reflectance;
            if !e.reflectance.iter().all(|v| v.is_finite() && (0.0..1.0).contains(v)) {
                invalid!(
                    "material {i} (object `{}`): reflectance [{r}, {g}, {b}] must be finite and in [0, 1)",
                    e.object
                );
            }
            Ok(MaterialEdit {
                object: e.object.clone(),
                reflectance: Rgb::new(r, g, b),
            })
        })
        .collect()
}

/// An edit resolved against a file: new reflectance per matrix patch and per object (by
/// index into the file's objects).
pub struct Resolved {
    /// `(matrix patch, new reflectance)`.
    pub patches: Vec<(u32, Rgb)>,
    /// `(object index, new reflectance)`.
    pub objects: Vec<(u32, Rgb)>,
}

/// The patch edits (matrix patch, new reflectance) of `edits` on `file`, with the object
/// indices edited. An object the file does not name is an error listing a few it does.
pub fn patch_edits(
    file: &RadFile<'_>,
    shares: &ObjectShares<'_>,
    edits: &[MaterialEdit],
) -> crate::Result<Resolved> {
    let mut objects = Vec::with_capacity(edits.len());
    for e in edits {
        let Some(o) = file.objects.iter().position(|n| n.as_ref() == e.object) else {
            let some: Vec<&str> = file.objects.iter().take(8).map(|n| n.as_ref()).collect();
            invalid!(
                "materials: object `{}` is not in the scene (its {} objects include {})",
                e.object,
                file.objects.len(),
                some.join(", ")
            );
        };
        objects.push((o as u32, e.reflectance));
    }
    let old = old_means(file, shares);
    let mut out = Vec::new();
    for (i, p) in file.patches.iter().enumerate() {
        let parts: Vec<(u32, f64)> = shares.of(i).collect();
        let total: f64 = parts.iter().map(|s| s.1).sum();
        let mut rho = [0f64; 3];
        let mut touched = false;
        for k in 0..3 {
            rho[k] = f64::from(p.reflectance.channel(k));
        }
        for &(o, new) in &objects {
            let Some(&(_, w)) = parts.iter().find(|s| s.0 == o) else {
                continue;
            };
            touched = true;
            if parts.len() == 1 {
                rho = [0, 1, 2].map(|k| f64::from(new.channel(k)));
            } else {
                let share = if total > 0.0 { w / total } else { 0.0 };
                for k in 0..3 {
                    rho[k] += share * (f64::from(new.channel(k)) - old[o as usize][k]);
                }
            }
        }
        if touched {
            // A mean of values in [0, 1) stays there, up to rounding.
            let c = |v: f64| (v.clamp(0.0, 1.0 - 1e-6)) as f32;
            out.push((i as u32, Rgb::new(c(rho[0]), c(rho[1]), c(rho[2]))));
        }
    }
    Ok(Resolved {
        patches: out,
        objects,
    })
}

/// Each object's mean reflectance before the edit: over its full-detail triangles by area, or
/// over its patches' shares without a mesh.
fn old_means(file: &RadFile<'_>, shares: &ObjectShares<'_>) -> Vec<[f64; 3]> {
    let mut acc = vec![(0f64, [0f64; 3]); file.objects.len()];
    let mut add = |o: usize, a: f64, rho: Rgb| {
        acc[o].0 += a;
        for k in 0..3 {
            acc[o].1[k] += a * f64::from(rho.channel(k));
        }
    };
    match &file.mesh {
        Some(m) => {
            for (t, tri) in m.triangles.iter().enumerate() {
                let [a, b, c] = m.corners(t).map(glam::Vec3::from);
                let area = 0.5 * f64::from((b - a).cross(c - a).length());
                add(tri.object as usize, area, tri.reflectance);
            }
        }
        None => {
            for (i, p) in file.patches.iter().enumerate() {
                for (o, w) in shares.of(i) {
                    add(o as usize, w, p.reflectance);
                }
            }
        }
    }
    acc.into_iter()
        .map(|(a, s)| if a > 0.0 { s.map(|v| v / a) } else { [0.0; 3] })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses_with_the_reason() {
        let e =
            parse(r#"{"materials":[{"object":"leftWall","reflectance":[0.1,0.5,0.9]}]}"#).unwrap();
        assert_eq!(e[0].object, "leftWall");
        assert_eq!(e[0].reflectance, Rgb::new(0.1, 0.5, 0.9));
        for (text, needle) in [
            ("{", "not a materials file"),
            (
                r#"{"materials":[{"object":"a","reflectance":[1,0,0]}]}"#,
                "in [0, 1)",
            ),
            (
                r#"{"materials":[{"object":"a","reflectance":[-0.1,0,0]}]}"#,
                "in [0, 1)",
            ),
            (
                r#"{"materials":[{"object":"a","reflectance":[0,0]}]}"#,
                "not a materials file",
            ),
            (
                r#"{"materials":[{"object":"a","reflectanse":[0,0,0]}]}"#,
                "not a materials file",
            ),
            (
                r#"{"materials":[{"object":"a","reflectance":[0,0,0]},{"object":"a","reflectance":[0,0,0]}]}"#,
                "edited twice",
            ),
        ] {
            let err = format!("{:#}", parse(text).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
        }
    }
}
