//! Patch orders on the Cornell box (CornellBox-Original.obj, about 1024 patches, all bounces):
//! the time of each order, and (printed once, before timing) the BC1 and BC4 compression error
//! of each, exact and from the sampled estimator, for the README.
//!
//! `cargo bench -p radiosity-benches --bench order`; `ORDER_PATCHES=4096` for another size,
//! `ORDER_EXACT=0` to skip the exact errors (the "exact" column then repeats the estimate).

use criterion::{Criterion, criterion_group, criterion_main};
use radiosity_bake::encode::EncodeParams;
use radiosity_bake::order::{self, DenseMatrix, ErrorMeter, OrderKind, OrderParams};
use radiosity_core::{Format, Patch};
use std::hint::black_box;
use std::sync::OnceLock;
use std::time::Instant;

struct Baked {
    patches: Vec<Patch>,
    m: Vec<f32>,
}

fn cornell() -> &'static Baked {
    static BAKED: OnceLock<Baked> = OnceLock::new();
    BAKED.get_or_init(|| {
        let target: usize = std::env::var("ORDER_PATCHES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1024);
        let t = Instant::now();
        let (patches, m) = radiosity_tests::fixtures::cornell_transfer(target);
        eprintln!(
            "order bench: Cornell box, {} patches, M baked in {:.1} s",
            patches.len(),
            t.elapsed().as_secs_f64()
        );
        Baked { patches, m }
    })
}

/// Prints, per format, each order's exact relative Frobenius error, the sampled estimate
/// with its standard error, and the time of each.
fn report_errors(b: &Baked) {
    let n = b.patches.len();
    let dense = DenseMatrix::new(n, 3, &b.m);
    // Exact errors encode every block of every order: ≈ 2.5 s per BC1 order at n = 1024 on 2
    // cores, 16× that at 4096. `ORDER_EXACT=0` prints only the sampled estimates.
    let exact_wanted = std::env::var("ORDER_EXACT").map_or(true, |v| v != "0");
    for format in [Format::Bc1, Format::Bc4] {
        let encode = EncodeParams::for_format(format);
        let params = OrderParams {
            signature_samples: std::env::var("ORDER_SIGNATURE")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(OrderParams::default().signature_samples),
            ..OrderParams::for_encode(encode)
        };
        let meter = ErrorMeter::new(dense, &encode).expect("valid matrix");
        let sampled = order::evaluate(&OrderKind::CONCRETE, &b.patches, dense, &params)
            .expect("valid matrix");
        let random = if exact_wanted {
            meter
                .exact_full(Some(&sampled[1].perm))
                .expect("valid")
                .relative
        } else {
            sampled[1].error.relative
        };
        eprintln!(
            "{:<4} n={n}  order     exact_err  vs_random  sampled_err ± 1σ          blocks  order_ms  measure_ms  exact_ms",
            format.name()
        );
        for c in &sampled {
            let t = Instant::now();
            let exact = if exact_wanted {
                meter.exact_full(Some(&c.perm)).expect("valid")
            } else {
                c.error
            };
            let exact_ms = t.elapsed().as_secs_f64() * 1e3;
            eprintln!(
                "{:<4} n={n}  {:<8} {:>10.5} {:>9.2}x  {:>10.5} ± {:.5}  {:>7}/{:<7} {:>8.1} {:>11.1} {:>9.1}",
                format.name(),
                c.kind.name(),
                exact.relative,
                random / exact.relative,
                c.error.relative,
                0.5 * c.error.relative_std * c.error.relative,
                c.error.blocks_encoded,
                c.error.blocks_nonzero,
                c.order_ms,
                c.measure_ms,
                exact_ms
            );
        }
        let best = &sampled[order::choose_best(&sampled[..])];
        eprintln!("{:<4} n={n}  best → {}", format.name(), best.kind.name());
    }
}

fn orders(c: &mut Criterion) {
    let b = cornell();
    report_errors(b);
    let n = b.patches.len();
    let dense = DenseMatrix::new(n, 3, &b.m);
    let params = OrderParams::default();
    let mut g = c.benchmark_group(format!("order_{n}"));
    g.sample_size(10);
    for kind in OrderKind::CONCRETE {
        g.bench_function(kind.name(), |bench| {
            bench.iter(|| order::permutation(kind, black_box(&b.patches), dense, &params))
        });
    }
    let meter = ErrorMeter::new(dense, &params.encode).expect("valid matrix");
    let perm = order::permutation(OrderKind::Spatial, &b.patches, dense, &params).expect("order");
    g.bench_function("measure_bc1_sampled", |bench| {
        bench.iter(|| meter.measure(Some(black_box(&perm)), params.sampling(n)))
    });
    g.bench_function("best_bc1", |bench| {
        bench.iter(|| order::permutation(OrderKind::Best, black_box(&b.patches), dense, &params))
    });
    g.bench_function("permute_matrix", |bench| {
        bench.iter(|| order::permute(black_box(&b.m), n, 3, &perm))
    });
    g.finish();
}

criterion_group!(benches, orders);
criterion_main!(benches);
