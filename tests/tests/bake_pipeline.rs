//! The whole bake on scenes with known physics: furnace, effect decisions that change the work
//! done, and compression quality on the Cornell box.

use radiosity_bake::order::OrderKind;
use radiosity_bake::patch::Patches;
use radiosity_bake::pipeline::check_dark;
use radiosity_bake::pipeline::{BakeOutput, BakeParams, FormatChoice, Hooks, bake};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use radiosity_bake::transfer::BounceSpec;
use radiosity_core::{Bounces, Format, Rgb};
use radiosity_tests::fixtures::reference_frame;
use radiosity_tests::scenes::{Material, Quad, closed_box, write_scene};
use std::f64::consts::PI;
use std::path::Path;

fn params(patches: usize, format: FormatChoice, bounces: BounceSpec) -> BakeParams {
    BakeParams {
        voxel: VoxelParams::with_patches(patches),
        format,
        bounces,
        order: OrderKind::Spatial,
        ..BakeParams::default()
    }
}

fn bake_file(path: &Path, p: &BakeParams) -> BakeOutput {
    let scene = Scene::load_obj(path).unwrap();
    bake(&scene, p, Hooks::default()).unwrap()
}

/// Radiosity of every file patch lit by its own emission only.
fn radiosity(out: &BakeOutput) -> Vec<Rgb> {
    reference_frame(&out.file, &vec![Rgb::ZERO; out.file.n()]).b
}

#[test]
fn white_furnace_matches_e_over_one_minus_rho() {
    // Closed box, uniform ρ, every face emitting L = 1/π (E = 1): B = 1/(1 − ρ) everywhere
    // (shared/reference/multibounce.md §1), whatever the meshing, if rows of F sum to 1. The
    // issue asks for 0.5%; f32 storage isolates the transfer, the default (BC4 for a grey scene)
    // adds compression.
    let dir = tempfile::tempdir().unwrap();
    for rho in [0.5, 0.9, 0.99, 0.999] {
        let mats = [Material::new("white", [rho; 3], [1.0 / PI; 3])];
        let path = write_scene(
            dir.path(),
            &format!("furnace{rho}"),
            &closed_box(2.0, 2, |_, _, _| "white".into()),
            &mats,
        );
        for format in [FormatChoice::Fixed(Format::F32), FormatChoice::Auto] {
            let out = bake_file(&path, &params(96, format, BounceSpec::Infinite));
            assert_eq!(out.report.rays_cast, 0, "a box is convex: no rays");
            assert_eq!(out.report.channels, 1, "grey scene: one channel");
            let want = 1.0 / (1.0 - rho);
            for (i, b) in radiosity(&out).iter().enumerate() {
                let rel = (f64::from(b.r) - want).abs() / want;
                assert!(
                    rel < 5e-3,
                    "ρ = {rho}, {format:?}: patch {i} B = {} vs {want} ({:.3}%)",
                    b.r,
                    rel * 100.0
                );
            }
        }
    }
}

fn cube_with(
    occluder: bool,
    coloured: bool,
    dark: bool,
) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let mut quads = closed_box(2.0, 1, |face, _, _| {
        if face == "ceiling" {
            "light".into()
        } else {
            "wall".into()
        }
    });
    if occluder {
        // A floating horizontal card, lit from the ceiling, shadowing the floor.
        let c = [
            [0.7, 1.0, 0.7],
            [1.3, 1.0, 0.7],
            [1.3, 1.0, 1.3],
            [0.7, 1.0, 1.3],
        ];
        quads.push(Quad::facing("card", "wall", c, [1.0, 2.0, 1.0]));
    }
    if dark {
        // A tile under the floor, facing away from the room: nothing is in front of it.
        let c = [
            [0.2, -0.5, 0.2],
            [0.5, -0.5, 0.2],
            [0.5, -0.5, 0.5],
            [0.2, -0.5, 0.5],
        ];
        quads.push(Quad::facing("rug", "wall", c, [0.35, -1.0, 0.35]));
    }
    let wall = if coloured { [0.7, 0.4, 0.2] } else { [0.6; 3] };
    let mats = [
        Material::new("wall", wall, [0.0; 3]),
        Material::new("light", [0.5; 3], [5.0; 3]),
    ];
    let path = write_scene(dir.path(), "cube", &quads, &mats);
    (dir, path)
}

