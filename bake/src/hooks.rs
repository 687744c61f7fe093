//! A front end's hooks into a bake: stage names as they start, progress, cancellation; and
//! the stages' timings the report gives ([`Laps`]).

use std::collections::BTreeMap;
use std::time::Instant;

/// Callbacks for a front end: stage names as they start, the progress of the counting stages,
/// and a cancellation flag.
#[derive(Clone, Copy, Default)]
pub struct Hooks<'a> {
    /// Called with a stage name when it starts.
    pub stage: Option<&'a (dyn Fn(&str) + Sync)>,
    /// Work done / total within the current stage (form-factor rows, transfer quarters,
    /// probes), called from worker threads.
    pub progress: Option<&'a (dyn Fn(usize, usize) + Sync)>,
    /// Set by the front end to stop the bake: checked between stages and between the rows of
    /// the form factors and the probes; a bake that sees it set returns
    /// [`BakeError::Cancelled`](crate::BakeError::Cancelled).
    pub cancel: Option<&'a std::sync::atomic::AtomicBool>,
}

impl Hooks<'_> {
    /// Starts stage `name` ([`Self::stage`]), or returns [`BakeError::Cancelled`] when the
    /// front end has asked to stop.
    ///
    /// [`BakeError::Cancelled`]: crate::BakeError::Cancelled
    pub fn start(&self, name: &str) -> Result<(), crate::BakeError> {
        self.check()?;
        if let Some(f) = self.stage {
            f(name);
        }
        Ok(())
    }

    /// [`BakeError::Cancelled`](crate::BakeError::Cancelled) when the front end has asked to
    /// stop.
    pub fn check(&self) -> Result<(), crate::BakeError> {
        if self.cancelled() {
            Err(crate::BakeError::Cancelled)
        } else {
            Ok(())
        }
    }

    /// Whether the front end has asked to stop.
    pub fn cancelled(&self) -> bool {
        self.cancel
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
    }

    /// Reports `done` of `total` in the current stage; returns whether to go on.
    pub fn report(&self, done: usize, total: usize) -> bool {
        if let Some(p) = self.progress {
            p(done, total);
        }
        !self.cancelled()
    }
}

/// Milliseconds per stage (the report's `timings_ms`), each lap from the end of the one before.
pub(crate) struct Laps {
    clock: Instant,
    timings: BTreeMap<&'static str, f64>,
}

impl Laps {
    /// Laps added to `timings` (those of the stages before), timed from now.
    pub(crate) fn after(timings: BTreeMap<&'static str, f64>) -> Self {
        Self {
            clock: Instant::now(),
            timings,
        }
    }

    /// Records the time since the last lap as `name`'s.
    pub(crate) fn lap(&mut self, name: &'static str) {
        self.timings
            .insert(name, self.clock.elapsed().as_secs_f64() * 1e3);
        self.clock = Instant::now();
    }

    /// Records `ms` as `name`'s, a stage timed apart.
    pub(crate) fn set(&mut self, name: &'static str, ms: f64) {
        self.timings.insert(name, ms);
    }

    /// The timings.
    pub(crate) fn into_timings(self) -> BTreeMap<&'static str, f64> {
        self.timings
    }
}
