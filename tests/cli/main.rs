//! The command line end to end: exit status, one-line errors, JSON shapes.

mod bad_input;
mod bench;
mod demo;
mod engine;
mod gltf;
mod materials;
mod memory;
mod ux;

mod parts;
mod pathtrace;
mod planned;
mod points;
mod runtime;
mod solve_physics;
mod sunset;
mod systems;

use radiosity_core::Format;
use radiosity_tests::fixtures::sample_file;
use std::path::Path;
use std::process::{Command, Output};

fn radiosity(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_radiosity"))
        .args(args)
        .output()
        .expect("binary runs")
}

/// Runs the binary and asserts it succeeded (stderr in the message when not).
fn radiosity_ok(args: &[&str]) -> Output {
    let out = radiosity(args);
    assert!(
        out.status.success(),
        "radiosity {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Asserts the contract for bad input: non-zero exit (not a panic's 101), and stderr exactly
/// one line starting with `error: ` that mentions `needle`.
fn assert_one_line_error(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must fail: {stderr}");
    assert_ne!(out.status.code(), Some(101), "must not panic: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr:?}");
    assert!(
        stderr.starts_with("error: ") && stderr.contains(needle),
        "{stderr:?} should mention {needle:?}"
    );
}

fn write_sample(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("sample.rad");
    std::fs::write(
        &path,
        sample_file(37, 3, Format::Bc1, 16).to_bytes().unwrap(),
    )
    .unwrap();
    path
}

#[test]
fn inspect_prints_text_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_sample(dir.path());
    let out = radiosity_ok(&["inspect", path.to_str().unwrap()]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("patches      37") && text.contains("bc1"),
        "{text}"
    );

    let out = radiosity_ok(&["inspect", path.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["patches"], 37);
    assert_eq!(v["channels"], 3);
    assert_eq!(v["format"], "bc1");
    assert_eq!(v["order"], "spatial");
    assert_eq!(v["bounces"], 4);
    let total = std::fs::metadata(&path).unwrap().len();
    assert_eq!(v["bytes"]["total"], total);
    assert!(
        v["bytes"]["blocks"].as_u64().unwrap() > 0 && v["bytes"]["sparse"].as_u64().unwrap() > 0
    );
    // The sample records an error estimate for its own order.
    assert!((v["compression_rmse"]["spatial"].as_f64().unwrap() - 0.0125).abs() < 1e-6);
    assert_eq!(v["note"], "sample", "the bake's report is merged in");
}

#[test]
fn inspect_bad_files_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_sample(dir.path());
    let mut bytes = std::fs::read(&path).unwrap();

    let missing = dir.path().join("nope.rad");
    assert_one_line_error(
        &radiosity(&["inspect", missing.to_str().unwrap()]),
        "cannot read",
    );

    let truncated = dir.path().join("truncated.rad");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    assert_one_line_error(
        &radiosity(&["inspect", truncated.to_str().unwrap()]),
        "truncated",
    );

    let flipped = dir.path().join("flipped.rad");
    let mid = bytes.len() - 40;
    bytes[mid] ^= 0x10;
    std::fs::write(&flipped, &bytes).unwrap();
    assert_one_line_error(
        &radiosity(&["inspect", flipped.to_str().unwrap()]),
        "corrupt",
    );

    let text = dir.path().join("text.rad");
    std::fs::write(&text, "hello, I am not a transfer matrix\n").unwrap();
    assert_one_line_error(
        &radiosity(&["inspect", text.to_str().unwrap()]),
        "not a .rad file",
    );
}

fn small_scene(dir: &Path) -> std::path::PathBuf {
    use radiosity_tests::scenes::{Material, closed_box, write_scene};
    let mats = [
        Material::new("wall", [0.6, 0.5, 0.4], [0.0; 3]),
        Material::new("lamp", [0.5; 3], [4.0; 3]),
    ];
    let quads = closed_box(2.0, 2, |face, i, j| {
        if face == "ceiling" && i == 0 && j == 0 {
            "lamp".into()
        } else {
            "wall".into()
        }
    });
    write_scene(dir, "room", &quads, &mats)
}

#[test]
fn bake_solve_inspect_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let rad = dir.path().join("room.rad");
    let out = radiosity(&[
        "bake",
        scene.to_str().unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "80",
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "patches",
        "channels",
        "format",
        "order",
        "bounces",
        "bytes",
        "rays_cast",
        "compression_rmse",
        "lighting_error",
        "effects",
        "timings_ms",
    ] {
        assert!(
            report.get(key).is_some(),
            "bake --json lacks {key}: {report}"
        );
    }
    assert_eq!(report["format"], "bc1", "a coloured scene defaults to bc1");
    assert_eq!(report["rays_cast"], 0, "a box is convex");
    assert_eq!(
        report["bytes"]["total"],
        std::fs::metadata(&rad).unwrap().len()
    );
    for order in ["none", "random", "paper", "spatial"] {
        assert!(
            report["compression_rmse"][order].as_f64().is_some(),
            "error of order {order} reported"
        );
    }

    let out = radiosity_ok(&["solve", rad.to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["patches"], report["patches"]);
    let objects = v["objects"].as_array().unwrap();
    let names: Vec<&str> = objects
        .iter()
        .map(|o| o["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["floor", "ceiling", "left", "right", "back", "front"]
    );
    let floor = &objects[0];
    assert!(
        (floor["area"].as_f64().unwrap() - 4.0).abs() < 1e-4,
        "floor area {}",
        floor["area"]
    );
    assert!(
        floor["irradiance"][0].as_f64().unwrap() > 0.0,
        "the lamp lights the floor"
    );

    // Solving the OBJ directly bakes in memory first: same objects.
    radiosity_ok(&[
        "solve",
        scene.to_str().unwrap(),
        "--patches",
        "80",
        "--json",
    ]);

    let dds = dir.path().join("dds");
    radiosity_ok(&[
        "inspect",
        rad.to_str().unwrap(),
        "--export-dds",
        dds.to_str().unwrap(),
    ]);
    let tex = std::fs::read(dds.join("tile_000_000_rgb.dds")).unwrap();
    assert_eq!(&tex[..4], b"DDS ", "a standard DDS file");
    let index: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dds.join("tiles.json")).unwrap()).unwrap();
    assert_eq!(index["tiles"][0]["format"], "bc1");
}

#[test]
fn bake_bad_input_fails_cleanly_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let s = scene.to_str().unwrap();
    let rad = dir.path().join("out.rad");
    let r = rad.to_str().unwrap();
    for (options, named) in [
        (&["--patches", "0"][..], "--patches"),
        (&["--format", "png"], "--format"),
        (&["--order", "alphabetical"], "--order"),
        (&["--form-factors", "exact"], "--form-factors"),
        (&["--bounces", "0"], "--bounces"),
        (&["--voxel", "-1"], "--voxel"),
        (&["--tile", "6"], "--tile"),
        (&["--tile", "0"], "--tile"),
        (&["--max-reflectance", "1"], "--max-reflectance"),
        (&["--max-reflectance", "NaN"], "--max-reflectance"),
    ] {
        let mut args = vec!["bake", s, "-o", r];
        args.extend_from_slice(options);
        assert_one_line_error(&radiosity(&args), named);
    }
    assert_one_line_error(
        &radiosity(&["bake", s, "-o", "/nonexistent/dir/out.rad"]),
        "does not exist",
    );
    assert_one_line_error(&radiosity(&["bake", "missing.obj", "-o", r]), "missing.obj");
    assert_one_line_error(&radiosity(&["bake", s]), "--output");
    let empty = dir.path().join("empty.obj");
    std::fs::write(&empty, "# nothing here\n").unwrap();
    assert_one_line_error(
        &radiosity(&["bake", empty.to_str().unwrap(), "-o", r]),
        "no non-degenerate triangle",
    );
    assert!(!rad.exists(), "no output after a failed bake");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(
        leftovers
            .iter()
            .all(|f| !f.to_string_lossy().starts_with(".tmp")),
        "no temporary files left: {leftovers:?}"
    );
}

