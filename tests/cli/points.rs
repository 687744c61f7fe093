//! `solve --points`: the total irradiance at points in the Cornell box against the path
//! tracer's at the same points, points inside an object and outside the scene, bad files.

use super::{assert_one_line_error, radiosity, radiosity_ok};
use serde_json::{Value, json};
use std::path::Path;

/// Points in the Cornell box's air (x, z in [-0.8, 0.8], y in [0.9, 1.8], drawn once with a
/// fixed seed), each with a normal of its own: up, down, towards each wall, and slanted.
const POINTS: [([f64; 3], [f64; 3]); 16] = [
    ([-0.419, 1.390, -0.208], [0.0, 1.0, 0.0]),
    ([0.166, 1.463, -0.695], [0.0, -1.0, 0.0]),
    ([-0.779, 1.654, -0.385], [1.0, 0.0, 0.0]),
    ([-0.425, 1.796, -0.048], [-1.0, 0.0, 0.0]),
    ([0.538, 1.329, 0.223], [0.0, 0.0, 1.0]),
    ([-0.559, 1.471, 0.589], [0.0, 0.0, -1.0]),
    ([0.037, 1.567, 0.274], [1.0, 1.0, 0.0]),
    ([-0.698, 1.582, 0.146], [-1.0, 0.5, 1.0]),
    ([-0.317, 0.928, 0.585], [0.0, 1.0, 0.0]),
    ([-0.044, 1.547, 0.606], [0.0, -1.0, 0.0]),
    ([0.343, 1.729, -0.168], [1.0, 0.0, 0.0]),
    ([0.481, 1.300, 0.697], [-1.0, 0.0, 0.0]),
    ([0.606, 0.988, -0.582], [0.0, 0.0, 1.0]),
    ([-0.453, 1.769, -0.102], [0.0, 0.0, -1.0]),
    ([0.203, 1.171, 0.012], [1.0, 1.0, 0.0]),
    ([-0.183, 1.216, 0.136], [-1.0, 0.5, 1.0]),
];

fn cornell() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/CornellBox-Original.obj")
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_owned()
}

fn json_of(args: &[&str]) -> Value {
    serde_json::from_slice(&radiosity_ok(args).stdout).unwrap()
}

/// The sum of a JSON `[r, g, b]`.
fn sum(v: &Value) -> f64 {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .sum()
}

/// The mean and the largest of `errors`, printed under `what`.
fn mean_and_worst(what: &str, errors: &[f64]) -> (f64, f64) {
    let worst = errors.iter().copied().fold(0.0, f64::max);
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    eprintln!(
        "{what}: mean {:.2}%, worst {:.2}%",
        100.0 * mean,
        100.0 * worst
    );
    (mean, worst)
}

/// `|a[key] − b["irradiance"]| / b["irradiance"]` of each pair of points (channels summed).
fn errors_against(ours: &[Value], reference: &[Value], key: &str) -> Vec<f64> {
    ours.iter()
        .zip(reference)
        .map(|(a, b)| {
            let q = sum(&b["irradiance"]);
            (sum(&a[key]) - q).abs() / q
        })
        .collect()
}

fn write_points(path: &Path, points: &[([f64; 3], [f64; 3])]) {
    let list: Vec<Value> = points
        .iter()
        .map(|(p, n)| json!({"position": p, "normal": n}))
        .collect();
    std::fs::write(path, json!({ "points": list }).to_string()).unwrap();
}

/// `solve RAD --points FILE --json` and `pathtrace` of the Cornell box at the same points with
/// `samples` paths a point: their `points` arrays.
fn solve_and_trace(rad: &Path, file: &Path, samples: &str) -> (Vec<Value>, Vec<Value>) {
    let ours = json_of(&["solve", &s(rad), "--points", &s(file), "--json"]);
    let (c, f) = (s(&cornell()), s(file));
    let pt = json_of(&[
        "pathtrace",
        &c,
        "--points",
        &f,
        "--samples",
        samples,
        "--json",
    ]);
    let list = |v: &Value| v["points"].as_array().unwrap().clone();
    (list(&ours), list(&pt))
}

