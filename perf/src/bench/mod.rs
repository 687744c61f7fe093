//! The bench (`radiosity bench`): the per-frame gather in every format against its peers, on
//! one scene, in one run ([`run`], which returns a [`Report`]).
//!
//! Setup: discretise the scene into about N patches, compute the exact transfer matrix
//! `M = (I − F^C)⁻¹ F` (all bounces), order the patches (the paper's neighbour sort), and
//! encode M in every format as the bake does (`encode_dense_with`: errors weighed for the
//! scene's light and runtime light alike). Then each method is a row: a [`Gather`] with the
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
//! Adding a backend is pushing one more `Row` (see `rows.rs`: `encoded_rows` and `peer_rows`).
//!
//! On every adapter wgpu finds, one more measurement: the host-device frame (the matrix in the
//! bake's default format, the scene's own full-detail mesh), its CPU recording time and the GPU
//! time of the gather and of the corner pass from timestamps
//! ([`radiosity_backend_wgpu::time_host_frame`]).
//!
//! [`Gather`]: radiosity_core::Gather

mod frames;
mod rows;

use crate::Progress;
use crate::peers::LuSolve;
use crate::roofline::Roofline;
use crate::timing::{interleaved_medians, ms, runs_for};
use anyhow::{Context, bail};
pub use frames::{DirectOut, HOST_FRAMES, HostFrameOut, ProbesOut};
use frames::{bench_probes, host_frames};
use radiosity_bake::encode::{EncodeParams, ErrorWeights};
use radiosity_bake::order::{self, DenseMatrix, OrderKind, OrderParams};
use radiosity_bake::pipeline::{BakeParams, Discretised, discretise, file_mesh};
use radiosity_bake::rng::SplitMix64;
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_core::{Format, Rgb};
use rows::{Row, encoded_rows, peer_rows};
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Largest patch count: the dense peers and the exact solution hold about 80·n² bytes
/// (5.4 GB at 8192).
pub const MAX_PATCHES: usize = 8192;
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
pub struct RowOut {
    /// `cpu-bc1`, `faer-dense-f32`, … (the names of `docs/contract.md`).
    pub method: String,
    /// Median milliseconds per call.
    pub ms: f64,
    /// Bytes read and written per call.
    pub bytes: u64,
    /// Relative L2 error of the irradiance from the scene's own light against the exact
    /// solution (`null` if the scene had no light).
    pub rel_error: Option<f64>,
    /// The same for a seeded random exitance on every patch (every column counts).
    pub rel_error_random: f64,
    /// Multiply-adds per call in f32 lanes (an f64 one counts twice).
    pub fmas: u64,
    /// The roofline's lower bound on the time, ms.
    pub bound_ms: f64,
    /// `ms / bound_ms`.
    pub from_bound: f64,
    /// Which roof binds: memory or compute.
    pub limit: &'static str,
    /// Read bandwidth of a working set of this row's size (a cache level when it fits), GB/s.
    pub roof_gb_s: f64,
    /// Bytes per call ÷ time, GB/s.
    pub achieved_gb_s: f64,
    /// One-off preparation (encoding, factorisation), ms.
    pub setup_ms: f64,
    /// GPU rows where the adapter has timestamps: median GPU time of the kernels alone, without
    /// the upload of x and the readback of y, ms (`null` otherwise).
    pub kernel_ms: Option<f64>,
    /// Timed calls.
    pub runs: usize,
    /// What the method is and runs on.
    pub note: String,
}

/// The machine's roofline ([`Roofline`]) in the report's units.
#[derive(Serialize)]
pub struct RooflineOut {
    /// Streaming-read bandwidth, GB/s.
    pub bandwidth_gb_s: f64,
    /// f32 multiply-adds, G/s.
    pub fma_gflop_s: f64,
    /// The SIMD path of the multiply-add loop.
    pub fma_path: &'static str,
    /// The bandwidth buffer's size.
    pub buffer_bytes: usize,
}

/// One method's speed-up over another, with its target.
#[derive(Serialize)]
pub struct Ratio {
    /// The faster method.
    pub method: &'static str,
    /// The one it is set against.
    pub against: &'static str,
    /// `against`'s time over `method`'s.
    pub speedup: f64,
    /// The speed-up aimed at.
    pub target: f64,
    /// Whether `speedup` reaches `target`.
    pub met: bool,
}

