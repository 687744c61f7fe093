//! `radiosity report [--quick] [-o DIR]`: what accuracy costs in time and memory, on the
//! embedded Cornell box. [`radiosity_perf::report`] measures the sweeps and draws the plots
//! into the output directory; this writes the tables, `report.csv` and `REPORT.md`
//! (`markdown.rs`, `table.rs`), with a spinner on stderr meanwhile.

mod markdown;
mod table;

use crate::embedded;
use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use radiosity_perf::Progress;
use radiosity_perf::report::{Report, Sample};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const CSV_HEADER: [&str; 14] = [
    "sweep",
    "patches",
    "bounces",
    "format",
    "order",
    "sparse_fraction",
    "corrections",
    "bake_ms",
    "file_bytes",
    "cpu_gather_ms",
    "gpu_gather_ms",
    "compression_rmse",
    "error_vs_exact",
    "error_vs_pathtracer",
];

/// A sample's line of `report.csv`, as [`CSV_HEADER`] names its fields.
fn csv_row(s: &Sample) -> Vec<String> {
    vec![
        s.sweep.into(),
        s.patches.to_string(),
        s.bounces.clone(),
        s.format.into(),
        s.order.into(),
        format!("{}", s.sparse_fraction),
        format!("{}", s.corrections),
        format!("{:.1}", s.bake_ms),
        s.file_bytes.to_string(),
        format!("{:.4}", s.cpu_ms),
        s.gpu_ms.map_or(String::new(), |v| format!("{v:.4}")),
        format!("{:.5e}", s.compression_rmse),
        format!("{:.5e}", s.err_exact),
        format!("{:.5e}", s.err_pt),
    ]
}

/// `radiosity report`: measures and draws into `out`, then writes `report.csv` and
/// `REPORT.md` there.
pub(crate) fn run(quick: bool, out: &Path) -> anyhow::Result<()> {
    let t_all = Instant::now();
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").expect("static template"),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let stage = |s: &str| bar.set_message(s.to_owned());
    let note = |s: &str| eprintln!("{s}");
    let scene = embedded::cornell_box()?;
    let progress = Progress {
        stage: &stage,
        progress: &|_, _| {},
        note: &note,
    };
    let report = radiosity_perf::report::run(&scene, quick, out, &progress);
    bar.finish_and_clear();
    let report = report?;
    let total_s = t_all.elapsed().as_secs_f64();
    write_tables(out, &report, quick, total_s)?;
    eprintln!(
        "wrote {} (REPORT.md, report.csv, plots) in {total_s:.0} s",
        out.display()
    );
    Ok(())
}

fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Writes `report.csv` and `REPORT.md`.
fn write_tables(out: &Path, report: &Report, quick: bool, total_s: f64) -> anyhow::Result<()> {
    let rows: Vec<Vec<String>> = report.samples.iter().map(csv_row).collect();
    let csv = table::csv(&CSV_HEADER, &rows);
    write(&out.join("report.csv"), csv.as_bytes())?;
    let md = markdown::markdown(report, quick, total_s);
    write(&out.join("REPORT.md"), md.as_bytes())
}

/// The `report` flags, checked.
pub(crate) fn output_dir(dir: Option<PathBuf>) -> anyhow::Result<PathBuf> {
    let dir = dir.unwrap_or_else(|| PathBuf::from("report"));
    if dir.exists() && !dir.is_dir() {
        bail!("-o {} exists and is not a directory", dir.display());
    }
    Ok(dir)
}
