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
    // A backend that cannot run a level says so in one line.
    assert_one_line_error(
        &radiosity(&["solve", p, "--backend", "gpu"]),
        "cannot light a level",
    );
    assert_one_line_error(
        &radiosity(&[
            "render",
            p,
            "-o",
            dir.path().join("x.png").to_str().unwrap(),
        ]),
        "level file",
    );
}
