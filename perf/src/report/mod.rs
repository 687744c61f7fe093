//! The report (`radiosity report`): what accuracy costs in time and memory ([`run`], which
//! returns a [`Report`]).
//!
//! On a scene (the command line's is the embedded Cornell box) it sweeps the patch count n
//! (every format at each n), and at one middle n the bounces K, the patch order (BC1 and BC4),
//! the sparse threshold and the share of blocks corrected. Each configuration is baked from one
//! shared discretisation per n (`discretise` then `bake_discretised`), and records: bake time
//! (discretisation included), file bytes, CPU gather time (median), GPU gather time when a GPU
//! backend is available, compression error, the error of the scene's own lighting against the
//! exact f64 solution of the same patches (LU), and the error of the per-object irradiance
//! against the reference path tracer (which also counts what the discretisation itself loses).
//! It draws PNG plots into the output directory, among them the paper's figures for this
//! scene; the caller writes the tables.
//!
//! `measure.rs` bakes and measures one configuration, `figures.rs` draws the pictures (with the
//! charts of [`crate::plots`]), `fit.rs` holds the Pareto front and the power-law fit.

mod figures;
mod fit;
mod measure;

use crate::Progress;
use crate::peers::LuSolve;
use crate::timing::ms;
use anyhow::Context;
pub use fit::{pareto_front, power_fit};
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
use std::path::Path;
use std::time::{Duration, Instant};

/// How much to sweep.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The patch counts swept, every format at each.
    pub patches: Vec<usize>,
    /// Where the K, order and threshold sweeps and the figures are made.
    pub middle: usize,
    /// The bounce counts of the K sweep.
    pub bounces: Vec<u32>,
    /// The sparse fractions of the threshold sweep.
    pub sparse: Vec<f32>,
    /// Shares of the blocks given a block correction (BC1).
    pub corrections: Vec<f32>,
    /// Path-tracer samples per object (standard error ∝ 1/√samples).
    pub pt_samples: usize,
    /// Rendered image side.
    pub image_side: u32,
    /// Path-traced samples per pixel.
    pub pt_spp: u32,
    /// Time spent per gather median.
    pub gather_budget: Duration,
}

