//! Hard cases for the whole bake: scenes generated in code whose physics is known,
//! checked for finite results, energy conservation, light leaks, scale invariance, and clean
//! errors where no answer exists.
//!
//! The white furnace at ρ ∈ {0.5, 0.9, 0.99, 0.999} through the library is in
//! `bake_pipeline.rs`; its command-line twin (with `--bounces auto` and H = B) is in
//! `tests/cli/solve_physics.rs`. Scenes here are small (tens to a few hundred patches) and use
//! `f32` storage, so what is measured is the bake's physics, not the compression.
//!
//! **The energy bound asserted everywhere** (`assert_energy`): with the scene's own emitters
//! and no runtime light, the power absorbed by the surfaces never exceeds the power emitted:
//!
//! `Σ_i A_i (1 − ρ_i) H_i ≤ Σ_i A_i E_i`, with equality when the scene is closed and K = ∞.
//!
//! Why: the power arriving at the patches is `Σ_i A_i H_i = Σ_i A_i Σ_j F_ij B_j =
//! Σ_j B_j Σ_i A_i F_ij = Σ_j A_j B_j Σ_i F_ji` by reciprocity (`A_i F_ij = A_j F_ji`), and
//! `Σ_i F_ji ≤ 1` (= 1 when closed): arriving ≤ leaving = `Σ A B = Σ A E + Σ A ρ H`. Moving
//! `Σ A ρ H` to the left gives the bound. Finite K leaves out the later bounces, which only
//! lowers H. "What the emitters can supply" is therefore the absorbed power; the arriving
//! power `Σ A H` itself may exceed `Σ A E` (by up to `1/(1 − ρ_max)`, as in the furnace),
//! which `assert_energy` checks too.
//!
//! One file (over 600 lines) on purpose: every case asserts the bound derived above with the
//! same scene builders and checks, which read best beside it.

use glam::DVec3;
use radiosity_bake::form_factor::ManyPieces;
use radiosity_bake::order::OrderKind;
use radiosity_bake::pipeline::{BakeOutput, BakeParams, FormatChoice, Hooks, bake};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_bake::transfer::BounceSpec;
use radiosity_core::{Format, Rgb};
use radiosity_tests::fixtures::reference_frame;
use radiosity_tests::scenes::{
    Material, Quad, block, closed_box, floating_cube, resting_blocks_room, write_scene,
};
use std::f64::consts::PI;
use std::path::Path;

fn params(patches: usize) -> BakeParams {
    BakeParams {
        voxel: VoxelParams::with_patches(patches),
        format: FormatChoice::Fixed(Format::F32),
        bounces: BounceSpec::Infinite,
        order: OrderKind::None,
        ..BakeParams::default()
    }
}

