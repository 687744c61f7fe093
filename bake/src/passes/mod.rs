//! Passes: outputs computed over a finished transfer. Each sees the finished file as the
//! runtime does (its patches, matrix and mesh, with the mesh's ray tree, [`BakedScene`]), adds
//! its section to the file and what it measured to the report. The pipeline runs them in
//! order after the encode, for one matrix and for a level alike; a new bake output is one new
//! [`Pass`] (ARCHITECTURE.md, "Adding a bake output").

pub mod probes;
pub mod sky;

use crate::BakeError;
use crate::hooks::Hooks;
use crate::report::{BakeReport, store};
use radiosity_core::RadFile;
use radiosity_runtime::BakedScene;

/// A bake output computed over a finished transfer.
pub trait Pass {
    /// Adds the pass's section to `rt.file` and what it measured to `report` (its effect,
    /// bytes, report and timing), announcing itself through `hooks` when it has work to do.
    fn run(
        &self,
        rt: &mut BakedScene,
        report: &mut BakeReport,
        hooks: Hooks<'_>,
    ) -> Result<(), BakeError>;
}

/// Runs `passes` in order over `file`, all through one view of it (the mesh's ray tree built
/// once; `robust`: the robust tree of a planned bake, [`crate::geometry::Occluders::robust`]),
/// then stores the report in the file.
pub fn run(
    file: RadFile<'static>,
    mut report: BakeReport,
    passes: &[&dyn Pass],
    robust: bool,
    hooks: Hooks<'_>,
) -> Result<(RadFile<'static>, BakeReport), BakeError> {
    let mut rt = BakedScene::new(file);
    if robust {
        // A planned bake carries visibility over from another scene's tree: both robust.
        rt.make_occluders_robust();
    }
    for pass in passes {
        pass.run(&mut rt, &mut report, hooks)?;
    }
    let mut file = rt.file;
    let report = store(&mut file, report)?;
    Ok((file, report))
}
