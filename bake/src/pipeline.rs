//! The whole bake: scene → patches → form factors → effect plan → transfer → order → encode →
//! [`RadFile`], with a report of every decision, error estimate and timing.

use crate::BakeError;
use crate::bvh::Occluders;
use crate::effects::{self, Effect, Effects};
use crate::encode::EncodeError;
use crate::encode::{
    EncodeParams, ErrorWeights, SparseSelection, default_correction_fraction,
    default_sparse_fraction, encode_dense_with,
};
use crate::form_factor::{
    FAR_RAYS, FormFactorParams, FormFactorSummary, MAX_EXACT_PIECES, NEAR_RAYS, Progress,
    Visibility, form_factors,
};
use crate::order::{self, Candidate, DenseMatrix, OrderKind, OrderParams};
use crate::row_check::{
    BURIED_POINTS, ESCAPE_LIMIT, Escape, buried_share, check_dark, escape_check,
};
use crate::scene::Scene;
use crate::transfer::{
    BounceSpec, Dense, TransferError, cap_row_sums, closure_of_sums, enforce_closure,
    transfer_matrix,
};
use crate::voxel::{Patches, VoxelParams, simplify};
use radiosity_core::{
    Bounces, DecodeMode, Format, Gather, Patch, RadFile, ReferenceGather, Rgb, TransferMatrix,
};
use rayon::prelude::*;
use serde::Serialize;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::time::Instant;

/// Which storage format to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FormatChoice {
    /// BC1 for colour scenes, BC4 for grey ones (BC1 cannot store a single channel).
    #[default]
    Auto,
    /// This format (BC1 on a grey scene is an error).
    Fixed(Format),
}

/// Everything a bake can be told. Presets: [`BakeParams::fast`], [`BakeParams::high_quality`].
#[derive(Clone, Debug, PartialEq)]
pub struct BakeParams {
    /// Simplification: target patch count or voxel size. More patches: finer lighting, n²
    /// memory and n³ transfer time.
    pub voxel: VoxelParams,
    /// Form-factor quadrature and visibility rays (rays are switched off by the effect plan when
    /// nothing can occlude).
    pub form_factors: FormFactorParams,
    /// Bounces carried by M.
    pub bounces: BounceSpec,
    /// Storage format.
    pub format: FormatChoice,
    /// Patch numbering (rows and columns together) before compression.
    pub order: OrderKind,
    /// Quantiser range, tile size, BC1 fit (its `format` and `sparse_fraction` are ignored: see
    /// `format` and `sparse_fraction`).
    pub encode: EncodeParams,
    /// Fraction of entries kept exact; `None` for [`default_sparse_fraction`] of the format
    /// (a fixed share of the block bytes).
    pub sparse_fraction: Option<f32>,
    /// Share of block positions given a block correction; `None` for
    /// [`default_correction_fraction`] of the format (a fixed share of the block bytes).
    pub corrections: Option<f32>,
    /// A scene is treated as closed when every row of F sums to 1 within this; its rows are then
    /// rebalanced to sum to exactly 1 (the correction is reported).
    pub closure_tolerance: f64,
    /// Seed of the random order.
    pub seed: u64,
}

impl Default for BakeParams {
    fn default() -> Self {
        Self {
            voxel: VoxelParams::default(),
            form_factors: FormFactorParams::default(),
            bounces: BounceSpec::default(),
            format: FormatChoice::Auto,
            order: OrderKind::Best,
            encode: EncodeParams::default(),
            sparse_fraction: None,
            corrections: None,
            closure_tolerance: 0.05,
            seed: 1,
        }
    }
}

impl BakeParams {
    /// Coarse and quick: previews.
    pub fn fast() -> Self {
        Self {
            voxel: VoxelParams::fast(),
            form_factors: FormFactorParams::fast(),
            order: OrderKind::Spatial,
            ..Self::default()
        }
    }

    /// Fine and slow: final bakes.
    pub fn high_quality() -> Self {
        Self {
            voxel: VoxelParams::high_quality(),
            form_factors: FormFactorParams::high_quality(),
            encode: EncodeParams::high_quality(Format::Bc1),
            ..Self::default()
        }
    }
}

/// Callbacks for a front end: stage names as they start, and form-factor progress.
#[derive(Clone, Copy, Default)]
pub struct Hooks<'a> {
    /// Called with a stage name when it starts.
    pub stage: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Form-factor rows done / total.
    pub progress: Option<Progress<'a>>,
}

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
    let mesh = crate::mesh::runtime_mesh(
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

/// What [`expose`] found: how much of the surface is buried under other objects.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Exposure {
    /// Patches partly buried (their areas and rows of F changed).
    pub partly: usize,
    /// Buried share of each patch's area (simplification order).
    pub share: Vec<f64>,
    /// Patches wholly buried (their rows and columns of F zeroed).
    pub wholly: usize,
    /// Buried area of each object (file object order).
    pub buried_area: Vec<f64>,
    /// Per piece (`Patches::pieces`): whether its centroid is buried (so it lends no
    /// direct-light sample to the runtime).
    pub buried_pieces: Vec<bool>,
}