#[test]
fn effect_decisions_change_the_work_done() {
    let p = params(150, FormatChoice::Fixed(Format::Bc4), BounceSpec::default());
    let (_d, plain) = cube_with(false, false, false);
    let base = bake_file(&plain, &p);
    // Occlusion: none in a convex box, rays once a card floats inside.
    assert!(!base.report.effects["occlusion"].on);
    assert_eq!(base.report.rays_cast, 0);
    let (_d2, card) = cube_with(true, false, false);
    let occluded = bake_file(&card, &p);
    assert!(occluded.report.effects["occlusion"].on);
    assert!(occluded.report.rays_cast > 0, "an occluder must cost rays");
    // Colour: grey stores one channel, colour three (three times the blocks at equal n).
    let (_d3, col) = cube_with(false, true, false);
    let coloured = bake_file(&col, &p);
    assert_eq!((base.report.channels, coloured.report.channels), (1, 3));
    assert_eq!(base.file.matrix.layout.planes(), 1);
    assert_eq!(coloured.file.matrix.layout.planes(), 3);
    let per_patch2 =
        |o: &BakeOutput| o.report.bytes.blocks as f64 / (o.report.patches as f64).powi(2);
    assert!(
        per_patch2(&coloured) > 2.5 * per_patch2(&base),
        "colour must cost about 3× the block bytes"
    );
    // Dark patches: the rug sees nothing; it faces the void, so it stays in the matrix with a
    // zero row (direct light from a lights file still reaches it).
    let (_d4, rug) = cube_with(false, false, true);
    let dark = bake_file(&rug, &p);
    assert!(
        dark.report.effects["dark_patches"].on,
        "{:?}",
        dark.report.effects["dark_patches"]
    );
    assert!(!base.report.effects["dark_patches"].on);
    // ... and hemisphere rays from it confirm that it sees nothing (no warning).
    let why = &dark.report.effects["dark_patches"].why;
    assert!(
        why.contains("at most 0.000")
            && why.contains("): 0 lie under")
            && why.contains("face the void")
            && why.contains(": 0 buried whole")
            && why.contains("stay with a zero row")
            && !why.contains("contradict"),
        "{why}"
    );
    assert!(
        !dark.report.warnings.iter().any(|w| w.contains("dark")),
        "{:?}",
        dark.report.warnings
    );
    // A small scene: every pair piece by piece.
    assert!(!base.report.effects["clustered_pairs"].on);
    // Emission is reported.
    assert!(base.report.effects["emission"].on);
}

/// The patches of the object called `name`.
fn patches_of(scene: &Scene, patches: &Patches, name: &str) -> Vec<usize> {
    let o = scene.objects.iter().position(|o| o == name).unwrap() as u32;
    (0..patches.len())
        .filter(|&i| patches.patches[i].object == o)
        .collect()
}

/// The check behind the dark-patch decision can say no: asked about a patch that does see
/// the room, it reports the light landing on other patches.
#[test]
fn the_dark_patch_check_tells_a_patch_that_sees_from_one_that_does_not() {
    let (_d, rug) = cube_with(false, false, true);
    let scene = Scene::load_obj(&rug).unwrap();
    let patches = simplify(&scene, &VoxelParams::with_patches(150)).unwrap();
    let occ = scene.occluders();
    let (rugs, floor) = (
        patches_of(&scene, &patches, "rug"),
        patches_of(&scene, &patches, "floor"),
    );
    assert!(!rugs.is_empty() && !floor.is_empty());
    let dark = check_dark(&patches, &occ, &rugs, 1);
    assert_eq!((dark.checked, dark.seeing), (rugs.len(), 0));
    assert_eq!(dark.largest_share, 0.0, "the rug faces the void");
    assert_eq!(
        dark.covered, 0,
        "nothing is in front of the rug, not even a back face"
    );
    // Inside a closed box every ray from the floor lands on a wall, ceiling or the floor's
    // other patches (share 1 exactly, whatever the rays).
    let lit = check_dark(&patches, &occ, &floor, 1);
    assert_eq!(lit.seeing, floor.len());
    assert_eq!(lit.largest_share, 1.0);

    // A mat under a lid 0.01 above it, the lid's front facing up: the mat's rays meet the
    // lid's back face, so it counts as covered (a floor under a block).
    let dir = tempfile::tempdir().unwrap();
    let mut quads = closed_box(2.0, 1, |_, _, _| "wall".into());
    let flat = |y: f64, lo: f64, hi: f64| [[lo, y, lo], [hi, y, lo], [hi, y, hi], [lo, y, hi]];
    quads.push(Quad::facing(
        "mat",
        "wall",
        flat(0.01, 0.9, 1.1),
        [1.0, 2.0, 1.0],
    ));
    quads.push(Quad::facing(
        "lid",
        "wall",
        flat(0.02, 0.5, 1.5),
        [1.0, 2.0, 1.0],
    ));
    let mats = [Material::new("wall", [0.5; 3], [0.0; 3])];
    let scene = Scene::load_obj(&write_scene(dir.path(), "mat", &quads, &mats)).unwrap();
    let patches = simplify(&scene, &VoxelParams::with_patches(150)).unwrap();
    let occ = scene.occluders();
    let mat = patches_of(&scene, &patches, "mat");
    let covered = check_dark(&patches, &occ, &mat, 1);
    assert_eq!(
        (covered.covered, covered.seeing),
        (mat.len(), 0),
        "{covered:?}"
    );
}

