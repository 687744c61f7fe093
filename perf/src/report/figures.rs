//! The report's pictures: the paper's figures at the middle size, the bake rendered beside the
//! path tracer, and the summary plots over every configuration.

use super::fit::{pareto_front, power_fit};
use super::{Level, Plan, Sample, middle_samples};
use crate::plots::{self, Chart, Series};
use crate::timing::ms;
use anyhow::Context;
use radiosity_backend_cpu::CpuGather;
use radiosity_bake::order::{self, OrderKind};
use radiosity_bake::pipeline::BakeOutput;
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_core::{DecodeMode, Format};
use radiosity_pathtrace::PathTracer;
use radiosity_runtime::BakedScene;
use radiosity_runtime::image::LinearImage;
use std::path::Path;
use std::time::Instant;

/// The tone-mapped image as an 8-bit sRGB `image` buffer.
fn srgb8(img: &LinearImage, exposure: f32) -> anyhow::Result<image::RgbImage> {
    image::RgbImage::from_raw(img.width, img.height, img.to_srgb8(exposure))
        .context("an sRGB image of three bytes a pixel")
}

/// Writes an 8-bit image as PNG, atomically (a temporary file beside it, renamed into place).
fn save_png(img: &image::RgbImage, path: &Path) -> anyhow::Result<()> {
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png)
        .with_context(|| format!("cannot encode {}", path.display()))?;
    Ok(radiosity_bake::host::write_atomic(path, png.get_ref())?)
}

/// Figs. 1, 2 and 4 of the paper at the middle size: the value distribution of F and M, the
/// matrix before and after reordering, and the BC1 compression error before and after.
pub(super) fn paper_figures(
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
    save_png(&img, &p)?;
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
    save_png(&img, &p)?;
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
pub(super) fn renders(
    out: &Path,
    pt: &PathTracer,
    baked: BakeOutput,
    s: &Sample,
    plan: &Plan,
) -> anyhow::Result<Vec<(String, String)>> {
    let rt = BakedScene::new(baked.file);
    let side = plan.image_side;
    let cam = radiosity_runtime::render::auto_camera(&rt, side, side)?;
    let mut g = CpuGather::new(rt.file.matrix.clone());
    let (frame, _) = rt.frame(&mut g, &[], 1.0)?;
    let prim = radiosity_runtime::render::primary(&rt, &cam, 2)?;
    let t = Instant::now();
    let ours = radiosity_runtime::render::shade(&rt, &prim, &frame, &[], 1.0, None)?;
    let ours_ms = ms(t.elapsed());
    let t = Instant::now();
    let reference: LinearImage = pt.render(&cam, plan.pt_spp, 11);
    let pt_ms = ms(t.elapsed());
    let exposure = reference.auto_exposure();
    let a = srgb8(&ours, exposure)?;
    let b = srgb8(&reference, exposure)?;
    save_png(&a, &out.join("render_baked.png"))?;
    save_png(&b, &out.join("render_pathtraced.png"))?;
    let p = out.join("fig7_render_vs_pathtracer.png");
    save_png(&plots::side_by_side(&[&a, &b], 8), &p)?;
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
pub(super) fn summary_plots(
    out: &Path,
    samples: &[Sample],
    speeds: &[(String, f64, usize)],
    sizes: &[(String, f64, usize)],
) -> anyhow::Result<Vec<(String, String)>> {
    let mut made = Vec::new();
    error_plots(out, samples, &mut made)?;
    scaling_plots(out, samples, &mut made)?;
    bar_plots(out, samples, speeds, sizes, &mut made)?;
    Ok(made)
}

/// One scatter series per format of the points `sel` picks from `samples`.
fn by_format(samples: &[Sample], sel: &dyn Fn(&Sample) -> Option<(f64, f64)>) -> Vec<Series> {
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
}

/// Error against gather time (at the middle size, then every size against the path tracer)
/// and against file size, each with its Pareto front.
fn error_plots(
    out: &Path,
    samples: &[Sample],
    made: &mut Vec<(String, String)>,
) -> anyhow::Result<()> {
    let by_format = |sel: &dyn Fn(&Sample) -> Option<(f64, f64)>| by_format(samples, sel);
    // Error vs gather time at the middle size (every sweep is there), Pareto front marked.
    let middle = middle_samples(samples);
    let pts: Vec<(f64, f64)> = middle.iter().map(|s| (s.cpu_ms, s.err_exact)).collect();
    let front: Vec<(f64, f64)> = pareto_front(&pts).iter().map(|&i| pts[i]).collect();
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
    let front: Vec<(f64, f64)> = pareto_front(&pts).iter().map(|&i| pts[i]).collect();
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
    let front: Vec<(f64, f64)> = pareto_front(&pts).iter().map(|&i| pts[i]).collect();
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
    Ok(())
}

/// Bake time and gather time against n, per format, with the fitted exponent.
fn scaling_plots(
    out: &Path,
    samples: &[Sample],
    made: &mut Vec<(String, String)>,
) -> anyhow::Result<()> {
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
                let name = match (fit, power_fit(&points)) {
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
    Ok(())
}

/// Compression error by order and format; the paper's Figs. 5 (sizes) and 6 (speeds).
fn bar_plots(
    out: &Path,
    samples: &[Sample],
    speeds: &[(String, f64, usize)],
    sizes: &[(String, f64, usize)],
    made: &mut Vec<(String, String)>,
) -> anyhow::Result<()> {
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
    Ok(())
}