impl Plan {
    /// The quick sweep (about 2 minutes on 2 cores) or the full one (under 30).
    pub fn new(quick: bool) -> Self {
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
pub struct Sample {
    /// The sweep it belongs to: `n`, `bounces`, `order`, `sparse` or `corrections`.
    pub sweep: &'static str,
    /// Patches of the bake.
    pub patches: usize,
    /// Bounces, `inf` for all of them.
    pub bounces: String,
    /// The storage format's name.
    pub format: &'static str,
    /// The patch order's name.
    pub order: &'static str,
    /// Fraction of the entries kept exactly.
    pub sparse_fraction: f64,
    /// Share of the blocks corrected ([`BakeParams::corrections`]).
    pub corrections: f64,
    /// Bake time, the shared discretisation included, ms.
    pub bake_ms: f64,
    /// Bytes of the file.
    pub file_bytes: usize,
    /// Median CPU gather time, ms.
    pub cpu_ms: f64,
    /// Median GPU gather time, ms, where a hardware GPU was found.
    pub gpu_ms: Option<f64>,
    /// Relative Frobenius error of the decoded matrix.
    pub compression_rmse: f64,
    /// Relative L2 error of the scene's own lighting against the exact solution.
    pub err_exact: f64,
    /// Area-weighted relative L2 error of the per-object irradiance against the path tracer.
    pub err_pt: f64,
}

impl Sample {
    /// `bc1 n=512 paper K=inf`.
    pub fn label(&self) -> String {
        format!(
            "{} n={} {} K={}",
            self.format, self.patches, self.order, self.bounces
        )
    }
}

/// What the report measured and drew.
#[derive(Clone, Debug)]
pub struct Report {
    /// The sweep made.
    pub plan: Plan,
    /// Every configuration, in the order measured.
    pub samples: Vec<Sample>,
    /// The reference path trace's time, ms.
    pub pt_ms: f64,
    /// The path tracer's own noise in the per-object error's norm.
    pub pt_noise: f64,
    /// The GPU column's state: `measured`, or why not.
    pub gpu: String,
    /// Threads of the CPU gathers.
    pub threads: usize,
    /// The CPU gather's SIMD path.
    pub simd_path: &'static str,
    /// The summary plots written: (file name, caption).
    pub plots: Vec<(String, String)>,
    /// The paper's figures and the renders written: (file name, caption).
    pub figures: Vec<(String, String)>,
}

impl Report {
    /// The samples at the size where every sweep was made (the one with the most samples).
    pub fn middle_samples(&self) -> Vec<&Sample> {
        middle_samples(&self.samples)
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

/// The report so far: every sample, the CPU gathers of the current size waiting to be timed,
/// the GPU's state, and what the figures need.
struct Sweep<'a> {
    plan: &'a Plan,
    progress: &'a Progress<'a>,
    samples: Vec<Sample>,
    /// Gathers of the current size, by the index of their sample.
    timers: Vec<(usize, Timer)>,
    gpu: Gpu,
    figures: Vec<(String, String)>,
    /// Fig. 6's bars: (label, ms, group).
    speeds: Vec<(String, f64, usize)>,
    /// Fig. 5's bars: (label, bytes, group).
    sizes: Vec<(String, f64, usize)>,
}

impl Sweep<'_> {
    /// Bakes and measures one configuration of `level`: pushes its sample and its CPU gather
    /// (timed with the rest of its size); returns its bake and its sample's index.
    fn add(
        &mut self,
        level: &Level<'_>,
        sweep: &'static str,
        params: &BakeParams,
    ) -> anyhow::Result<(BakeOutput, usize)> {
        let (s, o, timer) = sample(
            level,
            sweep,
            params,
            self.plan,
            &mut self.gpu,
            self.progress,
        )?;
        let at = self.samples.len();
        self.timers.push((at, timer));
        self.samples.push(s);
        Ok((o, at))
    }

    /// Every format at `target` patches (and at the middle size every sweep, the paper's
    /// figures and the renders beside the path tracer), timed in turns; the peers at the
    /// largest size.
    fn size(
        &mut self,
        target: usize,
        scene: &Scene,
        pt: &PathTracer,
        reference: &[ObjectEstimate],
        out: &Path,
    ) -> anyhow::Result<()> {
        let (plan, stage) = (self.plan, self.progress.stage);
        let n_max = *plan.patches.last().context("a patch count")?;
        stage(&format!("n = {target}: discretising"));
        let params = BakeParams {
            voxel: VoxelParams::with_patches(target),
            ..BakeParams::default()
        };
        let level = Level::new(scene, &params, reference)?;
        let mut keep: Option<(usize, BakeOutput)> = None;
        let mut by_format = Vec::new();
        for format in Format::ALL {
            stage(&format!("n = {target}: {} bake and gather", format.name()));
            let p = BakeParams {
                format: FormatChoice::Fixed(format),
                ..params.clone()
            };
            let (o, at) = self.add(&level, "n", &p)?;
            if target == n_max {
                let bytes = self.samples[at].file_bytes as f64;
                self.sizes
                    .push((format!("{} file", format.name()), bytes, 0));
            }
            by_format.push((format, at));
            if target == plan.middle && format == Format::Bc1 {
                keep = Some((at, o));
            }
        }
        let by_order = if target == plan.middle {
            self.middle_sweeps(&level, &params)?
        } else {
            Vec::new()
        };
        stage(&format!(
            "n = {target}: timing {} CPU gathers in turns",
            self.timers.len()
        ));
        time_in_turns(&mut self.timers, &mut self.samples);
        if target == n_max {
            for &(format, at) in &by_format {
                let ms = self.samples[at].cpu_ms;
                self.speeds
                    .push((format!("gather {}", format.name()), ms, 0));
            }
            stage(&format!("n = {target}: peers"));
            measure::peer_rows(&level, plan, &mut self.speeds, &mut self.sizes)?;
        }
        if target != plan.middle {
            return Ok(());
        }
        stage(&format!("n = {target}: the paper's figures"));
        self.figures = figures::paper_figures(out, &level, &by_order)?;
        stage("rendering beside the path tracer");
        let (at, best_out) = keep.take().context("the BC1 bake of the middle size")?;
        let renders = figures::renders(out, pt, best_out, &self.samples[at], plan)?;
        self.figures.extend(renders);
        Ok(())
    }

    /// The sweeps made at the middle size only: bounces K, patch orders (BC1 and BC4), sparse
    /// thresholds and block corrections. Returns the BC1 bake of each order, for the paper's
    /// figures.
    fn middle_sweeps(
        &mut self,
        level: &Level<'_>,
        params: &BakeParams,
    ) -> anyhow::Result<Vec<(OrderKind, BakeOutput)>> {
        let (target, stage) = (self.plan.middle, self.progress.stage);
        let bc1 = BakeParams {
            format: FormatChoice::Fixed(Format::Bc1),
            ..params.clone()
        };
        for &k in &self.plan.bounces {
            stage(&format!("n = {target}: K = {k}"));
            let p = BakeParams {
                bounces: BounceSpec::Fixed(k),
                ..bc1.clone()
            };
            self.add(level, "bounces", &p)?;
        }
        let mut by_order = Vec::new();
        for format in [Format::Bc1, Format::Bc4] {
            for kind in [
                OrderKind::None,
                OrderKind::Random,
                OrderKind::Paper,
                OrderKind::Spatial,
            ] {
                stage(&format!(
                    "n = {target}: order {} {}",
                    kind.name(),
                    format.name()
                ));
                let p = BakeParams {
                    format: FormatChoice::Fixed(format),
                    order: kind,
                    ..params.clone()
                };
                let (o, _) = self.add(level, "order", &p)?;
                if format == Format::Bc1 {
                    by_order.push((kind, o));
                }
            }
        }
        for &f in &self.plan.sparse {
            stage(&format!("n = {target}: sparse fraction {f}"));
            let p = BakeParams {
                sparse_fraction: Some(f),
                ..bc1.clone()
            };
            self.add(level, "sparse", &p)?;
        }
        for &f in &self.plan.corrections {
            stage(&format!("n = {target}: block corrections {f}"));
            let p = BakeParams {
                corrections: Some(f),
                ..bc1.clone()
            };
            self.add(level, "corrections", &p)?;
        }
        Ok(by_order)
    }
}

/// Measures the report on `scene` (`quick`: the smaller sweep, [`Plan::new`]) and draws its
/// plots and figures into `out` (created if need be): the reference path trace, then per
/// patch count the discretisation, the bakes of every format (and at the middle size every
/// sweep), their gathers timed in turns, the peers at the largest size and the figures at the
/// middle one; then the summary plots.
pub fn run(
    scene: &Scene,
    quick: bool,
    out: &Path,
    progress: &Progress<'_>,
) -> anyhow::Result<Report> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let plan = Plan::new(quick);
    (progress.stage)(&format!(
        "path tracing the reference ({} samples per object)",
        plan.pt_samples
    ));
    let t = Instant::now();
    let pt = PathTracer::new(scene, &[])
        .map_err(anyhow::Error::msg)
        .context("cannot build the path tracer")?;
    let reference = pt.object_irradiance(plan.pt_samples, 7);
    let pt_ms = ms(t.elapsed());
    let mut sweep = Sweep {
        plan: &plan,
        progress,
        samples: Vec::new(),
        timers: Vec::new(),
        gpu: Gpu::Untried,
        figures: Vec::new(),
        speeds: Vec::new(),
        sizes: Vec::new(),
    };
    for &target in &plan.patches {
        sweep.size(target, scene, &pt, &reference, out)?;
    }
    (progress.stage)("plots");
    let plots = figures::summary_plots(out, &sweep.samples, &sweep.speeds, &sweep.sizes)?;
    let gpu = match &sweep.gpu {
        Gpu::Available => "measured".into(),
        Gpu::Missing(why) => format!("not measured: {why}"),
        Gpu::Untried => "not tried".into(),
    };
    Ok(Report {
        samples: sweep.samples,
        figures: sweep.figures,
        plan,
        pt_ms,
        pt_noise: measure::pt_noise(&reference),
        gpu,
        threads: rayon::current_num_threads(),
        simd_path: radiosity_backend_cpu::SimdPath::detect().name(),
        plots,
    })
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
