//! An independent check of the form factors: rows of F against hemisphere rays.
//!
//! In a scene whose surfaces are all patches, `Σ_j F_ij` is the share of the light leaving
//! patch `i` that lands on some patch: the fraction of cosine-weighted rays from a uniform point
//! of `i` whose first hit is the front face of a patch's triangle. That share is estimated here
//! by casting such rays against the full-detail triangles, with none of the machinery the form
//! factors use (no kernel, no quadrature, no flat sites, no clustering), so the two can be
//! compared row by row. `radiosity check-rows` prints the comparison; a large scene's sampled
//! rows come from [`crate::form_factor::form_factor_rows`] without the whole matrix.
//!
//! Rays start on the surface itself ([`Occluders::closest_hit_from_surface`]: triangles whose
//! planes hold the start are passed through), so two parts modelled a hair apart see each
//! other, and the other sheet of a zero-thickness panel is not met. A ray lifted off the
//! surface by even 1e-6 of the extent stepped over such gaps in the conference room and made
//! the estimate, not the form factors, wrong on a fifth of its rows.
//!
//! The report splits off the rows whose rays mostly meet **back faces** first: patches inside
//! other objects or behind a second layer of their own surface (a chair leg inside its
//! sleeve). What such a patch sees is a question of the model more than of the method; rows
//! with a back-face share of at least [`RowCheckParams::enclosed_share`] are *enclosed*.

use crate::BakeError;
use crate::form_factor::{FormFactorParams, Progress, Visibility, form_factor_rows};
use crate::geometry::Occluders;
use crate::patch::Patches;
use crate::patch::points::{Owners, shares};
use crate::rng::SplitMix64;
use crate::scene::Scene;
use crate::simplify::{VoxelParams, simplify};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Parameters of [`check_rows`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowCheckParams {
    /// Hemisphere rays per row; the share's standard error is at most `0.5 / √rays`.
    pub rays: u32,
    /// Seed of the row sample and of the rays.
    pub seed: u64,
    /// A row whose rays meet back faces first at least this often is *enclosed*.
    pub enclosed_share: f64,
    /// A row sum above this counts as over-full (`Σ_j F_ij ≤ 1` in any scene).
    pub over_full: f64,
}

impl Default for RowCheckParams {
    fn default() -> Self {
        Self {
            rays: 4000,
            seed: 11,
            enclosed_share: 0.3,
            over_full: 1.05,
        }
    }
}

/// One checked row.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RowSample {
    /// Patch index (the simplification's numbering, before dark patches are dropped).
    pub patch: usize,
    /// `Σ_j F_ij` from the form factors.
    pub row_sum: f64,
    /// Share of hemisphere rays whose first hit is the front face of a patch's triangle.
    pub hemisphere: f64,
    /// Standard error of `hemisphere` (binomial).
    pub std_error: f64,
    /// Share of hemisphere rays whose first hit is a back face.
    pub back_faces: f64,
}

impl RowSample {
    /// `row_sum − hemisphere`.
    pub fn difference(&self) -> f64 {
        self.row_sum - self.hemisphere
    }
}

/// Differences over a group of rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RowGroup {
    /// Rows in the group.
    pub rows: usize,
    /// RMS of `row_sum − hemisphere`.
    pub rms: f64,
    /// Mean of `row_sum − hemisphere`.
    pub mean: f64,
    /// The largest `|row_sum − hemisphere|` and its patch.
    pub worst: f64,
    /// Patch of `worst` (`None` for an empty group).
    pub worst_patch: Option<usize>,
    /// RMS of the hemisphere estimates' standard errors: the part of `rms` that is the
    /// estimate's own noise.
    pub noise: f64,
    /// Rows whose sum exceeds [`RowCheckParams::over_full`].
    pub over_full: usize,
}

impl RowGroup {
    fn of<'a>(rows: impl Iterator<Item = &'a RowSample>, over_full: f64) -> Self {
        let mut g = Self::default();
        let (mut sq, mut sum, mut noise) = (0.0, 0.0, 0.0);
        for r in rows {
            let d = r.difference();
            g.rows += 1;
            sq += d * d;
            sum += d;
            noise += r.std_error * r.std_error;
            if g.worst_patch.is_none() || d.abs() > g.worst {
                g.worst = d.abs();
                g.worst_patch = Some(r.patch);
            }
            g.over_full += usize::from(r.row_sum > over_full);
        }
        if g.rows > 0 {
            let m = g.rows as f64;
            (g.rms, g.mean, g.noise) = ((sq / m).sqrt(), sum / m, (noise / m).sqrt());
        }
        g
    }
}

/// The comparison: every row, and the rows grouped.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RowCheck {
    /// Rays per row.
    pub rays: u32,
    /// Rows whose rays meet front faces mostly (back-face share below the threshold).
    pub open: RowGroup,
    /// Rows of patches inside other objects or behind a second layer (module doc).
    pub enclosed: RowGroup,
    /// All rows.
    pub all: RowGroup,
    /// Each row, in the order asked.
    pub samples: Vec<RowSample>,
}