#[test]
fn point_irradiance_matches_the_path_tracer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rad = d.join("cb.rad");
    radiosity_ok(&["bake", &s(&cornell()), "-o", &s(&rad), "--patches", "1024"]);
    let mut points = POINTS.to_vec();
    // Inside the short box (its top at y = 0.6), and beside the room facing away from it (a
    // point beyond the mesh's box none of whose rays meets a surface).
    points.push(([0.3, 0.3, 0.4], [0.0, 1.0, 0.0]));
    points.push(([5.0, 1.0, 0.0], [1.0, 0.0, 0.0]));
    let file = d.join("points.json");
    write_points(&file, &points);
    let (ours, pt) = solve_and_trace(&rad, &file, "65536");
    assert_eq!(ours.len(), points.len());
    for (k, a) in ours.iter().take(POINTS.len()).enumerate() {
        assert_eq!(a["status"], "ok", "point {k}: {a}");
    }
    // The path tracer's standard error here is 0.1–0.9% of each point's value.
    let (ours_here, pt_here) = (&ours[..POINTS.len()], &pt[..POINTS.len()]);
    let errors = errors_against(ours_here, pt_here, "irradiance");
    let what = "points against the path tracer";
    let (mean, worst) = mean_and_worst(what, &errors);
    // The same points from the probes the bake placed by default (`--probes auto`).
    let probe_errors = errors_against(ours_here, pt_here, "probe_irradiance");
    let what = "probes against the path tracer";
    let (probe_mean, probe_worst) = mean_and_worst(what, &probe_errors);
    // The issue's bounds: each within 5%, the mean within 3%. Measured 1.1% and 3.9% (468
    // probes 0.25 m apart, their weights factored to rank 128: docs/decisions/probe-factors.md;
    // the worst under the ceiling, facing the floor). The path tracer's standard error is
    // under 1.4% a point.
    assert!(
        probe_mean <= 0.03 && probe_worst <= 0.05,
        "probes: mean {probe_mean:.4}, worst {probe_worst:.4}"
    );
    // The issue's bounds: each within 5%, the mean within 3% (measured 3.3% and 0.65% at 1024
    // patches; the path tracer's standard error is under 1.4% at this count, and against 4× its
    // samples the same gather is within 0.96% and 0.36%: docs/decisions/secondary-gather.md).
    assert!(
        worst <= 0.05 && mean <= 0.03,
        "worst {worst:.4}, mean {mean:.4}"
    );
    let inside = &ours[POINTS.len()];
    assert_eq!(inside["status"], "inside an object", "{inside}");
    assert!(inside["irradiance"].is_null());
    let outside = &ours[POINTS.len() + 1];
    assert_eq!(outside["status"], "outside the scene", "{outside}");
    assert!(outside["irradiance"].is_null());
    // The normal comes back as given.
    assert_eq!(ours[0]["normal"], json!(POINTS[0].1));
}

/// Points 1 to 13 cm from the floor, the back wall and the blocks, with their normals, from
/// `docs/examples/points-anywhere.json` (its points 16, 13, 20, 12, 138, 122 and 31): each sees
/// a piece of surface smaller than a patch, in a corner or against a block.
const NEAR_SURFACES: [([f64; 3], [f64; 3]); 7] = [
    ([-0.835, 0.0525, -0.9907], [0.263, -0.3279, -0.9073]),
    ([-0.1563, 0.1294, 0.7111], [0.2271, -0.9738, 0.0153]),
    ([-0.9586, 0.0547, -0.7283], [0.4831, -0.7501, 0.4517]),
    ([0.8949, 0.031, 0.5393], [0.9791, 0.0592, 0.1943]),
    ([-0.2251, 0.4018, 0.2245], [0.7505, -0.3576, 0.5557]),
    ([0.7648, 0.3557, 0.259], [-0.0476, -0.6022, 0.7969]),
    ([0.291, 0.0972, -0.9988], [-0.105, -0.3907, -0.9145]),
];

/// Points 1 mm to 2.5 cm from the ceiling light (0.47 × 0.38 at y = 1.98, facing down), facing
/// it, beside it and slanted.
const BY_THE_LIGHT: [([f64; 3], [f64; 3]); 4] = [
    ([0.0, 1.97, 0.0], [0.0, 1.0, 0.0]),
    ([0.0, 1.979, 0.0], [0.0, 1.0, 0.0]),
    ([-0.2, 1.97, -0.2], [1.0, 1.0, 0.0]),
    ([0.25, 1.975, -0.05], [-1.0, 0.2, 0.0]),
];

/// Irradiance meters laid on the floor, the short block's top, the back wall and the right
/// wall, facing away from them: 0.6 and −1.04 lie a few 1e-8 inside the block and behind the
/// wall as the mesh stores them in f32.
const ON_SURFACES: [([f64; 3], [f64; 3]); 4] = [
    ([0.0, 0.0, -0.5], [0.0, 1.0, 0.0]),
    ([0.3, 0.6, 0.3], [0.0, 1.0, 0.0]),
    ([0.0, 1.0, -1.04], [0.0, 0.0, 1.0]),
    ([1.0, 1.0, 0.0], [-1.0, 0.0, 0.0]),
];

