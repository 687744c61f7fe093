//! Known physics through `radiosity solve --json`: the white furnace and the thin
//! wall, end to end with the default format and order, as a user (or a checker) runs them.

use radiosity_tests::scenes::{Material, Quad, closed_box, resting_blocks_room, write_scene};
use serde_json::Value;
use std::f64::consts::PI;
use std::path::Path;

fn solve_json(scene: &Path, extra: &[&str]) -> Value {
    let mut args = vec!["solve", scene.to_str().unwrap(), "--json"];
    args.extend_from_slice(extra);
    let out = super::radiosity(&args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The object named `name` in a `solve --json` answer.
fn object<'a>(out: &'a Value, name: &str) -> &'a Value {
    out["objects"]
        .as_array()
        .and_then(|objects| objects.iter().find(|o| o["name"] == name))
        .unwrap_or_else(|| panic!("{name} in {out}"))
}

/// Asserts each object's radiosity (first channel) within 0.5% of the closed form, the issue's
/// tolerance.
fn assert_radiosity(rho: f64, expected: &[(&Value, f64)]) {
    for &(o, want) in expected {
        let got = channel(o, "radiosity", 0);
        let rel = (got - want).abs() / want;
        assert!(
            rel < 5e-3,
            "ρ = {rho}: {} B = {got} vs {want} ({:.3}%)",
            o["name"],
            rel * 100.0
        );
    }
}

fn channel(o: &Value, key: &str, k: usize) -> f64 {
    o[key][k]
        .as_f64()
        .unwrap_or_else(|| panic!("{key}[{k}] in {o}"))
}