#[test]
fn closed_stdout_is_not_a_panic() {
    // `radiosity inspect x.rad | head -1`: the reader goes away before the output is written.
    let dir = tempfile::tempdir().unwrap();
    let path = write_sample(dir.path());
    let mut child = Command::new(env!("CARGO_BIN_EXE_radiosity"))
        .args(["inspect", path.to_str().unwrap()])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // close the read end at once
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
}

#[test]
fn solve_backends_agree_and_unavailable_ones_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_sample(dir.path());
    let p = path.to_str().unwrap();
    let run = |backend: &str| -> serde_json::Value {
        let out = radiosity(&["solve", p, "--backend", backend, "--json"]);
        assert!(
            out.status.success(),
            "{backend}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("backend: "),
            "the choice is printed"
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let (cpu, reference) = (run("cpu"), run("reference"));
    assert_eq!(
        (cpu["backend"].as_str(), reference["backend"].as_str()),
        (Some("cpu"), Some("reference"))
    );
    let agree = |a: &serde_json::Value, b: &serde_json::Value, rel: f64| {
        for (a, b) in a["objects"]
            .as_array()
            .unwrap()
            .iter()
            .zip(b["objects"].as_array().unwrap())
        {
            for k in 0..3 {
                let (x, y) = (
                    a["irradiance"][k].as_f64().unwrap(),
                    b["irradiance"][k].as_f64().unwrap(),
                );
                assert!((x - y).abs() <= rel * y.abs().max(1e-12), "{x} vs {y}");
            }
        }
    };
    // f32 accumulation in a different order over 37 patches: far below 1e-5 relative
    // (tests/tests/cpu_gather.rs bounds it per patch).
    agree(&cpu, &reference, 1e-5);
    // The GPU: with an adapter (CI has lavapipe) it agrees with the CPU; the adapter and the
    // decode path are printed. Decoding in the shader is the CPU's decode, so only summation
    // order differs (1e-5 as above); a GPU's texture unit may round each BC palette entry by up
    // to 2 codes, a factor e^(2s/255) ≤ 1.056 per entry at the largest log range (ln 1000), which
    // bounds the relative change of these sums of non-negative terms. Without an adapter it is a
    // one-line error saying why.
    let gpu = radiosity(&["solve", p, "--backend", "gpu", "--json"]);
    let stderr = String::from_utf8_lossy(&gpu.stderr).into_owned();
    if gpu.status.success() {
        assert!(
            stderr.contains("backend: gpu-") && stderr.contains("adapter "),
            "{stderr}"
        );
        let g: serde_json::Value = serde_json::from_slice(&gpu.stdout).unwrap();
        assert_eq!(g["backend"].as_str(), Some("gpu"));
        let rel = if stderr.contains("software decode") {
            1e-5
        } else {
            0.056
        };
        agree(&g, &cpu, rel);
    } else {
        assert_one_line_error(&gpu, "no GPU adapter");
    }
    assert_one_line_error(
        &radiosity(&["solve", p, "--backend", "quantum"]),
        "unknown backend",
    );
    let env = Command::new(env!("CARGO_BIN_EXE_radiosity"))
        .args(["solve", p])
        .env("RADIOSITY_BACKEND", "quantum")
        .output()
        .unwrap();
    assert_one_line_error(&env, "RADIOSITY_BACKEND");
}

/// Warnings of the simplification reach the terminal, not only `--json`: 64 glowing tiles under a
/// grey plate, each of its own emitting material, cannot come down to 10 patches, and the bake
/// says why.
#[test]
fn bake_prints_a_missed_patch_target() {
    let dir = tempfile::tempdir().unwrap();
    // 64 tiles, each of its own emitting material: a patch never spans two emitting materials
    // (a patch has one emission), so 10 patches cannot be met.
    let mut obj = String::from("mtllib tiles.mtl\n");
    let mut mtl = String::from("newmtl grey\nKd 0.5 0.5 0.5\n");
    let mut v = 1;
    for i in 0..8 {
        for j in 0..8 {
            let (x, y) = (f64::from(i) * 0.1, f64::from(j) * 0.1);
            mtl += &format!("newmtl e{i}{j}\nKd 0.5 0.5 0.5\nKe 1 1 1\n");
            obj += &format!(
                "o tile{i}{j}\nusemtl e{i}{j}\nv {x} {y} 0\nv {} {y} 0\nv {} {} 0\nv {x} {} 0\nf {v} {} {} {}\n",
                x + 0.08,
                x + 0.08,
                y + 0.08,
                y + 0.08,
                v + 1,
                v + 2,
                v + 3
            );
            v += 4;
        }
    }
    obj += &format!(
        "o lamp\nusemtl grey\nv 0 0 1\nv 0 0.8 1\nv 0.8 0.8 1\nv 0.8 0 1\nf {v} {} {} {}\n",
        v + 1,
        v + 2,
        v + 3
    );
    std::fs::write(dir.path().join("tiles.obj"), obj).unwrap();
    std::fs::write(dir.path().join("tiles.mtl"), mtl).unwrap();
    let scene = dir.path().join("tiles.obj");
    let rad = dir.path().join("tiles.rad");
    let out = radiosity_ok(&[
        "bake",
        scene.to_str().unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "10",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("warning: asked for 10 patches")
            && stderr.contains("64 emitting materials"),
        "{stderr}"
    );
}

#[test]
fn check_rows_prints_text_and_json() {
    // Sampled rows of the Cornell box's F against hemisphere rays (`radiosity check-rows`).
    // The JSON has one sample per row asked for, every share in [0, 1], and a summary whose
    // RMS is that of the listed differences; the text has the three summary lines.
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box/CornellBox-Original.obj"
    );
    let args = ["check-rows", scene, "--patches", "256", "--rows", "10"];
    let out = radiosity_ok(&args);
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        ["open (", "enclosed (", "all "]
            .iter()
            .all(|l| text.contains(l)),
        "{text}"
    );
    let mut json = args.to_vec();
    json.extend(["--json", "--rays", "500"]);
    let v: serde_json::Value = serde_json::from_slice(&radiosity_ok(&json).stdout).unwrap();
    let c = &v["check"];
    assert_eq!(c["rays"], 500);
    let samples = c["samples"].as_array().unwrap();
    assert_eq!(samples.len(), 10);
    let mut sq = 0.0;
    for s in samples {
        let (f, h) = (
            s["row_sum"].as_f64().unwrap(),
            s["hemisphere"].as_f64().unwrap(),
        );
        assert!((0.0..=1.0).contains(&h) && f.is_finite(), "{s}");
        sq += (f - h) * (f - h);
    }
    let rms = (sq / 10.0).sqrt();
    // The same sums in another order: f64 rounding only.
    assert!((c["all"]["rms"].as_f64().unwrap() - rms).abs() < 1e-12);
    assert!(v["patches"].as_u64().unwrap() > 200 && v["shadow_rays"].as_u64().unwrap() > 0);
    // Named rows instead of a sample (`--patch`, as `bake --json` names its largest row):
    // exactly those, once each.
    let named = [
        "check-rows",
        scene,
        "--patches",
        "256",
        "--patch",
        "7",
        "--patch",
        "3",
        "--patch",
        "7",
        "--rays",
        "200",
        "--json",
    ];
    let v: serde_json::Value = serde_json::from_slice(&radiosity_ok(&named).stdout).unwrap();
    let rows: Vec<u64> = v["check"]["samples"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["patch"].as_u64().unwrap())
        .collect();
    assert_eq!(rows, [3, 7]);
}

