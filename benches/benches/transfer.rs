//! K = ∞ by LU against the doubling series with as many bounces as ρ = 0.99 needs for 1e-3,
//! on a synthetic closed scene (rows of F sum to 1). Prints each method's relative error
//! against the exact furnace answer. Run: `cargo bench -p radiosity-benches --bench transfer`.

use criterion::{Criterion, criterion_group, criterion_main};
use radiosity_bake::transfer::{BounceSpec, Dense, transfer_matrix};
use std::hint::black_box;

/// A closed "scene" of n patches: F_ij ∝ 1/(1 + |i − j|), zero diagonal, rows normalised to 1.
fn closed_f(n: usize) -> Dense {
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        let mut sum = 0.0;
        for j in 0..n {
            if i != j {
                let f = 1.0 / (1.0 + (i as f64 - j as f64).abs());
                v[i * n + j] = f;
                sum += f;
            }
        }
        v[i * n..(i + 1) * n].iter_mut().for_each(|x| *x /= sum);
    }
    Dense::new(n, v)
}

fn bench(c: &mut Criterion) {
    let n = 256;
    let rho: f64 = 0.99;
    let f = closed_f(n);
    let refl = vec![[rho; 3]; n];
    // Furnace: with unit exitance everywhere, row sums of M are 1/(1 − ρ) exactly.
    let want = 1.0 / (1.0 - rho);
    let k_needed = ((1e-3f64).ln() / rho.ln()).ceil() as u32; // 688
    for (name, spec) in [
        ("lu", BounceSpec::Infinite),
        ("series", BounceSpec::Fixed(k_needed)),
    ] {
        let (m, _) = transfer_matrix(&f, &refl, 1, spec).unwrap();
        let worst = (0..n)
            .map(|i| {
                (m[i * n..(i + 1) * n]
                    .iter()
                    .map(|v| f64::from(*v))
                    .sum::<f64>()
                    - want)
                    .abs()
                    / want
            })
            .fold(0.0, f64::max);
        eprintln!("transfer {name} (n = {n}, ρ = {rho}): worst furnace row error {worst:.2e}");
    }
    let mut g = c.benchmark_group("transfer_256_rho_0.99");
    g.sample_size(10);
    g.bench_function("lu_infinite", |b| {
        b.iter(|| transfer_matrix(black_box(&f), &refl, 1, BounceSpec::Infinite).unwrap())
    });
    g.bench_function(format!("series_{k_needed}"), |b| {
        b.iter(|| transfer_matrix(black_box(&f), &refl, 1, BounceSpec::Fixed(k_needed)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
