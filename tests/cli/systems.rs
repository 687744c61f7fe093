//! `solve` and `inspect` on a level file (systems): the steady state and its JSON.

use super::{assert_one_line_error, radiosity, radiosity_ok};
use radiosity_tests::fixtures::sample_level;

#[test]
fn solve_lights_a_level_file_and_reports_its_systems() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("level.rad");
    std::fs::write(&path, sample_level(&[9, 14, 5]).to_bytes().unwrap()).unwrap();
    let p = path.to_str().unwrap();
    let out = radiosity_ok(&["solve", p, "--json", "--backend", "cpu"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["patches"], 28);
    assert_eq!(v["systems"]["count"], 3);
    let frames = v["systems"]["frames"].as_u64().unwrap();
    assert!((1..=100).contains(&frames), "{frames}");
    let change = v["systems"]["change"].as_f64().unwrap();
    assert!(change <= 1e-4, "steady: {change}");
    // The emitter (patch 0, object 0) lights the others through the systems.
    let objects = v["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 2);
    for o in objects {
        let e = o["irradiance"].as_array().unwrap();
        assert!(e.iter().all(|c| c.as_f64().unwrap() > 0.0), "{o}");
    }
    // A one-matrix file has no systems field.
    let one = super::write_sample(dir.path());
    let out = radiosity_ok(&["solve", one.to_str().unwrap(), "--json", "--backend", "cpu"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.get("systems").is_none());
    // inspect shows the systems.
    let out = radiosity_ok(&["inspect", p, "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["systems"]["count"], 3);
    assert_eq!(v["systems"]["sizes"], serde_json::json!([9, 14, 5]));
    assert!(v["systems"]["coupling_entries"].as_u64().unwrap() > 0);
    let cpu = v_objects(&radiosity_ok(&["solve", p, "--json", "--backend", "cpu"]));
    // Each system on the reference backend, or on the GPU where an adapter is found (CI
    // installs a software one): the same light within the steady tolerance (1e-4 a frame's
    // change, each backend's own f32 summation order).
    let reference = radiosity_ok(&["solve", p, "--json", "--backend", "reference"]);
    let v: serde_json::Value = serde_json::from_slice(&reference.stdout).unwrap();
    assert_eq!(v["gather"], "reference-systems");
    close(&v_objects(&reference), &cpu);
    let gpu = radiosity(&["solve", p, "--json", "--backend", "gpu"]);
    if gpu.status.success() {
        let v: serde_json::Value = serde_json::from_slice(&gpu.stdout).unwrap();
        assert!(v["gather"].as_str().unwrap().starts_with("gpu"), "{v}");
        close(&v_objects(&gpu), &cpu);
    } else {
        assert_one_line_error(&gpu, "not available");
        assert_ne!(
            std::env::var("CI").as_deref(),
            Ok("true"),
            "CI has a software adapter"
        );
    }
    // A level without a one-matrix transfer has none to export.
    assert_one_line_error(
        &radiosity(&["inspect", p, "--export-dds", dir.path().to_str().unwrap()]),
        "level file",
    );
}

/// `render` lights a level through its steady state: the picture of a room baked into three
/// systems is the picture of the same room baked into one matrix, but for the cut's light
/// (within the steady tolerance) and BC1's per-system compression.
#[test]
fn render_draws_a_level_as_the_one_matrix_bake() {
    let dir = tempfile::tempdir().unwrap();
    let scene = super::small_scene(dir.path());
    let s = scene.to_str().unwrap();
    let mut means = Vec::new();
    for systems in ["off", "3"] {
        let rad = dir.path().join(format!("room-{systems}.rad"));
        let png = dir.path().join(format!("room-{systems}.png"));
        radiosity_ok(&[
            "bake",
            s,
            "-o",
            rad.to_str().unwrap(),
            "--patches",
            "150",
            "--systems",
            systems,
        ]);
        let out = radiosity_ok(&[
            "render",
            rad.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--exposure",
            "0.5",
            "--backend",
            "cpu",
        ]);
        let said = String::from_utf8_lossy(&out.stderr);
        assert_eq!(
            said.contains("systems of a level"),
            systems != "off",
            "{said}"
        );
        let img = image::open(&png).unwrap().to_rgb8();
        let sum: f64 = img
            .pixels()
            .map(|p| f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2]))
            .sum();
        means.push(sum / (3 * img.width() * img.height()) as f64);
    }
    // The same exposure: the mean pixel within 1% (two BC1 encodings of the same light, the
    // steady state within 1e-4, sRGB rounding).
    assert!(means[0] > 10.0, "a lit room: {means:?}");
    assert!((means[1] - means[0]).abs() < 0.01 * means[0], "{means:?}");
}

/// Each object's irradiance (three channels) from `solve --json`.
fn v_objects(out: &std::process::Output) -> Vec<f64> {
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["objects"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|o| o["irradiance"].as_array().unwrap().clone())
        .map(|c| c.as_f64().unwrap())
        .collect()
}

/// Within twice the steady tolerance (each run within 1e-4 of the fixed point).
fn close(a: &[f64], b: &[f64]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() <= 2e-4 * y.abs().max(1e-6), "{x} vs {y}");
    }
}