fn load(path: &Path) -> Scene {
    Scene::load_obj(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn bake_ok(scene: &Scene, p: &BakeParams) -> BakeOutput {
    bake(scene, p, Hooks::default()).unwrap_or_else(|e| panic!("bake: {e}"))
}

/// Irradiance H and radiosity B of every file patch, lit by the scene's own emitters.
fn frame(out: &BakeOutput) -> (Vec<Rgb>, Vec<Rgb>) {
    let f = reference_frame(&out.file, &vec![Rgb::ZERO; out.file.n()]);
    (f.h, f.b)
}

/// Every H and B finite and non-negative, and the energy bound of the module docs. `closed`:
/// the scene is a closed enclosure baked with K = ∞, so the bound is an equality.
///
/// Tolerances: the matrix is stored in f32 and gathered in f64 (relative 2⁻²⁴ per entry); the
/// closure correction makes closed rows sum to 1 within 1e-13; reciprocity holds to f32
/// rounding because each pair's exchange is integrated once. So a closed scene balances to about
/// 1e-6; 1e-4 is asserted. An open scene's rows come from the quadrature and may over-sum by its
/// error δ (the bake caps rows only above 1 + its closure tolerance): then arriving ≤ (1 + δ)
/// leaving, and the bound becomes `absorbed ≤ emitted + δ·Σ A B`, with δ the largest row
/// excess the bake reports (before any cap, so an upper bound), plus the same 1e-4.
fn assert_energy(what: &str, out: &BakeOutput, closed: bool) -> (f64, f64) {
    let (h, b) = frame(out);
    let patches = &out.file.patches;
    let (mut absorbed, mut emitted, mut arriving, mut leaving) = (0.0, 0.0, 0.0, 0.0);
    let mut rho_max: f64 = 0.0;
    for (i, p) in patches.iter().enumerate() {
        for k in 0..3 {
            let (hk, bk) = (f64::from(h[i].channel(k)), f64::from(b[i].channel(k)));
            assert!(
                hk.is_finite() && bk.is_finite() && hk >= 0.0 && bk >= 0.0,
                "{what}: patch {i} channel {k}: H = {hk}, B = {bk}"
            );
            let (a, rho) = (f64::from(p.area), f64::from(p.reflectance.channel(k)));
            absorbed += a * (1.0 - rho) * hk;
            arriving += a * hk;
            leaving += a * bk;
            emitted += a * f64::from(p.emission.channel(k));
            rho_max = rho_max.max(rho);
        }
    }
    let tol = 1e-4;
    let excess = if closed {
        0.0
    } else {
        (out.report.closure.max_row_sum - 1.0).max(0.0)
    };
    assert!(
        absorbed <= emitted * (1.0 + tol) + excess * leaving,
        "{what}: absorbed {absorbed} > emitted {emitted} + row excess {excess:.2e} × leaving {leaving}"
    );
    if closed {
        assert!(
            absorbed >= emitted * (1.0 - tol),
            "{what}: closed, K = ∞: absorbed {absorbed} must equal emitted {emitted} (tolerance {tol})"
        );
    }
    // arriving ≤ (1 + δ)·leaving ≤ (1 + δ)(emitted + ρ_max·arriving).
    let supply = emitted * (1.0 + excess) / (1.0 - (1.0 + excess) * rho_max);
    assert!(
        arriving <= supply * (1.0 + tol),
        "{what}: arriving {arriving} > (1 + δ)·emitted/(1 − (1 + δ)ρ_max) = {supply}"
    );
    (absorbed, emitted)
}

/// Area-weighted mean irradiance (channel 0) per scene object, over the patches in the file.
fn object_irradiance(out: &BakeOutput, h: &[Rgb]) -> Vec<f64> {
    let mut acc = vec![(0.0, 0.0); out.file.objects.len()];
    for (i, p) in out.file.patches.iter().enumerate() {
        let a = &mut acc[p.object as usize];
        a.0 += f64::from(p.area);
        a.1 += f64::from(p.area) * f64::from(h[i].r);
    }
    acc.iter()
        .map(|(a, s)| if *a > 0.0 { s / a } else { 0.0 })
        .collect()
}

fn white_room(ceiling_lamp: bool) -> (Vec<Quad>, Vec<Material>) {
    let quads = closed_box(1.0, 2, |face, i, j| {
        if ceiling_lamp && face == "ceiling" && i == 0 && j == 1 {
            "lamp".into()
        } else {
            "wall".into()
        }
    });
    let mats = vec![
        Material::new("wall", [0.7, 0.6, 0.5], [0.0; 3]),
        Material::new("lamp", [0.5; 3], [2.0; 3]),
    ];
    (quads, mats)
}

#[test]
fn reflectance_one_is_a_clean_error_never_nan() {
    // The loader refuses Kd ≥ 1 (tests/bad/obj/kd-one.obj checks the command line), so the
    // solve's own refusal is reached through the library: a closed cube built in code whose only
    // material is then set to ρ = 1.
    let cube = cube_triangles(1.0);
    let mut scene = Scene::from_triangles(vec!["cube".into()], &cube);
    scene.materials[0].reflectance = Rgb::splat(1.0);
    scene.materials[0].emission = Rgb::splat(1.0);
    let e = bake(&scene, &params(60), Hooks::default()).expect_err("ρ = 1 closed must fail");
    let msg = e.to_string();
    assert!(
        msg.contains("reflectance") && !msg.contains('\n'),
        "one line naming the cause: {msg}"
    );
    for bounces in [BounceSpec::Auto { tolerance: 1e-3 }, BounceSpec::Fixed(8)] {
        let p = BakeParams {
            bounces,
            ..params(60)
        };
        assert!(
            bake(&scene, &p, Hooks::default()).is_err(),
            "{bounces:?}: ρ = 1 is refused whatever the bounce count"
        );
    }
    // The largest f32 below 1: B = E/(1 − ρ) ≈ 1.7e7·E is finite; the bake must either give
    // finite, non-negative, energy-conserving results or a clean error, never NaN or infinity.
    scene.materials[0].reflectance = Rgb::splat(1.0 - f32::EPSILON / 2.0);
    match bake(&scene, &params(60), Hooks::default()) {
        Ok(out) => {
            let (h, _) = frame(&out);
            let want = 1.0 / (f64::from(f32::EPSILON) / 2.0);
            for (i, v) in h.iter().enumerate() {
                let v = f64::from(v.r);
                // 1 − ρ is 6e-8: the row sums of F (1 within 1e-13) decide B to about 1e-5
                // relative, the f32 storage of M and of ρ itself to 1e-6; allow 1%.
                assert!(
                    v.is_finite() && (v - want).abs() < 0.01 * want,
                    "ρ = 1 − 2⁻²⁴: patch {i} H = {v}, want {want}"
                );
            }
        }
        Err(e) => assert!(!e.to_string().contains('\n'), "{e}"),
    }
}

/// The 12 inward-facing triangles of the cube `[0, s]³`.
fn cube_triangles(s: f64) -> Vec<([DVec3; 3], u32)> {
    let quads = closed_box(s, 1, |_, _, _| String::new());
    quads
        .iter()
        .flat_map(|q| {
            let c = q.corners.map(DVec3::from_array);
            [([c[0], c[1], c[2]], 0), ([c[0], c[2], c[3]], 0)]
        })
        .collect()
}

/// Two rooms `[0, 1]³` and `[1 + t, 2 + t] × [0, 1]²` side by side, their shared wall `t`
/// thick (the two rooms' own inward faces at `x = 1` and `x = 1 + t`, closed at the top and
/// bottom of the slab), a lamp in the first room's ceiling only. `same_names`: both rooms'
/// faces carry the same object names, so only geometry keeps them apart.
fn two_rooms(dir: &Path, t: f64, same_names: bool) -> std::path::PathBuf {
    let mut quads = Vec::new();
    for (room, x0) in [("a", 0.0), ("b", 1.0 + t)] {
        let centre = [x0 + 0.5, 0.5, 0.5];
        let prefix = if same_names {
            String::new()
        } else {
            format!("{room}_")
        };
        for q in closed_box(1.0, 3, |face, i, j| {
            if room == "a" && face == "ceiling" && i == 1 && j == 1 {
                "lamp".into()
            } else {
                "wall".into()
            }
        }) {
            let corners = q.corners.map(|[x, y, z]| [x + x0, y, z]);
            quads.push(Quad::facing(
                &format!("{prefix}{}", q.object),
                &q.material,
                corners,
                centre,
            ));
        }
    }
    let mats = [
        Material::new("wall", [0.8; 3], [0.0; 3]),
        Material::new("lamp", [0.8; 3], [10.0; 3]),
    ];
    write_scene(
        dir,
        if same_names { "rooms_same" } else { "rooms" },
        &quads,
        &mats,
    )
}

#[test]
fn thin_wall_does_not_leak() {
    // A wall 1% of the room's size thick between a lit room and a dark one: only the lamp's
    // room may receive light. Each room is closed on its own, so the exact answer in the dark
    // room is 0; the issue allows 1e-3 of the lit room's mean irradiance. With the rooms'
    // faces named alike, voxel cells that straddle the wall hold floor pieces of both rooms:
    // they must still become separate patches (a patch spanning the wall would carry the lit
    // room's light into the dark one).
    let dir = tempfile::tempdir().unwrap();
    // Two patch targets, so that the voxel grid's cells fall differently against the wall.
    for (same_names, patches) in [(false, 300), (true, 120), (true, 300)] {
        let path = two_rooms(dir.path(), 0.01, same_names);
        let out = bake_ok(&load(&path), &params(patches));
        assert!(out.report.effects["occlusion"].on, "two rooms occlude");
        assert_energy(
            &format!("two rooms, same names {same_names}, {patches} patches"),
            &out,
            true,
        );
        let (h, _) = frame(&out);
        let (mut lit, mut dark) = ((0.0, 0.0), (0.0, 0.0));
        for (i, p) in out.file.patches.iter().enumerate() {
            let a = f64::from(p.area);
            let side = if p.centre[0] < 1.005 {
                &mut lit
            } else {
                &mut dark
            };
            side.0 += a;
            side.1 += a * f64::from(h[i].r);
        }
        let (lit, dark) = (lit.1 / lit.0, dark.1 / dark.0);
        assert!(lit > 0.1, "the lamp lights its room: {lit}");
        assert!(
            dark <= 1e-3 * lit,
            "same names {same_names}, {patches} patches: dark room {dark} vs lit room {lit} (ratio {:.2e})",
            dark / lit
        );
    }
}

/// A closed room with the geometric troubles the issue lists, each as an extra object; every
/// one must bake to finite, energy-conserving results.
#[test]
fn awkward_geometry_stays_finite_and_conserves_energy() {
    let dir = tempfile::tempdir().unwrap();
    let mats = [
        Material::new("wall", [0.7, 0.6, 0.5], [0.0; 3]),
        Material::new("grey", [0.4; 3], [0.0; 3]),
        Material::new("lamp", [0.5; 3], [2.0; 3]),
        Material::new("tiny_lamp", [0.5; 3], [1.0e6; 3]),
    ];
    let (room, _) = white_room(true);

    // T-junctions: floor and ceiling split 2×2, the walls 3×3, so the walls' grid vertices
    // fall inside the floor's and ceiling's edges (and vice versa).
    let walls3 = closed_box(1.0, 3, |_, _, _| "wall".into());
    let t_junctions: Vec<Quad> = room
        .iter()
        .filter(|q| q.object == "floor" || q.object == "ceiling")
        .cloned()
        .chain(
            walls3
                .into_iter()
                .filter(|q| q.object != "floor" && q.object != "ceiling"),
        )
        .collect();

    // A tiny emitting square (side 1e-4: area 1e-8, 1e8 below a wall's 1 m²) floating at the
    // room's centre, facing the floor; a lamp of 1e6 so that its power (1e-2·π) is not lost in
    // rounding.
    let s = 0.5e-4;
    let tiny = Quad::facing(
        "tiny",
        "tiny_lamp",
        [
            [0.5 - s, 0.5, 0.5 - s],
            [0.5 + s, 0.5, 0.5 - s],
            [0.5 + s, 0.5, 0.5 + s],
            [0.5 - s, 0.5, 0.5 + s],
        ],
        [0.5, 0.0, 0.5],
    );

    // Coplanar overlapping faces: two squares on the floor plane, overlapping each other and
    // the floor, of another material.
    let overlap = |x0: f64| {
        Quad::facing(
            "overlap",
            "grey",
            [
                [x0, 0.0, 0.2],
                [x0 + 0.4, 0.0, 0.2],
                [x0 + 0.4, 0.0, 0.6],
                [x0, 0.0, 0.6],
            ],
            [0.5, 1.0, 0.5],
        )
    };

    // `closed`: whether absorbed = emitted must hold. Coplanar overlapping faces are both seen
    // through the same solid angle, so the rows of the patches that see them sum to about
    // 1 + (overlap area seen): beyond the closure tolerance, the bake treats the scene as open
    // and scales those rows down to 1 (`form_factor::matrix::dense::cap_row_sums`); only the bound can hold.
    // Before that cap the absorbed power came out 15% above the emitted.
    let cases: Vec<(&str, Vec<Quad>, bool)> = vec![
        ("shared edges", closed_box(1.0, 3, lamp_at), true),
        ("t-junctions", with_lamp(t_junctions), true),
        (
            "tiny beside huge",
            {
                let mut q = room.clone();
                q.push(tiny);
                q
            },
            true,
        ),
        (
            "coplanar overlap",
            {
                let mut q = room.clone();
                q.push(overlap(0.2));
                q.push(overlap(0.4));
                q
            },
            false,
        ),
    ];
    for (name, quads, closed) in cases {
        let path = write_scene(dir.path(), &name.replace(' ', "_"), &quads, &mats);
        let out = bake_ok(&load(&path), &params(150));
        // Closed, K = ∞: absorbed = emitted. The tiny card's back blocks 1e-8 of the room,
        // well within the closure tolerance, which rebalances the rows to 1.
        let (absorbed, emitted) = assert_energy(name, &out, closed);
        assert!(emitted > 0.0 && absorbed > 0.0, "{name}: something is lit");
    }

    // Degenerate triangles next to real ones: collinear corners, a repeated corner and a
    // sliver whose smallest angle (1e-9 rad) is above the loader's cut, in the floor's plane.
    let path = write_scene(dir.path(), "box", &room, &mats);
    let mut text = std::fs::read_to_string(&path).unwrap();
    let base = text.lines().filter(|l| l.starts_with("v ")).count();
    text.push_str("o junk\nusemtl grey\n");
    for v in [
        [0.1, 0.0, 0.1],
        [0.2, 0.0, 0.1],
        [0.3, 0.0, 0.1], // collinear with the first two
        [0.1, 0.0, 0.9],
        [0.9, 0.0, 0.9],
        [0.5, 0.0, 0.9 + 4e-10], // a sliver over 0.8 m: angle ≈ 1e-9 rad
    ] {
        text.push_str(&format!("v {} {} {}\n", v[0], v[1], v[2]));
    }
    let k = |i: usize| base + i;
    text.push_str(&format!(
        "f {} {} {}\nf {} {} {}\nf {} {} {}\n",
        k(1),
        k(2),
        k(3),
        k(1),
        k(1),
        k(2),
        k(4),
        k(6),
        k(5)
    ));
    let junk = dir.path().join("degenerate.obj");
    std::fs::write(&junk, text).unwrap();
    let scene = load(&junk);
    assert_eq!(scene.report.degenerate_triangles, 2, "collinear + repeated");
    let out = bake_ok(&scene, &params(150));
    assert_energy("degenerate triangles", &out, true);
}

fn lamp_at(face: &str, i: usize, j: usize) -> String {
    if face == "ceiling" && i == 1 && j == 1 {
        "lamp".into()
    } else {
        "wall".into()
    }
}

fn with_lamp(mut quads: Vec<Quad>) -> Vec<Quad> {
    if let Some(q) = quads.iter_mut().find(|q| q.object == "ceiling") {
        q.material = "lamp".into();
    }
    quads
}

#[test]
fn results_do_not_depend_on_the_scale() {
    // The same room (with an occluding card, so visibility rays run too) at 1e-4, 1 and 1e4:
    // form factors are scale-free and emission is per area, so every object's mean irradiance
    // must agree. The issue asks for 1e-4 relative; the patches are the same at every scale
    // (the voxel grid is relative to the scene's bounds), so what differs is rounding.
    let dir = tempfile::tempdir().unwrap();
    let (mut room, mats) = white_room(true);
    room.push(Quad::facing(
        "card",
        "wall",
        [
            [0.3, 0.5, 0.3],
            [0.7, 0.5, 0.3],
            [0.7, 0.5, 0.7],
            [0.3, 0.5, 0.7],
        ],
        [0.5, 1.0, 0.5],
    ));
    let mut results = Vec::new();
    for scale in [1.0, 1e-4, 1e4] {
        let quads: Vec<Quad> = room
            .iter()
            .map(|q| Quad {
                corners: q.corners.map(|c| c.map(|v| v * scale)),
                ..q.clone()
            })
            .collect();
        let path = write_scene(dir.path(), &format!("scaled{scale}"), &quads, &mats);
        let out = bake_ok(&load(&path), &params(120));
        assert!(out.report.rays_cast > 0, "the card occludes");
        assert_energy(&format!("scale {scale}"), &out, false);
        let (h, _) = frame(&out);
        results.push((scale, out.report.patches, object_irradiance(&out, &h)));
    }
    let (_, n1, base) = &results[0];
    for (scale, n, h) in &results[1..] {
        assert_eq!(n, n1, "scale {scale}: same patches");
        for (o, (a, b)) in base.iter().zip(h).enumerate() {
            assert!(
                (a - b).abs() <= 1e-4 * a.abs().max(1e-30),
                "scale {scale}: object {o} irradiance {b} vs {a} at scale 1 ({:.2e} relative)",
                (a - b).abs() / a
            );
        }
    }
}

#[test]
fn degenerate_scenes_give_clear_answers() {
    // Empty: no triangle at all.
    let empty = Scene::from_triangles(vec!["nothing".into()], &[]);
    let e = bake(&empty, &params(10), Hooks::default()).expect_err("empty scene");
    assert!(e.to_string().contains("no non-degenerate triangle"), "{e}");

    // One patch: a single square sees nothing, so no light can travel: a valid bake with a
    // zero transfer, its patch kept for the direct light.
    let c = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
    let one = Scene::from_triangles(
        vec!["card".into()],
        &[([c[0], c[1], c[2]], 0), ([c[0], c[2], c[3]], 0)],
    );
    let out = bake(&one, &params(1), Hooks::default()).expect("one patch bakes");
    assert_eq!(out.report.patches, 1);
    assert!(
        out.report.effects["dark_patches"].on,
        "the patch sees nothing"
    );

    // No emitters (and no runtime lights): a valid bake whose frame is dark everywhere.
    let dir = tempfile::tempdir().unwrap();
    let (room, mats) = white_room(false);
    let out = bake_ok(
        &load(&write_scene(dir.path(), "dark", &room, &mats)),
        &BakeParams {
            bounces: BounceSpec::Auto { tolerance: 1e-3 },
            ..params(40)
        },
    );
    assert_eq!(out.report.lighting_error, None, "nothing to measure");
    assert!(!out.report.effects["emission"].on);
    let (h, b) = frame(&out);
    assert!(
        h.iter().chain(&b).all(|v| *v == Rgb::ZERO),
        "no light in, no light out"
    );
}

#[test]
fn furnace_auto_bounces_pick_all_bounces_and_meet_the_closed_form() {
    // The auto bounce choice on the furnace (the K = ∞ runs are in bake_pipeline.rs): at
    // ρ ≥ 0.5 one or two bounces leave far more than 1e-3 of the energy, so auto must solve all
    // of them, and B = E/(1 − ρ), H = B follow. Derivation: closed box, uniform ρ and E; rows of
    // F sum to 1, so a uniform B solves B = E + ρ Σ_j F_ij B = E + ρB, i.e. B = E/(1 − ρ), and
    // H = Σ_j F_ij B = B. Tolerance 0.5% (the issue's), f32 storage.
    let dir = tempfile::tempdir().unwrap();
    for rho in [0.5, 0.999] {
        let mats = [Material::new("white", [rho; 3], [1.0 / PI; 3])];
        let path = write_scene(
            dir.path(),
            &format!("furnace{rho}"),
            &closed_box(2.0, 2, |_, _, _| "white".into()),
            &mats,
        );
        let out = bake_ok(
            &load(&path),
            &BakeParams {
                bounces: BounceSpec::Auto { tolerance: 1e-3 },
                ..params(96)
            },
        );
        assert_eq!(out.file.bounces, radiosity_core::Bounces::Infinite);
        let want = 1.0 / (1.0 - rho);
        let (h, b) = frame(&out);
        for i in 0..h.len() {
            for (what, v) in [("H", h[i].r), ("B", b[i].r)] {
                let rel = (f64::from(v) - want).abs() / want;
                assert!(rel < 5e-3, "ρ = {rho}: patch {i} {what} = {v} vs {want}");
            }
        }
        assert_energy(&format!("furnace ρ = {rho}"), &out, true);
    }
}

#[test]
fn flat_sites_keep_a_finely_tessellated_furnace_exact() {
    // A closed box whose faces are 20 × 20 quads (4 800 triangles) around a small floating
    // cube (so that visibility rays are cast), baked at about 96 patches: a wall patch is made
    // of about 60 pieces. Forced through flat sites (`exact_pieces = 0`), a wall patch is one
    // flat site in its far pairs (bounding spheres apart), its own rays ignore its own
    // triangles, and neighbours keep their pieces. The walls are flat and a patch is a grid cell
    // of them, so its site is its exact outline, and the furnace identity holds whatever the
    // geometry: uniform ρ and E in a closed scene give B = E/(1 − ρ) on every patch, blocker
    // included. Tolerance 0.5%, the issue's, at ρ = 0.99, where a row-sum error of 1e-4 would
    // already cost 1%: the closure correction must still see a closed scene.
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.99;
    let mats = [Material::new("white", [rho; 3], [1.0 / PI; 3])];
    let mut quads = closed_box(2.0, 20, |_, _, _| "white".into());
    quads.extend(floating_cube(0.8, 1.2, "cube", "white"));
    let path = write_scene(dir.path(), "fine", &quads, &mats);
    let mut p = params(96);
    p.form_factors.exact_pieces = 0;
    p.form_factors.many_pieces = ManyPieces::Clustered;
    let out = bake_ok(&load(&path), &p);
    let sites = &out.report.effects["flat_sites"];
    assert!(sites.on, "{}", sites.why);
    // Neighbouring wall patches keep their ~60 pieces each: clustered pairs.
    let clustered = &out.report.effects["clustered_pairs"];
    assert!(clustered.on, "{}", clustered.why);
    let occlusion = &out.report.effects["occlusion"];
    assert!(
        occlusion.on && out.report.rays_cast > 0,
        "{}",
        occlusion.why
    );
    assert!(
        out.report.effects["closed"].on,
        "{}",
        out.report.effects["closed"].why
    );
    let want = 1.0 / (1.0 - rho);
    let (_, b) = frame(&out);
    for (i, b) in b.iter().enumerate() {
        let rel = (f64::from(b.r) - want).abs() / want;
        assert!(rel < 5e-3, "patch {i}: B = {} vs {want}", b.r);
    }
    assert_energy("fine furnace through flat sites", &out, true);
}

#[test]
fn blocks_resting_on_surfaces_keep_a_closed_furnace_exact() {
    // A closed room with one block standing on its floor and one pressed against its left
    // wall, everything white at ρ = 0.999 and emitting. The floor under the first block, the
    // block's bottom, the wall behind the second block and that block's back face are not
    // surface: no light reaches or leaves them. The room minus the blocks is still a closed
    // enclosure, so the furnace identity B = E/(1 − ρ) = 1000 holds on every exposed point.
    // Before the bake took buried area out of its patches, a patch straddling a block's edge
    // spread its mean radiosity, dimmed by the buried part, over its exposed part: energy lost
    // at every bounce, and the rows short of 1 also hid the closure. Tolerance 0.5%, the issue's.
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.999;
    let (quads, mats, exposed) = resting_blocks_room(rho);
    let path = write_scene(dir.path(), "resting", &quads, &mats);
    let out = bake_ok(&load(&path), &params(150));
    let closed = &out.report.effects["closed"];
    assert!(closed.on, "{}", closed.why);
    assert!(closed.why.contains("partly buried"), "{}", closed.why);
    // The block's bottom and the wall behind the cube are buried whole: dark, and said so.
    let dark = &out.report.effects["dark_patches"];
    assert!(
        dark.on && dark.why.contains("buried whole") && !dark.why.contains(": 0 buried whole"),
        "{}",
        dark.why
    );
    let want = 1.0 / (1.0 - rho);
    let (h, b) = frame(&out);
    for i in 0..h.len() {
        for (what, v) in [("H", h[i].r), ("B", b[i].r)] {
            let rel = (f64::from(v) - want).abs() / want;
            assert!(rel < 5e-3, "patch {i} {what} = {v} vs {want}");
        }
    }
    assert_energy("blocks resting on surfaces", &out, true);
    // Exposed areas, against the geometry. Buried shares come from 512 stratified points per
    // partly buried patch (Sobol'): measured at most 0.07% off here (floor, left wall). With
    // 512 independent uniform points the floor is 0.26% off; 0.2% catches that.
    for (o, name) in out.file.objects.iter().enumerate() {
        let want = exposed.iter().find(|e| e.0 == name.as_ref()).unwrap().1;
        let got = out.report.object_areas[o];
        assert!(
            (got - want).abs() < 0.002 * want,
            "{name}: exposed area {got} vs {want}"
        );
    }
    // Whole areas and emitted power, exact sums over the triangles (E = π·Ke = 1 everywhere,
    // f32 Ke: 1e-6 relative), buried parts included.
    let whole = radiosity_tests::scenes::resting_blocks_surface_areas();
    for (o, name) in out.file.objects.iter().enumerate() {
        let want = whole.iter().find(|e| e.0 == name.as_ref()).unwrap().1;
        let got = out.report.object_surface_areas[o];
        assert!(
            (got - want).abs() < 1e-9 * want,
            "{name}: area {got} vs {want}"
        );
        for p in out.report.object_emitted_power[o] {
            assert!(
                (p - want).abs() < 1e-6 * want,
                "{name}: power {p} vs {want}"
            );
        }
    }
}

/// The furnace box [0, 2]³ of `split × split` quads a face, white at ρ = 0.999 and emitting
/// E = 1, with one ceiling quad taken out, baked at about `patches`: the bake and the opening's
/// share of the remaining area.
fn box_with_opening(split: usize, patches: usize) -> (BakeOutput, f64) {
    let dir = tempfile::tempdir().unwrap();
    let side = 2.0 / split as f64;
    let quads: Vec<Quad> = closed_box(2.0, split, |_, _, _| "white".into())
        .into_iter()
        .filter(|q| {
            !(q.object == "ceiling"
                && q.corners.iter().all(|c| {
                    (0.5..=0.5 + side).contains(&c[0]) && (0.5..=0.5 + side).contains(&c[2])
                }))
        })
        .collect();
    assert_eq!(quads.len(), 6 * split * split - 1);
    let mats = [Material::new("white", [0.999; 3], [1.0 / PI; 3])];
    let path = write_scene(dir.path(), "opening", &quads, &mats);
    let out = bake_ok(&load(&path), &params(patches));
    (out, side * side / (24.0 - side * side))
}

/// Asserts that a box at ρ = 0.999 and E = 1 that keeps `s = 1 − opening` of the light per
/// bounce is lit near the uniform-enclosure estimate `H = s / (1 − ρ s)`: the area-weighted
/// mean irradiance of its patches (first channel, lit by their own emission) within `mean_tol`
/// of it, relative, and every patch within `patch_tol`.
fn assert_near_enclosure(out: &BakeOutput, opening: f64, mean_tol: f64, patch_tol: f64) {
    let (h, _) = frame(out);
    let areas: Vec<f64> = out.file.patches.iter().map(|p| f64::from(p.area)).collect();
    let mean = h
        .iter()
        .zip(&areas)
        .map(|(v, a)| f64::from(v.r) * a)
        .sum::<f64>()
        / areas.iter().sum::<f64>();
    let (lo, hi) = h.iter().fold((f64::MAX, f64::MIN), |(lo, hi), v| {
        (lo.min(f64::from(v.r)), hi.max(f64::from(v.r)))
    });
    let s = 1.0 - opening;
    let want = s / (1.0 - 0.999 * s);
    println!("opening {opening:.5}: H mean {mean:.2} in [{lo:.2}, {hi:.2}], estimate {want:.2}");
    assert!(
        (mean / want - 1.0).abs() < mean_tol,
        "mean H {mean} vs {want}"
    );
    assert!(
        lo > want * (1.0 - patch_tol) && hi < want * (1.0 + patch_tol),
        "H in [{lo}, {hi}] vs {want}"
    );
}

#[test]
fn a_small_opening_is_open_though_the_rows_are_within_tolerance() {
    // The furnace box [0, 2]³ (split 4 × 4) with one ceiling quad of 0.5 × 0.5 taken out: an
    // opening of 0.25 / 23.75 = 1.05% of the area. Its rows of F are within the closure
    // tolerance of 1 (measured [0.955, 1.003]), so row sums alone called it closed, rebalanced
    // it, and the furnace gave B = 1000 at ρ = 0.999: the light that leaves through the
    // opening was kept. Hemisphere rays from the patches find it (`row_check::escape_check`):
    // measured 1.02% of them leave. The share is asserted within a factor 1.5 of the opening's
    // area share (16 384 rays: ±5% noise). Open, the irradiance is near the uniform-enclosure
    // estimate H = s / (1 − ρ s) = 85.9, s = 1 − 0.0105 (the path tracer: 85.2–87.8 ± 0.6 per
    // object; the closed answer would be 1000). Measured: mean 86.4, patches in [83.6, 88.3];
    // with the centroid quadrature rule the mean is 93.4 (+8.7%) and this fails. Bounds: the mean within 2.5% of the estimate, each patch within 5%.
    let (out, opening) = box_with_opening(4, 150);
    let closed = &out.report.effects["closed"];
    assert!(!closed.on, "{}", closed.why);
    assert!(closed.why.contains("opening"), "{}", closed.why);
    let c = &out.report.closure;
    assert!(c.min_row_sum > 0.95, "rows within tolerance: {c:?}");
    let share = c.escaped.expect("the rows said closed, so rays were asked");
    assert!((opening - 0.25 / 23.75).abs() < 1e-12);
    assert!(
        share > opening / 1.5 && share < opening * 1.5,
        "escaped {share} vs {opening}"
    );
    assert_near_enclosure(&out, opening, 0.025, 0.05);
}

#[test]
fn a_near_closed_box_at_high_reflectance_keeps_the_right_share() {
    // The box above with a smaller opening: one ceiling quad of 0.25 × 0.25 in split 8, 0.26%
    // of the area. At ρ = 0.999 light bounces about 280 times before it leaves, so F's mean
    // row sum, which sets the share kept per bounce, matters as much as the opening: a bias of
    // 1e-4 moves B by 4%. The uniform-enclosure estimate H = s / (1 − ρ s), s = 1 − opening,
    // is 276.4; the path tracer agrees (`radiosity pathtrace` with 20 000 samples a patch,
    // objects 272.4–278.0, ± 1.9 each). Measured: mean 276.9, every patch in [273.5, 278.4].
    // With the centroid rule F's rows average 4e-4 high and the mean is 316.7 (+15%; 329 at
    // 600 patches).
    // Bounds: the area-weighted mean within 1% of the estimate (the path tracer's own spread),
    // each patch within 3% (patches next to the opening see less of the box).
    let (out, opening) = box_with_opening(8, 150);
    let closed = &out.report.effects["closed"];
    assert!(!closed.on, "{}", closed.why);
    assert_near_enclosure(&out, opening, 0.01, 0.03);
}

/// `--patches N` counts the patches left in the matrix: nine posts sunk 3 m into a 4 m slab
/// bury a fifth of the first grid's patches whole, and the bake simplifies again (aiming
/// higher, the buried share measured anew each time) until about N stay live, and says so.
/// Measured at 256: 216 live at first, then 206, then 264.
#[test]
fn a_patch_target_counts_the_live_patches_when_solids_bury_some() {
    let dir = tempfile::tempdir().unwrap();
    let mut quads = block([-10.0, -4.0, -10.0], [10.0, 0.0, 10.0], "slab", "grey");
    for i in 0..3 {
        for j in 0..3 {
            let (x, z) = (-8.0 + 6.0 * f64::from(i), -8.0 + 6.0 * f64::from(j));
            quads.extend(block([x, -3.0, z], [x + 2.4, 1.0, z + 2.4], "post", "grey"));
        }
    }
    let mats = [Material::new("grey", [0.5; 3], [0.0; 3])];
    let scene = Scene::load_obj(&write_scene(dir.path(), "posts", &quads, &mats)).unwrap();
    let target = 256;
    let params = BakeParams {
        voxel: VoxelParams::with_patches(target),
        ..BakeParams::default()
    };
    let out = bake(&scene, &params, Hooks::default()).unwrap();
    let live = out.file.patches.len();
    // The simplification's own tolerance, ±10%, now on the live count.
    assert!(
        live.abs_diff(target) as f64 <= 0.1 * target as f64,
        "{live} live patches for a target of {target}"
    );
    let effect = &out.report.effects["buried_patches"];
    assert!(effect.on, "{}", effect.why);
}
