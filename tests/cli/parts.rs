//! A scene of many separate parts, each its own object (a yard of boxes around a shed, lit by a
//! sun): `--patches N` lands near N in the matrix, and every part keeps its own figures
//! (exposed area, direct light) though parts of several objects share patches.

use super::radiosity_ok;
use radiosity_tests::scenes::{Material, Quad, block, write_scene};
use serde_json::Value;
use std::collections::HashMap;
use std::path::Path;

/// Boxes in the yard.
const PARTS: usize = 250;

/// A 12 × 12 m ground, a 3 m shed, and [`PARTS`] boxes 0.2–0.5 m on a 0.55 m grid (each its
/// own object, none touching another), some of them in the shed's shadow.
/// Returns the scene's path and each box's bottom area (the part the ground buries).
fn yard(dir: &Path) -> (std::path::PathBuf, HashMap<String, f64>) {
    let mats = [
        Material::new("grey", [0.4; 3], [0.0; 3]),
        Material::new("wood", [0.5, 0.35, 0.2], [0.0; 3]),
    ];
    let mut quads = vec![Quad::facing(
        "ground",
        "grey",
        [[-6., 0., -6.], [6., 0., -6.], [6., 0., 6.], [-6., 0., 6.]],
        [0., 1., 0.],
    )];
    quads.extend(block([-1.5, 0., -5.5], [1.5, 3., -2.5], "shed", "grey"));
    // A fixed linear congruential sequence: the same yard on every machine.
    let mut state = 12345u64;
    let mut next = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut placed = 0;
    let mut bottoms = HashMap::new();
    'rows: for j in 0..14 {
        for i in 0..20 {
            let (x, z) = (-5.5 + 0.55 * i as f64, -2.2 + 0.55 * j as f64);
            let (w, d, h) = (0.2 + 0.3 * next(), 0.2 + 0.3 * next(), 0.2 + 0.3 * next());
            let name = format!("part{placed}");
            quads.extend(block([x, 0., z], [x + w, h, z + d], &name, "wood"));
            bottoms.insert(name, w * d);
            placed += 1;
            if placed == PARTS {
                break 'rows;
            }
        }
    }
    assert_eq!(placed, PARTS);
    (write_scene(dir, "yard", &quads, &mats), bottoms)
}

fn json(args: &[&str]) -> Value {
    serde_json::from_slice(&radiosity_ok(args).stdout).unwrap()
}

fn by_name(v: &Value) -> HashMap<String, Value> {
    v["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| (o["name"].as_str().unwrap().to_owned(), o.clone()))
        .collect()
}

#[test]
fn a_yard_of_parts_meets_the_patch_target_and_each_part_keeps_its_own_light() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, bottoms) = yard(dir.path());
    let sun = dir.path().join("sun.json");
    // 50° above the horizon, travelling towards +z: the shed's shadow falls on the boxes in
    // front of it (z from -2.5 to 0).
    std::fs::write(
        &sun,
        r#"{"lights":[{"type":"directional","direction":[0,-0.766044,0.642788],"irradiance":[1000,1000,1000]}]}"#,
    )
    .unwrap();
    let rad = dir.path().join("yard.rad");
    let s = |p: &Path| p.to_str().unwrap().to_owned();
    let bake = json(&[
        "bake",
        &s(&scene),
        "--patches",
        "128",
        "-o",
        &s(&rad),
        "--json",
    ]);
    // The issue's bound: within ±10% of the count asked for, in the matrix. One object a
    // patch, the count stays above the 252 objects: parts of different objects share patches.
    let patches = bake["patches"].as_u64().unwrap() as f64;
    assert!(
        (patches - 128.0).abs() <= 0.1 * 128.0,
        "asked for 128, {patches} in the matrix"
    );
    let shared = bake["shared_patches"].as_array().unwrap();
    assert!(!shared.is_empty(), "parts of several objects share patches");

    let solve = by_name(&json(&["solve", &s(&rad), "--lights", &s(&sun), "--json"]));
    let pt = by_name(&json(&[
        "pathtrace",
        &s(&scene),
        "--lights",
        &s(&sun),
        "--samples",
        "512",
        "--json",
    ]));
    let (mut num, mut den, mut parts_num, mut parts_den) = (0.0, 0.0, 0.0, 0.0);
    for (name, p) in &pt {
        let q = &solve[name];
        let f = |o: &Value, k: &str| o[k].as_f64().unwrap();
        // Each box is buried on its bottom face and nowhere else: its exposed area is its
        // own, not its patches'. The bake measures burial at 512 points a patch (a box's
        // bottom shares its patch with other boxes' bottoms, all buried): 2% of the box's
        // area covers the sampling.
        if let Some(bottom) = bottoms.get(name) {
            let (a, e) = (f(q, "area"), f(q, "exposed_area"));
            assert!(
                (e - (a - bottom)).abs() <= 0.02 * a,
                "{name}: exposed {e} of {a}, bottom {bottom}"
            );
        }
        let a = f(p, "area");
        for k in 0..3 {
            let (hs, hp) = (
                q["irradiance"][k].as_f64().unwrap(),
                p["irradiance"][k].as_f64().unwrap(),
            );
            num += a * (hs - hp).powi(2);
            den += a * hp.powi(2);
            if name.starts_with("part") {
                parts_num += a * (hs - hp).powi(2);
                parts_den += a * hp.powi(2);
            }
        }
    }
    let all = (num / den).sqrt();
    let parts = (parts_num / parts_den).sqrt();
    // Area-weighted error of the per-object mean irradiance against the path tracer, over the
    // whole scene (the issue's measure) and over the boxes alone. Measured: 0.077 and 0.123
    // (0.059 and 0.105 against 4096 paths an object: the rest is the path tracer's noise, the
    // same on every machine for its fixed seed). With each box given its patch's mean direct
    // light instead of its own samples' they were 0.113 and 0.225 against 4096 paths: the
    // bounds fail there.
    assert!(all <= 0.10, "whole scene: {all:.4}");
    assert!(parts <= 0.17, "the boxes: {parts:.4}");
}
