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
//! Cancellation: the callback's `false` makes [`bake_file`] return [`BakeError::Cancelled`] at
//! once, the output path as it was, and sets the bake's cancel flag ([`Hooks::cancel`]), which
//! the worker checks between stages, form-factor rows and probes before it stops, writing
//! nothing. The file is
//! written to a temporary file beside the output and renamed over it only when the bake has
//! finished and no cancellation came: a failed or cancelled bake leaves nothing behind.

mod flags;
pub mod output;

pub use flags::{BakeFlags, Word, capped_loading, form_factor_params, load_scene, voxel_params};
pub use output::{check_output, write_atomic};

use crate::BakeError;
use crate::pipeline::{BakeOutput, Hooks, bake};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How often [`bake_file`] calls the host's progress callback.
pub const PROGRESS_EVERY: Duration = Duration::from_millis(100);

/// The stages of a bake in order, with their usual share of its time (a Cornell box at 1024
/// to 4096 patches on a 2-core machine: the form factors dominate, the transfer grows as n³).
pub const STAGES: [(&str, f64); 10] = [
    ("load", 0.02),
    ("simplify", 0.04),
    ("form factors", 0.50),
    ("transfer", 0.18),
    ("order", 0.05),
    ("encode", 0.10),
    ("measure", 0.04),
    ("probes", 0.05),
    ("sky", 0.02),
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

/// Bakes the scene at `scene` (OBJ or glTF) with `flags` into `output`, calling
/// `progress(stage, fraction)` on this thread every [`PROGRESS_EVERY`] (module docs); a
/// `false` from it cancels the bake ([`BakeError::Cancelled`], nothing written). Returns the
/// bake's output (its report says what was done). `progress` ends with `("done", 1.0)` on
/// success.
///
/// A cancelled call returns within [`PROGRESS_EVERY`] of the callback's `false`. The worker
/// thread stops at its next check (the same stage, at most one form-factor row, probe, or
/// for the stages that do not count their work, the rest of the stage: seconds at 4096
/// patches) and writes nothing.
pub fn bake_file(
    scene: &Path,
    output: &Path,
    flags: &BakeFlags,
    progress: &mut dyn FnMut(&str, f64) -> bool,
) -> Result<BakeOutput, BakeError> {
    let (params, load) = flags.params()?;
    check_output(output)?;
    let cancel = Arc::new(AtomicBool::new(false));
    let standing = Arc::new(Mutex::new(Standing {
        stage: "load",
        within: 0.0,
        probes: params.probes != crate::passes::probes::ProbeSpec::None,
    }));
    let (done, result) = std::sync::mpsc::channel();
    let worker = {
        let (cancel, standing) = (Arc::clone(&cancel), Arc::clone(&standing));
        let (scene, output) = (scene.to_owned(), output.to_owned());
        std::thread::Builder::new()
            .name("radiosity-bake".into())
            .spawn(move || {
                let set = |f: &dyn Fn(&mut Standing)| {
                    f(&mut standing.lock().unwrap_or_else(|e| e.into_inner()))
                };
                let stage = |name: &str| {
                    if let Some(&(known, _)) = STAGES.iter().find(|s| s.0 == name) {
                        set(&|st| {
                            st.stage = known;
                            st.within = 0.0;
                        });
                    }
                };
                let counted = |done: usize, total: usize| {
                    set(&|st| st.within = done as f64 / total.max(1) as f64);
                };
                let hooks = Hooks {
                    stage: Some(&stage),
                    progress: Some(&counted),
                    cancel: Some(&cancel),
                };
                let run = || {
                    let loaded = load_scene(&scene, &load)?;
                    let out = bake(&loaded, &params, hooks)?;
                    hooks.start("write")?;
                    let bytes = out
                        .file
                        .to_bytes()
                        .map_err(|e| BakeError::Unbakeable(format!("internal: {e}")))?;
                    let temp = output::write_temp(&output, &bytes)?;
                    Ok::<_, BakeError>((out, temp))
                };
                // Nobody listens after a cancellation: the temporary file is then dropped.
                let _ = done.send(run());
            })
            .map_err(|e| BakeError::Unbakeable(format!("cannot start the bake's thread: {e}")))?
    };
    let mut last = 0.0f64;
    let finished = loop {
        match result.recv_timeout(PROGRESS_EVERY) {
            Ok(r) => break r,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                break Err(BakeError::Unbakeable("internal: the bake panicked".into()));
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
        }
        let (stage, fraction) = {
            let st = standing.lock().unwrap_or_else(|e| e.into_inner());
            (st.stage, st.fraction())
        };
        last = last.max(fraction);
        if !progress(stage, last) {
            // The worker stops at its next check; this call returns now.
            cancel.store(true, Ordering::Relaxed);
            return Err(BakeError::Cancelled);
        }
    };
    let _ = worker.join();
    let (out, temp) = finished?;
    output::persist(temp, output)?;
    progress("done", 1.0);
    Ok(out)
}
