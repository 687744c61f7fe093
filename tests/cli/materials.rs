//! `solve --materials`: reflectance edits at run time against a re-bake of the edited scene,
//! and bad materials files.

use super::{assert_one_line_error, radiosity, radiosity_ok};
use radiosity_tests::scenes::{Material, block, closed_box, write_scene};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A room [0, 2]³ with a red left wall, a lamp in the ceiling and a block on the floor; `red`
/// and `block` give the left wall's and the block's reflectance.
fn room(dir: &Path, name: &str, red: [f64; 3], block_rho: [f64; 3]) -> PathBuf {
    let mats = [
        Material::new("white", [0.7; 3], [0.0; 3]),
        Material::new("red", red, [0.0; 3]),
        Material::new("blockmat", block_rho, [0.0; 3]),
        Material::new("lamp", [0.5; 3], [2.0; 3]),
    ];
    let mut quads = closed_box(2.0, 3, |face, i, j| match face {
        "left" => "red".into(),
        "ceiling" if (i, j) == (1, 1) => "lamp".into(),
        _ => "white".into(),
    });
    quads.extend(block([0.5, 0.0, 0.7], [1.1, 0.6, 1.3], "block", "blockmat"));
    write_scene(dir, name, &quads, &mats)
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_owned()
}

fn solve(args: &[&str]) -> Value {
    serde_json::from_slice(&radiosity_ok(args).stdout).unwrap()
}

fn irradiance(v: &Value, object: &str) -> [f64; 3] {
    let o = v["objects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["name"] == object)
        .unwrap_or_else(|| panic!("no object {object}"));
    let a = o["irradiance"].as_array().unwrap();
    [0, 1, 2].map(|k| a[k].as_f64().unwrap())
}

#[test]
fn an_edit_at_run_time_matches_a_rebake_of_the_edited_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let baked = room(d, "room", [0.7, 0.1, 0.1], [0.7; 3]);
    let edited = room(d, "edited", [0.2, 0.6, 0.8], [0.05, 0.3, 0.05]);
    let lights = d.join("lights.json");
    std::fs::write(
        &lights,
        r#"{"lights":[{"type":"point","position":[1.5,1.6,1.5],"intensity":[3,3,3]}]}"#,
    )
    .unwrap();
    let edits = d.join("edits.json");
    std::fs::write(
        &edits,
        r#"{"materials":[{"object":"left","reflectance":[0.2,0.6,0.8]},
                         {"object":"block","reflectance":[0.05,0.3,0.05]}]}"#,
    )
    .unwrap();
    let l = s(&lights);
    // Stored in f32 the edit is exact: the edited frame is the re-bake's within f32 rounding
    // (1e-5 of each object's brightest channel leaves a wide margin over it).
    let (run, rebake) = edit_and_rebake(
        d,
        &baked,
        &edited,
        &edits,
        &l,
        &["--patches", "300", "--format", "f32"],
    );
    let plain = solve(&["solve", &s(&d.join("a.rad")), "--lights", &l, "--json"]);
    let mut moved = 0.0f64;
    for object in OBJECTS {
        let (e, r, p) = (
            irradiance(&run, object),
            irradiance(&rebake, object),
            irradiance(&plain, object),
        );
        let scale = r.iter().copied().fold(0.0, f64::max);
        for k in 0..3 {
            assert!(
                (e[k] - r[k]).abs() <= 1e-5 * scale,
                "f32 {object}[{k}]: edit {} against re-bake {}",
                e[k],
                r[k]
            );
            moved = moved.max((p[k] - r[k]).abs() / scale);
        }
    }
    // The edit is visible: unedited, some object is off by far more than 1%.
    assert!(moved > 0.05, "the edit moves the light by only {moved:.3}");
    let m = &run["materials"];
    assert_eq!(m["objects"], 2);
    assert!(m["patches"].as_u64().unwrap() > 10, "{m}");

    // In BC1 (the default) each matrix has its own compression error, and the edit gathers
    // its matrix twice. The issue's bound is 1% of the re-bake's figure (each object's
    // brightest channel, so a channel near zero is held to the same absolute error): at 2000
    // patches the worst channel is 0.80% (at 1000, 0.92%; at 300, where BC1's own error on the
    // red wall is 1.4%, 2.5%).
    let (run, rebake) = edit_and_rebake(d, &baked, &edited, &edits, &l, &["--patches", "2000"]);
    let mut worst = 0.0f64;
    for object in OBJECTS {
        let (e, r) = (irradiance(&run, object), irradiance(&rebake, object));
        let scale = r.iter().copied().fold(0.0, f64::max);
        for k in 0..3 {
            worst = worst.max((e[k] - r[k]).abs() / scale);
            assert!(
                (e[k] - r[k]).abs() <= 0.01 * scale,
                "bc1 {object}[{k}]: edit {} against re-bake {}",
                e[k],
                r[k]
            );
        }
    }
    eprintln!(
        "bc1 at 2000 patches: the edit within {:.2}% of the re-bake",
        100.0 * worst
    );
}

