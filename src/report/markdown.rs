//! `REPORT.md`: the notes, the headline Pareto front and one table per sweep.

use super::{Plan, Sample, middle_samples, table};
use std::fmt::Write as _;

/// What the tables do not hold: timings of the run, the GPU's state, the pictures made.
pub(super) struct Notes {
    pub(super) pt_ms: f64,
    pub(super) pt_noise: f64,
    pub(super) total_s: f64,
    pub(super) gpu: String,
    pub(super) plots: Vec<(String, String)>,
    pub(super) figures: Vec<(String, String)>,
}

/// The report's Markdown.
pub(super) fn markdown(samples: &[Sample], plan: &Plan, quick: bool, notes: &Notes) -> String {
    let mut md = String::new();
    let cmd = if quick {
        "radiosity report --quick"
    } else {
        "radiosity report"
    };
    let _ = writeln!(md, "# Radiosity report: what accuracy costs\n");
    let _ = writeln!(
        md,
        "Produced by `{cmd}` in {:.0} s on {} threads (CPU SIMD path {}). Scene: the embedded Cornell box (McGuire, CC BY 3.0), lit by its own light.\n",
        notes.total_s,
        rayon::current_num_threads(),
        radiosity_backend_cpu::SimdPath::detect().name()
    );
    let _ = writeln!(
        md,
        "- **error vs exact**: relative L2 error of the irradiance from the scene's light against the exact f64 solution of the same patches (LU of I − F^C): what compression and truncated bounces cost.\n- **error vs path tracer**: area-weighted relative L2 error of the per-object mean irradiance against the reference path tracer ({} samples per object, {:.1} s; its own noise in this norm is {:.2e}): what the discretisation costs as well.\n- Gather times are medians of repeated calls, every configuration of one patch count timed in turns (ten rounds, so that outside load slows them alike); bake time includes the shared discretisation (simplification and form factors). GPU: {}.\n",
        plan.pt_samples,
        notes.pt_ms / 1e3,
        notes.pt_noise,
        notes.gpu
    );
    let header = [
        "n",
        "K",
        "format",
        "order",
        "sparse",
        "corr.",
        "bake s",
        "file MB",
        "CPU ms",
        "GPU ms",
        "compression",
        "err vs exact",
        "err vs PT",
    ];
    let row = |s: &Sample| {
        vec![
            s.patches.to_string(),
            s.bounces.clone(),
            s.format.into(),
            s.order.into(),
            format!("{:.4}", s.sparse_fraction),
            format!("{:.4}", s.corrections),
            format!("{:.2}", s.bake_ms / 1e3),
            format!("{:.3}", s.file_bytes as f64 / 1e6),
            format!("{:.3}", s.cpu_ms),
            s.gpu_ms.map_or("–".into(), |v| format!("{v:.3}")),
            format!("{:.4}", s.compression_rmse),
            format!("{:.2e}", s.err_exact),
            format!("{:.2e}", s.err_pt),
        ]
    };
    let section = |md: &mut String, title: &str, sweep: &str, text: &str| {
        let rows: Vec<Vec<String>> = samples
            .iter()
            .filter(|s| s.sweep == sweep)
            .map(row)
            .collect();
        let _ = writeln!(md, "## {title}\n\n{text}\n");
        md.push_str(&table::markdown(&header, &rows));
        md.push('\n');
    };
    // Headline first.
    let _ = writeln!(
        md,
        "## Headline\n\n![error vs gather time](error_vs_time.png)\n"
    );
    let middle = middle_samples(samples);
    let pts: Vec<(f64, f64)> = middle.iter().map(|s| (s.cpu_ms, s.err_exact)).collect();
    let front: Vec<Vec<String>> = table::pareto_front(&pts)
        .iter()
        .map(|&i| row(middle[i]))
        .collect();
    let _ = writeln!(
        md,
        "The Pareto front of error against gather time at n = {} (no configuration of that size is both faster and more accurate):\n",
        middle.first().map_or(0, |s| s.patches)
    );
    md.push_str(&table::markdown(&header, &front));
    md.push('\n');
    section(
        &mut md,
        "Patches n, every format",
        "n",
        "Bounces `auto` (all of them for this box), order `best`, default sparse threshold.",
    );
    section(
        &mut md,
        "Bounces K",
        "bounces",
        &format!(
            "BC1 at n ≈ {}; the error against the exact (all-bounce) solution shows what stopping after K bounces leaves out (the n table's bc1 row is K = ∞).",
            plan.middle
        ),
    );
    section(
        &mut md,
        "Patch order",
        "order",
        "BC1 and BC4 with each order: the compression error column is the reordering gain.",
    );
    section(
        &mut md,
        "Sparse threshold",
        "sparse",
        "BC1 with a growing fraction of the largest entries kept exact: bytes against error.",
    );
    section(
        &mut md,
        "Block corrections",
        "corrections",
        "BC1 with a growing share of its 4×4 blocks given a block correction (sixteen 4-bit residuals per channel, 31 bytes; the default is 2.5%), the sparse fraction at its default: bytes against error.",
    );
    let _ = writeln!(md, "## Plots\n");
    for (f, caption) in notes.plots.iter().chain(&notes.figures) {
        let _ = writeln!(md, "### {f}\n\n{caption}\n\n![{f}]({f})\n");
    }
    let _ = writeln!(
        md,
        "Every number above is in `report.csv` (one row per configuration)."
    );
    md
}
