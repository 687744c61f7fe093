//! Form factors of McGuire's Cornell box (CornellBox-Original) at about 1024 and 4096 patches,
//! with the default parameters (adaptive centroid rule, one shadow ray per sample where a
//! blocker is possible), and the object view factors of the full-detail box.
//! Run with `cargo bench -p radiosity-benches --bench form_factors`.

use criterion::{Criterion, criterion_group, criterion_main};
use radiosity_bake::bvh::Occluders;
use radiosity_bake::form_factor::{FormFactorParams, form_factors};
use radiosity_bake::scene::Scene;
use radiosity_bake::view_factors::{ViewFactorParams, view_factors};
use radiosity_bake::voxel::{VoxelParams, simplify};
use std::hint::black_box;
use std::path::Path;

fn cornell() -> Scene {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/CornellBox-Original.obj");
    Scene::load_obj(&p).expect("the Cornell box ships with the repository")
}

fn patch_matrix(c: &mut Criterion) {
    let scene = cornell();
    let occ = Occluders::new(&scene);
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

criterion_group!(benches, patch_matrix, objects);
criterion_main!(benches);
