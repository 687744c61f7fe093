//! The whole bake: scene → patches → form factors → effect plan → transfer → order → encode →
//! [`RadFile`], with a report of every decision, error estimate and timing.
//!
//! [`discretise`] runs the first half (simplification, form factors, burial and closure
//! (`closure`), dark patches (`dark`)), [`bake_discretised`] the second (transfer, order,
//! encode, measure, the runtime mesh and the report (`report`)); [`bake`] runs both.

mod measure;
mod params;
pub(crate) mod systems;

pub use crate::closure::ClosureReport;
pub use crate::dark_patches::{DarkCheck, check_dark};
pub use crate::discretise::Discretised;
pub use crate::exposure::Exposure;
pub use crate::hooks::Hooks;
pub use crate::report::SystemsReport;
pub use crate::report::{BakeReport, Bytes, store};
pub use crate::systems::{AUTO_ONE_MATRIX, AUTO_SYSTEM_PATCHES, SystemsChoice};
pub use params::{BakeParams, FormatChoice};
pub use radiosity_runtime::{ObjectShares, SharedPatch};
pub use systems::SystemRecord;

use crate::passes::{self, sky::Sky};
use measure::{BakeSummary, Measured};

use crate::BakeError;
use crate::effects::{Effect, Effects};
use crate::encode::{
    EncodeError, EncodeParams, ErrorWeights, SparseSelection, default_correction_fraction,
    default_sparse_fraction, encode_dense_with,
};
use crate::form_factor::SparseFormFactors;
use crate::form_factor::matrix::dense_live_sparse;
use crate::order::{self, Candidate, DenseMatrix, OrderKind, OrderParams};
use crate::scene::Scene;
use crate::transfer::{BounceSpec, Dense, TransferError, transfer};
use radiosity_core::{Bounces, Format, Patch, RadFile, Rgb};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::time::Instant;

/// A finished bake.
#[derive(Clone, Debug)]
pub struct BakeOutput {
    /// The file to write.
    pub file: RadFile<'static>,
    /// What happened.
    pub report: BakeReport,
    /// For each file patch, its index in the simplification (`Patches::patches`).
    pub patch_source: Vec<u32>,
}

