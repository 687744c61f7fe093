//! What every reader checks the same way: a material's reflectance and emission, and each
//! triangle (degenerate ones and exact duplicates are skipped and counted).

use crate::{DEFAULT_REFLECTANCE, LoadOptions, LoadReport, SceneError};
use glam::DVec3;
use radiosity_core::Rgb;
use std::collections::HashSet;

/// A material's reflectance factor (`what`: `Kd`, `baseColorFactor`), each channel finite and
/// not negative: refused with `bad`'s error, or under geometry-only loading repaired (clamped
/// to [0, 0.999], non-finite to grey) with that error as a warning. At or above 1 is left to
/// `Scene::limit_reflectance`, which sees it times the texture.
pub(crate) fn checked_reflectance(
    what: &str,
    kd: [f64; 3],
    options: &LoadOptions,
    report: &mut LoadReport,
    bad: impl Fn(String) -> SceneError,
) -> Result<[f64; 3], SceneError> {
    if kd.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Ok(kd);
    }
    let e = bad(format!(
        "{what} {} {} {} is not a reflectance (each channel finite and not negative)",
        kd[0], kd[1], kd[2]
    ));
    if options.validate_materials {
        return Err(e);
    }
    report.warnings.push(format!("{e}; clamped to [0, 0.999]"));
    Ok(kd.map(|c| {
        if c.is_finite() {
            c.clamp(0.0, 0.999)
        } else {
            f64::from(DEFAULT_REFLECTANCE)
        }
    }))
}

/// An emitted radiance (`what` names it, `symbol` is its letter in the message: `Ke`, `L`),
/// each channel finite and not negative with an exitance π·L that f32 holds (the stored
/// exitance is f32: one that overflows it would reach the file as infinity): refused with
/// `bad`'s error, or under geometry-only loading dropped (zero) with that error as a warning.
pub(crate) fn checked_emission(
    what: &str,
    symbol: &str,
    ke: [f64; 3],
    options: &LoadOptions,
    report: &mut LoadReport,
    bad: impl Fn(String) -> SceneError,
) -> Result<[f64; 3], SceneError> {
    let exitance_fits = |c: f64| ((std::f64::consts::PI * c) as f32).is_finite();
    if ke
        .iter()
        .all(|&c| c.is_finite() && c >= 0.0 && exitance_fits(c))
    {
        return Ok(ke);
    }
    let e = bad(format!(
        "{what} {} {} {} must be finite and non-negative, with an exitance π·{symbol} below 3.4e38",
        ke[0], ke[1], ke[2]
    ));
    if options.validate_materials {
        return Err(e);
    }
    report.warnings.push(format!("{e}; emission dropped"));
    Ok([0.0; 3])
}

/// The stored emission of an emitted radiance L (checked by [`checked_emission`]): the
/// exitance π·L.
pub(crate) fn exitance(radiance: [f64; 3]) -> Rgb {
    let pi = std::f64::consts::PI;
    Rgb::new(
        (pi * radiance[0]) as f32,
        (pi * radiance[1]) as f32,
        (pi * radiance[2]) as f32,
    )
}

/// Skips degenerate triangles and exact duplicates (same corners in the same cyclic order, so
/// a reversed copy is not a duplicate), counting both in the [`LoadReport`].
#[derive(Default)]
pub(crate) struct TriangleFilter {
    seen: HashSet<[u64; 9]>,
}

impl TriangleFilter {
    /// Whether the triangle with corners `p` (finite) is kept.
    pub(crate) fn admit(&mut self, p: [DVec3; 3], report: &mut LoadReport) -> bool {
        if is_degenerate(p) {
            report.degenerate_triangles += 1;
            return false;
        }
        // Same corners in the same cyclic order: an exact duplicate.
        let start = (0..3)
            .min_by(|&a, &b| {
                p[a].to_array()
                    .partial_cmp(&p[b].to_array())
                    .expect("finite")
            })
            .expect("three corners");
        let mut key = [0u64; 9];
        for j in 0..3 {
            let q = p[(start + j) % 3];
            key[3 * j] = q.x.to_bits();
            key[3 * j + 1] = q.y.to_bits();
            key[3 * j + 2] = q.z.to_bits();
        }
        if !self.seen.insert(key) {
            report.duplicate_triangles += 1;
            return false;
        }
        true
    }
}

/// Whether a triangle has (numerically) no area: twice its area below 1e-12 of its longest
/// edge squared, i.e. its smallest angle is below about 1e-12 rad.
pub(crate) fn is_degenerate(p: [DVec3; 3]) -> bool {
    let a2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
    let e2 = (p[1] - p[0])
        .length_squared()
        .max((p[2] - p[1]).length_squared())
        .max((p[0] - p[2]).length_squared());
    !(a2 > 1e-12 * e2)
}
