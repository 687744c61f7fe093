//! `radiosity pathtrace` end to end: JSON shape and values against a closed form, analytic
//! lights from a file, the image, seeds, and one-line errors.

use super::{assert_one_line_error, radiosity};
use radiosity_tests::scenes::{Material, Quad, write_scene};
use serde_json::Value;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

/// C-11 row 1 of viewfactors.csv: identical unit squares one apart, F = 0.199824895698. The
/// emitter (Ke = 1, 0.5, 0.25) faces the black receiver.
const F_UNIT_SQUARES: f64 = 0.199824895698;

fn plates(dir: &Path) -> PathBuf {
    let square = |z: f64| [[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]];
    write_scene(
        dir,
        "plates",
        &[
            Quad::facing("receiver", "black", square(0.0), [0.5, 0.5, 1.0]),
            Quad::facing("emitter", "emit", square(1.0), [0.5, 0.5, 0.0]),
        ],
        &[
            Material::new("black", [0.0; 3], [0.0; 3]),
            Material::new("emit", [0.0; 3], [1.0, 0.5, 0.25]),
        ],
    )
}

fn run_json(args: &[&str]) -> Value {
    let out = radiosity(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

fn object<'a>(v: &'a Value, name: &str) -> &'a Value {
    v["objects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["name"] == name)
        .unwrap_or_else(|| panic!("no object {name} in {v}"))
}

fn triple(v: &Value) -> [f64; 3] {
    let a = v.as_array().expect("an array");
    assert_eq!(a.len(), 3, "{v}");
    [0, 1, 2].map(|i| a[i].as_f64().unwrap())
}

#[test]
fn pathtrace_json_gives_irradiance_with_standard_errors() {
    let dir = tempfile::tempdir().unwrap();
    let scene = plates(dir.path());
    let scene = scene.to_str().unwrap();
    let v = run_json(&[
        "pathtrace",
        scene,
        "--samples",
        "20000",
        "--seed",
        "3",
        "--json",
    ]);
    assert_eq!(v["samples_per_object"], 20000);
    assert_eq!(v["seed"], 3);
    assert!(v["image"].is_null());
    let rec = object(&v, "receiver");
    assert!((rec["area"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    let (h, se) = (triple(&rec["irradiance"]), triple(&rec["stderr"]));
    // Black receiver: B = 0; its radiosity error is zero too.
    assert_eq!(triple(&rec["radiosity"]), [0.0; 3]);
    assert_eq!(triple(&rec["radiosity_stderr"]), [0.0; 3]);
    for (c, ke) in [1.0, 0.5, 0.25].into_iter().enumerate() {
        let want = PI * ke * F_UNIT_SQUARES;
        // 4 standard errors (see src/pathtrace/tests.rs), and σ below 1% so that it means something.
        assert!(se[c] > 0.0 && se[c] < 0.01 * want, "σ {se:?}");
        assert!(
            (h[c] - want).abs() < 4.0 * se[c],
            "H[{c}] {} vs {want} (σ {})",
            h[c],
            se[c]
        );
    }
    // The emitter's radiosity is its exitance E = π·Ke, exactly (nothing lights it).
    let b = triple(&object(&v, "emitter")["radiosity"]);
    for (c, ke) in [1.0, 0.5, 0.25].into_iter().enumerate() {
        assert!((b[c] - PI * ke).abs() < 1e-6 * PI, "{b:?}");
    }

    // The same seed repeats itself; another seed draws other samples.
    let again = run_json(&[
        "pathtrace",
        scene,
        "--samples",
        "20000",
        "--seed",
        "3",
        "--json",
    ]);
    assert_eq!(v["objects"], again["objects"]);
    let other = run_json(&[
        "pathtrace",
        scene,
        "--samples",
        "20000",
        "--seed",
        "4",
        "--json",
    ]);
    assert_ne!(v["objects"], other["objects"]);

    // Text output: a table with the error bars.
    let out = radiosity(&["pathtrace", scene, "--samples", "100"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("receiver") && text.contains("emitter") && text.contains('±'),
        "{text}"
    );
}

#[test]
fn pathtrace_lights_file_and_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "floor",
        &[Quad::facing(
            "floor",
            "white",
            [
                [-0.05, -0.05, 0.0],
                [0.05, -0.05, 0.0],
                [0.05, 0.05, 0.0],
                [-0.05, 0.05, 0.0],
            ],
            [0.0, 0.0, 1.0],
        )],
        &[Material::new("white", [0.5; 3], [0.0; 3])],
    );
    let lights = dir.path().join("lights.json");
    std::fs::write(
        &lights,
        r#"{"lights":[{"type":"point","position":[0,0,2],"intensity":[8,4,2]}]}"#,
    )
    .unwrap();
    let camera = dir.path().join("camera.json");
    std::fs::write(
        &camera,
        r#"{"position":[0,0,1],"look_at":[0,0,0],"width":24,"height":16}"#,
    )
    .unwrap();
    let png = dir.path().join("floor.png");
    let v = run_json(&[
        "pathtrace",
        scene.to_str().unwrap(),
        "--lights",
        lights.to_str().unwrap(),
        "--samples",
        "2000",
        "--camera",
        camera.to_str().unwrap(),
        "--spp",
        "2",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v["lights"], 1);
    // A 0.1 square 2 below an 8 W/sr light: H = I·Ω/A, Ω = 4·atan(a²/(h·√(2a²+h²))) with
    // a = 0.05, which is within 0.1% of I/h² = 2 W/m².
    let a: f64 = 0.05;
    let omega = 4.0 * (a * a / (2.0 * (2.0 * a * a + 4.0f64).sqrt())).atan();
    let want = 8.0 * omega / (4.0 * a * a);
    let h = triple(&object(&v, "floor")["irradiance"]);
    assert!((h[0] - want).abs() < 1e-3 * want, "{h:?} vs {want}");
    assert!((h[1] - want / 2.0).abs() < 1e-3 * want, "{h:?}");
    assert_eq!(v["image"]["width"], 24);
    assert_eq!(v["image"]["spp"], 2);
    let img = image::open(&png).expect("a PNG").to_rgb8();
    assert_eq!(img.dimensions(), (24, 16));
    // The floor fills the middle of the view and is lit; the corners see past it (black).
    let mid = img.get_pixel(12, 8).0;
    assert!(mid[0] > 50 && mid[0] > mid[2], "{mid:?}");
    assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
}

#[test]
fn pathtrace_bad_input_fails_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene = plates(dir.path());
    let scene = scene.to_str().unwrap();
    let missing = dir.path().join("nope.obj");
    assert_one_line_error(
        &radiosity(&["pathtrace", missing.to_str().unwrap()]),
        "cannot load the scene",
    );
    assert_one_line_error(
        &radiosity(&["pathtrace", scene, "--samples", "1"]),
        "--samples",
    );
    assert_one_line_error(
        &radiosity(&["pathtrace", scene, "--samples", "many"]),
        "--samples",
    );
    let png = dir.path().join("x.png");
    assert_one_line_error(
        &radiosity(&[
            "pathtrace",
            scene,
            "--spp",
            "0",
            "-o",
            png.to_str().unwrap(),
        ]),
        "--spp",
    );
    assert_one_line_error(&radiosity(&["pathtrace", scene, "--spp", "4"]), "-o");
    assert_one_line_error(
        &radiosity(&["pathtrace", scene, "--max-reflectance", "0"]),
        "--max-reflectance",
    );
    let lights = dir.path().join("lights.json");
    std::fs::write(
        &lights,
        r#"{"lights":[{"type":"point","position":[0,0,2],"intensity":[-1,0,0]}]}"#,
    )
    .unwrap();
    assert_one_line_error(
        &radiosity(&["pathtrace", scene, "--lights", lights.to_str().unwrap()]),
        "negative",
    );
    let camera = dir.path().join("camera.json");
    std::fs::write(&camera, r#"{"position":[0,0,1],"look_at":[0,0,1]}"#).unwrap();
    assert_one_line_error(
        &radiosity(&[
            "pathtrace",
            scene,
            "--camera",
            camera.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ]),
        "look_at equals its position",
    );
    assert!(!png.exists(), "no image after an error");
}

#[test]
fn solve_agrees_with_the_path_tracer_on_the_cornell_box() {
    // The target: per-object irradiance within 3% of a converged reference. The bake is
    // uncompressed (f32) with every bounce, so what is left is discretisation: measured 0.83%
    // worst at 1007 patches (against 1e6 paths per object), 0.75% at 3910. The path tracer's own
    // σ here is about 0.3% per object (2e5 samples), so 3% is a 2.2% margin for discretisation.
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box/CornellBox-Original.obj"
    );
    let solved = run_json(&[
        "solve",
        scene,
        "--patches",
        "1000",
        "--bounces",
        "inf",
        "--format",
        "f32",
        "--json",
    ]);
    let traced = run_json(&["pathtrace", scene, "--samples", "200000", "--json"]);
    let objects = solved["objects"].as_array().unwrap();
    assert_eq!(objects.len(), traced["objects"].as_array().unwrap().len());

    // Both report the floor's whole area (the OBJ's quad, 4.0600 m²) and, as its exposed
    // area, that less the blocks' footprints (0.3613 and 0.3630 m²), under which it receives
    // nothing; the means are over the whole floor. Whole areas are exact sums of triangles
    // (solve's may round up to its f32 patches: 1e-6). Exposed areas: solve's buried shares
    // come from 512 stratified points per partly buried patch (±0.003 of a patch each,
    // hard_cases.rs), the path tracer's from 2e5 uniform points (σ 0.2% of the floor's
    // exposed area); 1% holds either, and misses leaving a footprint out (10%).
    let floor = [[-1.01, 0.99], [1.00, 0.99], [1.00, -1.04], [-0.99, -1.04]];
    let short = [[0.53, 0.75], [0.70, 0.17], [0.13, 0.00], [-0.05, 0.57]];
    let tall = [[-0.53, 0.09], [0.04, -0.09], [-0.14, -0.67], [-0.71, -0.49]];
    let whole = polygon_area(&floor);
    let exposed = whole - polygon_area(&short) - polygon_area(&tall);
    for v in [object(&solved, "floor"), object(&traced, "floor")] {
        let area = v["area"].as_f64().unwrap();
        assert!(
            (area - whole).abs() < 1e-6 * whole,
            "floor area {area} vs {whole}"
        );
        let e = v["exposed_area"].as_f64().unwrap();
        assert!(
            (e - exposed).abs() < 0.01 * exposed,
            "floor exposed area {e} vs {exposed}"
        );
    }
    for o in objects {
        let name = o["name"].as_str().unwrap();
        let reference = object(&traced, name);
        let (a, want) = (
            o["area"].as_f64().unwrap(),
            reference["area"].as_f64().unwrap(),
        );
        assert!((a - want).abs() < 1e-6 * want, "{name}: area {a} vs {want}");
        let (h, want, se) = (
            triple(&o["irradiance"]),
            triple(&reference["irradiance"]),
            triple(&reference["stderr"]),
        );
        for c in 0..3 {
            assert!(se[c] < 0.006 * want[c], "{name}: σ {se:?} of {want:?}");
            let rel = (h[c] - want[c]) / want[c];
            assert!(
                rel.abs() < 0.03,
                "{name}[{c}]: solve {} vs path traced {} ± {}: {:+.2}%",
                h[c],
                want[c],
                se[c],
                100.0 * rel
            );
        }
    }
}

/// A scene of `Kd 1 1 1` walls (CornellBox-Empty-White) is traced with them lowered to 0.95,
/// or to `--max-reflectance`, with the one warning that says what was lowered.
#[test]
fn pathtrace_takes_a_reflectance_cap() {
    let white = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box/CornellBox-Empty-White.obj"
    );
    let out = radiosity(&["pathtrace", white, "--samples", "64", "--json"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("lowered to 0.95"), "{stderr}");
    let out = radiosity(&[
        "pathtrace",
        white,
        "--samples",
        "64",
        "--json",
        "--max-reflectance",
        "0.8",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("lowered to 0.8 on"), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(!v["objects"].as_array().unwrap().is_empty());
}

/// Area of the simple polygon `p` (shoelace formula).
fn polygon_area(p: &[[f64; 2]]) -> f64 {
    let mut twice = 0.0;
    for (i, a) in p.iter().enumerate() {
        let b = p[(i + 1) % p.len()];
        twice += a[0] * b[1] - b[0] * a[1];
    }
    0.5 * twice.abs()
}
