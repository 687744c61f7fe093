//! Form factors of McGuire's Cornell box (CornellBox-Original) at about 1024 and 4096 patches,
//! with the default parameters (adaptive centroid rule, one shadow ray per sample where a
//! blocker is possible), the object view factors of the full-detail box, and piece by piece
//! against flat sites on a room of finely tessellated walls around a floating cube.
//! Run with `cargo bench -p radiosity-benches --bench form_factors`.

use criterion::{Criterion, criterion_group, criterion_main};
use radiosity_bake::check::view_factors::{ViewFactorParams, view_factors};
use radiosity_bake::form_factor::{FormFactorParams, form_factors};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use std::hint::black_box;
use std::path::Path;

fn cornell() -> Scene {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/CornellBox-Original.obj");
    Scene::load_obj(&p).expect("the Cornell box ships with the repository")
}

fn patch_matrix(c: &mut Criterion) {
    let scene = cornell();
    let occ = scene.occluders();
    let mut g = c.benchmark_group("form_factors");
    g.sample_size(10);
    for n in [1024, 4096] {
        let patches = simplify(&scene, &VoxelParams::with_patches(n)).expect("simplify");
        let name = format!("cornell_{}_patches", patches.len());
        g.bench_function(&name, |b| {
            b.iter(|| {
                form_factors(
                    black_box(&patches),
                    Some(&occ),
                    &FormFactorParams::default(),
                    None,
                )
                .rays_cast
            })
        });
    }
    g.finish();
}

fn objects(c: &mut Criterion) {
    let scene = cornell();
    let mut g = c.benchmark_group("view_factors");
    g.sample_size(10);
    g.bench_function("cornell_objects", |b| {
        b.iter(|| view_factors(black_box(&scene), &ViewFactorParams::default(), None).rays_cast)
    });
    g.finish();
}

/// A closed 2 × 2 × 2 room whose walls are `RADIOSITY_BENCH_SPLIT` × `RADIOSITY_BENCH_SPLIT`
/// quads (default 12: 1 728 triangles) around a floating cube, at about 96 patches: form
/// factors piece by piece (`exact_pieces` above the piece count) and as a large scene
/// (`exact_pieces = 0`: flat sites in far pairs, clustered pairs for neighbours of many pieces). The gain grows with the pieces per patch; 20 takes about 7 minutes
/// (ten 40 s iterations piece by piece). Prints each variant's rays and the range of the row
/// sums of F (1 for this closed room), so the price in accuracy stands next to the time.
fn flat_sites(c: &mut Criterion) {
    use radiosity_tests::scenes::{Material, closed_box, floating_cube, write_scene};
    let split: usize = std::env::var("RADIOSITY_BENCH_SPLIT")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(12);
    let dir = std::env::temp_dir().join(format!("radiosity-bench-sites-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    let mut quads = closed_box(2.0, split, |_, _, _| "white".into());
    quads.extend(floating_cube(0.8, 1.2, "cube", "white"));
    let mats = [Material::new("white", [0.99; 3], [0.0; 3])];
    let scene = Scene::load_obj(&write_scene(&dir, "room", &quads, &mats)).expect("room loads");
    let _ = std::fs::remove_dir_all(&dir);
    let occ = scene.occluders();
    let patches = simplify(&scene, &VoxelParams::with_patches(96)).expect("simplify");
    let mut g = c.benchmark_group(format!("flat_sites_split_{split}"));
    g.sample_size(10);
    for (name, exact_pieces) in [("piece_by_piece", usize::MAX), ("sites_and_clusters", 0)] {
        let params = FormFactorParams {
            exact_pieces,
            ..FormFactorParams::default()
        };
        let ff = form_factors(&patches, Some(&occ), &params, None);
        let (lo, hi) = ff
            .row_sums
            .iter()
            .fold((f64::INFINITY, 0f64), |(l, h), s| (l.min(*s), h.max(*s)));
        eprintln!(
            "flat_sites_split_{split}/{name}: {} patches, {} pieces, {} as sites, {} clustered pairs, {} rays, row sums [{lo:.5}, {hi:.5}]",
            patches.len(),
            ff.pieces,
            ff.sites,
            ff.clustered_pairs,
            ff.rays_cast
        );
        g.bench_function(name, |b| {
            b.iter(|| form_factors(black_box(&patches), Some(&occ), &params, None).rays_cast)
        });
    }
    g.finish();
}

criterion_group!(benches, patch_matrix, objects, flat_sites);
criterion_main!(benches);
