//! `radiosity bench [--patches N] [--json] [--runs R]`: the per-frame gather in every format
//! against its peers, on the embedded Cornell box, in one run ([`radiosity_perf::bench`]
//! measures; this prints its report as a table or as JSON, its progress on stderr).

use crate::embedded;
use anyhow::Context;
use radiosity_perf::Progress;
use radiosity_perf::bench::{HOST_FRAMES, Report, RowOut};

/// Runs the bench and prints the table (or JSON).
pub(crate) fn run(patches: usize, json: bool, runs: Option<usize>) -> anyhow::Result<()> {
    radiosity_perf::bench::check(patches, runs)?;
    let bar = crate::progress::stage_bar(28, "", false);
    let (stage, progress) = crate::progress::callbacks(&bar);
    let note = |s: &str| eprintln!("{s}");
    let scene = embedded::cornell_box()?;
    let report = radiosity_perf::bench::run(
        &scene,
        "cornell-box (embedded CornellBox-Original)",
        patches,
        runs,
        &Progress {
            stage: &stage,
            progress: &progress,
            note: &note,
        },
    )?;
    bar.finish_and_clear();
    if json {
        outln!(
            "{}",
            serde_json::to_string_pretty(&report).context("cannot serialise the report")?
        );
    } else {
        print_text(&report);
    }
    Ok(())
}

fn print_text(r: &Report) {
    outln!(
        "radiosity bench: {} patches ({} channels, {} order) on the {}, {} threads, CPU SIMD path {}",
        r.patches,
        r.channels,
        r.order,
        r.scene,
        r.threads,
        r.simd_path
    );
    outln!(
        "roofline: streaming read {:.1} GB/s from a {} MiB buffer (faster where a working set fits a cache: column roof), {:.1} G f32 FMA/s ({}); bound = max(bytes/roof, FMAs/rate)",
        r.roofline.bandwidth_gb_s,
        r.roofline.buffer_bytes >> 20,
        r.roofline.fma_gflop_s,
        r.roofline.fma_path
    );
    outln!(
        "times are medians of repeated calls (runs column), the methods timed in turns; errors are relative L2 of the irradiance against the exact f64 solution of the same patches\n"
    );
    print_rows(&r.rows);
    print_frames(r);
    for q in &r.ratios {
        outln!(
            "{} is {:.1}× faster than {} (target ≥ {}×: {})",
            q.method,
            q.speedup,
            q.against,
            q.target,
            if q.met { "met" } else { "NOT met" }
        );
    }
}

/// The methods' table and their notes.
fn print_rows(rows: &[RowOut]) {
    outln!(
        "{:<16} {:>9} {:>6} {:>10} {:>8} {:>7} {:>7} {:>9} {:>7} {:>8} {:>10} {:>10} {:>10}",
        "method",
        "ms",
        "runs",
        "MB/call",
        "MFMA",
        "GB/s",
        "roof",
        "bound ms",
        "×bound",
        "limit",
        "rel_error",
        "err(rand)",
        "setup ms"
    );
    for row in rows {
        outln!(
            "{:<16} {:>9.3} {:>6} {:>10.2} {:>8.1} {:>7.1} {:>7.1} {:>9.3} {:>7.1} {:>8} {:>10} {:>10.2e} {:>10.0}",
            row.method,
            row.ms,
            row.runs,
            row.bytes as f64 / 1e6,
            row.fmas as f64 / 1e6,
            row.achieved_gb_s,
            row.roof_gb_s,
            row.bound_ms,
            row.from_bound,
            row.limit,
            row.rel_error
                .map_or_else(|| "-".to_owned(), |e| format!("{e:.2e}")),
            row.rel_error_random,
            row.setup_ms
        );
    }
    outln!("");
    for row in rows {
        outln!("  {}: {}", row.method, row.note);
    }
    outln!("");
}

/// The frame around the gather: the direct light, the probes, the host-device frames.
fn print_frames(r: &Report) {
    if let Some(d) = &r.direct {
        outln!(
            "direct light with shadows ({} points): solve --lights {:.3} ms, rad_scene_direct {:.3} ms",
            d.points,
            d.cli_ms,
            d.c_ms
        );
        outln!("");
    }
    if let Some(p) = &r.probes {
        outln!(
            "probes (bake --probes auto): {} probes, {} weights, {:.2} MB; P·(B − E) on the CPU {:.3} ms",
            p.count,
            p.weights,
            p.bytes as f64 / 1e6,
            p.cpu_ms
        );
        outln!("");
    }
    if r.host_frames.is_empty() {
        return;
    }
    outln!(
        "host-device frame (HostGather + CornerPass + ProbePass recorded into one encoder, medians of {HOST_FRAMES} frames; GPU times from timestamps):"
    );
    let gpu = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v:.3}"));
    for f in &r.host_frames {
        outln!(
            "  {}: {} {} decode, {} dispatches, {} corners, {} probes: record {:.4} ms CPU, gather {} ms GPU, corners {} ms GPU, probes {} ms GPU",
            f.adapter,
            f.format,
            f.path,
            f.dispatches,
            f.corners,
            f.probes,
            f.record_ms,
            gpu(f.gather_ms),
            gpu(f.corners_ms),
            gpu(f.probes_ms)
        );
    }
    outln!("");
}
