//! The whole bake: scene → patches → form factors → effect plan → transfer → order → encode →
//! [`RadFile`], with a report of every decision, error estimate and timing.
//!
//! [`discretise`] runs the first half (simplification, form factors, burial and closure
//! (`closure`), dark patches (`dark`)), [`bake_discretised`] the second (transfer, order,
//! encode, measure, the runtime mesh and the report (`report`)); [`bake`] runs both.

mod params;
mod report;
pub(crate) mod systems;

pub use crate::closure::ClosureReport;
pub use crate::dark::{DarkCheck, check_dark};
pub use crate::exposure::Exposure;
pub use params::{BakeParams, FormatChoice, Hooks};
pub use radiosity_runtime::{ObjectShares, SharedPatch};
pub use report::{BakeReport, Bytes, store};
pub use systems::{AUTO_ONE_MATRIX, AUTO_SYSTEM_PATCHES, SystemsChoice, SystemsReport};

use report::{BakeSummary, Measured};

use crate::BakeError;
use crate::closure::{closure_effect, escape_check};
use crate::dark::dark_patches;
use crate::effects::{self, Effect, Effects};
use crate::encode::{
    EncodeError, EncodeParams, ErrorWeights, SparseSelection, default_correction_fraction,
    default_sparse_fraction, encode_dense_with,
};
use crate::exposure::expose;
use crate::form_factor::matrix::{Exchange, dense_live_sparse};
use crate::form_factor::{
    FAR_RAYS, FormFactorSummary, FormFactors, MAX_EXACT_PIECES, NEAR_RAYS, SparseFormFactors,
    Visibility,
};
use crate::order::{self, Candidate, DenseMatrix, OrderKind, OrderParams};
use crate::patch::Patches;
use crate::scene::Scene;
use crate::simplify::simplify;
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
    /// Form factors among the live patches (closure-corrected when the scene is closed);
    /// empty where they are kept as `sparse` rows.
    pub f: Dense,
    /// The same as sparse rows (f32), in place of `f`, where the bake cuts the level into
    /// systems and the form factors are ray-cast ([`SystemsChoice`]).
    pub sparse: Option<SparseFormFactors>,
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
    /// Direct-light points of each patch (simplification order): [`BakeParams::direct_points`],
    /// or [`BakeParams::shadow_points`] where a shadow may cross it
    /// ([`crate::shadow_points`]), as `exposure` marked them buried.
    pub direct_points: Vec<u32>,
    /// Per patch (simplification order), its shared objects' own gather rows
    /// ([`crate::part_rows`]), their entries' patches renumbered to live indices and their
    /// weights scaled as the closure scaled the patch's row.
    pub(crate) part_rows: Vec<Vec<crate::part_rows::PartRow>>,
    /// Shadow rays cast for the form factors.
    pub rays_cast: u64,
    /// The form-factor settings used.
    pub form_factors: FormFactorSummary,
    /// Largest reciprocity error of F.
    pub reciprocity_error: f64,
    /// Each patch's identity under a plan ([`crate::patch::identity::patch_keys`]); empty
    /// without one.
    pub keys: Vec<[u8; 16]>,
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
///
/// The system's F is handed to the transfer, which solves its last channel in F's own buffer:
/// one n² f64 matrix less at the peak than [`bake_discretised`], the same bytes.
pub fn bake(scene: &Scene, params: &BakeParams, hooks: Hooks<'_>) -> Result<BakeOutput, BakeError> {
    let mut system = discretise(scene, params, hooks)?;
    let f = std::mem::replace(&mut system.f, Dense::new(0, Vec::new()));
    let sparse = system.sparse.take().map(Cow::Owned);
    second_half(scene, &system, Cow::Owned(f), sparse, params, hooks)
}

