//! The per-frame gather at n = 4096 for every format, on the SIMD path this CPU dispatches to
//! and on the baseline (build-time) path, against dense f32 RGB mat-vecs of the same decoded
//! matrix: one written plainly with rayon + `wide`, and faer's. Inputs are seeded
//! (`transfer_like_matrix(4096, 3, 11)`) and encoded once (BC1 takes ~12 s: setup is slow).
//! Besides criterion's report it prints a summary (medians of its own repeated runs) with the
//! ratio of each gather to the dense baselines.
//!
//! Run: `cargo bench -p radiosity-benches --bench gather`.

use criterion::{Criterion, criterion_group, criterion_main};
use radiosity_backend_cpu::{CpuGather, SimdPath};
use radiosity_bake::encode::{EncodeParams, encode_dense};
use radiosity_core::{DecodeMode, Format, Gather, Rgb, TransferMatrix};
use radiosity_perf::peers::{FaerDense, dense_rgb};
use radiosity_perf::timing::{median, ms};
use radiosity_tests::fixtures::{SplitMix64, transfer_like_matrix};
use std::hint::black_box;
use std::time::Instant;

const N: usize = 4096;

fn bench(c: &mut Criterion) {
    let t0 = Instant::now();
    let dense = transfer_like_matrix(N, 3, 11);
    let matrices: Vec<(Format, TransferMatrix<'static>)> = Format::ALL
        .into_iter()
        .map(|f| {
            (
                f,
                encode_dense(N, 3, &dense, &EncodeParams::for_format(f)).unwrap(),
            )
        })
        .collect();
    drop(dense);
    eprintln!(
        "gather bench: encoded n = {N} in {:.1} s, rayon threads {}, detected path {}",
        t0.elapsed().as_secs_f64(),
        rayon::current_num_threads(),
        SimdPath::detect().name()
    );

    let mut rng = SplitMix64(5);
    let x: Vec<Rgb> = (0..N)
        .map(|_| Rgb::new(rng.next_f32(), rng.next_f32(), rng.next_f32()))
        .collect();
    let x_flat: Vec<f32> = x.iter().flat_map(|v| v.to_array()).collect();
    let mut y = vec![Rgb::ZERO; N];

    // The dense peers use the BC1 matrix decoded (blocks + sparse), as the issue compares.
    let decoded = matrices[0].1.decode_dense(DecodeMode::D3d10);
    let mut faer = FaerDense::new(N, 3, &decoded);

    let mut summary = Vec::new();
    let runs = 31;
    let t_dense = median(runs, || dense_rgb(N, &decoded, &x_flat, &mut y));
    let t_faer = median(runs, || faer.gather(&x, &mut y).unwrap());
    summary.push(("dense f32 rgb (rayon+wide)".to_string(), t_dense));
    summary.push(("dense f32 rgb (faer)".to_string(), t_faer));

    let mut g = c.benchmark_group("gather_4096");
    g.sample_size(30);
    g.bench_function("dense_f32_rgb_rayon_wide", |b| {
        b.iter(|| dense_rgb(N, black_box(&decoded), black_box(&x_flat), &mut y))
    });
    g.bench_function("dense_f32_rgb_faer", |b| {
        b.iter(|| faer.gather(black_box(&x), &mut y).unwrap())
    });
    for (format, m) in &matrices {
        let mut paths = vec![SimdPath::detect()];
        if SimdPath::detect() != SimdPath::Baseline {
            paths.push(SimdPath::Baseline);
        }
        for path in paths {
            let mut cpu = CpuGather::with_path(m.clone(), path).unwrap();
            let label = format!("{}_{}", format.name(), cpu.path());
            let t = median(runs, || cpu.gather(&x, &mut y).unwrap());
            summary.push((format!("{} gather [{}]", format.name(), cpu.path()), t));
            g.bench_function(&label, |b| {
                b.iter(|| cpu.gather(black_box(&x), &mut y).unwrap())
            });
        }
    }
    g.finish();

    eprintln!(
        "\ngather n = {N}, medians of {runs} runs, {} threads:",
        rayon::current_num_threads()
    );
    for (name, t) in &summary {
        eprintln!(
            "  {name:<34} {:>8.3} ms   dense/this {:>5.2}×   faer/this {:>5.2}×",
            ms(*t),
            ms(t_dense) / ms(*t),
            ms(t_faer) / ms(*t)
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
