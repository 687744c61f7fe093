//! The progress of the long commands (`bake`, `bench`, …): a stage name and a counter, on
//! stderr, fed by the bake's [`Hooks`](radiosity_bake::pipeline::Hooks) callbacks.
//!
//! On a terminal this is a bar, cleared at the end. When stderr is not a terminal (a log, a CI
//! job, a pipe) a bar cannot be drawn, so each stage prints one line when it ends, with its
//! time: `bake: form factors 12.3 s`, and a stage that counts its work prints where it stands
//! every [`PROGRESS_EVERY`], with an estimate of the time left: `bake: transfer 4/12 (312 s,
//! about 624 s left)`. A run that is over within [`QUIET_FOR`] prints none of them (a small
//! scene, or an input refused early, keeps stderr to its one warning or error).

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How long a run goes before its stage lines are printed (those of earlier stages then too).
const QUIET_FOR: Duration = Duration::from_secs(1);

/// How often a counting stage's line is printed when stderr is not a terminal.
const PROGRESS_EVERY: Duration = Duration::from_secs(60);

/// The share of a stage done before its line estimates the time left.
const ESTIMATE_FROM: f64 = 0.1;

/// The stage lines of a run whose stderr is not a terminal.
struct StageLog {
    /// What the lines start with: the subcommand (`bake`, `solve`, `bench`, …).
    label: String,
    start: Instant,
    current: Option<(String, Instant)>,
    /// When the current stage last printed a progress line (its start before the first).
    last_line: Instant,
    /// Lines of the stages ended within [`QUIET_FOR`], not printed yet.
    held: Vec<String>,
    printing: bool,
}

impl StageLog {
    fn emit(&mut self, line: String) {
        if !self.printing && self.start.elapsed() >= QUIET_FOR {
            self.printing = true;
            for l in self.held.drain(..) {
                eprintln!("{l}");
            }
        }
        if self.printing {
            eprintln!("{line}");
        } else {
            self.held.push(line);
        }
    }

    /// Ends the current stage (its line), and starts `next` if given.
    fn next(&mut self, next: Option<&str>) {
        if let Some((name, t)) = self.current.take() {
            let line = format!("{}: {name} {:.1} s", self.label, t.elapsed().as_secs_f64());
            self.emit(line);
        }
        self.current = next.map(|s| (s.to_owned(), Instant::now()));
        self.last_line = Instant::now();
    }

    /// The current stage has done `done` of `total` units: a line every [`PROGRESS_EVERY`],
    /// with the time left at the pace so far.
    fn progress(&mut self, done: usize, total: usize) {
        if let Some(line) = self.progress_line(done, total) {
            self.emit(line);
        }
    }

    /// The line [`StageLog::progress`] prints, when one is due.
    fn progress_line(&mut self, done: usize, total: usize) -> Option<String> {
        let (name, t) = self.current.as_ref()?;
        if self.last_line.elapsed() < PROGRESS_EVERY || done == 0 || done >= total {
            return None;
        }
        let spent = t.elapsed().as_secs_f64();
        self.last_line = Instant::now();
        // Units of one stage differ in cost (a row of many pieces against one of few), so the
        // pace of the first few says little: a form-factor stage 1/20000 done after a minute
        // read "about 2022251 s left" and ended minutes later. No estimate before ESTIMATE_FROM.
        if (done as f64) < ESTIMATE_FROM * total as f64 {
            return Some(format!(
                "{}: {name} {done}/{total} ({spent:.0} s so far)",
                self.label
            ));
        }
        let left = spent * (total - done) as f64 / done as f64;
        Some(format!(
            "{}: {name} {done}/{total} ({spent:.0} s, about {left:.0} s left)",
            self.label
        ))
    }
}

/// A stage-and-counter bar on a terminal, stage lines elsewhere ([`StageBar::stage`]).
pub(crate) struct StageBar {
    bar: ProgressBar,
    log: Option<Mutex<StageLog>>,
}

impl std::ops::Deref for StageBar {
    type Target = ProgressBar;
    fn deref(&self) -> &ProgressBar {
        &self.bar
    }
}

