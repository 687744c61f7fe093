//! How a long measurement ([`crate::bench`], [`crate::report`]) tells a person watching how
//! far it is: stage names, work done of a total, and notes (what it skipped, which backend it
//! chose). The measurement prints nothing itself.

use radiosity_bake::pipeline::Hooks;

/// The callbacks of a long measurement.
#[derive(Clone, Copy)]
pub struct Progress<'a> {
    /// A stage starts, named.
    pub stage: &'a (dyn Fn(&str) + Sync),
    /// Work done of a total within the current stage (called from worker threads while a bake
    /// runs).
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// A line for the person watching, as it is to be shown (`note: …` for something
    /// skipped and why, `backend: …` for a backend chosen).
    pub note: &'a (dyn Fn(&str) + Sync),
}

impl<'a> Progress<'a> {
    /// The bake's hooks with the same stage and progress callbacks (no cancelling).
    pub fn hooks(&self) -> Hooks<'a> {
        Hooks {
            stage: Some(self.stage),
            progress: Some(self.progress),
            cancel: None,
        }
    }
}
