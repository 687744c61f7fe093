//! `REPORT.md`: the notes, the headline Pareto front and one table per sweep.

use super::table;
use radiosity_perf::report::{Report, Sample, pareto_front};
use std::fmt::Write as _;

/// The columns of every table.
const HEADER: [&str; 13] = [
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

/// A sample's row of the tables.
fn row(s: &Sample) -> Vec<String> {
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
}

/// The report's Markdown (`total_s`: the whole run's seconds).
pub(super) fn markdown(report: &Report, quick: bool, total_s: f64) -> String {
    let mut md = String::new();
    notes(&mut md, report, quick, total_s);
    headline(&mut md, report);
    sweeps(&mut md, report);
    let _ = writeln!(md, "## Plots\n");
    for (f, caption) in report.plots.iter().chain(&report.figures) {
        let _ = writeln!(md, "### {f}\n\n{caption}\n\n![{f}]({f})\n");
    }
    let _ = writeln!(
        md,
        "Every number above is in `report.csv` (one row per configuration)."
    );
    md
}

/// The title, the command and the machine, and what the columns measure.
fn notes(md: &mut String, report: &Report, quick: bool, total_s: f64) {
    let cmd = if quick {
        "radiosity report --quick"
    } else {
        "radiosity report"
    };
    let _ = writeln!(md, "# Radiosity report: what accuracy costs\n");
    let _ = writeln!(
        md,
        "Produced by `{cmd}` in {:.0} s on {} threads (CPU SIMD path {}). Scene: the embedded Cornell box (McGuire, CC BY 3.0), lit by its own light.\n",
        total_s, report.threads, report.simd_path
    );
    let _ = writeln!(
        md,
        "- **error vs exact**: relative L2 error of the irradiance from the scene's light against the exact f64 solution of the same patches (LU of I − F^C): what compression and truncated bounces cost.\n- **error vs path tracer**: area-weighted relative L2 error of the per-object mean irradiance against the reference path tracer ({} samples per object, {:.1} s; its own noise in this norm is {:.2e}): what the discretisation costs as well.\n- Gather times are medians of repeated calls, every configuration of one patch count timed in turns (ten rounds, so that outside load slows them alike); bake time includes the shared discretisation (simplification and form factors). GPU: {}.\n",
        report.plan.pt_samples,
        report.pt_ms / 1e3,
        report.pt_noise,
        report.gpu
    );
}

/// The headline: the plot of error against time, and the Pareto front at the middle size.
fn headline(md: &mut String, report: &Report) {
    let _ = writeln!(
        md,
        "## Headline\n\n![error vs gather time](error_vs_time.png)\n"
    );
    let middle = report.middle_samples();
    let pts: Vec<(f64, f64)> = middle.iter().map(|s| (s.cpu_ms, s.err_exact)).collect();
    let front: Vec<Vec<String>> = pareto_front(&pts).iter().map(|&i| row(middle[i])).collect();
    let _ = writeln!(
        md,
        "The Pareto front of error against gather time at n = {} (no configuration of that size is both faster and more accurate):\n",
        middle.first().map_or(0, |s| s.patches)
    );
    md.push_str(&table::markdown(&HEADER, &front));
    md.push('\n');
}

/// One section a sweep: its title, what it varies, its table.
fn sweeps(md: &mut String, report: &Report) {
    let bounces = format!(
        "BC1 at n ≈ {}; the error against the exact (all-bounce) solution shows what stopping after K bounces leaves out (the n table's bc1 row is K = ∞).",
        report.plan.middle
    );
    let sections = [
        (
            "Patches n, every format",
            "n",
            "Bounces `auto` (all of them for this box), order `best`, default sparse threshold.",
        ),
        ("Bounces K", "bounces", bounces.as_str()),
        (
            "Patch order",
            "order",
            "BC1 and BC4 with each order: the compression error column is the reordering gain.",
        ),
        (
            "Sparse threshold",
            "sparse",
            "BC1 with a growing fraction of the largest entries kept exact: bytes against error.",
        ),
        (
            "Block corrections",
            "corrections",
            "BC1 with a growing share of its 4×4 blocks given a block correction (sixteen 4-bit residuals per channel, 31 bytes; the default is 2.5%), the sparse fraction at its default: bytes against error.",
        ),
    ];
    for (title, sweep, text) in sections {
        let rows: Vec<Vec<String>> = report
            .samples
            .iter()
            .filter(|s| s.sweep == sweep)
            .map(row)
            .collect();
        let _ = writeln!(md, "## {title}\n\n{text}\n");
        md.push_str(&table::markdown(&HEADER, &rows));
        md.push('\n');
    }
}
