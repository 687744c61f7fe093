//! The whole bake: scene → patches → form factors → effect plan → transfer → order → encode →
//! [`RadFile`], with a report of every decision, error estimate and timing.
//!
//! [`discretise`] runs the first half (simplification, form factors, burial and closure
//! (`closure`), dark patches (`dark`)), [`bake_discretised`] the second (transfer, order,
//! encode, measure, the runtime mesh and the report (`report`)); [`bake`] runs both.

mod closure;
mod dark;
mod params;
mod report;

pub use closure::Exposure;
pub use dark::{DarkCheck, check_dark};
pub use params::{BakeParams, FormatChoice, Hooks};
pub use report::{BakeReport, Bytes, ClosureReport, lighting_error, relative_frobenius};

use crate::BakeError;
use crate::bounce::{BounceSpec, Dense, TransferError, transfer_matrix};
use crate::effects::{self, Effect, Effects};
use crate::encode::{
    EncodeError, EncodeParams, ErrorWeights, SparseSelection, default_correction_fraction,
    default_sparse_fraction, encode_dense_with,
};
use crate::form_factor::{
    FAR_RAYS, FormFactorSummary, MAX_EXACT_PIECES, NEAR_RAYS, Visibility, form_factors,
};
use crate::geometry::Occluders;
use crate::order::{self, Candidate, DenseMatrix, OrderKind, OrderParams};
use crate::scene::Scene;
use crate::simplify::{Patches, simplify};
use closure::{closure_effect, escape_check, expose};
use dark::dark_patches;
use radiosity_core::{Bounces, DecodeMode, Format, Patch, RadFile, Rgb};
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

/// The discretised system every bake starts from: patches, their closure-corrected form
/// factors and reflectances, with the patches that see nothing removed. Independent of the
/// bounces, format, order and sparse threshold, so one `Discretised` serves many bakes
/// ([`bake_discretised`]) and the exact solution of the same patches
/// (`(I − F^C)⁻¹ F`, for measuring errors).
#[derive(Clone, Debug)]
pub struct Discretised {
    /// The simplification (all patches, dark ones included).
    pub patches: Patches,
    /// Simplification index of each matrix patch: the patches that see something.
    pub live: Vec<usize>,
    /// Form factors among the live patches (closure-corrected when the scene is closed).
    pub f: Dense,
    /// Reflectance of each live patch.
    pub reflectance: Vec<[f64; 3]>,
    /// The live patches as the core stores them (bake numbering).
    pub core_patches: Vec<Patch>,
    /// Stored channels: 3, or 1 for an all-grey scene.
    pub channels: usize,
    /// Decisions so far (colour, occlusion, emission, closed, dark patches).
    pub effects: Effects,
    /// Row sums of F and the closure correction.
    pub closure: ClosureReport,
    /// The surface buried under other objects, taken out of the patches ([`expose`]).
    pub exposure: Exposure,
    /// Shadow rays cast for the form factors.
    pub rays_cast: u64,
    /// The form-factor settings used.
    pub form_factors: FormFactorSummary,
    /// Largest reciprocity error of F.
    pub reciprocity_error: f64,
    /// Milliseconds of `simplify`, `plan`, `form_factors` and `closure` (burial and closure).
    pub timings_ms: BTreeMap<&'static str, f64>,
}

impl Discretised {
    /// Patches in the matrix.
    pub fn len(&self) -> usize {
        self.live.len()
    }

    /// Whether no patch is live (never true for a successful [`discretise`]).
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }
}

/// Bakes `scene`. Errors: an empty scene, impossible parameters, a transfer that cannot converge.
pub fn bake(scene: &Scene, params: &BakeParams, hooks: Hooks<'_>) -> Result<BakeOutput, BakeError> {
    let system = discretise(scene, params, hooks)?;
    bake_discretised(scene, &system, params, hooks)
}