/// The first half of [`bake`]: simplify, plan, form factors, closure, dark patches (uses the
/// parameters of [`BakeParams::discretise`]).
pub fn discretise(
    scene: &Scene,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<Discretised, BakeError> {
    crate::discretise::discretise(scene, &params.discretise(), hooks, None)
}

/// Bakes `scene`. Errors: an empty scene, impossible parameters, a transfer that cannot converge.
///
/// The system's F is handed to the transfer, which solves its last channel in F's own buffer:
/// one n² f64 matrix less at the peak than [`bake_discretised`], the same bytes.
pub fn bake(scene: &Scene, params: &BakeParams, hooks: Hooks<'_>) -> Result<BakeOutput, BakeError> {
    let mut system = discretise(scene, params, hooks)?;
    let f = std::mem::replace(&mut system.f, Dense::new(0, Vec::new()));
    let sparse = system.sparse.take().map(Cow::Owned);
    second_half(scene, &system, Cow::Owned(f), sparse, params, hooks)
}

/// The second half of [`bake`]: transfer, order, encode, measure, for a system from
/// [`discretise`] (its `voxel`, `form_factors` and `closure_tolerance` params are not looked
/// at again). Timings include the discretisation's, and `total` is theirs plus this half's.
pub fn bake_discretised(
    scene: &Scene,
    system: &Discretised,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<BakeOutput, BakeError> {
    let sparse = system.sparse.as_ref().map(Cow::Borrowed);
    second_half(
        scene,
        system,
        Cow::Borrowed(&system.f),
        sparse,
        params,
        hooks,
    )
}

/// [`bake_discretised`] with the system's F given apart (`f`, or `sparse` where the
/// discretisation kept sparse rows), borrowed or owned: an owned F is consumed by the
/// transfer.
fn second_half(
    scene: &Scene,
    system: &Discretised,
    f: Cow<'_, Dense>,
    sparse: Option<Cow<'_, SparseFormFactors>>,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<BakeOutput, BakeError> {
    let n = system.len();
    if let Some(count) = params.systems.count_for(n) {
        let ff = match sparse {
            Some(s) => s,
            None => Cow::Owned(dense_live_sparse(&f, &(0..n).collect::<Vec<_>>())),
        };
        drop(f);
        return systems::second_half_systems(scene, system, ff, count, params, hooks);
    }
    // Sparse rows kept for systems that the live patches turned out too few to need: one
    // matrix of their entries (widened from f32).
    let f = match sparse {
        Some(s) => {
            let mut d = vec![0.0; n * n];
            for i in 0..n {
                for (j, v) in s.row(i) {
                    d[i * n + j] = f64::from(v);
                }
            }
            Cow::Owned(Dense::new(n, d))
        }
        None => f,
    };
    let mut timings = system.timings_ms.clone();
    let t_all = Instant::now();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, timings: &mut BTreeMap<&'static str, f64>| {
        timings.insert(name, clock.elapsed().as_secs_f64() * 1e3);
        clock = Instant::now();
    };
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
    lap("transfer", &mut timings);

    let (format, encode_params) = encode_params_for(params, channels);

    hooks.start("order")?;
    let (candidates, chosen) = choose_order(system, &m, params, encode_params)?;
    order::permute_in_place(&mut m, n, channels, &chosen.perm);
    lap("order", &mut timings);

    hooks.start("encode")?;
    // Errors are weighed for the scene's own emitters and for runtime lights alike
    // (`ErrorWeights`), and the sparse entries chosen by that weighted error.
    let file_patches: Vec<Patch> = order::permute_rows(&system.core_patches, &chosen.perm);
    let emission: Vec<Rgb> = file_patches.iter().map(|p| p.emission).collect();
    let matrix = encode_dense_with(
        n,
        channels,
        &m,
        &encode_params,
        &ErrorWeights::for_emitters(&emission),
        SparseSelection::ErrorDriven,
    )
    .map_err(encode_error)?;
    lap("encode", &mut timings);

    hooks.start("measure")?;
    let measured = Measured::new(&m, n, channels, &matrix, &emission, &candidates, &chosen);
    lap("measure", &mut timings);

    let patch_source: Vec<u32> = chosen
        .perm
        .iter()
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
            scene
                .objects
                .iter()
                .map(|o| Cow::Owned(o.clone()))
                .collect(),
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
    timings.insert("total", discretise_ms + t_all.elapsed().as_secs_f64() * 1e3);
    let summary = BakeSummary {
        format,
        chosen: &chosen,
        bounces: transfer.bounces,
        measured,
        effects,
        timings,
        sample_objects,
    };
    let report = measure::report(scene, system, &file, summary);
    let sky = Sky {
        on: params.sky,
        planned: None,
    };
    let (file, report) = passes::run(file, report, &[&params.probes_pass(), &sky], false, hooks)?;
    Ok(BakeOutput {
        file,
        report,
        patch_source,
    })
}

/// Gives `file` what the runtime draws and shades with, in the file's numbering (`perm[k]`:
/// the live patch of file patch `k`; `patch_source[k]`: its simplification patch): the mesh,
/// the PARTS section and the triangles' coverage. Returns the object of each of the mesh's
/// direct-light samples.
fn attach_runtime(
    file: &mut RadFile<'static>,
    scene: &Scene,
    system: &Discretised,
    perm: &[u32],
    patch_source: &[u32],
    sky: bool,
) -> Vec<u32> {
    let (mesh, sample_objects) = file_mesh(scene, system, patch_source);
    file.parts = part_rows_section(system, perm, &mesh, sky);
    file.mesh = Some(mesh);
    file.coverage = scene
        .coverage
        .iter()
        .any(|&c| c < 1.0)
        .then(|| Cow::Owned(scene.coverage.clone()));
    sample_objects
}

/// The PARTS section of the file: each shared patch's part rows ([`Discretised::part_rows`])
/// in file numbering, their entries naming the mesh's samples; `None` where no patch is shared.
fn part_rows_section(
    system: &Discretised,
    perm: &[u32],
    mesh: &radiosity_core::Mesh<'_>,
    with_sky: bool,
) -> Option<radiosity_core::PartRows<'static>> {
    let mut file_of = vec![0u32; perm.len()];
    for (k, &at) in perm.iter().enumerate() {
        file_of[at as usize] = k as u32;
    }
    let mut parts = Vec::new();
    let (mut samples, mut counts, mut sky) = (Vec::new(), Vec::new(), Vec::new());
    let mut entries: Vec<(u32, u16)> = Vec::new();
    for (f, &at) in perm.iter().enumerate() {
        let Some(rows) = system.part_rows.get(system.live[at as usize]) else {
            continue;
        };
        for row in rows {
            entries.clear();
            entries.extend(row.entries.iter().map(|&(j, k, c)| {
                let file_j = file_of[j as usize] as usize;
                (mesh.sample_rows[file_j] + k, c)
            }));
            entries.sort_unstable();
            parts.push(radiosity_core::Part {
                patch: f as u32,
                object: row.object,
                scale: row.each as f32,
                start: samples.len() as u32,
            });
            samples.extend(entries.iter().map(|e| e.0));
            counts.extend(entries.iter().map(|e| e.1));
            if with_sky {
                sky.extend_from_slice(&row.sky);
            }
        }
    }
    (!parts.is_empty()).then_some(radiosity_core::PartRows {
        parts: Cow::Owned(parts),
        samples: Cow::Owned(samples),
        counts: Cow::Owned(counts),
        sky: Cow::Owned(sky),
    })
}