/// The first half of [`bake`]: simplify, plan, form factors, closure, dark patches (uses
/// `params.voxel`, `params.form_factors` and `params.closure_tolerance`).
pub fn discretise(
    scene: &Scene,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<Discretised, BakeError> {
    discretise_with(scene, params, hooks, None)
}

/// [`discretise`], with the burial survey and the ray-cast hit counts `given` (a plan's
/// shards computed them, [`crate::plan`]) in place of its own.
pub(crate) fn discretise_with(
    scene: &Scene,
    params: &BakeParams,
    hooks: Hooks<'_>,
    given: Option<crate::plan::GivenRows>,
) -> Result<Discretised, BakeError> {
    let most = crate::simplify::runtime_mesh::MAX_DIRECT_POINTS;
    if !(1..=most).contains(&params.direct_points) {
        return Err(BakeError::InvalidParams(format!(
            "direct-light points per patch must be 1 to {most}, not {}",
            params.direct_points
        )));
    }
    if !(1..=most).contains(&params.shadow_points) {
        return Err(BakeError::InvalidParams(format!(
            "direct-light points per patch a shadow may cross must be 1 to {most}, not {}",
            params.shadow_points
        )));
    }
    let mut timings = BTreeMap::new();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, timings: &mut BTreeMap<&'static str, f64>| {
        timings.insert(name, clock.elapsed().as_secs_f64() * 1e3);
        clock = Instant::now();
    };

    hooks.start("simplify")?;
    let mut patches = simplify(scene, &params.voxel)?;
    let keys = match given {
        Some(_) => crate::patch::identity::seed_patches(scene, &mut patches),
        None => Vec::new(),
    };
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
    // A plan's rows are always ray-cast, so they always have the BVH, robust as the shards'
    // ([`crate::geometry::Occluders::robust`]).
    let occluders = match given {
        Some(_) => Some(scene.occluders().robust()),
        None => occlusion.on.then(|| scene.occluders()),
    };
    effects.insert("occlusion", occlusion);
    effects.insert("emission", effects::plan_emission(&patches));
    lap("plan", &mut timings);

    hooks.start("form factors")?;
    let (burial, (mut f, ff)) = match (given, occluders.as_ref()) {
        (Some(given), Some(occ)) => {
            lap("burial", &mut timings);
            given.exchange(&patches, occ)?
        }
        _ => {
            // Which points other objects bury, asked once for the ray-cast rows and the
            // closure.
            let burial = occluders
                .as_ref()
                .map(|o| crate::form_factor::burial::survey(&patches, o))
                .unwrap_or_default();
            lap("burial", &mut timings);
            let go_on = |done: usize, total: usize| hooks.report(done, total);
            let f = crate::form_factor::matrix::form_factors(
                &patches,
                occluders.as_ref(),
                &ffp,
                &burial,
                &go_on,
                params.systems.count_for(patches.len()).is_some(),
            );
            (burial, f)
        }
    };
    // The rows skipped after a cancellation leave the matrix incomplete: it goes no further.
    hooks.check()?;
    lap("form_factors", &mut timings);
    form_factor_effects(&ff, ffp.exact_pieces, &mut effects);
    let n_all = patches.len();
    let full_areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    // Of F as the form factors left it (the dense matrix measured its own).
    let reciprocity_error = match &f {
        Exchange::Dense(_) => ff.reciprocity_error,
        Exchange::Sparse(_) => f.reciprocity_error(&full_areas),
    };
    // The checks below cast rays even where nothing occludes (no BVH was built for F: a sheet
    // above a floor blocks no pair of patches, yet shadows the floor from a sun): then one is
    // built, once, when a check first needs it.
    let built = std::cell::OnceCell::new();
    let checks_occ = || {
        occluders
            .as_ref()
            .unwrap_or_else(|| built.get_or_init(|| scene.occluders()))
    };
    let objects: Vec<u32> = scene.triangles.iter().map(|t| t.object).collect();
    let (direct_points, shadowed) = crate::shadow_points::direct_point_counts(
        &patches,
        checks_occ(),
        &objects,
        params.direct_points,
        params.shadow_points,
    );
    effects.insert("shadow_points", shadowed);
    let exposure = expose(
        &mut patches,
        occluders.as_ref(),
        &mut f,
        &burial,
        &direct_points,
    );
    let areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    let escape = |live: &[bool]| escape_check(&patches, checks_occ(), live, params.seed);
    let raw_sums: Vec<f64> = (0..n_all).map(|i| f.row_sum(i)).collect();
    let (closure, closed) = closure_effect(
        &patches,
        &mut f,
        &areas,
        &exposure,
        params.closure_tolerance,
        &escape,
    );
    effects.insert("closed", closed);
    lap("closure", &mut timings);

    // Patches that see nothing (row of F zero) receive and give no indirect light. Those
    // buried whole leave the matrix; the others stay, with a zero row and column: they face
    // the void (a roof under the open sky), and direct light from a lights file still reaches
    // them and their objects' figures (a tower's roof dropped here took its whole top out of
    // the tower's mean irradiance: −100% on that face in an outdoor scene).
    let zero: Vec<usize> = (0..n_all).filter(|&i| f.sees_nothing(i)).collect();
    let whole = |i: usize| exposure.share.get(i).is_some_and(|&b| b >= 1.0);
    let live: Vec<usize> = (0..n_all)
        .filter(|&i| !(whole(i) && zero.binary_search(&i).is_ok()))
        .collect();
    let dark_effect = if zero.is_empty() {
        Effect::new(false, "every patch sees some other patch: none dropped")
    } else {
        // An independent look at the decision: hemisphere rays from the dark patches.
        let buried = zero.iter().filter(|&&i| whole(i)).count();
        dark_patches(
            &mut patches,
            checks_occ(),
            &zero,
            buried,
            &full_areas,
            params.seed,
        )
    };
    effects.insert("dark_patches", dark_effect);
    // Each shared patch's parts gather through rows of their own, scaled as the closure
    // scaled their patch's row.
    let mut live_at = vec![u32::MAX; n_all];
    for (k, &i) in live.iter().enumerate() {
        live_at[i] = k as u32;
    }
    // Each patch's direct-light samples as the runtime mesh will hold them: the points not
    // buried, else the patch's centre.
    let any_shared = exposure.shared.iter().any(|s| s.len() >= 2);
    let occ_for_parts = occluders.as_ref().filter(|_| any_shared);
    let samples: Vec<Vec<(glam::DVec3, u32)>> = (0..n_all)
        .filter(|_| occ_for_parts.is_some())
        .map(|i| {
            let marks = exposure.buried_points.get(i).map_or(&[][..], Vec::as_slice);
            let mut v: Vec<(glam::DVec3, u32)> = crate::simplify::runtime_mesh::direct_points(
                patches.pieces_of(i),
                direct_points[i],
            )
            .iter()
            .enumerate()
            .filter(|(k, _)| marks.get(*k) != Some(&true))
            .map(|(_, d)| (d.position, d.object))
            .collect();
            if v.is_empty() {
                let p = &patches.patches[i];
                v.push((p.centre, p.object));
            }
            v
        })
        .collect();
    let part_rows: Vec<Vec<crate::part_rows::PartRow>> = match occ_for_parts {
        Some(occ) => {
            crate::part_rows::part_rows(&patches, occ, &exposure.shared, &samples, params.seed)
                .into_iter()
                .enumerate()
                .map(|(i, rows)| {
                    let after = f.row_sum(i);
                    let scale = if raw_sums[i] > 0.0 {
                        after / raw_sums[i]
                    } else {
                        1.0
                    };
                    rows.into_iter()
                        .map(|mut r| {
                            r.entries
                                .retain(|&(j, _, _)| live_at[j as usize] != u32::MAX);
                            for e in &mut r.entries {
                                e.0 = live_at[e.0 as usize];
                            }
                            r.each *= scale;
                            r
                        })
                        .collect()
                })
                .collect()
        }
        None => vec![Vec::new(); n_all],
    };
    lap("part_rows", &mut timings);
    // Where no patch sees another (one object, a convex one, a single sheet), no light travels
    // between surfaces: the transfer is zero and the file carries everything else (patches,
    // mesh, direct light, probes), so that one code path serves every asset.
    let (f_live, sparse) = match f {
        Exchange::Dense(d) => (crate::form_factor::matrix::live_rows_dense(d, &live), None),
        sparse => (Dense::new(0, Vec::new()), Some(sparse.live_sparse(&live))),
    };
    let reflectance: Vec<[f64; 3]> = live
        .iter()
        .map(|&i| patches.patches[i].reflectance.to_array().map(f64::from))
        .collect();
    let core_patches: Vec<Patch> = live.iter().map(|&i| to_core_patch(&patches, i)).collect();
    Ok(Discretised {
        patches,
        live,
        f: f_live,
        sparse,
        reflectance,
        core_patches,
        channels,
        effects,
        closure,
        exposure,
        direct_points,
        part_rows,
        rays_cast: ff.rays_cast,
        keys,
        form_factors: params.form_factors.summary(),
        reciprocity_error,
        timings_ms: timings,
    })
}

/// The `flat_sites` and `clustered_pairs` decisions the form factors made, with their reasons.
fn form_factor_effects(ff: &FormFactors, budget: usize, effects: &mut Effects) {
    let pieces = ff.pieces;
    let cast = ff.rays_per_patch > 0;
    let why = if cast {
        format!(
            "{pieces} pieces in all (over {budget}): every patch cast {} cosine-weighted rays against the full-detail triangles, hits counted per patch and pooled over both sides of each pair (the cost follows the patches, not the pieces)",
            ff.rays_per_patch
        )
    } else {
        format!("{pieces} pieces in all (at most {budget}): form factors integrated")
    };
    effects.insert("ray_cast", Effect::new(cast, why));
    let why = if cast {
        "the form factors were ray-cast".to_owned()
    } else if ff.sites > 0 {
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
    let why = if cast {
        "the form factors were ray-cast".to_owned()
    } else if ff.clustered_pairs > 0 {
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
    let report = report::report(scene, system, &file, summary);
    let report = report::store(&mut file, report)?;
    let out = BakeOutput {
        file,
        report,
        patch_source,
    };
    let out = crate::probes::attach(out, &params.probes, params.probe_rank, hooks)?;
    crate::sky::attach(out, params.sky, hooks)
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
