//! The discretisation, the bake's first half: scene → patches ([`crate::simplify`]) → the effect
//! plan → burial survey and form factors ([`crate::form_factor`]) → direct-light points
//! ([`crate::shadow_points`]) → buried surface ([`crate::exposure`]) → closure
//! ([`crate::closure`]) → dark patches ([`crate::dark_patches`]) → part rows
//! ([`crate::part_rows`]). What it gives ([`Discretised`]) is independent of the bounces,
//! format, order and sparse threshold, so one discretisation serves many bakes.

mod given;
mod steps;

pub use given::GivenRows;

use crate::BakeError;
use crate::closure::ClosureReport;
use crate::effect_plan::Effects;
use crate::exposure::Exposure;
use crate::form_factor::matrix::Dense;
use crate::form_factor::{FormFactorParams, FormFactorSummary, SparseFormFactors};
use crate::hooks::{Hooks, Laps};
use crate::patch::Patches;
use crate::scene::Scene;
use crate::simplify::VoxelParams;
use crate::systems::SystemsChoice;
use radiosity_core::Patch;
use std::collections::BTreeMap;

/// What the discretisation is told: the part of the bake's parameters
/// (`crate::pipeline::BakeParams::discretise`) it looks at.
#[derive(Clone, Debug, PartialEq)]
pub struct DiscretiseParams {
    /// Simplification: target patch count or voxel size.
    pub voxel: VoxelParams,
    /// Form-factor quadrature and visibility rays.
    pub form_factors: FormFactorParams,
    /// Direct-light points of a patch no shadow crosses.
    pub direct_points: u32,
    /// Direct-light points of a patch a shadow may cross.
    pub shadow_points: u32,
    /// How far from 1 a row sum of F may be for the scene to count as closed.
    pub closure_tolerance: f64,
    /// Seed of the checks' hemisphere rays.
    pub seed: u64,
    /// The cut into systems: a level keeps F as sparse rows.
    pub systems: SystemsChoice,
}

/// The discretised system every bake starts from: patches, their closure-corrected form
/// factors and reflectances, with the patches that see nothing removed. Independent of the
/// bounces, format, order and sparse threshold, so one `Discretised` serves many bakes
/// (`crate::pipeline::bake_discretised`) and the exact solution of the same patches
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
    /// The surface buried under other objects, taken out of the patches
    /// ([`crate::exposure::expose`]).
    pub exposure: Exposure,
    /// Direct-light points of each patch (simplification order):
    /// [`DiscretiseParams::direct_points`], or [`DiscretiseParams::shadow_points`] where a
    /// shadow may cross it ([`crate::shadow_points`]), as `exposure` marked them buried.
    pub direct_points: Vec<u32>,
    /// Per patch (simplification order), its shared objects' own gather rows
    /// ([`crate::part_rows`]), their entries' patches renumbered to live indices and their
    /// weights scaled as the closure scaled the patch's row.
    pub(crate) part_rows: Vec<Vec<crate::part_rows::PartRow>>,
    /// Per patch (simplification order), its first-bounce row ([`crate::bounce_rows`]) as
    /// `(live patch, sample, weight)` entries; `None` for a dropped patch, or for all where no
    /// patch sees another.
    pub(crate) bounce_rows: Vec<Option<Vec<(u32, u32, f64)>>>,
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

/// Discretises `scene` (see the module docs); with the burial survey and the ray-cast hit
/// counts `given` (a plan's shards computed them) in place of its own.
pub fn discretise(
    scene: &Scene,
    params: &DiscretiseParams,
    hooks: Hooks<'_>,
    given: Option<GivenRows>,
) -> Result<Discretised, BakeError> {
    steps::check_points(params)?;
    let mut laps = Laps::after(BTreeMap::new());
    hooks.start("simplify")?;
    let mut patches = crate::simplify::simplify(scene, &params.voxel)?;
    let keys = match given {
        Some(_) => crate::patch::identity::seed_patches(scene, &mut patches),
        None => Vec::new(),
    };
    laps.lap("simplify");
    let mut plan = steps::plan_effects(scene, &patches, params, given.is_some());
    laps.lap("plan");

    hooks.start("form factors")?;
    let surveyed = match given {
        None => steps::survey_for_target(scene, &mut patches, &mut plan, params)?,
        Some(_) => None,
    };
    let rows = steps::form_factors(&patches, &plan, params, given, hooks, &mut laps, surveyed)?;
    // The rows skipped after a cancellation leave the matrix incomplete: it goes no further.
    hooks.check()?;
    laps.lap("form_factors");
    steps::form_factor_effects(&rows.summary, plan.ffp.exact_pieces, &mut plan.effects);
    let corrected = steps::correct(scene, patches, rows, &mut plan, params);
    laps.lap("closure");
    let live = steps::drop_dark(scene, corrected, &mut plan, params);
    let part_rows = steps::part_rows(&live, plan.occluders.as_ref(), params.seed);
    laps.lap("part_rows");
    let bounce_rows = steps::bounce_rows(scene, &live, &mut plan, params.seed);
    laps.lap("bounce_rows");
    Ok(steps::finish(
        live,
        part_rows,
        bounce_rows,
        plan,
        params,
        keys,
        laps,
    ))
}

/// The live patch `i` of `patches` as the core stores it.
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