#[test]
fn white_furnace_through_solve_json() {
    // Closed box, one material: reflectance ρ and emitted radiance Ke = 1/π, so E = π·Ke = 1.
    // Every row of F sums to 1 (closed) and E, ρ are uniform, so a uniform B solves
    // B = E + ρ·Σ_j F_ij B_j = E + ρB: B = E/(1 − ρ), and H = Σ_j F_ij B_j = B. K = ∞ is exact;
    // `auto` must choose it (one or two bounces leave ρ or ρ² ≥ 0.25 of the energy).
    // Tolerance 0.5% (the issue's); the default format for a grey scene is BC4 with the sparse
    // list, whose per-tile log scale keeps the nearly constant furnace matrix within it.
    let dir = tempfile::tempdir().unwrap();
    for rho in [0.5, 0.9, 0.99, 0.999] {
        let mats = [Material::new("white", [rho; 3], [1.0 / PI; 3])];
        let path = write_scene(
            dir.path(),
            &format!("furnace{rho}"),
            &closed_box(2.0, 2, |_, _, _| "white".into()),
            &mats,
        );
        for bounces in ["auto", "inf"] {
            let v = solve_json(&path, &["--patches", "96", "--bounces", bounces]);
            assert_eq!(v["bounces"], "infinite", "ρ = {rho}, --bounces {bounces}");
            let want = 1.0 / (1.0 - rho);
            let objects = v["objects"].as_array().unwrap();
            assert_eq!(objects.len(), 6);
            for o in objects {
                for key in ["irradiance", "radiosity"] {
                    for k in 0..3 {
                        let got = channel(o, key, k);
                        let rel = (got - want).abs() / want;
                        assert!(
                            rel < 5e-3,
                            "ρ = {rho}, --bounces {bounces}: {} {key}[{k}] = {got} vs {want} ({:.3}%)",
                            o["name"],
                            rel * 100.0
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn furnace_with_blocks_resting_on_surfaces_through_solve_json() {
    // The furnace of the test above with a block standing on the floor and one pressed against
    // the left wall: the room minus the blocks is still closed, so B = E/(1 − ρ) = 1000 and
    // H = B hold on every exposed point. The floor under the block, the block's bottom, the
    // wall behind the cube and its back receive nothing (H = 0, B = E = 1), and the per-object
    // means are over the whole surface, so an object with exposed share s has the mean
    // H = 1000·s and B = 1000·s + (1 − s). ρ = 0.999, where one per cent of buried area left in
    // the patches used to cost two thirds of the light. Tolerances: 0.5% (the issue's) on the
    // means, taken with the reported exposed share; 1% on the exposed areas, which come from
    // 512 points on each partly buried patch (hard_cases.rs has the derivation); 1e-6 on the
    // whole areas, exact sums of the triangles (f32 patch areas may round above them).
    let dir = tempfile::tempdir().unwrap();
    let rho = 0.999;
    let (quads, mats, exposed) = resting_blocks_room(rho);
    let whole = radiosity_tests::scenes::resting_blocks_surface_areas();
    let path = write_scene(dir.path(), "resting", &quads, &mats);
    let v = solve_json(&path, &["--patches", "150"]);
    assert_eq!(
        v["effects"]["closed"]["on"], true,
        "{}",
        v["effects"]["closed"]
    );
    let inside = 1.0 / (1.0 - rho);
    let objects = v["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 8);
    for o in objects {
        let name = o["name"].as_str().unwrap();
        let exposed = exposed.iter().find(|e| e.0 == name).unwrap().1;
        let whole = whole.iter().find(|e| e.0 == name).unwrap().1;
        let (area, got_exposed) = (
            o["area"].as_f64().unwrap(),
            o["exposed_area"].as_f64().unwrap(),
        );
        assert!(
            (area - whole).abs() < 1e-6 * whole,
            "{name}: area {area} vs whole {whole}"
        );
        assert!(
            (got_exposed - exposed).abs() < 0.01 * exposed,
            "{name}: exposed area {got_exposed} vs {exposed}"
        );
        let s = got_exposed / area;
        for (key, want) in [
            ("irradiance", inside * s),
            ("radiosity", inside * s + (1.0 - s)),
        ] {
            let got = channel(o, key, 0);
            let rel = (got - want).abs() / want;
            assert!(rel < 5e-3, "{name} {key} = {got} vs {want}");
        }
    }
}

#[test]
fn files_baked_before_the_surface_fields_still_solve() {
    // A file whose report lacks `object_surface_areas` and `object_emitted_power` (baked before
    // them) takes the whole surface from its full-detail mesh: the same answer as the fields
    // give, to the mesh's f32 positions (1e-5 relative covers their rounding on these areas).
    // Without a mesh either, the means fall back to the exposed area (`object_areas`), as such
    // files were solved before: the furnace's B = 1000 on every object within 0.5%.
    let dir = tempfile::tempdir().unwrap();
    let (quads, mats, _) = resting_blocks_room(0.999);
    let scene = write_scene(dir.path(), "resting", &quads, &mats);
    let rad = dir.path().join("new.rad");
    let bake = super::radiosity(&[
        "bake",
        scene.to_str().unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "150",
    ]);
    assert!(
        bake.status.success(),
        "{}",
        String::from_utf8_lossy(&bake.stderr)
    );
    let new = solve_json(&rad, &[]);
    let bytes = std::fs::read(&rad).unwrap();
    let mut file = radiosity_core::RadFile::parse(&bytes).unwrap();
    let mut report: Value = serde_json::from_str(file.report.as_deref().unwrap()).unwrap();
    for key in ["object_surface_areas", "object_emitted_power"] {
        assert!(
            report.as_object_mut().unwrap().remove(key).is_some(),
            "{key}"
        );
    }
    file.report = Some(report.to_string().into());
    let with_mesh = dir.path().join("with-mesh.rad");
    std::fs::write(&with_mesh, file.to_bytes().unwrap()).unwrap();
    let old = solve_json(&with_mesh, &[]);
    for o in new["objects"].as_array().unwrap() {
        let name = o["name"].as_str().unwrap();
        let got = object(&old, name);
        for key in ["area", "exposed_area"] {
            let (a, b) = (o[key].as_f64().unwrap(), got[key].as_f64().unwrap());
            assert!((a - b).abs() < 1e-5 * a, "{name} {key}: {b} vs {a}");
        }
        for key in ["irradiance", "radiosity"] {
            let (a, b) = (channel(o, key, 0), channel(got, key, 0));
            assert!((a - b).abs() < 1e-5 * a, "{name} {key}: {b} vs {a}");
        }
    }
    assert!(file.mesh.is_some(), "the bake writes a mesh");
    file.mesh = None;
    // Part and first-bounce rows name the mesh's samples, coverage its triangles: a file
    // without a mesh has none of them.
    file.parts = None;
    file.bounce = None;
    file.coverage = None;
    let bare = dir.path().join("bare.rad");
    std::fs::write(&bare, file.to_bytes().unwrap()).unwrap();
    let old = solve_json(&bare, &[]);
    for o in old["objects"].as_array().unwrap() {
        let area = o["area"].as_f64().unwrap();
        let exposed = o["exposed_area"].as_f64().unwrap();
        assert!(
            area >= exposed && area < 1.01 * exposed,
            "{}: {area} vs {exposed}",
            o["name"]
        );
        let b = channel(o, "radiosity", 0);
        assert!((b - 1000.0).abs() < 5.0, "{}: B = {b}", o["name"]);
    }
}

/// Two rooms side by side sharing a wall `t` thick (each room's own inward faces), objects
/// named per room, a lamp in room `a`'s ceiling.
fn two_rooms(dir: &Path, t: f64) -> std::path::PathBuf {
    let mut quads = Vec::new();
    for (room, x0) in [("a", 0.0), ("b", 1.0 + t)] {
        for q in closed_box(1.0, 2, |face, i, j| {
            if room == "a" && face == "ceiling" && i == 0 && j == 1 {
                "lamp".into()
            } else {
                "wall".into()
            }
        }) {
            let corners = q.corners.map(|[x, y, z]| [x + x0, y, z]);
            quads.push(Quad::facing(
                &format!("{room}_{}", q.object),
                &q.material,
                corners,
                [x0 + 0.5, 0.5, 0.5],
            ));
        }
    }
    let mats = [
        Material::new("wall", [0.8, 0.7, 0.6], [0.0; 3]),
        Material::new("lamp", [0.8; 3], [10.0; 3]),
    ];
    write_scene(dir, "rooms", &quads, &mats)
}

#[test]
fn thin_wall_does_not_leak_through_solve_json() {
    // The wall is 1% of the room's size thick. Exact answer in room b: no light at all; the
    // issue allows 1e-3 of room a's mean irradiance. Default format (BC1 for this coloured
    // scene) and order: compression must not smear light across the wall either.
    let dir = tempfile::tempdir().unwrap();
    let path = two_rooms(dir.path(), 0.01);
    let v = solve_json(&path, &["--patches", "200"]);
    let (mut lit, mut dark) = ((0.0, 0.0), (0.0, 0.0));
    for o in v["objects"].as_array().unwrap() {
        let name = o["name"].as_str().unwrap();
        let area = o["area"].as_f64().unwrap();
        let h = channel(o, "irradiance", 0);
        let side = if name.starts_with("a_") {
            &mut lit
        } else {
            &mut dark
        };
        side.0 += area;
        side.1 += area * h;
    }
    let (lit, dark) = (lit.1 / lit.0, dark.1 / dark.0);
    assert!(lit > 1.0, "the lamp lights room a: {lit}");
    assert!(
        dark <= 1e-3 * lit,
        "room b {dark} vs room a {lit}: ratio {:.2e}",
        dark / lit
    );
}

#[test]
fn no_emitters_and_no_lights_give_darkness_not_an_error() {
    // A closed room without Ke, solved with an empty lights file: a valid scene with nothing
    // lighting it. Every object's irradiance and radiosity must be exactly 0 (no light in, no
    // light out: the gather of a zero exitance is zero in any format).
    let dir = tempfile::tempdir().unwrap();
    let mats = [Material::new("wall", [0.7, 0.6, 0.5], [0.0; 3])];
    let path = write_scene(
        dir.path(),
        "dark",
        &closed_box(1.0, 2, |_, _, _| "wall".into()),
        &mats,
    );
    let lights = dir.path().join("none.json");
    std::fs::write(&lights, r#"{"lights":[]}"#).unwrap();
    let v = solve_json(
        &path,
        &["--patches", "24", "--lights", lights.to_str().unwrap()],
    );
    assert_eq!(v["lights"], 0);
    for o in v["objects"].as_array().unwrap() {
        for key in ["irradiance", "radiosity"] {
            for k in 0..3 {
                assert_eq!(channel(o, key, k), 0.0, "{} {key}", o["name"]);
            }
        }
    }
}

#[test]
fn concentric_spheres_through_solve_json() {
    // Concentric spheres: an emitting sphere (E1 = 1, outward faces) inside
    // a sphere twice its radius (inward faces), both of reflectance ρ. The inner surface is
    // convex, so it sees only the outer one (F12 = 1) and, by reciprocity, F21 = A1/A2 and
    // F22 = 1 − A1/A2 — exactly, for the tessellated spheres too, with their own areas (taken
    // from the JSON). With uniform radiosity on each surface:
    //   B2 = ρ F21 E1 / (1 − ρ F22 − ρ² F21),   B1 = E1 + ρ B2.
    // Uniformity holds by symmetry on true spheres and nearly on icospheres: measured with these
    // 320-triangle ones at 152 patches, 4e-7 (ρ = 0.5) and 1.3e-5 (ρ = 0.999) from the closed
    // form. Tolerance 0.5%, the issue's; K = ∞ and f32 storage keep compression out of it.
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = radiosity_tests::scenes::icosphere(2);
    for rho in [0.5, 0.999] {
        let mut obj = format!("mtllib s{rho}.mtl\n");
        for r in [0.5, 1.0] {
            for p in &v {
                obj += &format!("v {} {} {}\n", r * p[0], r * p[1], r * p[2]);
            }
        }
        let nv = v.len();
        for (k, o) in [(0, "inner"), (nv, "outer")] {
            obj += &format!("o {o}\nusemtl {o}\n");
            for [a, b, c] in &f {
                let (a, b, c) = (a + k + 1, b + k + 1, c + k + 1);
                // The outer sphere faces in: reversed winding.
                obj += &if k == 0 {
                    format!("f {a} {b} {c}\n")
                } else {
                    format!("f {a} {c} {b}\n")
                };
            }
        }
        let mtl = format!(
            "newmtl inner\nKd {rho} {rho} {rho}\nKe {e} {e} {e}\nnewmtl outer\nKd {rho} {rho} {rho}\n",
            e = 1.0 / PI
        );
        std::fs::write(dir.path().join(format!("s{rho}.mtl")), mtl).unwrap();
        let path = dir.path().join(format!("s{rho}.obj"));
        std::fs::write(&path, obj).unwrap();
        let out = solve_json(
            &path,
            &["--patches", "150", "--format", "f32", "--bounces", "inf"],
        );
        let (inner, outer) = (object(&out, "inner"), object(&out, "outer"));
        let ratio = inner["area"].as_f64().unwrap() / outer["area"].as_f64().unwrap();
        let (f21, f22) = (ratio, 1.0 - ratio);
        let b2 = rho * f21 / (1.0 - rho * f22 - rho * rho * f21);
        let b1 = 1.0 + rho * b2;
        assert_radiosity(rho, &[(inner, b1), (outer, b2)]);
    }
}

#[test]
fn inside_a_sphere_through_solve_json() {
    // Inside a sphere: on the inside of a sphere F_ij = A_j / A for any
    // two areas, so with reflectance ρ everywhere B_i = E_i + ρ B̄, B̄ = Σ A_j E_j / (A (1 − ρ)).
    // An icosphere of 1280 facets, split at y = 0 into an emitting top (E = 1) and a dark
    // bottom, solved at the default settings but 400 patches (394). Its facets are flat, so
    // the closed form holds only nearly: measured top −0.018% / bottom +0.063% at ρ = 0.5 and
    // +0.017% / +0.018% at ρ = 0.999. Tolerance 0.5%, the issue's; the default BC1 stays in,
    // since its error on this smooth matrix is far below that.
    let dir = tempfile::tempdir().unwrap();
    let (v, f) = radiosity_tests::scenes::icosphere(3);
    for rho in [0.5, 0.999] {
        let mut obj = format!("mtllib in{rho}.mtl\n");
        for p in &v {
            obj += &format!("v {} {} {}\n", p[0], p[1], p[2]);
        }
        for (name, top) in [("top", true), ("bottom", false)] {
            obj += &format!("o {name}\nusemtl {name}\n");
            for [a, b, c] in &f {
                if (v[*a][1] + v[*b][1] + v[*c][1] > 0.0) == top {
                    // Counter-clockwise from outside: reversed, the facet faces the centre.
                    obj += &format!("f {} {} {}\n", a + 1, c + 1, b + 1);
                }
            }
        }
        let mtl = format!(
            "newmtl top\nKd {rho} {rho} {rho}\nKe {e} {e} {e}\nnewmtl bottom\nKd {rho} {rho} {rho}\n",
            e = 1.0 / PI
        );
        std::fs::write(dir.path().join(format!("in{rho}.mtl")), mtl).unwrap();
        let path = dir.path().join(format!("in{rho}.obj"));
        std::fs::write(&path, obj).unwrap();
        let out = solve_json(&path, &["--patches", "400"]);
        let (top, bottom) = (object(&out, "top"), object(&out, "bottom"));
        let area = |o: &Value| o["area"].as_f64().unwrap();
        let mean = area(top) / ((area(top) + area(bottom)) * (1.0 - rho));
        assert_radiosity(rho, &[(top, 1.0 + rho * mean), (bottom, rho * mean)]);
    }
}

/// The Cornell page's box draws its light in the ceiling's plane, overlapping it: the floor
/// and the short block, lit mostly by it, match the path tracer (they were 12.5% low while
/// the coincident ceiling hid the light from rays of F: docs/decisions/coplanar-emitters.md).
#[test]
fn a_light_drawn_on_the_ceiling_lights_the_room() {
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-original/cornell_box_data.obj");
    let ours = solve_json(&scene, &[]);
    let out = super::radiosity(&[
        "pathtrace",
        scene.to_str().unwrap(),
        "--samples",
        "65536",
        "--json",
    ]);
    assert!(out.status.success());
    let pt: Value = serde_json::from_slice(&out.stdout).unwrap();
    let total = |o: &Value| (0..3).map(|k| channel(o, "irradiance", k)).sum::<f64>();
    for name in ["floor", "short_block", "tall_block", "back_wall"] {
        let (h, q) = (total(object(&ours, name)), total(object(&pt, name)));
        // Measured within 1.6% at the default 1024 patches (the path tracer's standard error
        // about 0.5% here); the fault this guards against read 12.6% low on the floor.
        assert!((h - q).abs() / q < 0.04, "{name}: {h} against {q}");
    }
}