#[test]
fn points_near_surfaces_and_the_light_match_the_path_tracer() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rad = d.join("cb.rad");
    let bake = ["bake", &s(&cornell()), "-o", &s(&rad), "--patches", "1024"];
    radiosity_ok(&[&bake[..], &["--probes", "none"]].concat());
    let file = d.join("points.json");
    let points = [&NEAR_SURFACES[..], &BY_THE_LIGHT[..], &ON_SURFACES[..]].concat();
    write_points(&file, &points);
    let (ours, pt) = solve_and_trace(&rad, &file, "1048576");
    let errors = errors_against(&ours, &pt, "irradiance");
    assert_eq!(errors.len(), points.len());
    let (near, rest) = errors.split_at(NEAR_SURFACES.len());
    let (light, on) = rest.split_at(BY_THE_LIGHT.len());
    // On a surface a meter sees the room (measured within 0.6%; each was "inside an object"
    // or "outside the scene" before the point was moved off the f32 surface).
    let (_, worst_on) = mean_and_worst("points on surfaces", on);
    assert!(worst_on <= 0.02, "on surfaces: {on:?}");
    // By the light the direct light is all but the whole figure, and it is exact where the
    // light is in full view (Lambert's contour integral; area samples alone read 30% high at
    // 1 cm and 94% low at 1 mm). The path tracer's standard error there is under 0.2%.
    let (_, worst_by_light) = mean_and_worst("points by the light", light);
    assert!(worst_by_light <= 0.01, "by the light: {light:?}");
    let (mean, worst) = mean_and_worst("points near surfaces against the path tracer", near);
    // Measured 1.0% mean, 3.9% worst (the point 1 cm from the back wall by the corner), where
    // interpolating the patches at every hit gave 4.5% and 9.2%: hits this near gather again
    // (docs/decisions/secondary-gather.md). The path tracer itself spreads by about 1.5% at
    // that corner point from one seed's stream to another's (0.1876, 0.1889 and 0.1910 from
    // three), more than its standard error says, so the worst is held to the issue's 5%.
    assert!(
        worst <= 0.05 && mean <= 0.02,
        "mean {mean:.4}, worst {worst:.4}"
    );
}

#[test]
fn bad_points_files_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rad = d.join("cb.rad");
    radiosity_ok(&["bake", &s(&cornell()), "-o", &s(&rad), "--patches", "64"]);
    for (name, text, needle) in [
        ("malformed", "{\"points\": [", "bad points file"),
        (
            "zero",
            r#"{"points":[{"position":[0,1,0],"normal":[0,0,0]}]}"#,
            "normal [0, 0, 0] has zero length",
        ),
        (
            "field",
            r#"{"points":[{"position":[0,1,0],"normal":[0,1,0],"up":1}]}"#,
            "bad points file",
        ),
    ] {
        let path = d.join(format!("{name}.json"));
        std::fs::write(&path, text).unwrap();
        assert_one_line_error(
            &radiosity(&["solve", &s(&rad), "--points", &s(&path)]),
            needle,
        );
    }
    let missing = d.join("missing.json");
    assert_one_line_error(
        &radiosity(&["solve", &s(&rad), "--points", &s(&missing)]),
        "cannot read points file",
    );
}

#[test]
fn probes_are_baked_and_answer_points_off_the_surfaces() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rad = d.join("cb.rad");
    let bake: Value = json_of(&[
        "bake",
        &s(&cornell()),
        "-o",
        &s(&rad),
        "--patches",
        "1024",
        "--probes",
        "auto",
        "--json",
    ]);
    let probes = &bake["probes"];
    // `auto` lays a lattice of about 512 probes over the box (8 a side); those inside the two
    // blocks go. Their weights are factored to rank 128, which costs less a frame than the
    // rows the rays found.
    let placed = probes["placed"].as_u64().unwrap();
    assert!((400..=512).contains(&placed), "{probes}");
    assert!(probes["dropped_inside"].as_u64().unwrap() >= 1, "{probes}");
    assert_eq!(probes["rank"].as_u64(), Some(128), "{probes}");
    let weights = probes["weights"].as_u64().unwrap();
    assert!(128 * (1024 + 9 * placed) < 9 * weights, "{probes}");
    let mut points = POINTS.to_vec();
    points.push(([0.3, 0.3, 0.4], [0.0, 1.0, 0.0]));
    let file = d.join("points.json");
    write_points(&file, &points);
    let out = json_of(&["solve", &s(&rad), "--points", &s(&file), "--json"]);
    let out = out["points"].as_array().unwrap();
    let mut errors = Vec::new();
    for p in &out[..POINTS.len()] {
        let (gather, probe) = (sum(&p["irradiance"]), sum(&p["probe_irradiance"]));
        errors.push((probe - gather).abs() / gather);
    }
    let (mean, worst) = mean_and_worst("probes against the final gather", &errors);
    // Measured 1.4% and 8.5% here (L2 alone costs up to 5%, the interpolation between probes
    // 0.40 m apart the rest: docs/decisions/probe-interpolation.md). A broken weight or SH
    // convention gives errors of 100% and more; the bounds leave the measured figures half
    // again as much room.
    assert!(
        mean < 0.03 && worst < 0.15,
        "mean {mean:.4}, worst {worst:.4}"
    );
    // A point inside the short box has neither figure.
    let inside = &out[POINTS.len()];
    assert_eq!(inside["status"], "inside an object");
    assert!(inside.get("probe_irradiance").is_none(), "{inside}");
}