#[test]
fn check_rows_refuses_bad_counts() {
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box/CornellBox-Original.obj"
    );
    assert_one_line_error(&radiosity(&["check-rows", scene, "--rows", "0"]), "--rows");
    assert_one_line_error(&radiosity(&["check-rows", scene, "--rays", "0"]), "--rays");
    assert_one_line_error(
        &radiosity(&["check-rows", scene, "--form-factors", "best"]),
        "--form-factors",
    );
    assert_one_line_error(
        &radiosity(&["check-rows", scene, "--patches", "0"]),
        "--patches",
    );
    // A patch the scene does not have (Goral's box loads without warnings: one line).
    let goral = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-original/cornell_box_data.obj"
    );
    assert_one_line_error(
        &radiosity(&["check-rows", goral, "--patches", "64", "--patch", "100000"]),
        "--patch 100000",
    );
    assert_one_line_error(
        &radiosity(&["check-rows", "/nonexistent/scene.obj"]),
        "cannot load the scene",
    );
    // Malformed geometry is refused as `bake` refuses it. (Materials are not checked: like
    // `view-factors`, the check needs the geometry only, so a `Kd 1` scene is checked as is.)
    let bad = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/bad/obj/");
    for (file, needle) in [
        ("bad-index.obj", "bad vertex index"),
        ("nan-coordinate.obj", "is not finite"),
        ("empty.obj", "no non-degenerate triangle"),
    ] {
        let path = format!("{bad}{file}");
        assert_one_line_error(&radiosity(&["check-rows", &path, "--rows", "4"]), needle);
    }
}

