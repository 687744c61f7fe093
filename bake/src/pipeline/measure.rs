//! The measurements the bake reports: the compression errors of the chosen order and the
//! others, the lighting error, and the report assembled from a discretisation and a file.

use super::Discretised;
use crate::effect_plan::Effects;
use crate::order::{self, Candidate};
use crate::report::{BakeReport, Bytes};
use crate::scene::Scene;
use radiosity_core::{Bounces, DecodeMode, Format, RadFile, Rgb, TransferMatrix};
use radiosity_runtime::SharedPatch;
use std::collections::BTreeMap;

/// `‖a − b‖ / ‖a‖` over all entries (0 for an all-zero `a` equal to `b`).
pub(crate) fn relative_frobenius(a: &[f32], b: &[f32]) -> f64 {
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

/// The compression errors of a bake: measured on the encoded matrix for the chosen order,
/// estimated on sampled blocks for the others.
pub(super) struct Measured {
    /// Relative Frobenius error of the decoded matrix.
    pub(super) rmse: f64,
    /// [`lighting_error`] of the encoded matrix.
    pub(super) lighting_error: Option<f64>,
    /// Per order, the relative Frobenius error (the chosen one's measured).
    pub(super) compression_rmse: BTreeMap<String, f64>,
    /// Per order, the RMS error in 8-bit codes (the chosen one's measured; log formats only).
    pub(super) compression_code_rmse: BTreeMap<String, f64>,
}

impl Measured {
    /// Measures `matrix`, the encode of the dense `m` (`n × n × channels`, file numbering)
    /// whose patches emit `emission`, with `candidates`' estimates for the other orders.
    pub(super) fn new(
        m: &[f32],
        n: usize,
        channels: usize,
        matrix: &TransferMatrix<'_>,
        emission: &[Rgb],
        candidates: &[Candidate],
        chosen: &Candidate,
    ) -> Self {
        let decoded = matrix.decode_dense(DecodeMode::D3d10);
        let rmse = relative_frobenius(m, &decoded);
        let code_rmse = order::code_rms(matrix, m, &decoded);
        drop(decoded);
        let lighting_error = crate::encode::lighting_error(m, n, channels, matrix, emission);
        let mut compression_rmse: BTreeMap<String, f64> = candidates
            .iter()
            .map(|c| (c.kind.name().to_owned(), c.error.relative))
            .collect();
        compression_rmse.insert(chosen.kind.name().to_owned(), rmse);
        let mut compression_code_rmse: BTreeMap<String, f64> = candidates
            .iter()
            .filter_map(|c| Some((c.kind.name().to_owned(), c.error.code_rms?)))
            .collect();
        if let Some(e) = code_rmse {
            compression_code_rmse.insert(chosen.kind.name().to_owned(), e);
        }
        Self {
            rmse,
            lighting_error,
            compression_rmse,
            compression_code_rmse,
        }
    }
}

/// What the second half of the bake decided, for its report.
pub(super) struct BakeSummary<'a> {
    /// Storage format.
    pub(super) format: Format,
    /// The order used.
    pub(super) chosen: &'a Candidate,
    /// Bounces carried by M.
    pub(super) bounces: Bounces,
    /// The compression errors.
    pub(super) measured: Measured,
    /// Every effect decision.
    pub(super) effects: Effects,
    /// Milliseconds per stage.
    pub(super) timings: BTreeMap<&'static str, f64>,
    /// The object of each direct-light sample of the file's mesh (its sample order).
    pub(super) sample_objects: Vec<u32>,
}

/// The report of a bake of `scene` from `system` into `file` (its size still 0: [`store`]).
pub(super) fn report(
    scene: &Scene,
    system: &Discretised,
    file: &RadFile<'_>,
    summary: BakeSummary<'_>,
) -> BakeReport {
    BakeReport {
        patches: system.len(),
        channels: system.channels,
        format: summary.format.name(),
        order: summary.chosen.kind.name(),
        bounces: match summary.bounces {
            Bounces::Finite(k) => serde_json::json!(k),
            Bounces::Infinite => serde_json::json!("infinite"),
        },
        bytes: Bytes {
            total: 0,
            blocks: file.matrix.blocks.len(),
            sparse: file.matrix.sparse.bytes(),
            corrections: file.matrix.corrections.bytes(),
            corrected_blocks: file.matrix.corrections.count(),
            probes: file.probes.as_ref().map_or(0, |p| p.to_bytes().len()),
            sky: file.sky.as_ref().map_or(0, |s| s.to_bytes().len()),
            parts: file.parts.as_ref().map_or(0, |p| p.to_bytes().len()),
            bounce: file.bounce.as_ref().map_or(0, |b| b.to_bytes().len()),
        },
        rays_cast: system.rays_cast,
        form_factors: system.form_factors,
        compression_rmse: summary.measured.compression_rmse,
        compression_code_rmse: summary.measured.compression_code_rmse,
        lighting_error: summary.measured.lighting_error,
        effects: summary.effects,
        closure: system.closure.clone(),
        reciprocity_error: system.reciprocity_error,
        timings_ms: summary.timings,
        warnings: scene
            .report
            .warnings
            .iter()
            .chain(&system.patches.warnings)
            .cloned()
            .collect(),
        object_areas: scene
            .object_areas()
            .iter()
            .enumerate()
            .map(|(o, a)| a - system.exposure.buried_area.get(o).copied().unwrap_or(0.0))
            .collect(),
        object_surface_areas: scene.object_areas(),
        object_emitted_power: emitted_power(scene),
        shared_patches: summary
            .chosen
            .perm
            .iter()
            .enumerate()
            .filter_map(|(k, &at)| {
                let shares = &system.exposure.shared[system.live[at as usize]];
                let samples = file.mesh.as_ref().map_or(0..0, |m| {
                    m.sample_rows[k] as usize..m.sample_rows[k + 1] as usize
                });
                (!shares.is_empty()).then(|| SharedPatch {
                    patch: k as u32,
                    objects: shares.iter().map(|s| s.0).collect(),
                    areas: shares.iter().map(|s| s.1).collect(),
                    sample_objects: summary.sample_objects.get(samples).unwrap_or(&[]).to_vec(),
                })
            })
            .collect(),
        probes: None,
        sky: None,
        systems: None,
    }
}

/// Power each object of `scene` emits over its whole full-detail surface (`Σ A·E` per channel).
fn emitted_power(scene: &Scene) -> Vec<[f64; 3]> {
    let mut p = vec![[0.0; 3]; scene.objects.len()];
    for (t, tri) in scene.triangles.iter().enumerate() {
        let e = scene.materials[tri.material as usize].emission;
        let a = scene.triangle_area(t);
        for (c, acc) in p[tri.object as usize].iter_mut().enumerate() {
            *acc += a * f64::from(e.channel(c));
        }
    }
    p
}