/// The transfer stage: `M` from the live patches' F and reflectances under `params.bounces`,
/// and the `bounces` decision in `effects`.
fn transfer_step(
    reflectance: &[[f64; 3]],
    channels: usize,
    f: Cow<'_, Dense>,
    params: &BakeParams,
    effects: &mut Effects,
    hooks: Hooks<'_>,
) -> Result<(Vec<f32>, crate::transfer::TransferReport), BakeError> {
    let (m, transfer) = transfer(f, reflectance, channels, params.bounces, hooks.progress)
        .map_err(|e| match e {
            TransferError::Divergent { .. } => BakeError::InvalidParams(e.to_string()),
            other => BakeError::InvalidParams(other.to_string()),
        })?;
    effects.insert(
        "bounces",
        Effect::new(
            true,
            match transfer.bounces {
                Bounces::Infinite => format!(
                    "{} bounces needed at energy gain {:.4} per bounce: all of them, by LU (cheaper than 3 or more series terms)",
                    bounces_needed(transfer.max_gain, params.bounces),
                    transfer.max_gain
                ),
                Bounces::Finite(k) => format!(
                    "{k} bounce(s) leave at most {:.1e} of the energy (gain {:.4} per bounce)",
                    transfer.energy_left, transfer.max_gain
                ),
            },
        ),
    );
    Ok((m, transfer))
}

/// The storage format (`params.format`, or the automatic choice for `channels`) and the
/// encode parameters with the format's default sparse and correction shares where `params`
/// leaves them open.
fn encode_params_for(params: &BakeParams, channels: usize) -> (Format, EncodeParams) {
    let format = match params.format {
        FormatChoice::Auto if channels == 1 => Format::Bc4,
        FormatChoice::Auto => Format::Bc1,
        FormatChoice::Fixed(f) => f,
    };
    let encode_params = EncodeParams {
        format,
        sparse_fraction: params
            .sparse_fraction
            .unwrap_or_else(|| default_sparse_fraction(format, channels)),
        corrections: params
            .corrections
            .unwrap_or_else(|| default_correction_fraction(format, channels)),
        ..params.encode
    };
    (format, encode_params)
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

/// The runtime mesh: full-detail triangles, corner weights and direct-light samples, in the
/// file's patch numbering (`patch_source[i]`: the simplification patch of file patch `i`),
/// with the object of every direct-light sample. What a bake stores; `radiosity bench` builds
/// its corner pass from it.
pub fn file_mesh(
    scene: &Scene,
    system: &Discretised,
    patch_source: &[u32],
) -> (radiosity_core::Mesh<'static>, Vec<u32>) {
    let mut file_index = vec![None; system.patches.len()];
    for (i, &k) in patch_source.iter().enumerate() {
        file_index[k as usize] = Some(i as u32);
    }
    crate::simplify::runtime_mesh::runtime_mesh(
        scene,
        &system.patches,
        &file_index,
        &system.exposure.buried_points,
        &system.direct_points,
    )
}

fn encode_error(e: EncodeError) -> BakeError {
    BakeError::InvalidParams(e.to_string())
}

fn bounces_needed(gain: f64, spec: BounceSpec) -> String {
    let tol = match spec {
        BounceSpec::Auto { tolerance } => tolerance,
        _ => 1e-3,
    };
    if gain >= 1.0 || gain <= 0.0 {
        return "unbounded".into();
    }
    format!("{:.0}", (tol.ln() / gain.ln()).ceil())
}