/// What the bench measured (`radiosity bench --json` prints it as it is).
#[derive(Serialize)]
pub struct Report {
    /// Patches of the discretised scene.
    pub patches: usize,
    /// The scene's name.
    pub scene: String,
    /// Colour channels of the transfer.
    pub channels: usize,
    /// The patch order of the encoded matrices.
    pub order: &'static str,
    /// Threads of the CPU gathers.
    pub threads: usize,
    /// The CPU gather's SIMD path.
    pub simd_path: &'static str,
    /// The machine's roofline.
    pub roofline: RooflineOut,
    /// Every method measured.
    pub rows: Vec<RowOut>,
    /// `cpu-bc1`'s speed-ups over the peers.
    pub ratios: Vec<Ratio>,
    /// The scene's light probes at `--probes auto` and the CPU cost of their frame.
    pub probes: Option<ProbesOut>,
    /// The direct light of a point light with shadow rays, as `solve --lights` and the C ABI's
    /// `rad_scene_direct` compute it.
    pub direct: Option<DirectOut>,
    /// The host-device frame on every adapter (gather, corner pass, probe pass), empty without
    /// one.
    pub host_frames: Vec<HostFrameOut>,
    /// Milliseconds of each setup step.
    pub timings_ms: BTreeMap<&'static str, f64>,
}

/// Refuses, before any work, a patch count the bake or the dense peers cannot hold and a run
/// count of zero.
pub fn check(patches: usize, runs: Option<usize>) -> anyhow::Result<()> {
    radiosity_bake::limits::check_patches(
        patches,
        BounceSpec::Infinite,
        radiosity_bake::pipeline::SystemsChoice::Off,
    )?;
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
    Ok(())
}

/// Benches `scene` (named `name` in the report) at about `patches` patches, `runs` timed
/// calls a method (else about 0.8 s of them): the system, its exact answers, the encoded and
/// peer rows, the roofline, then every row checked and timed in turns.
pub fn run(
    scene: &Scene,
    name: &str,
    patches: usize,
    runs: Option<usize>,
    progress: &Progress<'_>,
) -> anyhow::Result<Report> {
    check(patches, runs)?;
    let mut timings = BTreeMap::new();
    let mut setup = Setup::new(scene, patches, progress, &mut timings)?;
    let (n, channels) = (setup.sys.len(), setup.sys.channels);
    let (mut rows, frames) = frame_rows(scene, &mut setup, progress)?;
    timings.insert("encode", rows.iter().map(|r| r.setup_ms).sum());
    (progress.stage)("peers");
    peer_rows(
        &setup.sys,
        setup.m,
        setup.oracle.lu,
        setup.oracle.lu_setup,
        &mut rows,
    );

    (progress.stage)("roofline");
    let t = Instant::now();
    let roof = Roofline::measure(ROOFLINE_BYTES, 5);
    timings.insert("roofline", ms(t.elapsed()));

    let answers = &setup.oracle.answers;
    let measured = check_rows(&mut rows, &setup.ordered.perm, answers, runs, progress)?;
    (progress.stage)("time every method in turns");
    (progress.progress)(rows.len(), rows.len());
    let out_rows = time_rows(&mut rows, measured, &roof)?;

    Ok(Report {
        patches: n,
        scene: name.to_owned(),
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
        ratios: ratios(&out_rows),
        rows: out_rows,
        probes: frames.probes,
        direct: frames.direct,
        host_frames: frames.host,
        timings_ms: timings,
    })
}

/// The system a bench measures on, in the bake's numbering and the file's.
struct Setup {
    sys: Discretised,
    /// M with every bounce (what the bake stores), in the bake's numbering.
    m: Vec<f32>,
    oracle: Oracle,
    ordered: Ordered,
    /// The scene's full-detail mesh in the file's numbering, for the corner pass.
    mesh: radiosity_core::Mesh<'static>,
}