/// `count` distinct patch indices below `n` drawn without replacement (all of them when
/// `count ≥ n`), ascending.
pub fn sample_rows(n: usize, count: usize, seed: u64) -> Vec<usize> {
    let mut all: Vec<usize> = (0..n).collect();
    let mut rng = SplitMix64(seed);
    let k = count.min(n);
    // Partial Fisher–Yates: the first k slots are a uniform sample.
    for i in 0..k {
        let j = i + rng.below((n - i) as u64) as usize;
        all.swap(i, j);
    }
    all.truncate(k);
    all.sort_unstable();
    all
}

/// Compares `row_sums[k]` (`Σ_j F_ij` for patch `rows[k]`) with hemisphere rays from that
/// patch against `occ` (built from the scene whose triangles the patches' pieces index).
///
/// # Panics
/// If `rows` and `row_sums` differ in length or a row is not a patch.
pub fn check_rows(
    patches: &Patches,
    occ: &Occluders,
    rows: &[usize],
    row_sums: &[f64],
    params: &RowCheckParams,
) -> RowCheck {
    assert_eq!(rows.len(), row_sums.len(), "one row sum per row");
    let owners = Owners::new(patches);
    let samples: Vec<RowSample> = rows
        .par_iter()
        .zip(row_sums)
        .map(|(&i, &row_sum)| {
            let (h, back) = shares(patches, &owners, occ, i, params.rays, params.seed);
            RowSample {
                patch: i,
                row_sum,
                hemisphere: h,
                std_error: (h * (1.0 - h) / f64::from(params.rays.max(1))).sqrt(),
                back_faces: back,
            }
        })
        .collect();
    let enclosed = |r: &&RowSample| r.back_faces >= params.enclosed_share;
    RowCheck {
        rays: params.rays,
        open: RowGroup::of(samples.iter().filter(|r| !enclosed(r)), params.over_full),
        enclosed: RowGroup::of(samples.iter().filter(enclosed), params.over_full),
        all: RowGroup::of(samples.iter(), params.over_full),
        samples,
    }
}

/// [`check_rows`] on a scene as the bake sees it: simplified with `voxel`, occlusion planned as
/// [`crate::pipeline::discretise`] plans it (a convex enclosure casts no visibility rays), and
/// `count` sampled rows of F computed alone ([`form_factor_rows`]), or the rows `only` names
/// when it is not empty (patches in simplification order, as the bake's
/// `closure.max_row_patch` names them; an error if one is not a patch). Returns the check, the
/// patch count, the shadow rays the rows cast and the seconds spent on the rows and on the
/// hemisphere rays. `progress` is told about finished rows of F.
pub fn check_scene(
    scene: &Scene,
    voxel: &VoxelParams,
    form_factors: &FormFactorParams,
    count: usize,
    only: &[usize],
    params: &RowCheckParams,
    progress: Option<Progress<'_>>,
) -> Result<SceneCheck, BakeError> {
    let patches = simplify(scene, voxel)?;
    if let Some(&bad) = only.iter().find(|&&i| i >= patches.len()) {
        return Err(BakeError::InvalidParams(format!(
            "--patch {bad}: the scene simplifies to {} patches (0 to {})",
            patches.len(),
            patches.len().saturating_sub(1)
        )));
    }
    let occ = scene.occluders();
    let mut ffp = *form_factors;
    if !crate::effect_plan::plan_occlusion(scene).on {
        ffp.visibility = Visibility::Off;
    }
    let rows = if only.is_empty() {
        sample_rows(patches.len(), count, params.seed)
    } else {
        let mut rows = only.to_vec();
        rows.sort_unstable();
        rows.dedup();
        rows
    };
    let clock = Instant::now();
    let (f, shadow_rays) = form_factor_rows(&patches, Some(&occ), &ffp, &rows, progress);
    let rows_s = clock.elapsed().as_secs_f64();
    let sums: Vec<f64> = f.iter().map(|r| r.iter().sum()).collect();
    let clock = Instant::now();
    let check = check_rows(&patches, &occ, &rows, &sums, params);
    Ok(SceneCheck {
        patches: patches.len(),
        shadow_rays,
        form_factor_seconds: rows_s,
        hemisphere_seconds: clock.elapsed().as_secs_f64(),
        check,
    })
}

/// What [`check_scene`] returns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneCheck {
    /// Patches after simplification (dark ones included).
    pub patches: usize,
    /// Shadow rays the sampled rows of F cast.
    pub shadow_rays: u64,
    /// Seconds spent computing the sampled rows of F.
    pub form_factor_seconds: f64,
    /// Seconds spent on the hemisphere rays.
    pub hemisphere_seconds: f64,
    /// The comparison.
    pub check: RowCheck,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_row_sample_is_distinct_sorted_and_covers_small_scenes() {
        let s = sample_rows(1000, 120, 5);
        assert_eq!(s.len(), 120);
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert!(s.iter().all(|&i| i < 1000));
        assert_eq!(sample_rows(7, 120, 5), (0..7).collect::<Vec<_>>());
        assert_ne!(sample_rows(1000, 120, 6), s);
    }
}