#[test]
fn auto_bounces_follow_the_energy() {
    let dir = tempfile::tempdir().unwrap();
    let result = |rho: f64| {
        let mats = [
            Material::new("m", [rho; 3], [0.0; 3]),
            Material::new("light", [rho; 3], [1.0; 3]),
        ];
        let quads = closed_box(2.0, 1, |f, _, _| {
            if f == "ceiling" {
                "light".into()
            } else {
                "m".into()
            }
        });
        let path = write_scene(dir.path(), &format!("b{rho}"), &quads, &mats);
        bake_file(
            &path,
            &params(
                60,
                FormatChoice::Fixed(Format::F32),
                BounceSpec::Auto { tolerance: 1e-3 },
            ),
        )
    };
    // Gain per bounce ≈ ρ in a closed box: 1e-4 ≤ 1e-3 → one bounce; 0.02² = 4e-4 → two.
    assert_eq!(result(1e-4).file.bounces, Bounces::Finite(1));
    assert_eq!(result(0.02).file.bounces, Bounces::Finite(2));
    assert_eq!(result(0.5).file.bounces, Bounces::Infinite);
}

#[test]
fn cornell_box_orders_and_compression() {
    // The project's targets, measured at 4096 patches by `radiosity bake --patches 4096 --json` (see
    // README): BC1 lighting error ≤ 2%, BC4 ≤ 1%, best order ≥ 3× below random for BC1. This
    // test runs at 1500 patches to stay quick, so its bounds are the 1500-patch measurements with
    // about 25% headroom: they catch a regression, not tune to a target. Measured with the
    // value-space, error-driven encoder (ARCHITECTURE.md, "radiosity-bake: encoding"): BC1
    // lighting 0.64%, BC4 0.11% (were 3.7% and 1.7%); random/best 1.83× for BC1, 2.43× for BC4
    // (were 3.2× and 2.5×). The ratio fell because `random` improved most: its blocks mix
    // entries decades apart, which a code-space fit got badly wrong in value and the value-space
    // refinement does not (4096 patches: random 13.2% → 6.3%, paper 3.1% → 2.6%), so the 3×
    // ratio is not met for BC1 (2.4× at 4096) while every order's error is lower. The bake
    // takes the buried floor under the blocks out of its patches, so the patches along the
    // blocks' feet carry their exposed irradiance, not dimmed by the buried part, and BC4's
    // lighting error at 1500 patches is 0.149% (BC1 0.68%).
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/CornellBox-Original.obj");
    for (format, max_lighting, min_gain) in [(Format::Bc1, 0.0085, 1.5), (Format::Bc4, 0.0019, 2.0)]
    {
        let mut p = params(1500, FormatChoice::Fixed(format), BounceSpec::Infinite);
        p.order = OrderKind::Best;
        let out = bake_file(&path, &p);
        let r = &out.report;
        let e = r.lighting_error.expect("the Cornell box emits");
        let rmse = &r.compression_rmse;
        eprintln!("{format}: lighting error {e:.4}, compression {rmse:?}");
        assert!(
            e <= max_lighting,
            "{format}: lighting error {e} > {max_lighting}"
        );
        let best = rmse[r.order];
        // The chosen order's error is exact, the others are sampled (≈1% standard error).
        assert!(
            best <= rmse["none"] * 1.03,
            "{format}: best {best} worse than none {}",
            rmse["none"]
        );
        let gain = rmse["random"] / best;
        assert!(
            gain >= min_gain,
            "{format}: best order only {gain:.2}× below random"
        );
        // The paper's measure (texture RMS in codes) is reported for every order measured,
        // and the best order's gain on it is larger than on values: it counts the codes of
        // tiny entries, which `random` gets wrong most. No ratio bound here beyond "larger
        // than the value gain" (tests/tests/order.rs guards the ratio at n = 286).
        let codes = &r.compression_code_rmse;
        assert_eq!(
            codes.keys().collect::<Vec<_>>(),
            rmse.keys().collect::<Vec<_>>(),
            "{format}: code RMS for the same orders"
        );
        let code_gain = codes["random"] / codes[r.order];
        eprintln!("{format}: texture codes {codes:?}, gain {code_gain:.2}×");
        assert!(
            code_gain > gain,
            "{format}: code gain {code_gain:.2}× not above the value gain {gain:.2}×"
        );
    }
}