impl Setup {
    /// Discretises `scene` to about `patches` patches, computes M, factorises the oracle and
    /// orders the patches, each step timed into `timings`.
    fn new(
        scene: &Scene,
        patches: usize,
        progress: &Progress<'_>,
        timings: &mut BTreeMap<&'static str, f64>,
    ) -> anyhow::Result<Self> {
        let t = Instant::now();
        (progress.stage)("load");
        let params = BakeParams {
            voxel: VoxelParams::with_patches(patches),
            ..BakeParams::default()
        };
        let sys = discretise(scene, &params, progress.hooks())
            .context("cannot discretise the Cornell box")?;
        timings.insert("discretise", ms(t.elapsed()));

        (progress.stage)("transfer (LU)");
        let t = Instant::now();
        let (m, _) = transfer_matrix(&sys.f, &sys.reflectance, sys.channels, BounceSpec::Infinite)
            .context("cannot compute the transfer matrix")?;
        timings.insert("transfer", ms(t.elapsed()));

        (progress.stage)("factorise I − F^C");
        let oracle = Oracle::new(&sys, timings);
        (progress.stage)("order (paper)");
        let ordered = Ordered::new(&sys, &m, timings)?;
        let patch_source: Vec<u32> = ordered
            .perm
            .iter()
            .map(|&k| sys.live[k as usize] as u32)
            .collect();
        let (mesh, _) = file_mesh(scene, &sys, &patch_source);
        Ok(Setup {
            sys,
            m,
            oracle,
            ordered,
            mesh,
        })
    }
}

/// What the bench measures of a frame around the gather.
#[derive(Default)]
struct Frames {
    probes: Option<ProbesOut>,
    direct: Option<DirectOut>,
    host: Vec<HostFrameOut>,
}

/// The encoded rows ([`encoded_rows`]) and, on the matrix in the bake's default format, the
/// probes, the direct light and the host-device frames. Takes M in the file's numbering out
/// of `setup` (the encoders are its last users).
fn frame_rows(
    scene: &Scene,
    setup: &mut Setup,
    progress: &Progress<'_>,
) -> anyhow::Result<(Vec<Row>, Frames)> {
    let m_file = std::mem::take(&mut setup.ordered.m_file);
    let (sys, perm, mesh) = (&setup.sys, &setup.ordered.perm, &setup.mesh);
    let mut frames = Frames::default();
    let rows = encoded_rows(
        sys.len(),
        sys.channels,
        m_file,
        &setup.ordered.weights,
        progress,
        &mut |matrix| {
            (progress.stage)("probes");
            let probes = match bench_probes(progress, scene, sys, perm, matrix, mesh) {
                Ok(p) => Some(p),
                Err(e) => {
                    (progress.note)(&format!("note: no probes over the box: {e:#}"));
                    None
                }
            };
            (progress.stage)("host-device frame");
            let pass = probes
                .as_ref()
                .map(|(p, patches, _, _)| (p, patches.as_slice()));
            frames.host = host_frames(progress, matrix, mesh, pass);
            if let Some((_, _, out, direct)) = probes {
                frames.probes = Some(out);
                frames.direct = direct;
            }
        },
    )?;
    Ok((rows, frames))
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
    /// M in the file's numbering (taken by the encoders).
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
        // Encoded as the bake encodes: errors weighed for the scene's own light and runtime
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
    progress: &Progress<'_>,
) -> anyhow::Result<Vec<Measured>> {
    let n = answers.emission.len();
    let total = rows.len();
    let mut measured = Vec::new();
    for (i, row) in rows.iter_mut().enumerate() {
        (progress.progress)(i, total);
        (progress.stage)(&format!("check {}", row.method));
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
pub fn relative_l2(y: &[Rgb], exact: impl Fn(usize) -> [f64; 3]) -> f64 {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_l2_is_relative_and_absolute_against_zero() {
        let y = [Rgb::new(1.0, 2.0, 2.0), Rgb::ZERO];
        // Exact (1, 2, 2) and 0: y is right.
        assert_eq!(relative_l2(&y, |i| [[1.0, 2.0, 2.0], [0.0; 3]][i]), 0.0);
        // Exact twice y: the error is half of ‖exact‖ = 6, so 3/6.
        let e = relative_l2(&y, |i| [[2.0, 4.0, 4.0], [0.0; 3]][i]);
        assert!((e - 0.5).abs() < 1e-12, "{e}");
        // Exact zero: the absolute norm ‖y‖ = 3.
        assert!((relative_l2(&y, |_| [0.0; 3]) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn bad_counts_are_refused_before_any_work() {
        let e = check(MAX_PATCHES + 1, None).unwrap_err().to_string();
        assert!(e.contains("--patches"), "{e}");
        let e = check(256, Some(0)).unwrap_err().to_string();
        assert!(e.contains("--runs"), "{e}");
        check(256, Some(3)).unwrap();
    }
}