/// Takes out of every patch the share of its area that another object buries (a floor under a
/// block that rests on it, a face pressed against a wall): no light reaches or leaves that
/// part, so it is not surface. A patch with exposed share `e` keeps the area `e·A` and the row
/// `F/e`, the mean over its exposed part; `A·F_ij` and the column are unchanged, so
/// reciprocity holds. Without this a partly buried patch spreads its mean radiosity, dimmed by
/// the dark part, over only the exposed part: energy lost at every bounce (ARCHITECTURE.md,
/// "Buried surface": a closed room at ρ = 0.999 with 1% of its area buried gave a quarter of
/// the furnace's light). A wholly buried patch's row and column are zeroed (it is dropped as
/// dark). Nothing is done where nothing occludes (`occ` is `None`).
fn expose(patches: &mut Patches, occ: Option<&Occluders>, f: &mut Dense, seed: u64) -> Exposure {
    let objects = patches
        .patches
        .iter()
        .map(|p| p.object as usize + 1)
        .max()
        .unwrap_or(0);
    let mut exposure = Exposure {
        buried_area: vec![0.0; objects],
        buried_pieces: vec![false; patches.pieces.len()],
        ..Exposure::default()
    };
    let Some(occ) = occ else {
        return exposure;
    };
    exposure.share = (0..patches.len())
        .into_par_iter()
        .map(|i| buried_share(patches, occ, i, seed))
        .collect();
    let n = f.n;
    for (i, &b) in exposure.share.iter().enumerate() {
        if b <= 0.0 {
            continue;
        }
        let p = &mut patches.patches[i];
        exposure.buried_area[p.object as usize] += b * p.area;
        let e = 1.0 - b;
        if e <= 0.0 {
            exposure.wholly += 1;
            for j in 0..n {
                f.values[i * n + j] = 0.0;
                f.values[j * n + i] = 0.0;
            }
            continue;
        }
        exposure.partly += 1;
        p.area *= e;
        for v in &mut f.values[i * n..(i + 1) * n] {
            *v /= e;
        }
        for k in p.pieces.clone() {
            // The point the runtime samples direct light at (`mesh::runtime_mesh`).
            let q = &patches.pieces[k];
            exposure.buried_pieces[k] = occ.buried(q.polygon.centroid(), q.normal);
        }
    }
    exposure
}

/// Decides whether the scene is closed, corrects `f` (of exposed patches, [`expose`]) to
/// match, and says why: a closed scene's rows are rebalanced to sum to 1, an open scene's rows
/// above 1 are capped where they would create energy.
fn closure_effect(
    patches: &Patches,
    f: &mut Dense,
    areas: &[f64],
    exposure: &Exposure,
    params: &BakeParams,
    escape: &dyn Fn(&[bool]) -> Escape,
) -> (ClosureReport, Effect) {
    let tol = params.closure_tolerance;
    // A partly buried patch's row is F's mean over its whole area divided by the exposed
    // share, two estimates with their own errors: a patch a few per cent exposed carries both
    // magnified (on a room with a block resting on its floor those rows range over [0.85,
    // 1.17] at 1368 patches; 0.68 to 1.86 before shadow rays started across their quadrature
    // leaf). Those rows are rebalanced or capped with the rest, but only the others say
    // whether light escapes. Among those, a patch whose buried sliver the first look
    // (`row_check::BURIED_FIRST`) misses keeps a row short by that sliver (0.955–0.968 at
    // 4358 patches on the same room with a 32-point look, 0.992 at worst with 64).
    let partly = |i: usize| exposure.share.get(i).is_some_and(|&b| b > 0.0 && b < 1.0);
    let sums: Vec<f64> = (0..f.n).map(|i| f.row(i).iter().sum()).collect();
    let rest = (0..f.n).filter(|&i| !partly(i) && sums[i] > 0.0);
    let closure = if rest.clone().next().is_some() {
        closure_of_sums(rest.map(|i| sums[i]), tol)
    } else {
        closure_of_sums(sums.iter().copied(), tol)
    };
    let mut report = ClosureReport {
        min_row_sum: closure.min_row_sum,
        max_row_sum: closure.max_row_sum,
        max_row_patch: (0..f.n).max_by(|&a, &b| sums[a].total_cmp(&sums[b])),
        correction: 0.0,
        escaped: None,
    };
    let mut range = format!(
        "row sums of F in [{:.5}, {:.5}]",
        closure.min_row_sum, closure.max_row_sum
    );
    if exposure.partly > 0 {
        let buried: f64 = exposure.buried_area.iter().sum();
        let (lo, hi) = (0..f.n)
            .filter(|&i| partly(i))
            .fold((f64::INFINITY, 0f64), |(lo, hi), i| {
                (lo.min(sums[i]), hi.max(sums[i]))
            });
        report.max_row_sum = report.max_row_sum.max(hi);
        range += &format!(
            " ({} patches partly buried under other objects, {:.4} of the area, by {BURIED_POINTS} points each: their rows, over the exposed part, in [{lo:.3}, {hi:.3}])",
            exposure.partly,
            buried / (areas.iter().sum::<f64>() + buried)
        );
    }
    // Rows within the tolerance can still hide an opening smaller than it: the geometry has
    // the last word (`escape_check`).
    let mut opening = String::new();
    let closed = closure.closed
        && {
            let live: Vec<bool> = sums.iter().map(|s| *s > 0.0).collect();
            let e = escape(&live);
            report.escaped = Some(e.share());
            range += &format!(
                "; {} of {} hemisphere rays from the patches leave the scene",
                e.escaped, e.rays
            );
            if e.share() > ESCAPE_LIMIT {
                opening = format!(
                    " through an opening (more than {ESCAPE_LIMIT:.0e} of the rays), though every row is within {tol} of 1"
                );
            }
            e.share() <= ESCAPE_LIMIT
        };
    if closed {
        enforce_closure(f, areas);
        // The largest relative change of a row sum, apart from and among the partly buried.
        let (mut rest, mut buried) = (0f64, 0f64);
        for (i, b) in sums.iter().enumerate().filter(|(_, b)| **b > 0.0) {
            let change = (f.row(i).iter().sum::<f64>() - b).abs() / b;
            let m = if partly(i) { &mut buried } else { &mut rest };
            *m = m.max(change);
        }
        report.correction = rest;
        let why = format!(
            "{range}: closed; rebalanced to 1 keeping reciprocity (largest correction {rest:.2e}{})",
            if exposure.partly > 0 {
                format!(", {buried:.2e} on the partly buried")
            } else {
                String::new()
            }
        );
        return (report, Effect::new(true, why));
    }
    // Open. Rows above 1 send out more light than the patch gives: beyond the tolerance that
    // is coincident faces (both seen through the same solid angle), scaled down to 1 keeping
    // reciprocity. Excesses within the tolerance are quadrature error and stay (capping the
    // Cornell box's 1% near-field excess raised its BC1 lighting error from 3.8% to 5.1%),
    // unless some row's reflected light would then reach 1: the transfer could not converge.
    if report.max_row_sum > 1.0 + tol || largest_gain(f, patches) >= 1.0 {
        report.correction = cap_row_sums(f, areas);
    }
    let why = format!(
        "{range}: light escapes{opening}; {}",
        if report.correction > 0.0 {
            format!(
                "rows above 1 scaled down to 1 keeping reciprocity (largest correction {:.2e})",
                report.correction
            )
        } else {
            "no closure correction".to_owned()
        }
    );
    (report, Effect::new(false, why))
}

