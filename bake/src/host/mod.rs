//! The bake as a host calls it (an editor, an engine's tools, the C ABI, the command line): the
//! bake flags as one validated set ([`BakeFlags`]), the scene loader with the command line's
//! checks ([`load_scene`]), and [`bake_file`], a whole bake from a scene file to a `.rad` file
//! with progress, cancellation and an atomic write.
//!
//! Progress: [`bake_file`] runs the bake on a worker thread and calls the host's callback on
//! the calling thread, with the stage's name and the fraction of the whole bake done (never
//! decreasing, 1 at the end), every [`PROGRESS_EVERY`] until the bake ends. The fraction
//! weighs each stage by its usual share of a bake's time ([`STAGES`]) and moves within the
//! stages that count their work (form-factor rows, transfer quarters, probes).
//!
//! Cancellation: the callback's `false` sets the bake's cancel flag ([`Hooks::cancel`]),
//! which the bake checks between stages and between form-factor rows and probes; the bake
//! then returns [`BakeError::Cancelled`] and the output path is left as it was. The file is
//! written to a temporary file beside the output and renamed over it only when the bake has
//! finished and no cancellation came: a failed or cancelled bake leaves nothing behind.

mod flags;
mod output;

pub use flags::{BakeFlags, Word, capped_loading, form_factor_params, load_scene, voxel_params};
pub use output::{check_output, temp_file_in, write_atomic};

use crate::BakeError;
use crate::pipeline::{BakeOutput, Hooks, bake};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// How often [`bake_file`] calls the host's progress callback.
pub const PROGRESS_EVERY: Duration = Duration::from_millis(100);

/// The stages of a bake in order, with their usual share of its time (a Cornell box at 1024
/// to 4096 patches on a 2-core machine: the form factors dominate, the transfer grows as n³).
pub const STAGES: [(&str, f64); 9] = [
    ("load", 0.02),
    ("simplify", 0.04),
    ("form factors", 0.50),
    ("transfer", 0.18),
    ("order", 0.05),
    ("encode", 0.10),
    ("measure", 0.04),
    ("probes", 0.05),
    ("write", 0.02),
];

/// Where a bake stands: its stage and the share of that stage done.
struct Standing {
    stage: &'static str,
    within: f64,
    probes: bool,
}

impl Standing {
    /// The fraction of the whole bake done (stages without probes leave theirs out).
    fn fraction(&self) -> f64 {
        let used = |name: &str| self.probes || name != "probes";
        let total: f64 = STAGES.iter().filter(|s| used(s.0)).map(|s| s.1).sum();
        let mut before = 0.0;
        for &(name, w) in STAGES.iter().filter(|s| used(s.0)) {
            if name == self.stage {
                return ((before + w * self.within.clamp(0.0, 1.0)) / total).min(1.0);
            }
            before += w;
        }
        0.0
    }
}

/// Unparks a thread when dropped.
struct Wake<'a>(&'a std::thread::Thread);

impl Drop for Wake<'_> {
    fn drop(&mut self) {
        self.0.unpark();
    }
}

/// Bakes the scene at `scene` (OBJ or glTF) with `flags` into `output`, calling
/// `progress(stage, fraction)` on this thread every [`PROGRESS_EVERY`] (module docs); a
/// `false` from it cancels the bake ([`BakeError::Cancelled`], nothing written). Returns the
/// bake's output (its report says what was done). `progress` ends with `("done", 1.0)` on
/// success.
pub fn bake_file(
    scene: &Path,
    output: &Path,
    flags: &BakeFlags,
    progress: &mut dyn FnMut(&str, f64) -> bool,
) -> Result<BakeOutput, BakeError> {
    let (params, load) = flags.params()?;
    check_output(output)?;
    let cancel = AtomicBool::new(false);
    let standing = Mutex::new(Standing {
        stage: "load",
        within: 0.0,
        probes: params.probes != crate::probes::ProbeSpec::None,
    });
    let set =
        |f: &dyn Fn(&mut Standing)| f(&mut standing.lock().unwrap_or_else(|e| e.into_inner()));
    let host = std::thread::current();
    let result = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            // Wakes the host's loop as soon as the bake ends, however it ends.
            let _wake = Wake(&host);
            let stage = |name: &str| {
                let known = STAGES.iter().find(|s| s.0 == name).map(|s| s.0);
                set(&|st| {
                    if let Some(k) = known {
                        st.stage = k;
                        st.within = 0.0;
                    }
                });
            };
            let counted = |done: usize, total: usize| {
                set(&|st| st.within = done as f64 / total.max(1) as f64);
            };
            let hooks = Hooks {
                stage: Some(&stage),
                progress: Some(&counted),
                cancel: Some(&cancel),
            };
            let loaded = load_scene(scene, &load)?;
            let out = bake(&loaded, &params, hooks)?;
            hooks.start("write")?;
            let bytes = out
                .file
                .to_bytes()
                .map_err(|e| BakeError::Unbakeable(format!("internal: {e}")))?;
            let temp = output::write_temp(output, &bytes)?;
            Ok::<_, BakeError>((out, temp))
        });
        let mut last = 0.0f64;
        while !worker.is_finished() {
            let (stage, fraction) = {
                let st = standing.lock().unwrap_or_else(|e| e.into_inner());
                (st.stage, st.fraction())
            };
            last = last.max(fraction);
            if !cancel.load(Ordering::Relaxed) && !progress(stage, last) {
                cancel.store(true, Ordering::Relaxed);
            }
            std::thread::park_timeout(PROGRESS_EVERY);
        }
        worker
            .join()
            .unwrap_or_else(|_| Err(BakeError::Unbakeable("internal: the bake panicked".into())))
    });
    // A cancellation that came after the last check still wins: the temporary file goes.
    if cancel.load(Ordering::Relaxed) {
        return Err(BakeError::Cancelled);
    }
    let (out, temp) = result?;
    output::persist(temp, output)?;
    progress("done", 1.0);
    Ok(out)
}