#[test]
fn bad_probe_flags_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rad = d.join("cb.rad");
    let bad = d.join("bad.json");
    std::fs::write(&bad, r#"{"probes": [[0, 1]]}"#).unwrap();
    for (value, needle) in [
        ("-1", "--probes spacing must be positive"),
        ("0", "--probes spacing must be positive"),
        ("nothere.json", "cannot read it as a file"),
        (bad.to_str().unwrap(), "bad probes file"),
    ] {
        let out = radiosity(&[
            "bake",
            &s(&cornell()),
            "-o",
            &s(&rad),
            "--patches",
            "64",
            "--probes",
            value,
        ]);
        assert_one_line_error(&out, needle);
        assert!(!rad.exists(), "nothing is written");
    }
}

/// A point in a sealed room takes no light from the lit room beyond the wall. Two rooms share
/// one floor slab and one ceiling slab (`rooms_under_one_slab`); the gather's hits on the
/// sealed room's floor interpolated the patches around them, and the lit room's floor beyond
/// the 0.2 m wall lies in the same plane within the kernel: 0.1–0.6 W/m² at points where the
/// path tracer reads exactly 0, with the lit room's points at 12–45 W/m².
#[test]
fn points_in_a_sealed_room_take_no_light_through_its_wall() {
    let dir = tempfile::tempdir().unwrap();
    let obj = radiosity_tests::scenes::rooms_under_one_slab(dir.path());
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let rad = dir.path().join("rooms.rad");
    radiosity_ok(&["bake", &s(&obj), "-o", &s(&rad), "--voxel", "2"]);
    let lights = dir.path().join("lights.json");
    let sun_sky = json!({"lights": [
        {"type": "directional", "direction": [0.3, -0.6, 0.74], "irradiance": [1000, 1000, 1000]},
        {"type": "sky", "radiance": [30, 30, 30]}
    ]});
    std::fs::write(&lights, sun_sky.to_string()).unwrap();
    // The sealed room is x 6.4–9.7: its floor and ceiling near the wall and away from it,
    // and the wall's face; one point on the lit room's floor.
    let mut points = Vec::new();
    for x in [6.5, 6.8, 7.5] {
        for z in [1.0, 3.0, 5.0] {
            points.push(json!({"position": [x, 0.001, z], "normal": [0, 1, 0]}));
            points.push(json!({"position": [x, 2.599, z], "normal": [0, -1, 0]}));
        }
    }
    points.push(json!({"position": [6.4001, 1.3, 3.0], "normal": [1, 0, 0]}));
    points.push(json!({"position": [4.0, 0.001, 3.0], "normal": [0, 1, 0]}));
    let file = dir.path().join("points.json");
    std::fs::write(&file, json!({ "points": points }).to_string()).unwrap();
    let out = radiosity_ok(&[
        "solve",
        &s(&rad),
        "--lights",
        &s(&lights),
        "--points",
        &s(&file),
        "--json",
    ]);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let h: Vec<f64> = v["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["irradiance"][0].as_f64().unwrap())
        .collect();
    let (sealed, lit) = (&h[..h.len() - 1], h[h.len() - 1]);
    assert!(lit > 5.0, "the lit room's floor gets {lit} W/m²");
    // Exactly 0 in the path tracer; 0.05 W/m² is 0.1–0.4% of the lit room's points, under
    // what the kernel carried through the wall (0.1–0.6).
    let worst = sealed.iter().copied().fold(0.0, f64::max);
    assert!(
        worst < 0.05,
        "a point in the sealed room gets {worst} W/m²: {sealed:?}"
    );
}