/// The Cornell box lit by its own lamp at the default patch count, its left wall edited to blue:
/// each object within 0.5% of a re-bake of the blue box (the issue's bound). Both files are
/// BC1; the bake keeps the lamp's columns exact where the blocks would light the box more
/// than 0.25% off (`exact_emitters`), so what is left is the edit's correction gathered
/// through compressed columns. Measured: 0.24% (the lamp's own face), 0.11% elsewhere.
#[test]
fn an_edit_of_the_cornell_box_under_its_own_lamp_matches_a_rebake() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box");
    let obj = std::fs::read_to_string(src.join("CornellBox-Original.obj")).unwrap();
    let mtl = std::fs::read_to_string(src.join("CornellBox-Original.mtl")).unwrap();
    std::fs::write(d.join("CornellBox-Original.mtl"), &mtl).unwrap();
    std::fs::write(d.join("cb.obj"), &obj).unwrap();
    // The edit applies to the object `leftWall`, whose group holds some of the short box's
    // faces too (under their own `usemtl`): the re-baked scene gives every face of that group
    // the blue material, as the edit does.
    let mut group = String::new();
    let blue: String = obj
        .lines()
        .map(|line| {
            if let Some(g) = line.strip_prefix("g ") {
                group = g.trim().to_owned();
            }
            match (group.as_str(), line.starts_with("usemtl ")) {
                ("leftWall", true) => "usemtl blue".to_owned(),
                _ => line.replace("mtllib CornellBox-Original.mtl", "mtllib blue.mtl"),
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(d.join("blue.obj"), blue).unwrap();
    std::fs::write(
        d.join("blue.mtl"),
        format!("{mtl}\nnewmtl blue\nKd 0.1 0.2 0.8\nKe 0 0 0\n"),
    )
    .unwrap();
    let edits = d.join("edits.json");
    std::fs::write(
        &edits,
        r#"{"materials":[{"object":"leftWall","reflectance":[0.1,0.2,0.8]}]}"#,
    )
    .unwrap();
    let (a, b) = (d.join("a.rad"), d.join("b.rad"));
    for (scene, out) in [("cb.obj", &a), ("blue.obj", &b)] {
        radiosity_ok(&[
            "bake",
            &s(&d.join(scene)),
            "-o",
            &s(out),
            "--probes",
            "none",
        ]);
    }
    let run = solve(&["solve", &s(&a), "--materials", &s(&edits), "--json"]);
    let rebake = solve(&["solve", &s(&b), "--json"]);
    let plain = solve(&["solve", &s(&a), "--json"]);
    let names: Vec<String> = (rebake["objects"].as_array().unwrap().iter())
        .map(|o| o["name"].as_str().unwrap().to_owned())
        .collect();
    assert_eq!(names.len(), 7, "{names:?}");
    let (mut worst, mut moved) = (0.0f64, 0.0f64);
    for object in &names {
        let (e, r, p) = (
            irradiance(&run, object),
            irradiance(&rebake, object),
            irradiance(&plain, object),
        );
        let scale = r.iter().copied().fold(0.0, f64::max);
        for k in 0..3 {
            worst = worst.max((e[k] - r[k]).abs() / scale);
            moved = moved.max((p[k] - r[k]).abs() / scale);
        }
    }
    eprintln!(
        "Cornell box, own lamp, default patches: the edit within {:.3}% of the re-bake (unedited {:.1}% off)",
        100.0 * worst,
        100.0 * moved
    );
    // The edit is visible: unedited, some object is off by far more than the bound.
    assert!(moved > 0.05, "the edit moves the light by only {moved:.3}");
    assert!(
        worst <= 0.005,
        "the edit is {:.3}% off the re-bake",
        100.0 * worst
    );
    // The bake says why the lamp's columns are exact.
    let inspect: Value =
        serde_json::from_slice(&radiosity_ok(&["inspect", &s(&a), "--json"]).stdout).unwrap();
    let effect = &inspect["effects"]["exact_emitters"];
    assert_eq!(effect["on"], true, "{effect}");
}

const OBJECTS: [&str; 7] = [
    "left", "right", "floor", "ceiling", "back", "front", "block",
];

/// Bakes `baked` and `edited` with `flags`, then solves the first with `edits` and the second
/// as it is, both under `lights`: (edited frame, re-bake).
fn edit_and_rebake(
    d: &Path,
    baked: &Path,
    edited: &Path,
    edits: &Path,
    lights: &str,
    flags: &[&str],
) -> (Value, Value) {
    let (a, b) = (d.join("a.rad"), d.join("b.rad"));
    let bake = |scene: &Path, out: &Path| {
        let mut args = vec!["bake".to_owned(), s(scene), "-o".into(), s(out)];
        args.extend(flags.iter().map(|f| (*f).to_owned()));
        radiosity_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    };
    bake(baked, &a);
    bake(edited, &b);
    let run = solve(&[
        "solve",
        &s(&a),
        "--lights",
        lights,
        "--materials",
        &s(edits),
        "--json",
    ]);
    let rebake = solve(&["solve", &s(&b), "--lights", lights, "--json"]);
    (run, rebake)
}

#[test]
fn bad_materials_files_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = room(d, "room", [0.7, 0.1, 0.1], [0.7; 3]);
    let rad = d.join("a.rad");
    radiosity_ok(&["bake", &s(&scene), "-o", &s(&rad), "--patches", "100"]);
    for (name, text, needle) in [
        ("malformed", "{\"materials\": [", "bad materials file"),
        (
            "unknown",
            r#"{"materials":[{"object":"nothere","reflectance":[0.1,0.1,0.1]}]}"#,
            "object `nothere` is not in the scene",
        ),
        (
            "one",
            r#"{"materials":[{"object":"left","reflectance":[1.0,0.1,0.1]}]}"#,
            "in [0, 1)",
        ),
        (
            "field",
            r#"{"materials":[{"object":"left","albedo":[0.1,0.1,0.1]}]}"#,
            "bad materials file",
        ),
    ] {
        let path = d.join(format!("{name}.json"));
        std::fs::write(&path, text).unwrap();
        let out = radiosity(&["solve", &s(&rad), "--materials", &s(&path)]);
        assert_one_line_error(&out, needle);
    }
    let out = radiosity(&[
        "solve",
        &s(&rad),
        "--materials",
        &s(&d.join("missing.json")),
    ]);
    assert_one_line_error(&out, "cannot read materials file");
}

/// A level (three systems) takes the same edit: each system's gather carries its patches'
/// edit and the light between systems the new reflectance, so the edited level lights as the
/// edited one-matrix bake of the same patches (both stored in f32).
#[test]
fn an_edit_of_a_level_matches_the_edit_of_one_matrix() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let baked = room(d, "room", [0.7, 0.1, 0.1], [0.7; 3]);
    let edits = d.join("edits.json");
    std::fs::write(
        &edits,
        r#"{"materials":[{"object":"left","reflectance":[0.2,0.6,0.8]},
                         {"object":"block","reflectance":[0.05,0.3,0.05]}]}"#,
    )
    .unwrap();
    let mut got = Vec::new();
    for systems in ["off", "3"] {
        let rad = d.join(format!("room-{systems}.rad"));
        radiosity_ok(&[
            "bake",
            &s(&baked),
            "-o",
            &s(&rad),
            "--patches",
            "300",
            "--format",
            "f32",
            "--systems",
            systems,
        ]);
        let args = [
            "solve",
            &s(&rad),
            "--json",
            "--backend",
            "cpu",
            "--materials",
        ];
        let v = solve(&[&args[..], &[&s(&edits)]].concat());
        assert!(
            v["materials"]["patches"].as_u64().unwrap() > 0,
            "{}",
            v["materials"]
        );
        assert_eq!(v.get("systems").is_some(), systems != "off");
        got.push(v);
    }
    let plain = solve(&[
        "solve",
        &s(&d.join("room-3.rad")),
        "--json",
        "--backend",
        "cpu",
    ]);
    for object in ["left", "block", "floor"] {
        let (one, level) = (irradiance(&got[0], object), irradiance(&got[1], object));
        let before = irradiance(&plain, object);
        for k in 0..3 {
            // The same F and the same edit; the level settles to 1e-4 of its fixed point.
            assert!(
                (one[k] - level[k]).abs() <= 1e-3 * one[k].abs().max(1e-3),
                "{object}[{k}]: one matrix {} against the level {}",
                one[k],
                level[k]
            );
        }
        // The edit changed the level's light (the left wall went from red to blue).
        if object == "left" {
            assert!(
                (level[2] - before[2]).abs() > 0.05 * before[2],
                "{level:?} {before:?}"
            );
        }
    }
    // The GPU takes no edit of a level: one line that says where it runs.
    let out = radiosity(&[
        "solve",
        &s(&d.join("room-3.rad")),
        "--backend",
        "gpu",
        "--materials",
        &s(&edits),
    ]);
    assert_one_line_error(&out, "cpu or reference backend");
}