/// The first half of [`bake`]: simplify, plan, form factors, closure, dark patches (uses
/// `params.voxel`, `params.form_factors` and `params.closure_tolerance`).
pub fn discretise(
    scene: &Scene,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<Discretised, BakeError> {
    let stage = |s: &str| {
        if let Some(f) = hooks.stage {
            f(s)
        }
    };
    let mut timings = BTreeMap::new();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, timings: &mut BTreeMap<&'static str, f64>| {
        timings.insert(name, clock.elapsed().as_secs_f64() * 1e3);
        clock = Instant::now();
    };

    stage("simplify");
    let mut patches = simplify(scene, &params.voxel)?;
    lap("simplify", &mut timings);

    let mut effects = Effects::new();
    let colour = effects::plan_colour(&patches);
    let channels = if colour.on { 3 } else { 1 };
    effects.insert("colour", colour);
    let occlusion = effects::plan_occlusion(scene);
    let mut ffp = params.form_factors;
    if !occlusion.on {
        ffp.visibility = Visibility::Off;
    }
    let occluders = occlusion.on.then(|| Occluders::new(scene));
    effects.insert("occlusion", occlusion);
    effects.insert("emission", effects::plan_emission(&patches));
    lap("plan", &mut timings);

    stage("form factors");
    let ff = form_factors(&patches, occluders.as_ref(), &ffp, hooks.progress);
    lap("form_factors", &mut timings);
    let (pieces, budget) = (ff.pieces, ffp.exact_pieces);
    let why = if ff.sites > 0 {
        format!(
            "{pieces} pieces in all (over {budget}): {} flat patches of more than {MAX_EXACT_PIECES} pieces stand in as one flat site each in their far pairs, neighbours keep their pieces (piece by piece everywhere would cost {:.1e} piece pairs)",
            ff.sites,
            (pieces as f64).powi(2) / 2.0
        )
    } else if pieces > budget {
        format!(
            "{pieces} pieces in all (over {budget}), but no patch of more than {MAX_EXACT_PIECES} pieces is flat: every pair integrated piece by piece"
        )
    } else {
        format!("{pieces} pieces in all (at most {budget}): every pair integrated piece by piece")
    };
    effects.insert("flat_sites", Effect::new(ff.sites > 0, why));
    let why = if ff.clustered_pairs > 0 {
        format!(
            "{pieces} pieces in all (over {budget}): all {} patch pairs integrated as clusters (piece pairs far apart for their size centre to centre, the rest by quadrature; {FAR_RAYS} shadow rays per far pair and {NEAR_RAYS} per near pair, drawn in proportion to what each piece pair carries)",
            ff.clustered_pairs
        )
    } else {
        format!(
            "{pieces} pieces in all (at most {budget}): every pair integrated piece by piece, one shadow ray per quadrature leaf and piece"
        )
    };
    effects.insert("clustered_pairs", Effect::new(ff.clustered_pairs > 0, why));

    let n_all = patches.len();
    let mut f = Dense::new(n_all, ff.matrix.iter().map(|v| f64::from(*v)).collect());
    let full_areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    let exposure = expose(&mut patches, occluders.as_ref(), &mut f, params.seed);
    let areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    // The checks below cast rays even where nothing occludes (no BVH was built for F): then
    // one is built, once, when a check first needs it.
    let built = std::cell::OnceCell::new();
    let checks_occ = || {
        occluders
            .as_ref()
            .unwrap_or_else(|| built.get_or_init(|| Occluders::new(scene)))
    };
    let escape = |live: &[bool]| escape_check(&patches, checks_occ(), live, params.seed);
    let (closure, closed) = closure_effect(&patches, &mut f, &areas, &exposure, params, &escape);
    effects.insert("closed", closed);
    lap("closure", &mut timings);

    // Patches that see nothing (row of F zero) receive and give no indirect light: drop them.
    let (live, dark): (Vec<usize>, Vec<usize>) =
        (0..n_all).partition(|&i| f.row(i).iter().any(|v| *v > 0.0));
    let dark_effect = if dark.is_empty() {
        Effect::new(false, "every patch sees some other patch: none dropped")
    } else {
        // An independent look at the decision: hemisphere rays from the dark patches.
        let buried = dark
            .iter()
            .filter(|&&i| exposure.share.get(i).is_some_and(|&b| b >= 1.0))
            .count();
        dark_patches(
            &mut patches,
            checks_occ(),
            &dark,
            buried,
            &full_areas,
            params.seed,
        )
    };
    effects.insert("dark_patches", dark_effect);
    if live.is_empty() {
        return Err(BakeError::Unbakeable(
            "no patch sees any other patch, so no light can travel between surfaces (a single surface, or every surface facing away from the rest)".into(),
        ));
    }
    let f_live = Dense::new(
        live.len(),
        live.iter()
            .flat_map(|&i| live.iter().map(move |&j| (i, j)))
            .map(|(i, j)| f.get(i, j))
            .collect(),
    );
    let reflectance: Vec<[f64; 3]> = live
        .iter()
        .map(|&i| patches.patches[i].reflectance.to_array().map(f64::from))
        .collect();
    let core_patches: Vec<Patch> = live.iter().map(|&i| to_core_patch(&patches, i)).collect();
    Ok(Discretised {
        patches,
        live,
        f: f_live,
        reflectance,
        core_patches,
        channels,
        effects,
        closure,
        exposure,
        rays_cast: ff.rays_cast,
        form_factors: params.form_factors.summary(),
        reciprocity_error: ff.reciprocity_error,
        timings_ms: timings,
    })
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
    let stage = |s: &str| {
        if let Some(f) = hooks.stage {
            f(s)
        }
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
    let live = &system.live;
    let n = live.len();
    let f_live = &system.f;
    let reflectance = &system.reflectance;

    stage("transfer");
    let (m, transfer) =
        transfer_matrix(f_live, reflectance, channels, params.bounces).map_err(|e| match e {
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
    lap("transfer", &mut timings);

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

    stage("order");
    // Every concrete order is computed and its compression error estimated on sampled blocks
    // (the report lists them all); `best` then picks among none/paper/spatial.
    let live_patches = &system.core_patches;
    let dense = DenseMatrix::new(n, channels, &m);
    let order_params = OrderParams {
        seed: params.seed,
        encode: encode_params,
        ..OrderParams::default()
    };
    let candidates = order::evaluate(&OrderKind::CONCRETE, live_patches, dense, &order_params)
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
    let m = order::permute(&m, n, channels, &chosen.perm);
    lap("order", &mut timings);

    stage("encode");
    // Errors are weighed for the scene's own emitters and for runtime lights alike
    // (`ErrorWeights`), and the sparse entries chosen by that weighted error.
    let file_patches: Vec<Patch> = order::permute_rows(live_patches, &chosen.perm);
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

    stage("measure");
    let decoded = matrix.decode_dense(DecodeMode::D3d10);
    let rmse = relative_frobenius(&m, &decoded);
    let code_rmse = order::code_rms(&matrix, &m, &decoded);
    drop(decoded);
    let lighting_error = lighting_error(&m, n, channels, &matrix, &emission);
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
    lap("measure", &mut timings);

    let patch_source: Vec<u32> = chosen
        .perm
        .iter()
        .map(|&k| live[k as usize] as u32)
        .collect();
    // The runtime mesh: full-detail triangles, corner weights and direct-light samples, in
    // the file's patch numbering.
    let mut file_index = vec![None; system.patches.len()];
    for (i, &k) in patch_source.iter().enumerate() {
        file_index[k as usize] = Some(i as u32);
    }
    let mesh = crate::simplify::runtime_mesh::runtime_mesh(
        scene,
        &system.patches,
        &file_index,
        &system.exposure.buried_pieces,
    );
    let mut file = RadFile {
        patches: Cow::Owned(file_patches),
        order: Cow::Owned(chosen.perm.clone()),
        matrix,
        objects: scene
            .objects
            .iter()
            .map(|o| Cow::Owned(o.clone()))
            .collect(),
        bounces: transfer.bounces,
        patch_order: chosen.kind.patch_order().expect("a concrete order"),
        compression_rmse: Some(rmse as f32),
        lighting_error: lighting_error.map(|e| e as f32),
        report: None,
        mesh: Some(mesh),
    };
    let blocks = file.matrix.blocks.len();
    let sparse = file.matrix.sparse.bytes();
    let corrections = file.matrix.corrections.bytes();
    let corrected_blocks = file.matrix.corrections.count();
    let discretise_ms: f64 = system.timings_ms.values().sum();
    timings.insert("total", discretise_ms + t_all.elapsed().as_secs_f64() * 1e3);
    let mut report = BakeReport {
        patches: n,
        channels,
        format: format.name(),
        order: chosen.kind.name(),
        bounces: match transfer.bounces {
            Bounces::Finite(k) => serde_json::json!(k),
            Bounces::Infinite => serde_json::json!("infinite"),
        },
        bytes: Bytes {
            total: 0,
            blocks,
            sparse,
            corrections,
            corrected_blocks,
        },
        rays_cast: system.rays_cast,
        form_factors: system.form_factors,
        compression_rmse,
        compression_code_rmse,
        lighting_error,
        effects,
        closure: system.closure.clone(),
        reciprocity_error: system.reciprocity_error,
        timings_ms: timings,
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
    };
    // The report stores the file size, which depends on the report: write twice (the size
    // field has the same width both times only by luck, so measure until it is stable).
    for _ in 0..3 {
        file.report = Some(Cow::Owned(
            serde_json::to_string(&report).expect("report serialises"),
        ));
        let total = file
            .to_bytes()
            .map_err(|e| BakeError::InvalidParams(format!("internal: {e}")))?
            .len();
        if total == report.bytes.total {
            break;
        }
        report.bytes.total = total;
    }
    Ok(BakeOutput {
        file,
        report,
        patch_source,
    })
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

fn to_core_patch(patches: &Patches, i: usize) -> Patch {
    let p = &patches.patches[i];
    Patch {
        centre: p.centre.as_vec3().to_array(),
        area: p.area as f32,
        normal: p.normal.as_vec3().normalize().to_array(),
        object: p.object,
        reflectance: p.reflectance,
        emission: p.emission,
    }
}
