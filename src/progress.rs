//! The progress bar of the long commands (`bake`, `bench`): a stage name and a counter, on
//! stderr, fed by the bake's [`Hooks`](radiosity_bake::pipeline::Hooks) callbacks.

use indicatif::{ProgressBar, ProgressStyle};

/// A stage-and-counter bar: `{spinner} stage [bar] done/total`, with `extra` after it (e.g.
/// `" ({eta})"`), the stage name padded to `width`. Hidden when `quiet`.
pub(crate) fn stage_bar(width: usize, extra: &str, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{spinner}} {{msg:<{width}}} {{bar:30}} {{pos}}/{{len}}{extra}"
        ))
        .expect("the template is well formed"),
    );
    bar
}

/// The two callbacks a bake reports through: a new stage (named on the bar) and rows done out
/// of a total.
pub(crate) fn callbacks(
    bar: &ProgressBar,
) -> (impl Fn(&str) + Sync + '_, impl Fn(usize, usize) + Sync + '_) {
    let stage = move |s: &str| {
        bar.set_message(s.to_owned());
        bar.tick();
    };
    let progress = move |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    (stage, progress)
}
