//! `radiosity report [--quick] [-o DIR]`: what accuracy costs in time and memory.
//!
//! On the embedded Cornell box it sweeps the patch count n (every format at each n), and at one
//! middle n the bounces K, the patch order (BC1 and BC4), the sparse threshold and the share of
//! blocks corrected. Each configuration is baked from one shared discretisation per n ([`discretise`] then
//! [`bake_discretised`]), and records: bake time (discretisation included), file bytes, CPU
//! gather time (median), GPU gather time when a GPU backend is available, compression error,
//! the error of the scene's own lighting against the exact f64 solution of the same patches
//! (LU), and the error of the per-object irradiance against the reference path tracer (which
//! also counts what the discretisation itself loses). It writes `REPORT.md`, `report.csv`,
//! and PNG plots, among them the paper's figures for this scene.
//!
//! `measure.rs` bakes and measures one configuration, `figures.rs` draws the pictures (with the
//! charts of `radiosity_perf::plots`), `markdown.rs` and `table.rs` write the tables.

mod figures;
mod markdown;
mod measure;
mod table;

use crate::embedded;
use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use markdown::{Notes, markdown};
use measure::{Timer, sample, time_in_turns};
use radiosity_bake::order::OrderKind;
use radiosity_bake::pipeline::{
    BakeOutput, BakeParams, Discretised, FormatChoice, Hooks, discretise,
};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_bake::transfer::BounceSpec;
use radiosity_core::Format;
use radiosity_pathtrace::{ObjectEstimate, PathTracer};
use radiosity_perf::peers::LuSolve;
use radiosity_perf::timing::ms;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How much to sweep.
struct Plan {
    patches: Vec<usize>,
    /// Where the K, order and threshold sweeps and the figures are made.
    middle: usize,
    bounces: Vec<u32>,
    sparse: Vec<f32>,
    /// Shares of the blocks given a block correction (BC1).
    corrections: Vec<f32>,
    /// Path-tracer samples per object (standard error ∝ 1/√samples).
    pt_samples: usize,
    /// Rendered image side and path-traced samples per pixel.
    image_side: u32,
    pt_spp: u32,
    /// Time spent per gather median.
    gather_budget: Duration,
}

impl Plan {
    fn new(quick: bool) -> Self {
        if quick {
            Self {
                patches: vec![256, 512, 1024],
                middle: 512,
                bounces: vec![1, 2, 4, 8],
                sparse: vec![0.0, 0.002, 0.008, 0.032],
                corrections: vec![0.0, 0.025, 0.1],
                pt_samples: 1 << 16,
                image_side: 160,
                pt_spp: 32,
                gather_budget: Duration::from_millis(150),
            }
        } else {
            Self {
                patches: vec![256, 512, 1024, 2048, 4096],
                middle: 2048,
                bounces: vec![1, 2, 4, 8, 16],
                sparse: vec![0.0, 0.001, 0.002, 0.004, 0.008, 0.016, 0.032, 0.064],
                corrections: vec![0.0, 0.0125, 0.025, 0.05, 0.1],
                pt_samples: 1 << 20,
                image_side: 384,
                pt_spp: 512,
                gather_budget: Duration::from_millis(600),
            }
        }
    }
}

/// One baked configuration and what it measured.
#[derive(Clone, Debug)]
struct Sample {
    sweep: &'static str,
    patches: usize,
    bounces: String,
    format: &'static str,
    order: &'static str,
    sparse_fraction: f64,
    /// Share of the blocks corrected ([`BakeParams::corrections`]).
    corrections: f64,
    bake_ms: f64,
    file_bytes: usize,
    cpu_ms: f64,
    gpu_ms: Option<f64>,
    compression_rmse: f64,
    err_exact: f64,
    err_pt: f64,
}

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

impl Sample {
    fn csv_row(&self) -> Vec<String> {
        vec![
            self.sweep.into(),
            self.patches.to_string(),
            self.bounces.clone(),
            self.format.into(),
            self.order.into(),
            format!("{}", self.sparse_fraction),
            format!("{}", self.corrections),
            format!("{:.1}", self.bake_ms),
            self.file_bytes.to_string(),
            format!("{:.4}", self.cpu_ms),
            self.gpu_ms.map_or(String::new(), |v| format!("{v:.4}")),
            format!("{:.5e}", self.compression_rmse),
            format!("{:.5e}", self.err_exact),
            format!("{:.5e}", self.err_pt),
        ]
    }

    fn label(&self) -> String {
        format!(
            "{} n={} {} K={}",
            self.format, self.patches, self.order, self.bounces
        )
    }
}

