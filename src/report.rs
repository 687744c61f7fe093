//! `radiosity report [--quick] [-o DIR]`: what accuracy costs in time and memory (issue #7).
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

mod plots;
mod table;

use crate::bench::relative_l2;
use crate::embedded;
use crate::pathtrace::{ObjectEstimate, PathTracer};
use crate::picture::LinearImage;
use crate::runtime::Runtime;
use anyhow::{Context, bail};
use indicatif::{ProgressBar, ProgressStyle};
use plots::{Chart, Series};
use radiosity_backend_cpu::CpuGather;
use radiosity_bake::order::{self, OrderKind};
use radiosity_bake::pipeline::{
    BakeOutput, BakeParams, Discretised, FormatChoice, Hooks, bake_discretised, discretise,
};
use radiosity_bake::scene::Scene;
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_bake::voxel::VoxelParams;
use radiosity_perf::peers::{FaerDense, JacobiBounces, LuSolve};
use radiosity_perf::timing::{interleaved_medians, median, ms, runs_for};
use radiosity_core::{DecodeMode, Format, Gather, Rgb};
use std::fmt::Write as _;
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

/// GPU availability, decided on the first try.
enum Gpu {
    Untried,
    Available,
    Missing(String),
}

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
    let pt = PathTracer::new(&scene, &[]).context("cannot build the path tracer")?;
    let reference = pt.object_irradiance(plan.pt_samples, 7);
    let pt_ms = ms(t.elapsed());
    let pt_noise = pt_noise(&reference);

    let mut samples: Vec<Sample> = Vec::new();
    let mut gpu = Gpu::Untried;
    let mut figures = Vec::new();
    let mut speeds: Vec<(String, f64, usize)> = Vec::new();
    let mut sizes: Vec<(String, f64, usize)> = Vec::new();
    let n_max = *plan.patches.last().expect("a patch count");
    for &target in &plan.patches {
        say(format!("n = {target}: discretising"));
        let t = Instant::now();
        let params = BakeParams {
            voxel: VoxelParams::with_patches(target),
            ..BakeParams::default()
        };
        let sys = discretise(&scene, &params, Hooks::default())
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
        let level = Level {
            scene: &scene,
            sys,
            discretise_ms,
            exact,
            reference: &reference,
        };
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
        let mut by_order = Vec::new();
        if target == plan.middle {
            for &k in &plan.bounces {
                say(format!("n = {target}: K = {k}"));
                let p = BakeParams {
                    format: FormatChoice::Fixed(Format::Bc1),
                    bounces: BounceSpec::Fixed(k),
                    ..params.clone()
                };
                let (s, _, timer) = sample(&level, "bounces", &p, &plan, &mut gpu)?;
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
                    say(format!(
                        "n = {target}: order {} {}",
                        kind.name(),
                        format.name()
                    ));
                    let p = BakeParams {
                        format: FormatChoice::Fixed(format),
                        order: kind,
                        ..params.clone()
                    };
                    let (s, o, timer) = sample(&level, "order", &p, &plan, &mut gpu)?;
                    timers.push((samples.len(), timer));
                    samples.push(s);
                    if format == Format::Bc1 {
                        by_order.push((kind, o));
                    }
                }
            }
            for &f in &plan.sparse {
                say(format!("n = {target}: sparse fraction {f}"));
                let p = BakeParams {
                    format: FormatChoice::Fixed(Format::Bc1),
                    sparse_fraction: Some(f),
                    ..params.clone()
                };
                let (s, _, timer) = sample(&level, "sparse", &p, &plan, &mut gpu)?;
                timers.push((samples.len(), timer));
                samples.push(s);
            }
            for &f in &plan.corrections {
                say(format!("n = {target}: block corrections {f}"));
                let p = BakeParams {
                    format: FormatChoice::Fixed(Format::Bc1),
                    corrections: Some(f),
                    ..params.clone()
                };
                let (s, _, timer) = sample(&level, "corrections", &p, &plan, &mut gpu)?;
                timers.push((samples.len(), timer));
                samples.push(s);
            }
        }
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
            peer_rows(&level, &plan, &mut speeds, &mut sizes)?;
        }
        if target != plan.middle {
            continue;
        }
        say(format!("n = {target}: the paper's figures"));
        figures = paper_figures(out, &level, &by_order)?;
        say("rendering beside the path tracer".into());
        let (at, best_out) = keep.take().context("the BC1 bake of the middle size")?;
        figures.extend(renders(out, &pt, best_out, &samples[at], &plan)?);
    }
    bar.finish_and_clear();

    say("plots".into());
    let plot_names = summary_plots(out, &samples, &speeds, &sizes)?;
    let total_s = t_all.elapsed().as_secs_f64();
    let csv = table::csv(
        &CSV_HEADER,
        &samples.iter().map(Sample::csv_row).collect::<Vec<_>>(),
    );
    write(&out.join("report.csv"), csv.as_bytes())?;
    let md = markdown(
        &samples,
        &plan,
        quick,
        &Notes {
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
        },
    );
    write(&out.join("REPORT.md"), md.as_bytes())?;
    eprintln!(
        "wrote {} (REPORT.md, report.csv, plots) in {total_s:.0} s",
        out.display()
    );
    Ok(())
}

