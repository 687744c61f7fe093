//! The scale probe of `docs/decisions/systems.md`: sparse ray-cast form factors of a level at
//! many patches, its cut into systems of at most each given size (the crossing exchange), and
//! with `BAKE_SYSTEMS=max` every system's transfer and encoding, timed.
//!
//!     BAKE_SYSTEMS=4096 /usr/bin/time -v cargo run --release -p radiosity-bake --example systems_scale -- /tmp/city/city.obj 65536 4096 5120
use radiosity_bake::form_factor::{FormFactorParams, form_factors_sparse};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = Scene::load(std::path::Path::new(&a[1])).unwrap();
    let want: usize = a[2].parse().unwrap();
    let t = Instant::now();
    let patches = simplify(&scene, &VoxelParams::with_patches(want)).unwrap();
    let n = patches.len();
    eprintln!(
        "simplify: {n} patches, {} pieces, {:.1} s",
        patches.pieces.len(),
        t.elapsed().as_secs_f64()
    );
    let occ = scene.occluders();
    let params = FormFactorParams {
        exact_pieces: 0,
        ..FormFactorParams::default()
    };
    let t = Instant::now();
    let ff = form_factors_sparse(&patches, Some(&occ), &params, None).unwrap();
    eprintln!(
        "sparse form factors: {:.1} s, {} rays, nnz {} ({:.0} a row, {:.0} MB as u32+f32)",
        t.elapsed().as_secs_f64(),
        ff.rays_cast,
        ff.nnz(),
        ff.nnz() as f64 / n as f64,
        ff.nnz() as f64 * 8.0 / 1e6
    );
    let bake_max: Option<usize> = std::env::var("BAKE_SYSTEMS")
        .ok()
        .map(|v| v.parse().unwrap());
    if let Some(max) = bake_max {
        use radiosity_bake::encode::{
            EncodeParams, ErrorWeights, SparseSelection, encode_dense_with,
        };
        use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
        let p = radiosity_bake::systems::partition(&patches, &ff, max);
        let split = radiosity_bake::systems::Split::new(&ff, &p);
        let (mut t_transfer, mut t_encode, mut bytes) = (0.0, 0.0, 0usize);
        for s in 0..p.count {
            let f = split.own_block(&ff, s);
            let refl: Vec<[f64; 3]> = split.order[split.ranges[s].clone()]
                .iter()
                .map(|&i| {
                    let r = patches.patches[i as usize].reflectance;
                    [f64::from(r.r), f64::from(r.g), f64::from(r.b)]
                })
                .collect();
            let t = Instant::now();
            let (m, _) = transfer_matrix(&f, &refl, 3, BounceSpec::Infinite).unwrap();
            t_transfer += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let enc = encode_dense_with(
                f.n,
                3,
                &m,
                &EncodeParams::default(),
                &ErrorWeights::uniform(),
                SparseSelection::ErrorDriven,
            )
            .unwrap();
            t_encode += t.elapsed().as_secs_f64();
            bytes += enc.blocks.len();
            eprintln!(
                "  system {s}: {} patches, transfer+encode so far {:.0} s + {:.0} s",
                f.n, t_transfer, t_encode
            );
        }
        eprintln!(
            "systems bake ≤ {max}: {} systems, transfer {:.0} s, encode {:.0} s, blocks {:.0} MB, coupling {} entries",
            p.count,
            t_transfer,
            t_encode,
            bytes as f64 / 1e6,
            split.coupling.cols.len()
        );
    }
    for max in a[3..].iter().map(|m| m.parse::<usize>().unwrap()) {
        let t = Instant::now();
        let p = radiosity_bake::systems::partition(&patches, &ff, max);
        let sizes: Vec<usize> = p.members().iter().map(Vec::len).collect();
        eprintln!(
            "systems of ≤ {max}: {} systems ({:?}), crossing {:.2}% of the exchange, cut in {:.2} s",
            p.count,
            sizes,
            100.0 * p.crossing_share(&patches, &ff),
            t.elapsed().as_secs_f64()
        );
    }
}
