//! The frame probe of `docs/decisions/systems.md`: a level baked into systems (sparse rows, the
//! cut, each system's transfer and BC1 encoding), lit through the core's `Systems` with the
//! CPU backend's gather per system; frame times and the error after a sun jump. `PARALLEL=1`
//! runs the coupling product over threads.
//!
//!     PARALLEL=1 cargo run --release --example systems_frame -- /tmp/city/city.obj 65536 4096
use radiosity_backend_cpu::CpuGather;
use radiosity_bake::encode::{EncodeParams, ErrorWeights, SparseSelection, encode_dense_with};
use radiosity_bake::form_factor::{FormFactorParams, form_factors_sparse};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use radiosity_bake::systems::{Split, partition};
use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
use radiosity_core::Rgb;
use radiosity_core::systems::Systems;
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = Scene::load(std::path::Path::new(&a[1])).unwrap();
    let want: usize = a[2].parse().unwrap();
    let max: usize = a[3].parse().unwrap();
    let patches = simplify(&scene, &VoxelParams::with_patches(want)).unwrap();
    let n = patches.len();
    let params = FormFactorParams {
        exact_pieces: 0,
        ..FormFactorParams::default()
    };
    let ff = form_factors_sparse(&patches, Some(&scene.occluders()), &params, None).unwrap();
    let p = partition(&patches, &ff, max);
    let split = Split::new(&ff, &p);
    let mut gathers = Vec::new();
    for s in 0..p.count {
        let f = split.own_block(&ff, s);
        let refl: Vec<[f64; 3]> = split.order[split.ranges[s].clone()]
            .iter()
            .map(|&i| {
                let r = patches.patches[i as usize].reflectance;
                [f64::from(r.r), f64::from(r.g), f64::from(r.b)]
            })
            .collect();
        let (m, _) = transfer_matrix(&f, &refl, 3, BounceSpec::Infinite).unwrap();
        let enc = encode_dense_with(
            f.n,
            3,
            &m,
            &EncodeParams::default(),
            &ErrorWeights::uniform(),
            SparseSelection::ErrorDriven,
        )
        .unwrap();
        gathers.push(CpuGather::new(enc));
    }
    eprintln!("{n} patches, {} systems baked", p.count);
    let reflectance: Vec<Rgb> = split
        .order
        .iter()
        .map(|&i| patches.patches[i as usize].reflectance)
        .collect();
    let sun = |d: [f64; 3]| -> Vec<Rgb> {
        split
            .order
            .iter()
            .map(|&i| {
                let q = &patches.patches[i as usize];
                let c =
                    (-(q.normal.x * d[0] + q.normal.y * d[1] + q.normal.z * d[2])).max(0.0) as f32;
                q.reflectance * c
            })
            .collect()
    };
    let xa = sun([0.3, -0.8, 0.52]);
    let xb = sun([-0.6, -0.5, -0.62]);
    let mut level = Systems::new(
        gathers,
        split.ranges.clone(),
        split.coupling.clone(),
        reflectance,
    )
    .unwrap();
    if std::env::var("PARALLEL").is_ok() {
        level.set_incoming(radiosity_runtime::systems::parallel_incoming);
    }
    for _ in 0..30 {
        level.frame(&xa).unwrap();
    }
    // Steady state for sun B, then back to the A state and count frames.
    for _ in 0..30 {
        level.frame(&xb).unwrap();
    }
    let want_b: Vec<Rgb> = level.gathered().to_vec();
    let area: Vec<f64> = split
        .order
        .iter()
        .map(|&i| patches.patches[i as usize].area)
        .collect();
    for _ in 0..30 {
        level.frame(&xa).unwrap();
    }
    let mut times = Vec::new();
    let mut errs = Vec::new();
    for _ in 0..6 {
        let t = Instant::now();
        level.frame(&xb).unwrap();
        times.push(t.elapsed().as_secs_f64() * 1e3);
        let (mut e, mut w) = (0.0, 0.0);
        for k in 0..n {
            let h = |v: Rgb| f64::from(v.r + v.g + v.b);
            let hd = h(xb[k]); // proportional to the direct light here; error of H = H_d + y
            e += area[k] * (h(level.gathered()[k]) - h(want_b[k])).abs();
            w += area[k] * (h(want_b[k]) + hd);
        }
        errs.push(100.0 * e / w);
    }
    eprintln!("frame ms: {times:.1?}");
    eprintln!("after the sun jumps, error % of H per frame: {errs:.3?}");
}
