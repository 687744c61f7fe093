//! `radiosity bench [--patches N] [--json] [--runs R]`: the per-frame gather in every format
//! against its peers, on the embedded Cornell box, in one run.
//!
//! Setup (progress on stderr): discretise the box into about N patches, compute the exact
//! transfer matrix `M = (I − F^C)⁻¹ F` (all bounces), order the patches (the paper's neighbour
//! sort), and encode M in every format as the bake does (`encode_dense_with`: errors weighed for
//! the box's light and runtime light alike). Then each method is a row: a [`Gather`] with the
//! numbering its vectors are in and its cost per call. Times are medians of repeated calls after
//! a warm-up, the methods timed in turns: ten rounds, each method's calls spread over all of
//! them, so that on a shared machine outside load slows every method alike and the ratios hold
//! (timed one after the other, four runs of one build gave BC1 5.2×, 3.7×, 2.3× and 4.8× faer
//! on a 2-vCPU cloud machine; in turns 3.4×, 3.3× and 3.8×). Errors are relative L2 norms of
//! the irradiance against the exact f64 solution of the same patches (an LU solve), for the
//! scene's own light and for a seeded random exitance.
//! A roofline measured on this machine (streaming-read bandwidth, 256-bit FMA rate) bounds each
//! row from below.
//!
//! Adding a backend is pushing one more [`Row`] (see [`encoded_rows`] and [`peer_rows`]).
//!
//! On every adapter wgpu finds, one more measurement: the host-device frame (the matrix in the
//! bake's default format, the box's own full-detail mesh), its CPU recording time and the GPU
//! time of the gather and of the corner pass from timestamps ([`time_host_frame`]).

mod frames;
mod rows;

use crate::embedded;
use anyhow::{Context, bail};
use frames::{DirectOut, HOST_FRAMES, HostFrameOut, ProbesOut, bench_probes, host_frames};
use radiosity_bake::encode::{EncodeParams, ErrorWeights};
use radiosity_bake::order::{self, DenseMatrix, OrderKind, OrderParams};
use radiosity_bake::pipeline::{BakeParams, Discretised, Hooks, discretise, file_mesh};
use radiosity_bake::rng::SplitMix64;
use radiosity_bake::simplify::VoxelParams;
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_core::{Format, Rgb};
use radiosity_perf::peers::LuSolve;
use radiosity_perf::roofline::Roofline;
use radiosity_perf::timing::{interleaved_medians, ms, runs_for};
use rows::{Row, encoded_rows, peer_rows};
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Largest patch count: the dense peers and the exact solution hold about 80·n² bytes
/// (5.4 GB at 8192).
const MAX_PATCHES: usize = 8192;
/// Bandwidth buffer: 8× a 32 MiB last-level cache.
const ROOFLINE_BYTES: usize = 256 << 20;
/// Timed calls per method when `--runs` is not given: about this much time, within the
/// bounds below.
const TIME_BUDGET: Duration = Duration::from_millis(800);
const MIN_RUNS: usize = 7;
const MAX_RUNS: usize = 201;
/// Rounds of [`interleaved_medians`]: every method is timed in each.
const TIMING_ROUNDS: usize = 10;

/// A row's errors and what its timed calls use: how many, the exitance and the output.
struct Measured {
    rel_error: Option<f64>,
    rel_error_random: f64,
    runs: usize,
    x: Vec<Rgb>,
    y: Vec<Rgb>,
}

/// A measured row, as printed and as JSON.
#[derive(Serialize)]
struct RowOut {
    method: String,
    /// Median milliseconds per call.
    ms: f64,
    /// Bytes read and written per call.
    bytes: u64,
    /// Relative L2 error of the irradiance from the scene's own light against the exact
    /// solution (`null` if the scene had no light).
    rel_error: Option<f64>,
    /// The same for a seeded random exitance on every patch (every column counts).
    rel_error_random: f64,
    /// Multiply-adds per call in f32 lanes (an f64 one counts twice).
    fmas: u64,
    /// The roofline's lower bound on the time, ms.
    bound_ms: f64,
    /// `ms / bound_ms`.
    from_bound: f64,
    /// Which roof binds: memory or compute.
    limit: &'static str,
    /// Read bandwidth of a working set of this row's size (a cache level when it fits), GB/s.
    roof_gb_s: f64,
    /// Bytes per call ÷ time, GB/s.
    achieved_gb_s: f64,
    setup_ms: f64,
    /// GPU rows where the adapter has timestamps: median GPU time of the kernels alone, without
    /// the upload of x and the readback of y, ms (`null` otherwise).
    kernel_ms: Option<f64>,
    runs: usize,
    note: String,
}

#[derive(Serialize)]
struct RooflineOut {
    bandwidth_gb_s: f64,
    fma_gflop_s: f64,
    fma_path: &'static str,
    buffer_bytes: usize,
}

