//! Times the gather of a baked `.rad` file on every SIMD path this CPU has, and checks that the
//! paths agree. Usage:
//!
//! ```text
//! cargo run --release -p radiosity-backend-cpu --example gather_file -- BAKED.rad [RUNS]
//! ```
//!
//! Prints, per path, the median time of `RUNS` gathers (default 101) of a seeded random
//! exitance with rayon's pool, and the largest relative difference from the first path.

use radiosity_backend_cpu::{CpuGather, SimdPath};
use radiosity_core::{Gather, RadFile, Rgb};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: gather_file BAKED.rad [RUNS]");
        std::process::exit(2);
    };
    let runs: usize = args
        .get(2)
        .map_or(101, |r| r.parse().expect("RUNS is a number"));
    let bytes = std::fs::read(path).unwrap_or_else(|e| {
        eprintln!("error: {path}: {e}");
        std::process::exit(1)
    });
    let file = RadFile::parse(&bytes).unwrap_or_else(|e| {
        eprintln!("error: {path}: {e}");
        std::process::exit(1)
    });
    let m = file.matrix;
    let n = m.layout.n();
    // A fixed pseudo-random exitance (xorshift), so runs are comparable.
    let mut s = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let x: Vec<Rgb> = (0..n).map(|_| Rgb::new(next(), next(), next())).collect();
    println!(
        "{path}: n = {n}, format {}, {} rayon threads",
        m.layout.format().name(),
        rayon::current_num_threads()
    );
    let mut first: Option<Vec<Rgb>> = None;
    for simd in SimdPath::ALL.into_iter().filter(|p| p.is_available()) {
        let mut g = CpuGather::with_path(m.clone(), simd).expect("available path");
        let mut y = vec![Rgb::ZERO; n];
        g.gather(&x, &mut y).expect("gather");
        let mut times: Vec<f64> = (0..runs)
            .map(|_| {
                let t = Instant::now();
                g.gather(&x, &mut y).expect("gather");
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let diff = first.as_ref().map_or(0.0, |f| {
            f.iter()
                .zip(&y)
                .flat_map(|(a, b)| (0..3).map(move |k| (a.channel(k), b.channel(k))))
                .map(|(a, b)| ((a - b).abs() / a.abs().max(1e-30)) as f64)
                .fold(0.0, f64::max)
        });
        println!(
            "  {:<10} median {:.3} ms  (min {:.3})  max rel diff from first path {diff:.1e}",
            g.path(),
            times[runs / 2],
            times[0]
        );
        first.get_or_insert(y);
    }
}
