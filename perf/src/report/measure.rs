//! Measuring one configuration: its bake, the error of its lighting against the exact
//! solution and the path tracer, its GPU gather, and (with the rest of its level, in turns) its
//! CPU gather; the dense peers at the largest size.

use super::{Gpu, Level, Plan, Sample};
use crate::Progress;
use crate::backend::{Request, choose};
use crate::bench::relative_l2;
use crate::peers::{FaerDense, JacobiBounces};
use crate::timing::{interleaved_medians, median, ms, runs_for};
use anyhow::Context;
use radiosity_backend_cpu::CpuGather;
use radiosity_bake::pipeline::{BakeOutput, BakeParams, Hooks, ObjectShares, bake_discretised};
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_core::{Format, Gather, Rgb, TransferMatrix};
use radiosity_pathtrace::ObjectEstimate;
use std::time::Instant;

/// Bakes one configuration from the level's system and measures it; the GPU backend chosen
/// is a note of `progress`.
pub(super) fn sample(
    level: &Level<'_>,
    sweep: &'static str,
    params: &BakeParams,
    plan: &Plan,
    gpu: &mut Gpu,
    progress: &Progress<'_>,
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
    let gpu_ms = gpu_median(gpu, &file.matrix, &x, runs, progress)?;
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

/// The median GPU gather time of `matrix` on `auto`'s backend, when that is a GPU. `auto`
/// takes a hardware GPU only (a software rasteriser such as llvmpipe would time the CPU
/// twice); anything else is recorded once in `gpu` as the reason there is no GPU column.
fn gpu_median(
    gpu: &mut Gpu,
    matrix: &TransferMatrix<'_>,
    x: &[Rgb],
    runs: usize,
    progress: &Progress<'_>,
) -> anyhow::Result<Option<f64>> {
    if let Gpu::Missing(_) = gpu {
        return Ok(None);
    }
    let auto = Request::new(Some("auto"), None)?;
    Ok(match choose(&auto, matrix.clone().into_owned()) {
        Ok(mut chosen) => {
            (progress.note)(&format!(
                "backend: {} ({})",
                chosen.gather.name(),
                chosen.detail
            ));
            if chosen.kind != "gpu" {
                *gpu = Gpu::Missing(format!(
                    "no hardware GPU adapter (auto chose {}: {})",
                    chosen.kind, chosen.detail
                ));
                return Ok(None);
            }
            *gpu = Gpu::Available;
            let mut y = vec![Rgb::ZERO; x.len()];
            chosen.gather.gather(x, &mut y)?;
            Some(ms(median(runs, || {
                let _ = chosen.gather.gather(x, &mut y);
            })))
        }
        Err(e) => {
            *gpu = Gpu::Missing(format!("{e:#}"));
            None
        }
    })
}

/// A configuration's CPU gather, kept until its whole level is timed.
pub(super) struct Timer {
    gather: CpuGather<'static>,
    x: Vec<Rgb>,
    y: Vec<Rgb>,
    runs: usize,
}

/// Rounds of [`interleaved_medians`] per level.
pub(super) const TIMING_ROUNDS: usize = 10;

/// Times every gather of a level in turns (`TIMING_ROUNDS` rounds, each a share of every
/// configuration's runs), so that outside load on a shared machine slows them alike and the
/// comparison between configurations holds, and writes each median into its sample
/// (`timers` hold indices into `samples`). Timed one by one, right after each bake, one
/// configuration moved by up to ±40% between the report's sweeps.
pub(super) fn time_in_turns(timers: &mut Vec<(usize, Timer)>, samples: &mut [Sample]) {
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
/// `√(Σ_o A_o ‖h_o − p_o‖² / Σ_o A_o ‖p_o‖²)`. Means are over each object's whole full-detail
/// area (buried parts and patches that see nothing count as dark), as `solve` reports them
/// and the path tracer measures them.
pub(super) fn object_error(out: &BakeOutput, y: &[Rgb], reference: &[ObjectEstimate]) -> f64 {
    let areas = &out.report.object_surface_areas;
    let shares = ObjectShares::new(
        &out.file.patches,
        out.file.objects.len(),
        out.report.shared_patches.clone(),
    );
    let mut sums = vec![[0f64; 3]; out.file.objects.len()];
    for (i, h) in y.iter().enumerate() {
        for (o, w) in shares.of(i) {
            for k in 0..3 {
                sums[o as usize][k] += w * f64::from(h.channel(k));
            }
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
pub(super) fn pt_noise(reference: &[ObjectEstimate]) -> f64 {
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
pub(super) fn peer_rows(
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