#[derive(Serialize)]
struct Ratio {
    method: &'static str,
    against: &'static str,
    speedup: f64,
    target: f64,
    met: bool,
}

#[derive(Serialize)]
struct Report {
    patches: usize,
    scene: &'static str,
    channels: usize,
    order: &'static str,
    threads: usize,
    simd_path: &'static str,
    roofline: RooflineOut,
    rows: Vec<RowOut>,
    ratios: Vec<Ratio>,
    /// The box's light probes at `--probes auto` and the CPU cost of their frame.
    probes: Option<ProbesOut>,
    /// The direct light of a point light with shadow rays, as `solve --lights` and the C ABI's
    /// `rad_scene_direct` compute it.
    direct: Option<DirectOut>,
    /// The host-device frame on every adapter (gather, corner pass, probe pass), empty without
    /// one.
    host_frames: Vec<HostFrameOut>,
    timings_ms: BTreeMap<&'static str, f64>,
}

/// Runs the bench and prints the table (or JSON): the system, its exact answers, the encoded
/// and peer rows, the roofline, then every row checked and timed in turns.
pub(crate) fn run(patches: usize, json: bool, runs: Option<usize>) -> anyhow::Result<()> {
    if patches == 0 {
        bail!("--patches must be at least 1");
    }
    if patches > MAX_PATCHES {
        bail!(
            "--patches {patches} is too many for the dense peers (at most {MAX_PATCHES}: they hold about 80·n² bytes)"
        );
    }
    if runs == Some(0) {
        bail!("--runs must be at least 1");
    }
    let mut timings = BTreeMap::new();
    let bar = crate::progress::stage_bar(28, "", false);
    let (stage, progress) = crate::progress::callbacks(&bar);

    // The system: patches, F, reflectance, as a bake sees them.
    let t = Instant::now();
    stage("load");
    let scene = embedded::cornell_box()?;
    let params = BakeParams {
        voxel: VoxelParams::with_patches(patches),
        ..BakeParams::default()
    };
    let sys = discretise(
        &scene,
        &params,
        Hooks {
            stage: Some(&stage),
            progress: Some(&progress),
            cancel: None,
        },
    )
    .context("cannot discretise the Cornell box")?;
    timings.insert("discretise", ms(t.elapsed()));
    let (n, channels) = (sys.len(), sys.channels);

    // M with every bounce (what the bake stores), in the bake's numbering.
    stage("transfer (LU)");
    let t = Instant::now();
    let (m, _) = transfer_matrix(&sys.f, &sys.reflectance, channels, BounceSpec::Infinite)
        .context("cannot compute the transfer matrix")?;
    timings.insert("transfer", ms(t.elapsed()));

    stage("factorise I − F^C");
    let oracle = Oracle::new(&sys, &mut timings);
    stage("order (paper)");
    let ordered = Ordered::new(&sys, &m, &mut timings)?;
    // The box's full-detail mesh in the file's numbering, for the corner pass.
    let patch_source: Vec<u32> = ordered
        .perm
        .iter()
        .map(|&k| sys.live[k as usize] as u32)
        .collect();
    let (mesh, _) = file_mesh(&scene, &sys, &patch_source);
    let mut frames = Vec::new();
    let mut probes_out = None;
    let mut direct_out = None;
    let mut rows = encoded_rows(
        n,
        channels,
        ordered.m_file,
        &ordered.weights,
        &stage,
        &mut |matrix| {
            stage("probes");
            let probes = match bench_probes(&scene, &sys, &ordered.perm, matrix, &mesh) {
                Ok(p) => Some(p),
                Err(e) => {
                    eprintln!("note: no probes over the box: {e:#}");
                    None
                }
            };
            stage("host-device frame");
            let pass = probes
                .as_ref()
                .map(|(p, patches, _, _)| (p, patches.as_slice()));
            frames = host_frames(matrix, &mesh, pass);
            if let Some((_, _, out, direct)) = probes {
                probes_out = Some(out);
                direct_out = direct;
            }
        },
    )?;
    timings.insert("encode", rows.iter().map(|r| r.setup_ms).sum());
    stage("peers");
    peer_rows(&sys, m, oracle.lu, oracle.lu_setup, &mut rows);

    stage("roofline");
    let t = Instant::now();
    let roof = Roofline::measure(ROOFLINE_BYTES, 5);
    timings.insert("roofline", ms(t.elapsed()));

    let perm = &ordered.perm;
    bar.set_length(rows.len() as u64);
    let measured = check_rows(&mut rows, perm, &oracle.answers, runs, &bar, &stage)?;
    stage("time every method in turns");
    bar.set_position(rows.len() as u64);
    let out_rows = time_rows(&mut rows, measured, &roof)?;
    bar.finish_and_clear();

    let ratios = ratios(&out_rows);
    let report = Report {
        patches: n,
        scene: "cornell-box (embedded CornellBox-Original)",
        channels,
        order: "paper",
        threads: rayon::current_num_threads(),
        simd_path: radiosity_backend_cpu::SimdPath::detect().name(),
        roofline: RooflineOut {
            bandwidth_gb_s: roof.bandwidth / 1e9,
            fma_gflop_s: roof.fma_rate / 1e9,
            fma_path: roof.fma_path,
            buffer_bytes: roof.buffer_bytes,
        },
        rows: out_rows,
        ratios,
        probes: probes_out,
        direct: direct_out,
        host_frames: frames,
        timings_ms: timings,
    };
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

/// The two exitances every row is checked with and their exact irradiance, in the bake's
/// numbering.
struct Answers {
    /// The scene's own light.
    emission: Vec<Rgb>,
    /// A seeded random exitance on every patch (every column counts).
    random: Vec<Rgb>,
    /// Whether the scene has any light (else its row has no error).
    lit: bool,
    exact_emission: Vec<[f64; 3]>,
    exact_random: Vec<[f64; 3]>,
}

/// The exact oracle, which is also the lu-per-frame peer, and the answers it gives.
struct Oracle {
    lu: LuSolve,
    /// Its factorisation time, ms.
    lu_setup: f64,
    answers: Answers,
}

impl Oracle {
    /// Factorises `I − F^C` of `sys` and solves for the scene's light and a random exitance.
    fn new(sys: &Discretised, timings: &mut BTreeMap<&'static str, f64>) -> Self {
        let t = Instant::now();
        let mut lu = LuSolve::new(&sys.f, &sys.reflectance);
        let lu_setup = ms(t.elapsed());
        timings.insert("lu_factorise", lu_setup);
        let emission: Vec<Rgb> = sys.core_patches.iter().map(|p| p.emission).collect();
        let mut rng = SplitMix64(0xbe7c);
        let random: Vec<Rgb> = (0..sys.len())
            .map(|_| Rgb::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
            .collect();
        let to64 = |v: &[Rgb]| -> Vec<[f64; 3]> {
            v.iter().map(|x| x.to_array().map(f64::from)).collect()
        };
        let lit = emission.iter().any(|e| e.max_channel() > 0.0);
        let exact_emission = lu.solve(&to64(&emission));
        let exact_random = lu.solve(&to64(&random));
        Oracle {
            lu,
            lu_setup,
            answers: Answers {
                emission,
                random,
                lit,
                exact_emission,
                exact_random,
            },
        }
    }
}

/// The file's numbering and what the encoders weigh errors by.
struct Ordered {
    /// File patch → bake patch (the paper's neighbour sort).
    perm: Vec<u32>,
    /// M in the file's numbering.
    m_file: Vec<f32>,
    weights: ErrorWeights,
}

impl Ordered {
    /// Orders the patches of `sys` as the bake does for BC1 and permutes `m` to match.
    fn new(
        sys: &Discretised,
        m: &[f32],
        timings: &mut BTreeMap<&'static str, f64>,
    ) -> anyhow::Result<Self> {
        let (n, channels) = (sys.len(), sys.channels);
        let t = Instant::now();
        let bc1_params = EncodeParams::for_format(Format::Bc1);
        let perm = order::permutation(
            OrderKind::Paper,
            &sys.core_patches,
            DenseMatrix::new(n, channels, m),
            &OrderParams::for_encode(bc1_params),
        )
        .context("cannot order the patches")?;
        let m_file = order::permute(m, n, channels, &perm);
        // Encoded as the bake encodes: errors weighed for the box's own light and runtime
        // light alike, sparse entries chosen by that error.
        let file_emission: Vec<Rgb> = order::permute_rows(&sys.core_patches, &perm)
            .iter()
            .map(|p| p.emission)
            .collect();
        let weights = ErrorWeights::for_emitters(&file_emission);
        timings.insert("order", ms(t.elapsed()));
        Ok(Ordered {
            perm,
            m_file,
            weights,
        })
    }
}

/// Errors of every row against the exact answers, and how many calls each gets (`runs`, or
/// about [`TIME_BUDGET`] of them). `perm` maps the file's numbering to the bake's.
fn check_rows(
    rows: &mut [Row],
    perm: &[u32],
    answers: &Answers,
    runs: Option<usize>,
    bar: &indicatif::ProgressBar,
    stage: &dyn Fn(&str),
) -> anyhow::Result<Vec<Measured>> {
    let n = answers.emission.len();
    let mut measured = Vec::new();
    for (i, row) in rows.iter_mut().enumerate() {
        bar.set_position(i as u64);
        stage(&format!("check {}", row.method));
        let file = |v: &[Rgb]| -> Vec<Rgb> {
            if row.file_order {
                perm.iter().map(|&old| v[old as usize]).collect()
            } else {
                v.to_vec()
            }
        };
        let x_emission = file(&answers.emission);
        let x_random = file(&answers.random);
        let mut y = vec![Rgb::ZERO; n];
        let mut error_for = |x: &[Rgb], exact: &[[f64; 3]]| -> anyhow::Result<f64> {
            row.gather
                .gather(x, &mut y)
                .with_context(|| format!("{} failed", row.method))?;
            let exact_in_order = |i: usize| {
                if row.file_order {
                    exact[perm[i] as usize]
                } else {
                    exact[i]
                }
            };
            Ok(relative_l2(&y, exact_in_order))
        };
        let rel_error = if answers.lit {
            Some(error_for(&x_emission, &answers.exact_emission)?)
        } else {
            None
        };
        let rel_error_random = error_for(&x_random, &answers.exact_random)?;

        let t = Instant::now();
        row.gather
            .gather(&x_random, &mut y)
            .with_context(|| format!("{} failed", row.method))?;
        let runs = runs.unwrap_or_else(|| runs_for(t.elapsed(), TIME_BUDGET, MIN_RUNS, MAX_RUNS));
        measured.push(Measured {
            rel_error,
            rel_error_random,
            runs,
            x: x_random,
            y,
        });
    }
    Ok(measured)
}

/// Times every row in turns (`TIMING_ROUNDS` rounds), so that outside load on a shared
/// machine slows them alike and the ratios between them hold, and sets each against the
/// roofline.
fn time_rows(
    rows: &mut [Row],
    mut measured: Vec<Measured>,
    roof: &Roofline,
) -> anyhow::Result<Vec<RowOut>> {
    let run_counts: Vec<usize> = measured.iter().map(|m| m.runs).collect();
    let mut failed = None;
    let times = interleaved_medians(&run_counts, TIMING_ROUNDS, |i| {
        let (row, m) = (&mut rows[i], &mut measured[i]);
        if let Err(e) = row.gather.gather(&m.x, &mut m.y) {
            failed.get_or_insert_with(|| format!("{} failed: {e}", row.method));
        }
    });
    if let Some(e) = failed {
        bail!("{e}");
    }
    let mut out_rows = Vec::new();
    for ((row, m), t) in rows.iter().zip(measured).zip(times) {
        let Measured {
            rel_error,
            rel_error_random,
            runs,
            ..
        } = m;
        let bound = roof.bound(row.cost);
        let bound_ms = bound.seconds * 1e3;
        out_rows.push(RowOut {
            method: row.method.clone(),
            ms: ms(t),
            bytes: row.cost.bytes,
            rel_error,
            rel_error_random,
            fmas: row.cost.fmas_f32,
            bound_ms,
            from_bound: ms(t) / bound_ms,
            limit: bound.limit,
            roof_gb_s: bound.bandwidth / 1e9,
            achieved_gb_s: row.cost.bytes as f64 / t.as_secs_f64() / 1e9,
            setup_ms: row.setup_ms,
            kernel_ms: row.kernel_ms,
            runs,
            note: row.note.clone(),
        });
    }
    Ok(out_rows)
}

/// `cpu-bc1`'s speed-ups over faer and the Jacobi bounces, with their targets.
fn ratios(out_rows: &[RowOut]) -> Vec<Ratio> {
    let time_of = |name: &str| out_rows.iter().find(|r| r.method == name).map(|r| r.ms);
    let mut ratios = Vec::new();
    for (against, target) in [("faer-dense-f32", 4.0), ("jacobi-8", 10.0)] {
        if let (Some(bc1), Some(other)) = (time_of("cpu-bc1"), time_of(against)) {
            let speedup = other / bc1;
            ratios.push(Ratio {
                method: "cpu-bc1",
                against,
                speedup,
                target,
                met: speedup >= target,
            });
        }
    }
    ratios
}

/// `‖y − exact‖ / ‖exact‖` over every patch and channel (`exact(i)` in `y`'s numbering); the
/// absolute norm when the exact answer is zero.
pub(crate) fn relative_l2(y: &[Rgb], exact: impl Fn(usize) -> [f64; 3]) -> f64 {
    let (mut num, mut den) = (0f64, 0f64);
    for (i, v) in y.iter().enumerate() {
        let e = exact(i);
        for k in 0..3 {
            num += (f64::from(v.channel(k)) - e[k]).powi(2);
            den += e[k] * e[k];
        }
    }
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        num.sqrt()
    }
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
    for row in &r.rows {
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
    for row in &r.rows {
        outln!("  {}: {}", row.method, row.note);
    }
    outln!("");
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
    if !r.host_frames.is_empty() {
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
