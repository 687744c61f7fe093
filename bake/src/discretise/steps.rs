//! The discretisation's steps, in the order [`super::discretise`] runs them.

use super::{DiscretiseParams, Discretised, GivenRows, to_core_patch};
use crate::BakeError;
use crate::closure::{ClosureReport, closure_effect, escape_check};
use crate::dark_patches::dark_patches;
use crate::effect_plan::{self, Effect, Effects};
use crate::exposure::{Exposure, expose};
use crate::form_factor::burial::{EXPOSED, survey};
use crate::form_factor::matrix::Dense;
use crate::form_factor::matrix::{Exchange, live_rows_dense};
use crate::form_factor::{
    FAR_RAYS, FormFactorParams, FormFactors, MAX_EXACT_PIECES, NEAR_RAYS, RAYS_PER_PIECE_PAIR,
    Visibility,
};
use crate::geometry::Occluders;
use crate::hooks::{Hooks, Laps};
use crate::part_rows::PartRow;
use crate::patch::Patches;
use crate::scene::Scene;
use crate::simplify::runtime_mesh::{MAX_DIRECT_POINTS, direct_points};
use crate::simplify::{Resolution, VoxelParams};
use glam::DVec3;
use std::cell::OnceCell;

/// Refuses direct-light point counts the runtime mesh cannot hold.
pub(super) fn check_points(params: &DiscretiseParams) -> Result<(), BakeError> {
    let most = MAX_DIRECT_POINTS;
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
    Ok(())
}

/// The effect plan and what follows from it: the decisions so far, the channels, the
/// form-factor settings and the ray tree the form factors cast against (none where nothing
/// occludes). The checks after the form factors cast rays even where nothing occludes (a
/// sheet above a floor blocks no pair of patches, yet shadows the floor from a sun): then a
/// tree is built, once, when a check first needs it ([`Planned::checks`]).
pub(super) struct Planned {
    pub(super) effects: Effects,
    pub(super) channels: usize,
    pub(super) ffp: FormFactorParams,
    pub(super) occluders: Option<Occluders>,
    built: OnceCell<Occluders>,
}

impl Planned {
    /// The ray tree of the checks: the form factors' own, else one built on first use.
    fn checks<'a>(&'a self, scene: &Scene) -> &'a Occluders {
        self.occluders
            .as_ref()
            .unwrap_or_else(|| self.built.get_or_init(|| scene.occluders()))
    }
}

/// Decides colour, occlusion and emission from the scene and its patches.
pub(super) fn plan_effects(
    scene: &Scene,
    patches: &Patches,
    params: &DiscretiseParams,
    planned_bake: bool,
) -> Planned {
    let mut effects = Effects::new();
    let colour = effect_plan::plan_colour(patches);
    let channels = if colour.on { 3 } else { 1 };
    effects.insert("colour", colour);
    let occlusion = effect_plan::plan_occlusion(scene);
    let mut ffp = params.form_factors;
    if !occlusion.on {
        ffp.visibility = Visibility::Off;
    }
    // A plan's rows are always ray-cast, so they always have the BVH, robust as the shards'
    // ([`crate::geometry::Occluders::robust`]).
    let occluders = if planned_bake {
        Some(scene.occluders().robust())
    } else {
        occlusion.on.then(|| scene.occluders())
    };
    effects.insert("occlusion", occlusion);
    effects.insert("emission", effect_plan::plan_emission(patches));
    effects.insert("surroundings", effect_plan::plan_surroundings(patches));
    effects.insert("sight", effect_plan::plan_sight(patches));
    Planned {
        effects,
        channels,
        ffp,
        occluders,
        built: OnceCell::new(),
    }
}