/// The largest row sum of `F^C` (`Σ_j F_ij ρ_j`, over channels): a bound of the share of
/// light kept per bounce.
fn largest_gain(f: &Dense, patches: &Patches) -> f64 {
    let rho: Vec<[f64; 3]> = patches
        .patches
        .iter()
        .map(|p| p.reflectance.to_array().map(f64::from))
        .collect();
    (0..f.n)
        .map(|i| {
            (0..3)
                .map(|c| {
                    f.row(i)
                        .iter()
                        .zip(&rho)
                        .map(|(v, r)| v * r[c])
                        .sum::<f64>()
                })
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

/// The `dark_patches` decision for a non-empty `dark` list, of which the burial test buried
/// `buried` whole ([`expose`]), checked by hemisphere rays ([`check_dark`]); a dark patch whose
/// rays land on patches also adds a warning to `patches`.
fn dark_patches(
    patches: &mut Patches,
    occ: &Occluders,
    dark: &[usize],
    buried: usize,
    areas: &[f64],
    seed: u64,
) -> Effect {
    let check = check_dark(patches, occ, dark, seed);
    let verdict = if check.seeing > 0 {
        patches.warnings.push(format!(
            "{} of {} dark patches send light to other patches by hemisphere rays (up to {:.3} of it, patch {}), though their form factors are zero: that light is lost",
            check.seeing,
            check.checked,
            check.largest_share,
            check.worst_patch.unwrap_or(0)
        ));
        format!("; {} contradict it: see the warnings)", check.seeing)
    } else {
        format!(
            "): {} lie under or inside other objects (their rays meet back faces), {} face the void",
            check.covered,
            check.checked - check.covered
        )
    };
    // Hemisphere rays pass through a face they start on, so a patch lying face to face against
    // a part whose other side looks out of the room "faces the void" to them.
    let buried = if buried > 0 {
        format!(
            "; {buried} of the {} were buried whole (inside another object or face to face against one)",
            dark.len()
        )
    } else {
        String::new()
    };
    let dark_area: f64 = dark.iter().map(|&i| areas[i]).sum();
    Effect::new(
        true,
        format!(
            "{} of {} patches ({:.3} of the area) see nothing and are dropped from the matrix; hemisphere rays from {} of them land on a patch at most {:.3} of the time ({} rays each{verdict}{buried}",
            dark.len(),
            patches.len(),
            dark_area / areas.iter().sum::<f64>(),
            check.checked,
            check.largest_share,
            check.rays,
        ),
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