fn write(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Bakes one configuration from the level's system and measures it.
fn sample(
    level: &Level<'_>,
    sweep: &'static str,
    params: &BakeParams,
    plan: &Plan,
    gpu: &mut Gpu,
) -> anyhow::Result<(Sample, BakeOutput, Timer)> {
    let t = Instant::now();
    let out = bake_discretised(level.scene, &level.sys, params, Hooks::default())
        .context("bake failed")?;
    let bake_ms = level.discretise_ms + ms(t.elapsed());
    let file = &out.file;
    let n = file.n();
    let x: Vec<Rgb> = file.patches.iter().map(|p| p.emission).collect();
    let mut y = vec![Rgb::ZERO; n];
    let mut cpu = CpuGather::new(file.matrix.clone().into_owned());
    let t = Instant::now();
    cpu.gather(&x, &mut y)?;
    let runs = runs_for(t.elapsed(), plan.gather_budget, 5, 101);
    let err_exact = relative_l2(&y, |i| level.exact[file.order[i] as usize]);
    let err_pt = object_error(&out, &y, level.reference);
    // `auto` takes a hardware GPU only (a software rasteriser such as llvmpipe would time the
    // CPU twice); anything else is recorded once as the reason there is no GPU column.
    let gpu_ms = match gpu {
        Gpu::Missing(_) => None,
        _ => match crate::backend::choose(Some("auto"), file.matrix.clone()) {
            Ok(mut chosen) if chosen.kind == "gpu" => {
                *gpu = Gpu::Available;
                let mut yg = vec![Rgb::ZERO; n];
                chosen.gather.gather(&x, &mut yg)?;
                Some(ms(median(runs, || {
                    let _ = chosen.gather.gather(&x, &mut yg);
                })))
            }
            Ok(chosen) => {
                *gpu = Gpu::Missing(format!(
                    "no hardware GPU adapter (auto chose {}: {})",
                    chosen.kind, chosen.detail
                ));
                None
            }
            Err(e) => {
                *gpu = Gpu::Missing(format!("{e:#}"));
                None
            }
        },
    };
    let r = &out.report;
    let s = Sample {
        sweep,
        patches: n,
        bounces: match &r.bounces {
            serde_json::Value::String(s) if s == "infinite" => "inf".into(),
            v => v.to_string(),
        },
        format: r.format,
        order: r.order,
        sparse_fraction: f64::from(params.sparse_fraction.unwrap_or_else(|| {
            radiosity_bake::encode::default_sparse_fraction(
                Format::from_name(r.format).unwrap_or(Format::Bc1),
                r.channels,
            )
        })),
        corrections: f64::from(params.corrections.unwrap_or_else(|| {
            radiosity_bake::encode::default_correction_fraction(
                Format::from_name(r.format).unwrap_or(Format::Bc1),
                r.channels,
            )
        })),
        bake_ms,
        file_bytes: r.bytes.total,
        // Timed with the rest of its level, in turns (`time_in_turns`).
        cpu_ms: f64::NAN,
        gpu_ms,
        compression_rmse: r.compression_rmse.get(r.order).copied().unwrap_or(f64::NAN),
        err_exact,
        err_pt,
    };
    let timer = Timer {
        gather: cpu,
        x,
        y,
        runs,
    };
    Ok((s, out, timer))
}

/// A configuration's CPU gather, kept until its whole level is timed.
struct Timer {
    gather: CpuGather<'static>,
    x: Vec<Rgb>,
    y: Vec<Rgb>,
    runs: usize,
}

/// Rounds of [`interleaved_medians`] per level.
const TIMING_ROUNDS: usize = 10;

/// Times every gather of a level in turns (`TIMING_ROUNDS` rounds, each a share of every
/// configuration's runs), so that outside load on a shared machine slows them alike and the
/// comparison between configurations holds, and writes each median into its sample
/// (`timers` hold indices into `samples`). Timed one by one, right after each bake, one
/// configuration moved by up to ±40% between the report's sweeps.
fn time_in_turns(timers: &mut Vec<(usize, Timer)>, samples: &mut [Sample]) {
    let runs: Vec<usize> = timers.iter().map(|(_, t)| t.runs).collect();
    let times = interleaved_medians(&runs, TIMING_ROUNDS, |i| {
        let t = &mut timers[i].1;
        t.gather
            .gather(&t.x, &mut t.y)
            .expect("gathered once already");
    });
    for ((at, _), t) in timers.drain(..).zip(times) {
        samples[at].cpu_ms = ms(t);
    }
}

/// Area-weighted relative L2 error of the per-object mean irradiance against the path tracer:
/// `√(Σ_o A_o ‖h_o − p_o‖² / Σ_o A_o ‖p_o‖²)`. Means are over each object's full-detail area
/// (patches that see nothing count as dark), as `solve` reports them.
fn object_error(out: &BakeOutput, y: &[Rgb], reference: &[ObjectEstimate]) -> f64 {
    let areas = &out.report.object_areas;
    let mut sums = vec![[0f64; 3]; out.file.objects.len()];
    for (p, h) in out.file.patches.iter().zip(y) {
        for k in 0..3 {
            sums[p.object as usize][k] += f64::from(p.area) * f64::from(h.channel(k));
        }
    }
    let (mut num, mut den) = (0f64, 0f64);
    for (o, name) in out.file.objects.iter().enumerate() {
        let Some(r) = reference.iter().find(|r| r.name == name.as_ref()) else {
            continue;
        };
        let a = areas.get(o).copied().unwrap_or(r.area);
        if !(a > 0.0) {
            continue;
        }
        for k in 0..3 {
            num += a * (sums[o][k] / a - r.irradiance[k]).powi(2);
            den += a * r.irradiance[k].powi(2);
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        f64::NAN
    }
}

/// The path tracer's own noise in the same norm: `√(Σ A σ² / Σ A p²)`.
fn pt_noise(reference: &[ObjectEstimate]) -> f64 {
    let (mut num, mut den) = (0f64, 0f64);
    for r in reference {
        for k in 0..3 {
            num += r.area * r.stderr[k].powi(2);
            den += r.area * r.irradiance[k].powi(2);
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        f64::NAN
    }
}

/// The dense peers at the largest n, for the speed and size figures (the paper's Figs. 5, 6).
fn peer_rows(
    level: &Level<'_>,
    plan: &Plan,
    speeds: &mut Vec<(String, f64, usize)>,
    sizes: &mut Vec<(String, f64, usize)>,
) -> anyhow::Result<()> {
    let sys = &level.sys;
    let n = sys.len();
    let (m, _) = transfer_matrix(&sys.f, &sys.reflectance, sys.channels, BounceSpec::Infinite)
        .context("transfer")?;
    let x: Vec<Rgb> = sys.core_patches.iter().map(|p| p.emission).collect();
    let mut y = vec![Rgb::ZERO; n];
    let mut time = |g: &mut dyn Gather| -> anyhow::Result<f64> {
        let t = Instant::now();
        g.gather(&x, &mut y)?;
        let runs = runs_for(t.elapsed(), plan.gather_budget, 3, 101);
        Ok(ms(median(runs, || {
            let _ = g.gather(&x, &mut y);
        })))
    };
    let mut faer = FaerDense::new(n, sys.channels, &m);
    drop(m);
    speeds.push(("faer dense f32 M".into(), time(&mut faer)?, 1));
    drop(faer);
    let mut jacobi = JacobiBounces::new(&sys.f, &sys.reflectance, 8);
    speeds.push(("8 Jacobi bounces (F)".into(), time(&mut jacobi)?, 1));
    let nn = (n * n) as f64;
    sizes.push(("F dense f32".into(), 4.0 * nn, 1));
    sizes.push((
        format!("M dense f32 ×{}", sys.channels),
        4.0 * nn * sys.channels as f64,
        1,
    ));
    Ok(())
}

/// Figs. 1, 2 and 4 of the paper at the middle size: the value distribution of F and M, the
/// matrix before and after reordering, and the BC1 compression error before and after.
fn paper_figures(
    out: &Path,
    level: &Level<'_>,
    by_order: &[(OrderKind, BakeOutput)],
) -> anyhow::Result<Vec<(String, String)>> {
    let sys = &level.sys;
    let n = sys.len();
    let ch = sys.channels;
    let (m, _) =
        transfer_matrix(&sys.f, &sys.reflectance, ch, BounceSpec::Infinite).context("transfer")?;
    let mut figs = Vec::new();
    // Fig. 1: value distribution (one channel of M: green; F).
    let m_green: Vec<f32> = m.iter().skip(ch / 2).step_by(ch).copied().collect();
    let f32s: Vec<f32> = sys.f.values.iter().map(|v| *v as f32).collect();
    let p = out.join("fig1_value_distribution.png");
    plots::value_histograms(
        &p,
        &format!("Cornell box, n = {n}"),
        &[
            ("F (form factors)", &f32s),
            ("M green (all bounces)", &m_green),
        ],
    )?;
    figs.push((
        "fig1_value_distribution.png".into(),
        "Fig. 1: value distribution of F and of M (green channel): log and linear bins. On a linear 0–255 scale almost every entry would round to zero, hence the log quantiser and the exact sparse list for the largest.".into(),
    ));
    // Fig. 2: M before (bake numbering) and after the chosen order, whole and a fragment.
    let top = m_green.iter().fold(0f32, |a, b| a.max(*b));
    let side = 512u32;
    let frag = (n / 8).max(16).min(n);
    let before = |r: usize, c: usize| m_green[r * n + c];
    let paper = by_order
        .iter()
        .find(|(k, _)| *k == OrderKind::Paper)
        .map(|(_, o)| o)
        .context("paper order bake")?;
    let perm = &paper.file.order;
    let after = |r: usize, c: usize| m_green[perm[r] as usize * n + perm[c] as usize];
    let img = plots::side_by_side(
        &[
            &plots::matrix_image(n, side, &before, top, 6.0),
            &plots::matrix_image(n, side, &after, top, 6.0),
            &plots::matrix_image(frag, side / 2, &before, top, 6.0),
            &plots::matrix_image(frag, side / 2, &after, top, 6.0),
        ],
        8,
    );
    let p = out.join("fig2_matrix_orders.png");
    crate::picture::save_png_atomic(&img, &p)?;
    figs.push((
        "fig2_matrix_orders.png".into(),
        format!("Fig. 2: M (green, log10 over 6 decades, brighter = larger; each pixel the largest entry it covers) in the bake's numbering and after the paper's neighbour sort; right: the top-left {frag}×{frag} fragment of each."),
    ));
    // Fig. 4: BC1 compression error map before/after reordering, same fragment, in units of
    // the matrix maximum.
    let none = by_order
        .iter()
        .find(|(k, _)| *k == OrderKind::None)
        .map(|(_, o)| o)
        .context("unordered bake")?;
    let err_image = |o: &BakeOutput| {
        let decoded = o.file.matrix.decode_dense(DecodeMode::D3d10);
        let perm = &o.file.order;
        let exact = order::permute(&m, n, ch, perm);
        let c = ch / 2;
        let diff = |r: usize, col: usize| {
            let i = (r * n + col) * ch + c;
            (decoded[i] - exact[i]).abs()
        };
        plots::matrix_image(frag, side, &diff, top, 4.0)
    };
    let img = plots::side_by_side(&[&err_image(none), &err_image(paper)], 8);
    let p = out.join("fig4_error_map.png");
    crate::picture::save_png_atomic(&img, &p)?;
    let rmse = |o: &BakeOutput| {
        o.report
            .compression_rmse
            .get(o.report.order)
            .copied()
            .unwrap_or(f64::NAN)
    };
    figs.push((
        "fig4_error_map.png".into(),
        format!(
            "Fig. 4: |decoded BC1 − exact| over the top-left {frag}×{frag} fragment (green, log10 over 4 decades below the matrix maximum), order none (left, relative RMS error {:.4}) and paper (right, {:.4}).",
            rmse(none),
            rmse(paper)
        ),
    ));
    Ok(figs)
}

/// Figs. 7–10: the baked solution rendered beside the path tracer, same camera and exposure.
fn renders(
    out: &Path,
    pt: &PathTracer,
    baked: BakeOutput,
    s: &Sample,
    plan: &Plan,
) -> anyhow::Result<Vec<(String, String)>> {
    let rt = Runtime::new(baked.file);
    let side = plan.image_side;
    let cam = crate::render::camera(&rt, None, side, side)?;
    let mut g = CpuGather::new(rt.file.matrix.clone());
    let (frame, _) = rt.frame(&mut g, &[], 1.0)?;
    let prim = crate::render::primary(&rt, &cam, 2)?;
    let t = Instant::now();
    let ours = crate::render::shade(&rt, &prim, &frame, &[], 1.0)?;
    let ours_ms = ms(t.elapsed());
    let t = Instant::now();
    let reference: LinearImage = pt.render(&cam, plan.pt_spp, 11);
    let pt_ms = ms(t.elapsed());
    let exposure = reference.auto_exposure();
    let a = ours.to_srgb8(exposure);
    let b = reference.to_srgb8(exposure);
    crate::picture::save_png_atomic(&a, &out.join("render_baked.png"))?;
    crate::picture::save_png_atomic(&b, &out.join("render_pathtraced.png"))?;
    let p = out.join("fig7_render_vs_pathtracer.png");
    crate::picture::save_png_atomic(&plots::side_by_side(&[&a, &b], 8), &p)?;
    Ok(vec![(
        "fig7_render_vs_pathtracer.png".into(),
        format!(
            "Figs. 7–10: left, the bake ({}) lit by the box's own light, shaded in {ours_ms:.0} ms ({} s² samples/pixel, gather {:.2} ms); right, the path tracer, {} paths/pixel in {:.1} s. Same camera and exposure.",
            s.label(),
            2,
            s.cpu_ms,
            plan.pt_spp,
            pt_ms / 1e3
        ),
    )])
}

/// The summary plots; returns (file, caption) pairs.
fn summary_plots(
    out: &Path,
    samples: &[Sample],
    speeds: &[(String, f64, usize)],
    sizes: &[(String, f64, usize)],
) -> anyhow::Result<Vec<(String, String)>> {
    let mut made = Vec::new();
    let by_format = |sel: &dyn Fn(&Sample) -> Option<(f64, f64)>| -> Vec<Series> {
        Format::ALL
            .iter()
            .map(|f| Series {
                name: f.name().into(),
                points: samples
                    .iter()
                    .filter(|s| s.format == f.name())
                    .filter_map(sel)
                    .collect(),
                line: false,
            })
            .filter(|s| !s.points.is_empty())
            .collect()
    };
    // Error vs gather time at the middle size (every sweep is there), Pareto front marked.
    let middle = middle_samples(samples);
    let pts: Vec<(f64, f64)> = middle.iter().map(|s| (s.cpu_ms, s.err_exact)).collect();
    let front: Vec<(f64, f64)> = table::pareto_front(&pts).iter().map(|&i| pts[i]).collect();
    let n_mid = middle.first().map_or(0, |s| s.patches);
    let title = format!(
        "Lighting error vs CPU gather time, Cornell box n = {n_mid} (formats, K, orders, thresholds)"
    );
    let only_middle = |s: &Sample| (s.patches == n_mid).then_some((s.cpu_ms, s.err_exact));
    plots::chart(
        &out.join("error_vs_time.png"),
        &Chart {
            title: &title,
            x_label: "gather time, ms (median)",
            y_label: "relative L2 error vs exact f64 solution",
            log_x: true,
            series: by_format(&only_middle),
            front: Some(("Pareto front".into(), front)),
        },
    )?;
    made.push(("error_vs_time.png".to_owned(), format!("Headline: error of the scene's own lighting against the exact solution of the same {n_mid} patches, against CPU gather time, for every format, bounce count, order, sparse threshold and block-correction share at that size; the black line is the Pareto front.")));
    // The true error (against the path tracer) over every size.
    let pts: Vec<(f64, f64)> = samples.iter().map(|s| (s.cpu_ms, s.err_pt)).collect();
    let front: Vec<(f64, f64)> = table::pareto_front(&pts).iter().map(|&i| pts[i]).collect();
    plots::chart(
        &out.join("error_pt_vs_time.png"),
        &Chart {
            title: "Per-object error vs the path tracer, against gather time (every configuration)",
            x_label: "gather time, ms (median)",
            y_label: "relative L2 error of object irradiance vs path tracer",
            log_x: true,
            series: by_format(&|s| Some((s.cpu_ms, s.err_pt))),
            front: Some(("Pareto front".into(), front)),
        },
    )?;
    made.push(("error_pt_vs_time.png".to_owned(), "The true error: per-object mean irradiance against the reference path tracer, every size and configuration (the path tracer's own noise is in the notes at the top).".to_owned()));
    let pts: Vec<(f64, f64)> = samples
        .iter()
        .map(|s| (s.file_bytes as f64 / 1e6, s.err_exact))
        .collect();
    let front: Vec<(f64, f64)> = table::pareto_front(&pts).iter().map(|&i| pts[i]).collect();
    plots::chart(
        &out.join("error_vs_memory.png"),
        &Chart {
            title: "Lighting error vs file size",
            x_label: "file, MB",
            y_label: "relative L2 error vs exact f64 solution",
            log_x: true,
            series: by_format(&|s| Some((s.file_bytes as f64 / 1e6, s.err_exact))),
            front: Some(("Pareto front".into(), front)),
        },
    )?;
    made.push((
        "error_vs_memory.png".into(),
        "Error against file size (memory).".into(),
    ));
    // Bake time vs n with the fitted exponent, per format; gather time vs n.
    let n_series = |val: &dyn Fn(&Sample) -> f64, fit: bool| -> Vec<Series> {
        Format::ALL
            .iter()
            .filter_map(|f| {
                let points: Vec<(f64, f64)> = samples
                    .iter()
                    .filter(|s| s.sweep == "n" && s.format == f.name())
                    .map(|s| (s.patches as f64, val(s)))
                    .collect();
                if points.is_empty() {
                    return None;
                }
                let name = match (fit, table::power_fit(&points)) {
                    (true, Some((k, _))) => format!("{} (∝ n^{k:.2})", f.name()),
                    _ => f.name().to_owned(),
                };
                Some(Series {
                    name,
                    points,
                    line: true,
                })
            })
            .collect()
    };
    plots::chart(
        &out.join("bake_time_vs_n.png"),
        &Chart {
            title: "Bake time vs patches (fitted exponent in the legend)",
            x_label: "patches n",
            y_label: "bake time, ms",
            log_x: true,
            series: n_series(&|s| s.bake_ms, true),
            front: None,
        },
    )?;
    made.push(("bake_time_vs_n.png".into(), "Bake time (discretisation, form factors, transfer, orders, encoding) against n, with the least-squares exponent of each format.".into()));
    plots::chart(
        &out.join("gather_time_vs_n.png"),
        &Chart {
            title: "CPU gather time vs patches (fitted exponent in the legend)",
            x_label: "patches n",
            y_label: "gather time, ms",
            log_x: true,
            series: n_series(&|s| s.cpu_ms, true),
            front: None,
        },
    )?;
    made.push((
        "gather_time_vs_n.png".into(),
        "Gather time against n (n² entries: exponent 2 once out of the caches).".into(),
    ));
    // Compression error by order and format.
    let orders = ["none", "random", "paper", "spatial"];
    let mut bars = Vec::new();
    for (g, f) in ["bc1", "bc4"].iter().enumerate() {
        for o in orders {
            if let Some(s) = samples
                .iter()
                .find(|s| s.sweep == "order" && s.format == *f && s.order == o)
            {
                bars.push((format!("{f} {o}"), s.compression_rmse, g));
            }
        }
    }
    plots::bars(
        &out.join("order_error.png"),
        "Compression error by patch order and format (the reordering gain)",
        "relative Frobenius error of the decoded M",
        &bars,
        &["bc1", "bc4"],
    )?;
    made.push((
        "order_error.png".into(),
        "Compression error of M by order and format at the middle size.".into(),
    ));
    plots::bars(
        &out.join("fig5_sizes.png"),
        "Fig. 5: sizes at the largest n, bytes",
        "bytes",
        sizes,
        &["compressed transfer files", "dense matrices"],
    )?;
    made.push(("fig5_sizes.png".into(), "Fig. 5: sizes of the transfer files in each format against the dense form-factor matrix F and the dense multi-bounce M.".into()));
    plots::bars(
        &out.join("fig6_speeds.png"),
        "Fig. 6: per-frame light transport at the largest n, ms",
        "ms per frame (median)",
        speeds,
        &["one gather of M", "peers"],
    )?;
    made.push(("fig6_speeds.png".into(), "Fig. 6: one gather per format against faer's dense mat-vec of M and 8 Jacobi bounces with F (classical radiosity).".into()));
    Ok(made)
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

struct Notes {
    pt_ms: f64,
    pt_noise: f64,
    total_s: f64,
    gpu: String,
    plots: Vec<(String, String)>,
    figures: Vec<(String, String)>,
}

fn markdown(samples: &[Sample], plan: &Plan, quick: bool, notes: &Notes) -> String {
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

/// The `report` flags, checked.
pub(crate) fn output_dir(dir: Option<PathBuf>) -> anyhow::Result<PathBuf> {
    let dir = dir.unwrap_or_else(|| PathBuf::from("report"));
    if dir.exists() && !dir.is_dir() {
        bail!("-o {} exists and is not a directory", dir.display());
    }
    Ok(dir)
}
