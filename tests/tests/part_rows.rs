//! Parts of several objects sharing a patch each gather their own bounced light (the PARTS
//! section, `docs/decisions/part-rows.md`): under a high sun, the bench of a small pavilion
//! stands in the roof's shade on a ground that is sunlit around it, and the patches
//! they share with the ground hold the sunlit ground's mean. With the part rows their
//! per-object irradiance is near the path tracer's; without them (the section taken out of the
//! same file) it is far above.

use glam::Vec3;
use radiosity_bake::pipeline::{BakeParams, Hooks, bake};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::{Light, RadFile, Rgb};
use radiosity_pathtrace::PathTracer;
use radiosity_runtime::BakedScene;
use radiosity_tests::fixtures::reference_frame;
use radiosity_tests::scenes::{Material, Quad, block, write_scene};

/// A 12 m ground, a 4 m roof slab on four posts 2.4 m high, a bench under it, and a row of
/// 40 small crates in the sun (each its own object, so that the patch target is met only with
/// parts of several objects sharing patches).
fn pavilion(dir: &std::path::Path) -> Scene {
    let mut quads: Vec<Quad> = Vec::new();
    quads.push(Quad::facing(
        "ground",
        "grey",
        [
            [-6.0, 0.0, -6.0],
            [6.0, 0.0, -6.0],
            [6.0, 0.0, 6.0],
            [-6.0, 0.0, 6.0],
        ],
        [0.0, 1.0, 0.0],
    ));
    quads.extend(block([-2.0, 2.4, -2.0], [2.0, 2.6, 2.0], "roof", "grey"));
    for (k, (x, z)) in [(-1.9, -1.9), (1.8, -1.9), (-1.9, 1.8), (1.8, 1.8)]
        .into_iter()
        .enumerate()
    {
        quads.extend(block(
            [x, 0.0, z],
            [x + 0.1, 2.4, z + 0.1],
            &format!("post{k}"),
            "grey",
        ));
    }
    quads.extend(block([-0.8, 0.4, -0.2], [0.8, 0.45, 0.2], "seat", "grey"));
    for (k, x) in [-0.7, 0.6].into_iter().enumerate() {
        quads.extend(block(
            [x, 0.0, -0.15],
            [x + 0.1, 0.4, 0.15],
            &format!("leg{k}"),
            "grey",
        ));
    }
    for k in 0..40 {
        let x = -5.5 + 0.27 * f64::from(k);
        quads.extend(block(
            [x, 0.0, 4.0],
            [x + 0.15, 0.15, 4.15],
            &format!("crate{k}"),
            "grey",
        ));
    }
    let mats = [Material::new("grey", [0.7; 3], [0.0; 3])];
    Scene::load_obj(&write_scene(dir, "pavilion", &quads, &mats)).unwrap()
}

/// Each object's mean irradiance (grey: the first channel) in one frame under `lights`.
fn per_object(rt: &BakedScene, lights: &[Light]) -> Vec<(String, f64)> {
    let file = &rt.file;
    let (direct, at_samples) = rt.direct_with_samples(lights).unwrap();
    let f = reference_frame(file, &rt.sent(&direct, &at_samples));
    radiosity_runtime::objects::per_object(
        file,
        &f.h,
        &f.b,
        &direct,
        &at_samples,
        radiosity_core::sky_sh_of(lights).as_ref(),
    )
    .into_iter()
    .map(|o| (o.name, o.irradiance[0]))
    .collect()
}

#[test]
fn shaded_parts_sharing_a_sunlit_patch_gather_their_own_light() {
    let dir = tempfile::tempdir().unwrap();
    let scene = pavilion(dir.path());
    let params = BakeParams {
        voxel: VoxelParams::with_patches(32),
        sky: false,
        ..BakeParams::default()
    };
    let file = bake(&scene, &params, Hooks::default()).unwrap().file;
    let parts = file.parts.as_ref().expect("shared patches get part rows");
    assert!(!parts.parts.is_empty());
    // The section survives the file's own bytes.
    let bytes = file.to_bytes().unwrap();
    let back = RadFile::parse(&bytes).unwrap();
    assert_eq!(back.parts, file.parts);
    let without = BakedScene::new(RadFile {
        parts: None,
        bounce: None,
        coverage: None,
        systems: None,
        ..back.clone().into_owned()
    });
    let with = BakedScene::new(back.into_owned());

    // A high sun: the roof shades the bench; the ground around the roof is sunlit.
    let lights = [Light::Directional {
        direction: Vec3::new(0.2, -1.0, 0.15).normalize(),
        irradiance: Rgb::splat(1000.0),
    }];
    let got = per_object(&with, &lights);
    let old = per_object(&without, &lights);
    let reference = PathTracer::new(&scene, &lights)
        .unwrap()
        .object_irradiance(8192, 5);
    let shaded = ["seat", "leg0", "leg1"];
    let (mut err_with, mut err_without) = (0.0, 0.0);
    for name in shaded {
        let want = reference.iter().find(|e| e.name == name).unwrap();
        let w = want.irradiance[0];
        let a = got.iter().find(|o| o.0 == name).unwrap().1;
        let b = old.iter().find(|o| o.0 == name).unwrap().1;
        eprintln!(
            "{name}: with part rows {a:.2}, without {b:.2}, path tracer {w:.2} ± {:.2}",
            want.stderr[0]
        );
        err_with += (a - w).abs() / w;
        err_without += (b - w).abs() / w;
    }
    let n = shaded.len() as f64;
    // The shaded parts' light is all bounced (a high sun: the roof's shadow covers the bench),
    // so the patch's sunlit-ground mean puts them far above the path tracer without their
    // rows (measured: +95%, +181%, +183%); with them, 256 rays a part (≈ 6% noise on a part's
    // gathered light) and the senders' resolution at 32 patches (one sample per ~2 m² of
    // ground) leave +0%, +45%, +12% (mean 0.19 against 1.53).
    assert!(
        err_with < 0.25 * err_without,
        "mean |error| with part rows {:.3}, without {:.3}",
        err_with / n,
        err_without / n
    );
    assert!(err_with / n < 0.3, "mean |error| {:.3}", err_with / n);
}