/// What every sample at one n shares.
struct Level<'a> {
    scene: &'a Scene,
    sys: Discretised,
    discretise_ms: f64,
    /// Exact irradiance from the scene's emitters, bake numbering (live patches).
    exact: Vec<[f64; 3]>,
    reference: &'a [ObjectEstimate],
}

impl<'a> Level<'a> {
    /// Discretises `scene` as `params` say and solves its own lighting exactly (LU).
    fn new(
        scene: &'a Scene,
        params: &BakeParams,
        reference: &'a [ObjectEstimate],
    ) -> anyhow::Result<Self> {
        let t = Instant::now();
        let sys = discretise(scene, params, Hooks::default())
            .context("cannot discretise the Cornell box")?;
        let discretise_ms = ms(t.elapsed());
        let emission: Vec<[f64; 3]> = sys
            .core_patches
            .iter()
            .map(|p| p.emission.to_array().map(f64::from))
            .collect();
        let mut lu = LuSolve::new(&sys.f, &sys.reflectance);
        let exact = lu.solve(&emission);
        drop(lu);
        Ok(Level {
            scene,
            sys,
            discretise_ms,
            exact,
            reference,
        })
    }
}

/// GPU availability, decided on the first try.
enum Gpu {
    Untried,
    Available,
    Missing(String),
}

/// `radiosity report`: the reference path trace, then per patch count the discretisation, the
/// bakes of every format (and at the middle size every sweep), their gathers timed in turns,
/// the peers at the largest size and the figures at the middle one; then the plots, the CSV
/// and `REPORT.md` in `out`.
pub(crate) fn run(quick: bool, out: &Path) -> anyhow::Result<()> {
    let t_all = Instant::now();
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let plan = Plan::new(quick);
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").expect("static template"),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    let say = |s: String| bar.set_message(s);

    let scene = embedded::cornell_box()?;
    say(format!(
        "path tracing the reference ({} samples per object)",
        plan.pt_samples
    ));
    let t = Instant::now();
    let pt = PathTracer::new(&scene, &[])
        .map_err(anyhow::Error::msg)
        .context("cannot build the path tracer")?;
    let reference = pt.object_irradiance(plan.pt_samples, 7);
    let pt_ms = ms(t.elapsed());
    let pt_noise = measure::pt_noise(&reference);

    let mut samples: Vec<Sample> = Vec::new();
    let mut gpu = Gpu::Untried;
    let mut figures = Vec::new();
    let mut speeds: Vec<(String, f64, usize)> = Vec::new();
    let mut sizes: Vec<(String, f64, usize)> = Vec::new();
    let n_max = *plan.patches.last().expect("a patch count");
    for &target in &plan.patches {
        say(format!("n = {target}: discretising"));
        let params = BakeParams {
            voxel: VoxelParams::with_patches(target),
            ..BakeParams::default()
        };
        let level = Level::new(&scene, &params, &reference)?;
        let mut keep: Option<(usize, BakeOutput)> = None;
        let mut timers: Vec<(usize, Timer)> = Vec::new();
        let mut by_format = Vec::new();
        for format in Format::ALL {
            say(format!("n = {target}: {} bake and gather", format.name()));
            let p = BakeParams {
                format: FormatChoice::Fixed(format),
                ..params.clone()
            };
            let (s, o, timer) = sample(&level, "n", &p, &plan, &mut gpu)?;
            if target == n_max {
                sizes.push((format!("{} file", format.name()), s.file_bytes as f64, 0));
            }
            by_format.push((format, samples.len()));
            timers.push((samples.len(), timer));
            if target == plan.middle && format == Format::Bc1 {
                keep = Some((samples.len(), o));
            }
            samples.push(s);
        }
        let by_order = if target == plan.middle {
            middle_sweeps(
                &level,
                &params,
                &plan,
                &mut gpu,
                &mut samples,
                &mut timers,
                &bar,
            )?
        } else {
            Vec::new()
        };
        say(format!(
            "n = {target}: timing {} CPU gathers in turns",
            timers.len()
        ));
        time_in_turns(&mut timers, &mut samples);
        if target == n_max {
            for &(format, at) in &by_format {
                speeds.push((format!("gather {}", format.name()), samples[at].cpu_ms, 0));
            }
            say(format!("n = {target}: peers"));
            measure::peer_rows(&level, &plan, &mut speeds, &mut sizes)?;
        }
        if target != plan.middle {
            continue;
        }
        say(format!("n = {target}: the paper's figures"));
        figures = figures::paper_figures(out, &level, &by_order)?;
        say("rendering beside the path tracer".into());
        let (at, best_out) = keep.take().context("the BC1 bake of the middle size")?;
        figures.extend(figures::renders(out, &pt, best_out, &samples[at], &plan)?);
    }
    bar.finish_and_clear();

    say("plots".into());
    let plot_names = figures::summary_plots(out, &samples, &speeds, &sizes)?;
    let total_s = t_all.elapsed().as_secs_f64();
    let notes = Notes {
        pt_ms,
        pt_noise,
        total_s,
        gpu: match &gpu {
            Gpu::Available => "measured".into(),
            Gpu::Missing(why) => format!("not measured: {why}"),
            Gpu::Untried => "not tried".into(),
        },
        plots: plot_names,
        figures,
    };
    write_tables(out, &samples, &plan, quick, &notes)?;
    eprintln!(
        "wrote {} (REPORT.md, report.csv, plots) in {total_s:.0} s",
        out.display()
    );
    Ok(())
}