impl StageBar {
    /// Starts a stage: names it on the bar, and ends the previous one's line.
    pub(crate) fn stage(&self, s: &str) {
        if let Some(log) = &self.log {
            log.lock().unwrap_or_else(|e| e.into_inner()).next(Some(s));
        }
        self.bar.set_message(s.to_owned());
        self.bar.tick();
    }

    /// Ends the last stage (its line, when lines are printed) and clears the bar.
    pub(crate) fn finish_and_clear(&self) {
        if let Some(log) = &self.log {
            log.lock().unwrap_or_else(|e| e.into_inner()).next(None);
        }
        self.bar.finish_and_clear();
    }
}

/// The subcommand the stage lines are labelled with.
fn command_name() -> String {
    std::env::args()
        .nth(1)
        .filter(|a| !a.starts_with('-'))
        .unwrap_or_else(|| "radiosity".to_owned())
}

/// A stage-and-counter bar: `{spinner} stage [bar] done/total`, with `extra` after it (e.g.
/// `" ({eta})"`), the stage name padded to `width`. The bar is hidden when `quiet` (`--json`);
/// the stage lines of a stderr that is not a terminal are printed either way.
pub(crate) fn stage_bar(width: usize, extra: &str, quiet: bool) -> StageBar {
    let log = (!std::io::stderr().is_terminal()).then(|| {
        Mutex::new(StageLog {
            label: command_name(),
            start: Instant::now(),
            current: None,
            last_line: Instant::now(),
            held: Vec::new(),
            printing: false,
        })
    });
    if quiet {
        return StageBar {
            bar: ProgressBar::hidden(),
            log,
        };
    }
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} {{msg:<{width}}} {{bar:30}} {{pos}}/{{len}}{extra}"
        ))
        .expect("the template is well formed"),
    );
    StageBar { bar, log }
}

/// The two callbacks a bake reports through: a new stage (named on the bar) and rows done out
/// of a total.
pub(crate) fn callbacks(
    bar: &StageBar,
) -> (impl Fn(&str) + Sync + '_, impl Fn(usize, usize) + Sync + '_) {
    let stage = move |s: &str| bar.stage(s);
    let progress = move |done: usize, total: usize| {
        bar.bar.set_length(total as u64);
        bar.bar.set_position(done as u64);
        if let Some(log) = &bar.log {
            log.lock()
                .unwrap_or_else(|e| e.into_inner())
                .progress(done, total);
        }
    };
    (stage, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_runs_hold_their_lines_and_slow_ones_print_them_all() {
        let mut log = StageLog {
            label: "bake".into(),
            start: Instant::now(),
            current: None,
            last_line: Instant::now(),
            held: Vec::new(),
            printing: false,
        };
        log.next(Some("simplify"));
        log.next(Some("form factors"));
        assert_eq!(log.held.len(), 1);
        assert!(log.held[0].starts_with("bake: simplify ") && log.held[0].ends_with(" s"));
        log.start -= QUIET_FOR;
        log.next(None);
        assert!(log.printing && log.held.is_empty());
    }

    #[test]
    fn a_long_counting_stage_prints_where_it_stands_and_the_time_left() {
        let mut log = StageLog {
            label: "bake".into(),
            start: Instant::now() - QUIET_FOR,
            current: None,
            last_line: Instant::now(),
            held: Vec::new(),
            printing: true,
        };
        log.next(Some("transfer"));
        // Within PROGRESS_EVERY of the stage's start: no line.
        assert_eq!(log.progress_line(1, 4), None);
        // A stage 100 s in, a quarter done: three times as long to go.
        let (name, _) = log.current.take().unwrap();
        log.current = Some((name, Instant::now() - Duration::from_secs(100)));
        log.last_line -= PROGRESS_EVERY;
        let line = log.progress_line(1, 4).expect("a line is due");
        assert_eq!(line, "bake: transfer 1/4 (100 s, about 300 s left)");
        // Early in a stage the pace of its first units says little: no estimate.
        log.last_line -= PROGRESS_EVERY;
        let line = log.progress_line(3, 1000).expect("a line is due");
        assert_eq!(line, "bake: transfer 3/1000 (100 s so far)");
        // Right after a line, the next waits; nothing is printed for a finished count.
        assert_eq!(log.progress_line(2, 4), None);
        log.last_line -= PROGRESS_EVERY;
        assert_eq!(log.progress_line(4, 4), None);
    }
}