/// With a target patch count (`--patches N`) and occluders: the burial survey, and where so
/// many patches lie buried whole under other objects that fewer than `N` (less the target's
/// tolerance) would stay in the matrix, the scene simplified again for `N` live ones (the
/// aim scaled by the target over the live count, up to [`RETARGETS`] times, each try surveyed
/// again, the one nearest the target kept). Overlapping solids, as a BIM
/// export has them, bury a third of some buildings' surface: a house asked for 4096 patches
/// had 2413 left. The `buried_patches` effect says what was done.
pub(super) fn survey_for_target(
    scene: &Scene,
    patches: &mut Patches,
    plan: &mut Planned,
    params: &DiscretiseParams,
) -> Result<Option<Vec<Vec<u32>>>, BakeError> {
    let (Resolution::TargetPatches(target), Some(occ)) =
        (params.voxel.resolution, plan.occluders.as_ref())
    else {
        return Ok(None);
    };
    let burial = survey(patches, occ);
    let buried = buried_whole(&burial);
    let live = patches.len() - buried;
    let floor = (1.0 - params.voxel.tolerance) * target as f64;
    if buried == 0 || live as f64 >= floor || live == 0 {
        return Ok(Some(burial));
    }
    // The buried share moves with the grid (a finer one may bury more whole patches), so
    // the aim is corrected up to RETARGETS times and the try nearest the target kept.
    let before = (patches.len(), buried);
    let mut best: Option<(Patches, Vec<Vec<u32>>, usize)> = None;
    let mut aim = target as f64 * patches.len() as f64 / live as f64;
    let mut tries = Vec::new();
    for _ in 0..RETARGETS {
        let voxel = VoxelParams {
            resolution: Resolution::TargetPatches(aim.round() as usize),
            ..params.voxel
        };
        let next = crate::simplify::simplify(scene, &voxel)?;
        let burial = survey(&next, occ);
        let live = next.len() - buried_whole(&burial);
        tries.push(format!("{} aiming at {:.0} ({live} live)", next.len(), aim));
        let miss = |l: usize| (l as f64 - target as f64).abs();
        if best.as_ref().is_none_or(|b| miss(live) < miss(b.2)) {
            best = Some((next, burial, live));
        }
        if (live as f64 - target as f64).abs() <= params.voxel.tolerance * target as f64
            || live == 0
        {
            break;
        }
        aim *= target as f64 / live as f64;
    }
    let Some((next, next_burial, live)) = best else {
        return Ok(Some(burial));
    };
    if live.abs_diff(target) >= (before.0 - before.1).abs_diff(target) {
        return Ok(Some(burial));
    }
    *patches = next;
    plan.effects
        .insert("colour", effect_plan::plan_colour(patches));
    plan.effects
        .insert("emission", effect_plan::plan_emission(patches));
    plan.effects
        .insert("surroundings", effect_plan::plan_surroundings(patches));
    plan.effects
        .insert("sight", effect_plan::plan_sight(patches));
    plan.effects.insert(
        "buried_patches",
        Effect::new(
            true,
            format!(
                "{} of {} patches lay buried whole under other objects, which would have left {} of the {target} asked for: simplified again, {}; kept {} patches, {live} live",
                before.1,
                before.0,
                before.0 - before.1,
                tries.join(", "),
                patches.len(),
            ),
        ),
    );
    Ok(Some(next_burial))
}

/// Simplifications tried at most for a target of live patches ([`survey_for_target`]).
const RETARGETS: usize = 3;

/// Patches whose every surveyed start another object buries ([`survey`]).
fn buried_whole(burial: &[Vec<u32>]) -> usize {
    burial
        .iter()
        .filter(|seen| !seen.is_empty() && seen.iter().all(|&o| o != EXPOSED))
        .count()
}

/// The burial survey and F, as the rows were given or computed here.
pub(super) struct Rows {
    burial: Vec<Vec<u32>>,
    f: Exchange,
    pub(super) summary: FormFactors,
}

/// The burial survey (which points other objects bury, asked once for the ray-cast rows and
/// the exposure) and the form factors: `given` by a plan's shards, else computed.
pub(super) fn form_factors(
    patches: &Patches,
    plan: &Planned,
    params: &DiscretiseParams,
    given: Option<GivenRows>,
    hooks: Hooks<'_>,
    laps: &mut Laps,
    surveyed: Option<Vec<Vec<u32>>>,
) -> Result<Rows, BakeError> {
    if let (Some(given), Some(occ)) = (given, plan.occluders.as_ref()) {
        laps.lap("burial");
        let (burial, (f, summary)) = given.exchange(patches, occ)?;
        return Ok(Rows { burial, f, summary });
    }
    let burial = match surveyed {
        Some(b) => b,
        None => plan
            .occluders
            .as_ref()
            .map(|o| survey(patches, o))
            .unwrap_or_default(),
    };
    laps.lap("burial");
    let go_on = |done: usize, total: usize| hooks.report(done, total);
    let (f, summary) = crate::form_factor::matrix::form_factors(
        patches,
        plan.occluders.as_ref(),
        &plan.ffp,
        &burial,
        &go_on,
        params.systems.count_for(patches.len()).is_some(),
    );
    Ok(Rows { burial, f, summary })
}