/// The sweeps made at the middle size only: bounces K, patch orders (BC1 and BC4), sparse
/// thresholds and block corrections. Pushes their samples and CPU timers; returns the BC1 bake
/// of each order, for the paper's figures.
fn middle_sweeps(
    level: &Level<'_>,
    params: &BakeParams,
    plan: &Plan,
    gpu: &mut Gpu,
    samples: &mut Vec<Sample>,
    timers: &mut Vec<(usize, Timer)>,
    bar: &ProgressBar,
) -> anyhow::Result<Vec<(OrderKind, BakeOutput)>> {
    let target = plan.middle;
    let mut by_order = Vec::new();
    for &k in &plan.bounces {
        bar.set_message(format!("n = {target}: K = {k}"));
        let p = BakeParams {
            format: FormatChoice::Fixed(Format::Bc1),
            bounces: BounceSpec::Fixed(k),
            ..params.clone()
        };
        let (s, _, timer) = sample(level, "bounces", &p, plan, gpu)?;
        timers.push((samples.len(), timer));
        samples.push(s);
    }
    for format in [Format::Bc1, Format::Bc4] {
        for kind in [
            OrderKind::None,
            OrderKind::Random,
            OrderKind::Paper,
            OrderKind::Spatial,
        ] {
            bar.set_message(format!(
                "n = {target}: order {} {}",
                kind.name(),
                format.name()
            ));
            let p = BakeParams {
                format: FormatChoice::Fixed(format),
                order: kind,
                ..params.clone()
            };
            let (s, o, timer) = sample(level, "order", &p, plan, gpu)?;
            timers.push((samples.len(), timer));
            samples.push(s);
            if format == Format::Bc1 {
                by_order.push((kind, o));
            }
        }
    }
    for &f in &plan.sparse {
        bar.set_message(format!("n = {target}: sparse fraction {f}"));
        let p = BakeParams {
            format: FormatChoice::Fixed(Format::Bc1),
            sparse_fraction: Some(f),
            ..params.clone()
        };
        let (s, _, timer) = sample(level, "sparse", &p, plan, gpu)?;
        timers.push((samples.len(), timer));
        samples.push(s);
    }
    for &f in &plan.corrections {
        bar.set_message(format!("n = {target}: block corrections {f}"));
        let p = BakeParams {
            format: FormatChoice::Fixed(Format::Bc1),
            corrections: Some(f),
            ..params.clone()
        };
        let (s, _, timer) = sample(level, "corrections", &p, plan, gpu)?;
        timers.push((samples.len(), timer));
        samples.push(s);
    }
    Ok(by_order)
}

fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Writes `report.csv` and `REPORT.md`.
fn write_tables(
    out: &Path,
    samples: &[Sample],
    plan: &Plan,
    quick: bool,
    notes: &Notes,
) -> anyhow::Result<()> {
    let csv = table::csv(
        &CSV_HEADER,
        &samples.iter().map(Sample::csv_row).collect::<Vec<_>>(),
    );
    write(&out.join("report.csv"), csv.as_bytes())?;
    let md = markdown(samples, plan, quick, notes);
    write(&out.join("REPORT.md"), md.as_bytes())
}

/// The samples at the size where every sweep was made (the one with the most samples).
fn middle_samples(samples: &[Sample]) -> Vec<&Sample> {
    let n = samples
        .iter()
        .filter(|s| s.sweep == "order")
        .map(|s| s.patches)
        .next()
        .unwrap_or(0);
    samples.iter().filter(|s| s.patches == n).collect()
}

/// The `report` flags, checked.
pub(crate) fn output_dir(dir: Option<PathBuf>) -> anyhow::Result<PathBuf> {
    let dir = dir.unwrap_or_else(|| PathBuf::from("report"));
    if dir.exists() && !dir.is_dir() {
        bail!("-o {} exists and is not a directory", dir.display());
    }
    Ok(dir)
}
