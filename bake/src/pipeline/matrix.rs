//! One matrix for the whole scene: the live patches' transfer, its order, its encoding and the
//! file, measured.

use super::measure::{self, BakeSummary, Measured};
use super::steps::{
    attach_runtime, encode_error, encode_params_for, exact_emitters_effect, finish, objects_of,
    transfer_step,
};
use super::{BakeOutput, BakeParams};
use crate::BakeError;
use crate::discretise::Discretised;
use crate::encode::{EncodeParams, ErrorWeights, SparseSelection, encode_dense_noting};
use crate::hooks::{Hooks, Laps};
use crate::order::{self, Candidate, DenseMatrix, OrderKind, OrderParams};
use crate::scene::Scene;
use crate::transfer::Dense;
use radiosity_core::{Patch, RadFile, Rgb};
use std::borrow::Cow;
use std::time::Instant;

/// Bakes `system` as one matrix from its live patches' F (`f`, consumed when owned).
pub(super) fn one_matrix(
    scene: &Scene,
    system: &Discretised,
    f: Cow<'_, Dense>,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<BakeOutput, BakeError> {
    let n = system.len();
    let t_all = Instant::now();
    let mut laps = Laps::after(system.timings_ms.clone());
    let mut effects = system.effects.clone();
    let channels = system.channels;

    hooks.start("transfer")?;
    let (mut m, transfer) = transfer_step(
        &system.reflectance,
        channels,
        f,
        params,
        &mut effects,
        hooks,
    )?;
    laps.lap("transfer");

    let (format, encode_params) = encode_params_for(params, channels);

    hooks.start("order")?;
    let (candidates, chosen) = choose_order(system, &m, params, encode_params)?;
    order::permute_in_place(&mut m, n, channels, &chosen.perm);
    laps.lap("order");

    hooks.start("encode")?;
    // Errors are weighed for the scene's own emitters and for runtime lights alike
    // (`ErrorWeights`), and the sparse entries chosen by that weighted error.
    let file_patches: Vec<Patch> = order::permute_rows(&system.core_patches, &chosen.perm);
    let emission: Vec<Rgb> = file_patches.iter().map(|p| p.emission).collect();
    let (matrix, emitters) = encode_dense_noting(
        n,
        channels,
        &m,
        &encode_params,
        &ErrorWeights::for_emitters(&emission),
        SparseSelection::ErrorDriven,
    )
    .map_err(encode_error)?;
    if let Some(effect) = exact_emitters_effect(&[emitters]) {
        effects.insert("exact_emitters", effect);
    }
    laps.lap("encode");

    hooks.start("measure")?;
    let measured = Measured::new(&m, n, channels, &matrix, &emission, &candidates, &chosen);
    laps.lap("measure");

    let patch_source: Vec<u32> = (chosen.perm.iter())
        .map(|&k| system.live[k as usize] as u32)
        .collect();
    let mut file = RadFile {
        patch_order: chosen.kind.patch_order().expect("a concrete order"),
        compression_rmse: Some(measured.rmse as f32),
        lighting_error: measured.lighting_error.map(|e| e as f32),
        ..RadFile::new(
            Cow::Owned(file_patches),
            Cow::Owned(chosen.perm.clone()),
            matrix,
            objects_of(scene),
            transfer.bounces,
        )
    };
    let sample_objects = attach_runtime(
        &mut file,
        scene,
        system,
        &chosen.perm,
        &patch_source,
        params.sky,
    );
    let discretise_ms: f64 = system.timings_ms.values().sum();
    laps.set("total", discretise_ms + t_all.elapsed().as_secs_f64() * 1e3);
    let summary = BakeSummary {
        format,
        chosen: &chosen,
        bounces: transfer.bounces,
        measured,
        effects,
        timings: laps.into_timings(),
        sample_objects,
    };
    let report = measure::report(scene, system, &file, summary);
    finish(file, report, patch_source, params, None, hooks)
}

/// The order stage: every concrete order is computed and its compression error estimated on
/// sampled blocks (the report lists them all); `best` then picks among none/paper/spatial.
/// Returns every candidate and the chosen one.
fn choose_order(
    system: &Discretised,
    m: &[f32],
    params: &BakeParams,
    encode_params: EncodeParams,
) -> Result<(Vec<Candidate>, Candidate), BakeError> {
    let dense = DenseMatrix::new(system.len(), system.channels, m);
    let order_params = OrderParams {
        seed: params.seed,
        encode: encode_params,
        ..OrderParams::default()
    };
    let candidates = order::evaluate(
        &OrderKind::CONCRETE,
        &system.core_patches,
        dense,
        &order_params,
    )
    .map_err(encode_error)?;
    let chosen = match params.order {
        OrderKind::Best => {
            let eligible: Vec<Candidate> = candidates
                .iter()
                .filter(|c| OrderKind::CANDIDATES.contains(&c.kind))
                .cloned()
                .collect();
            eligible[order::choose_best(&eligible)].clone()
        }
        kind => candidates
            .iter()
            .find(|c| c.kind == kind)
            .expect("every concrete order evaluated")
            .clone(),
    };
    Ok((candidates, chosen))
}