/// The `ray_cast`, `flat_sites` and `clustered_pairs` decisions the form factors made, with
/// their reasons.
pub(super) fn form_factor_effects(ff: &FormFactors, budget: usize, effects: &mut Effects) {
    let pieces = ff.pieces;
    let cast = ff.rays_per_patch > 0;
    let why = if cast {
        let because = if pieces > budget {
            format!("{pieces} pieces in all (over {budget})")
        } else {
            format!(
                "{pieces} pieces in all: integrating their {:.1e} piece pairs would cost about {:.0}× casting the rays",
                ff.piece_pairs,
                ff.piece_pairs * RAYS_PER_PIECE_PAIR
                    / (ff.n as f64 * f64::from(ff.rays_per_patch)).max(1.0)
            )
        };
        format!(
            "{because}: every patch cast {} cosine-weighted rays against the full-detail triangles, hits counted per patch and pooled over both sides of each pair (the cost follows the patches, not the pieces)",
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

/// F as the burial and the closure corrected it, with what they measured.
pub(super) struct Corrected {
    patches: Patches,
    f: Exchange,
    exposure: Exposure,
    direct_points: Vec<u32>,
    closure: ClosureReport,
    /// Each patch's row sum of F before the burial and the closure.
    raw_sums: Vec<f64>,
    /// Each patch's area before the burial.
    full_areas: Vec<f64>,
    reciprocity_error: f64,
    rays_cast: u64,
    /// The patches kept in the matrix ([`drop_dark`]).
    live: Vec<usize>,
}

/// Direct-light points, buried surface and closure: each patch's direct-light point count
/// (more where a shadow may cross it), the share other objects bury taken out of its area and
/// row, then the closure's decision and correction of F.
pub(super) fn correct(
    scene: &Scene,
    mut patches: Patches,
    rows: Rows,
    plan: &mut Planned,
    params: &DiscretiseParams,
) -> Corrected {
    let Rows {
        burial,
        mut f,
        summary,
    } = rows;
    let n_all = patches.len();
    let full_areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    // Of F as the form factors left it (the dense matrix measured its own).
    let reciprocity_error = match &f {
        Exchange::Dense(_) => summary.reciprocity_error,
        Exchange::Sparse(_) => f.reciprocity_error(&full_areas),
    };
    let objects: Vec<u32> = scene.triangles.iter().map(|t| t.object).collect();
    let (direct_points, shadowed) = crate::shadow_points::direct_point_counts(
        &patches,
        plan.checks(scene),
        &objects,
        params.direct_points,
        params.shadow_points,
    );
    plan.effects.insert("shadow_points", shadowed);
    let exposure = expose(
        &mut patches,
        plan.occluders.as_ref(),
        &mut f,
        &burial,
        &direct_points,
    );
    let areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    let escape = |live: &[bool]| escape_check(&patches, plan.checks(scene), live, params.seed);
    let raw_sums: Vec<f64> = (0..n_all).map(|i| f.row_sum(i)).collect();
    let (closure, closed) = closure_effect(
        &patches,
        &mut f,
        &areas,
        &exposure,
        params.closure_tolerance,
        &escape,
    );
    plan.effects.insert("closed", closed);
    Corrected {
        patches,
        f,
        exposure,
        direct_points,
        closure,
        raw_sums,
        full_areas,
        reciprocity_error,
        rays_cast: summary.rays_cast,
        live: Vec::new(),
    }
}

/// Patches that see nothing (row of F zero) receive and give no indirect light. Those buried
/// whole leave the matrix; the others stay, with a zero row and column: they face the void (a
/// roof under the open sky), and direct light from a lights file still reaches them and their
/// objects' figures (a tower's roof dropped here took its whole top out of the tower's mean
/// irradiance: −100% on that face in an outdoor scene).
pub(super) fn drop_dark(
    scene: &Scene,
    mut c: Corrected,
    plan: &mut Planned,
    params: &DiscretiseParams,
) -> Corrected {
    let n_all = c.patches.len();
    let zero: Vec<usize> = (0..n_all).filter(|&i| c.f.sees_nothing(i)).collect();
    let whole = |i: usize| c.exposure.share.get(i).is_some_and(|&b| b >= 1.0);
    c.live = (0..n_all)
        .filter(|&i| !(whole(i) && zero.binary_search(&i).is_ok()))
        .collect();
    let dark_effect = if zero.is_empty() {
        Effect::new(false, "every patch sees some other patch: none dropped")
    } else {
        // An independent look at the zero rows the matrix keeps: hemisphere rays from the dark
        // patches not buried whole. Those buried whole the burial survey decided at 512 points
        // each; rays from inside a solid meet the front faces of whatever else it encloses (the
        // rafters inside a roof slab), which says nothing of the zero row.
        let kept: Vec<usize> = zero.iter().copied().filter(|&i| !whole(i)).collect();
        dark_patches(
            &mut c.patches,
            plan.checks(scene),
            &zero,
            &kept,
            &c.full_areas,
            params.seed,
        )
    };
    plan.effects.insert("dark_patches", dark_effect);
    c
}

/// Each shared patch's parts gather through rows of their own, scaled as the closure scaled
/// their patch's row, their entries renumbered to live patches.
pub(super) fn part_rows(
    c: &Corrected,
    occluders: Option<&Occluders>,
    seed: u64,
) -> Vec<Vec<PartRow>> {
    let n_all = c.patches.len();
    let any_shared = c.exposure.shared.iter().any(|s| s.len() >= 2);
    let Some(occ) = occluders.filter(|_| any_shared) else {
        return vec![Vec::new(); n_all];
    };
    let live_at = live_numbers(c);
    let samples = direct_samples(c);
    crate::part_rows::part_rows(&c.patches, occ, &c.exposure.shared, &samples, seed)
        .into_iter()
        .enumerate()
        .map(|(i, rows)| {
            let scale = closure_scale(c, i);
            rows.into_iter()
                .map(|mut r| {
                    to_live(&mut r.entries, &live_at);
                    r.each *= scale;
                    r
                })
                .collect()
        })
        .collect()
}

/// Every live patch's first-bounce row ([`crate::bounce_rows`]) as weights: sample `k` of a
/// sender it keeps (`bounce_rows::keep_uneven`) weighs its `c_k` rays' share of the patch's rays, scaled as
/// the closure scaled the patch's row of F. Entries `(live patch, sample, weight)`; `None` for
/// the dropped patches and where no patch sees another (the transfer is zero: no bounce to
/// correct). Casts through the checks' ray tree, built here where nothing occludes the form
/// factors.
pub(super) fn bounce_rows(
    scene: &Scene,
    c: &Corrected,
    plan: &mut Planned,
    seed: u64,
) -> Vec<Option<Vec<(u32, u32, f64)>>> {
    let n_all = c.patches.len();
    if !c.live.iter().any(|&i| c.f.row_sum(i) > 0.0) {
        plan.effects.insert(
            "first_bounce",
            Effect::new(
                false,
                "no patch sees another: there is no bounce to correct",
            ),
        );
        return vec![None; n_all];
    }
    let live_at = live_numbers(c);
    let samples = direct_samples(c);
    let rows =
        crate::bounce_rows::bounce_rows(&c.patches, plan.checks(scene), &c.live, &samples, seed);
    let rows: Vec<Option<Vec<(u32, u32, f64)>>> = rows
        .into_iter()
        .enumerate()
        .map(|(i, row)| {
            row.map(|(each, r)| {
                let each = each * closure_scale(c, i);
                r.into_iter()
                    .filter(|e| live_at[e.0 as usize] != u32::MAX)
                    .map(|(j, k, n)| (live_at[j as usize], k, each * f64::from(n)))
                    .collect()
            })
        })
        .collect();
    let entries: usize = rows.iter().flatten().map(Vec::len).sum();
    plan.effects.insert(
        "first_bounce",
        Effect::new(
            true,
            format!(
                "each patch's first bounce gathered where {} cosine-weighted rays from it land, at the direct-light samples they meet ({entries} entries, {:.2} MB): a sender lit on part of its area sends that part's light where it is seen, not its mean",
                crate::bounce_rows::BOUNCE_RAYS,
                (entries * 6) as f64 / 1e6
            ),
        ),
    );
    rows
}

/// Each patch's live index (`u32::MAX` for a dropped one).
fn live_numbers(c: &Corrected) -> Vec<u32> {
    let mut live_at = vec![u32::MAX; c.patches.len()];
    for (k, &i) in c.live.iter().enumerate() {
        live_at[i] = k as u32;
    }
    live_at
}

/// The closure's scaling of patch `i`'s row of F.
fn closure_scale(c: &Corrected, i: usize) -> f64 {
    if c.raw_sums[i] > 0.0 {
        c.f.row_sum(i) / c.raw_sums[i]
    } else {
        1.0
    }
}

/// A row's `(patch, sample, count)` entries renumbered to live patches, those on dropped
/// patches left out.
fn to_live(entries: &mut Vec<(u32, u32, u16)>, live_at: &[u32]) {
    entries.retain(|&(j, _, _)| live_at[j as usize] != u32::MAX);
    for e in entries {
        e.0 = live_at[e.0 as usize];
    }
}

/// Each patch's direct-light samples `(position, object, area)` as the runtime mesh will hold
/// them: the points not buried, else the patch's centre.
fn direct_samples(c: &Corrected) -> Vec<Vec<(DVec3, u32, f64)>> {
    (0..c.patches.len())
        .map(|i| {
            let marks = c
                .exposure
                .buried_points
                .get(i)
                .map_or(&[][..], Vec::as_slice);
            let mut v: Vec<(DVec3, u32, f64)> =
                direct_points(c.patches.pieces_of(i), c.direct_points[i])
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| marks.get(*k) != Some(&true))
                    .map(|(_, d)| (d.position, d.object, d.area))
                    .collect();
            if v.is_empty() {
                let p = &c.patches.patches[i];
                v.push((p.centre, p.object, p.area));
            }
            v
        })
        .collect()
}

/// The live patches' F (dense, or sparse rows for a level), reflectances and core patches.
/// Where no patch sees another (one object, a convex one, a single sheet), no light travels
/// between surfaces: the transfer is zero and the file carries everything else (patches,
/// mesh, direct light, probes), so that one code path serves every asset.
pub(super) fn finish(
    c: Corrected,
    part_rows: Vec<Vec<PartRow>>,
    bounce_rows: Vec<Option<Vec<(u32, u32, f64)>>>,
    plan: Planned,
    params: &DiscretiseParams,
    keys: Vec<[u8; 16]>,
    laps: Laps,
) -> Discretised {
    let live = c.live;
    let (f_live, sparse) = match c.f {
        Exchange::Dense(d) => (live_rows_dense(d, &live), None),
        sparse => (Dense::new(0, Vec::new()), Some(sparse.live_sparse(&live))),
    };
    let reflectance: Vec<[f64; 3]> = live
        .iter()
        .map(|&i| c.patches.patches[i].reflectance.to_array().map(f64::from))
        .collect();
    let core_patches = live.iter().map(|&i| to_core_patch(&c.patches, i)).collect();
    Discretised {
        patches: c.patches,
        live,
        f: f_live,
        sparse,
        reflectance,
        core_patches,
        channels: plan.channels,
        effects: plan.effects,
        closure: c.closure,
        exposure: c.exposure,
        direct_points: c.direct_points,
        part_rows,
        bounce_rows,
        rays_cast: c.rays_cast,
        keys,
        form_factors: params.form_factors.summary(),
        reciprocity_error: c.reciprocity_error,
        timings_ms: laps.into_timings(),
    }
}
