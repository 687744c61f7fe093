//! The whole bake: scene → patches → form factors → effect plan → transfer → order → encode →
//! [`RadFile`], with a report of every decision, error estimate and timing.
//!
//! [`discretise`] runs the first half (simplification, form factors, burial and closure
//! (`closure`), dark patches (`dark`)), [`bake_discretised`] the second (transfer, order,
//! encode, measure, the runtime mesh and the report (`report`)); [`bake`] runs both.

mod level;
mod matrix;
mod measure;
mod params;
mod steps;

pub use crate::closure::ClosureReport;
pub use crate::dark_patches::{DarkCheck, check_dark};
pub use crate::discretise::Discretised;
pub use crate::exposure::Exposure;
pub use crate::hooks::Hooks;
pub use crate::report::SystemsReport;
pub use crate::report::{BakeReport, Bytes, store};
pub use crate::systems::{AUTO_ONE_MATRIX, AUTO_SYSTEM_PATCHES, SystemsChoice};
pub use level::SystemRecord;
pub(crate) use level::{OldSystems, SystemsBake, SystemsCut, systems_bake};
pub use params::{BakeParams, FormatChoice};
pub use radiosity_runtime::{ObjectShares, SharedPatch};

use crate::BakeError;
use crate::form_factor::SparseFormFactors;
use crate::form_factor::matrix::dense_live_sparse;
use crate::scene::Scene;
use crate::transfer::Dense;
use radiosity_core::RadFile;
use std::borrow::Cow;

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
/// transfer. A level where the parameters cut the live patches into systems, else one matrix.
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
        return level::second_half_systems(scene, system, ff, count, params, hooks);
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
    matrix::one_matrix(scene, system, f, params, hooks)
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