#[test]
fn form_factor_quality_changes_the_rule_and_the_rays() {
    // `--form-factors draft|default|fine` picks `FormFactorParams::{fast, default,
    // high_quality}`; the report states the rule and rays asked for, and the work follows:
    // draft reads coarser leaves (fewer leaves, fewer rays), fine reads finer leaves next to
    // edges with four rays each. Measured on the Cornell box at about 300 patches: rays
    // 168 k / 302 k / 1.54 M. Asserted as strict orderings, which any of the three settings
    // collapsing onto another would break.
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box/CornellBox-Original.obj"
    );
    let rad = dir.path().join("cb.rad");
    let mut rays = Vec::new();
    for (quality, rule, per_leaf) in [
        ("draft", "centroid", 1),
        ("default", "degree 2", 1),
        ("fine", "degree 2", 4),
    ] {
        let out = radiosity_ok(&[
            "bake",
            scene,
            "-o",
            rad.to_str().unwrap(),
            "--patches",
            "300",
            "--format",
            "f32",
            "--form-factors",
            quality,
            "--json",
        ]);
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let ff = &report["form_factors"];
        assert_eq!(ff["rule"], rule, "{quality}: {ff}");
        assert_eq!(ff["rays_per_leaf"], per_leaf, "{quality}: {ff}");
        rays.push(report["rays_cast"].as_u64().unwrap());
    }
    println!("rays draft / default / fine: {rays:?}");
    assert!(rays[0] < rays[1] && rays[1] < rays[2], "rays {rays:?}");
}
