//! What the bake reports: the `bake --json` object ([`BakeReport`], `docs/contract.md`), also
//! stored in the file's REPORT section for `inspect`, and the error measures it holds.

use crate::effects::Effects;
use crate::form_factor::FormFactorSummary;
use radiosity_core::{DecodeMode, Gather, ReferenceGather, Rgb, TransferMatrix};
use serde::Serialize;
use std::collections::BTreeMap;

/// Sizes in bytes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bytes {
    /// The whole `.rad` file.
    pub total: usize,
    /// Block data.
    pub blocks: usize,
    /// Sparse arrays.
    pub sparse: usize,
    /// Block corrections (their four arrays).
    pub corrections: usize,
    /// Blocks corrected.
    pub corrected_blocks: usize,
}

/// What the bake did and measured: the `bake --json` object (DESIGN.md), also stored in the
/// file's REPORT section for `inspect`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BakeReport {
    /// Patches in the matrix.
    pub patches: usize,
    /// Stored channels.
    pub channels: usize,
    /// Storage format.
    pub format: &'static str,
    /// Patch order used.
    pub order: &'static str,
    /// Bounces (a number, or "infinite").
    pub bounces: serde_json::Value,
    /// Sizes.
    pub bytes: Bytes,
    /// Shadow rays cast for form factors.
    pub rays_cast: u64,
    /// The form-factor quadrature and rays asked for (`FormFactorParams::summary`).
    pub form_factors: FormFactorSummary,
    /// Relative Frobenius error of the decoded matrix, per order measured (the chosen one
    /// exactly, the others estimated on sampled blocks of the encoder's first pass, which the
    /// bake's own encode improves on: see `order::ErrorMeter`).
    pub compression_rmse: BTreeMap<String, f64>,
    /// RMS error of the compressed log texture in 8-bit codes, per order measured as
    /// `compression_rmse` is (`order::ErrorEstimate::code_rms`): the paper's own measure (its
    /// Fig. 4 compares the compressed texture with the uncompressed one). Empty for the float
    /// formats.
    pub compression_code_rmse: BTreeMap<String, f64>,
    /// Relative L2 error of the irradiance from the scene's own emitters caused by compression
    /// (`null` without emitters).
    pub lighting_error: Option<f64>,
    /// Every effect decision with its reason.
    pub effects: Effects,
    /// Row sums of F before any correction, and the correction applied.
    pub closure: ClosureReport,
    /// Largest reciprocity error of F.
    pub reciprocity_error: f64,
    /// Milliseconds per stage.
    pub timings_ms: BTreeMap<&'static str, f64>,
    /// Warnings from loading and simplification.
    pub warnings: Vec<String>,
    /// Exposed area of each object (file object order): its full-detail area less the part
    /// buried under other objects, dark patches included: what per-object means are taken over.
    pub object_areas: Vec<f64>,
}

/// Closure measurements.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClosureReport {
    /// Smallest row sum of F over patches that see anything and are not partly buried (whose
    /// rows mix two estimates, see `closure_effect`), before any correction.
    pub min_row_sum: f64,
    /// Largest row sum, before any correction.
    pub max_row_sum: f64,
    /// The patch of the largest row sum, in simplification order (`Patches::patches`, the
    /// numbering `radiosity check-rows --patch` takes).
    pub max_row_patch: Option<usize>,
    /// Largest relative change of a row sum made by the closure correction (0 when open), apart
    /// from the rows of partly buried patches.
    pub correction: f64,
    /// Share of hemisphere rays from the patches that left the scene
    /// (`row_check::escape_check`), asked only when the row sums say closed; above
    /// `row_check::ESCAPE_LIMIT` the scene is open after all.
    pub escaped: Option<f64>,
}
/// `‖a − b‖ / ‖a‖` over all entries (0 for an all-zero `a` equal to `b`).
pub fn relative_frobenius(a: &[f32], b: &[f32]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (f64::from(*x) - f64::from(*y)).powi(2))
        .sum();
    let den: f64 = a.iter().map(|x| f64::from(*x).powi(2)).sum();
    if den == 0.0 {
        num.sqrt()
    } else {
        (num / den).sqrt()
    }
}

/// Relative L2 error of `y = M·E` (the scene's own emitters) between the exact dense `m` and
/// the encoded matrix; `None` when nothing emits.
pub fn lighting_error(
    m: &[f32],
    n: usize,
    channels: usize,
    encoded: &TransferMatrix<'_>,
    emission: &[Rgb],
) -> Option<f64> {
    let peak = emission
        .iter()
        .map(|e| e.max_channel())
        .fold(0.0f32, f32::max);
    if !(peak > 0.0) {
        return None;
    }
    // The error is relative, so scale-free: measure with the brightest emitter at 1, so that
    // emission near f32's limit cannot overflow the f32 gather into a NaN estimate.
    let scaled: Vec<Rgb> = emission.iter().map(|e| *e * (1.0 / peak)).collect();
    let emission = &scaled[..];
    let mut exact = vec![[0f64; 3]; n];
    for i in 0..n {
        for j in 0..n {
            let e = emission[j].to_array();
            for k in 0..3 {
                let v = m[(i * n + j) * channels + if channels == 1 { 0 } else { k }];
                exact[i][k] += f64::from(v) * f64::from(e[k]);
            }
        }
    }
    let mut gather = ReferenceGather::new(encoded.clone(), DecodeMode::D3d10);
    let mut y = vec![Rgb::ZERO; n];
    gather.gather(emission, &mut y).ok()?;
    let num: f64 = exact
        .iter()
        .zip(&y)
        .map(|(a, b)| {
            (0..3)
                .map(|k| (a[k] - f64::from(b.channel(k))).powi(2))
                .sum::<f64>()
        })
        .sum();
    let den: f64 = exact
        .iter()
        .map(|a| a.iter().map(|v| v * v).sum::<f64>())
        .sum();
    (den > 0.0).then(|| (num / den).sqrt())
}
