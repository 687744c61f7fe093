//! What a new user meets: the help without arguments, the example lights and camera files,
//! a warning for a scene nothing lights, the camera fields a file leaves to their defaults,
//! output modes under the umask, and the lighting error said alike by `bake` and `inspect`.
//! (Refusals, one `error:` line each, are in `bad_input.rs`.)

use super::{radiosity, radiosity_ok};
use std::path::{Path, PathBuf};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// The Cornell box baked at about 200 patches into `dir` (the example files are for it).
fn cornell_rad(dir: &Path) -> PathBuf {
    let rad = dir.join("cb.rad");
    radiosity_ok(&[
        "bake",
        repo("scenes/cornell-box/CornellBox-Original.obj")
            .to_str()
            .unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "200",
    ]);
    rad
}

#[test]
fn no_arguments_print_the_help() {
    let out = radiosity(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(!stderr.starts_with("error"), "{stderr}");
    assert!(
        stderr.contains("Usage:") && stderr.contains("Commands:") && stderr.contains("bake"),
        "{stderr}"
    );
}

#[test]
fn the_example_lights_and_camera_files_work_and_the_lights_change_the_result() {
    let dir = tempfile::tempdir().unwrap();
    let rad = cornell_rad(dir.path());
    let r = rad.to_str().unwrap();
    let lights = repo("docs/examples/lights.json");
    let camera = repo("docs/examples/camera.json");
    let solve = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["solve", r, "--json"];
        args.extend_from_slice(extra);
        serde_json::from_slice(&radiosity_ok(&args).stdout).unwrap()
    };
    let own = solve(&[]);
    let lit = solve(&["--lights", lights.to_str().unwrap()]);
    assert_eq!(lit["lights"], 3, "a point, a spot and a directional light");
    // Every light adds light (none is shadowed everywhere): the floor gets more than the
    // ceiling lamp alone gives it, and so does the whole box.
    let total = |v: &serde_json::Value| -> f64 {
        v["objects"]
            .as_array()
            .unwrap()
            .iter()
            .map(|o| {
                o["area"].as_f64().unwrap()
                    * o["irradiance"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|c| c.as_f64().unwrap())
                        .sum::<f64>()
            })
            .sum()
    };
    assert!(
        total(&lit) > 1.01 * total(&own),
        "{} vs {}",
        total(&lit),
        total(&own)
    );
    for one in ["point", "spot", "directional"] {
        let text = std::fs::read_to_string(&lights).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let only: Vec<&serde_json::Value> = v["lights"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|l| l["type"] == one)
            .collect();
        let path = dir.path().join(format!("{one}.json"));
        std::fs::write(&path, serde_json::json!({ "lights": only }).to_string()).unwrap();
        let with = solve(&["--lights", path.to_str().unwrap()]);
        assert!(
            total(&with) > total(&own),
            "the example's {one} light reaches the box"
        );
    }

    // The camera file sets the image size (320×240), not --width and --height.
    let png = dir.path().join("cb.png");
    let out = radiosity_ok(&[
        "render",
        r,
        "--lights",
        lights.to_str().unwrap(),
        "--camera",
        camera.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--aa",
        "1",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("note: camera file"),
        "it gives every field: {stderr}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (320, 240));

    // A camera file that leaves fields out says which took their defaults.
    let short = dir.path().join("short.json");
    std::fs::write(
        &short,
        r#"{"position":[0,1,3.9],"look_at":[0,1,0],"width":40,"height":30}"#,
    )
    .unwrap();
    let out = radiosity_ok(&[
        "render",
        r,
        "--camera",
        short.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("note: camera file")
            && stderr.contains("no up, fov_deg given: up [0, 1, 0], fov_deg 40 used"),
        "{stderr}"
    );
}

#[test]
fn a_scene_nothing_lights_is_rendered_with_a_warning_saying_how_to_add_light() {
    use radiosity_tests::scenes::{Material, closed_box, write_scene};
    let dir = tempfile::tempdir().unwrap();
    let mats = [Material::new("wall", [0.6, 0.5, 0.4], [0.0; 3])];
    let scene = write_scene(
        dir.path(),
        "dark",
        &closed_box(1.0, 2, |_, _, _| "wall".into()),
        &mats,
    );
    let rad = dir.path().join("dark.rad");
    radiosity_ok(&[
        "bake",
        scene.to_str().unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "30",
    ]);
    let png = dir.path().join("dark.png");
    for args in [
        vec!["solve", rad.to_str().unwrap(), "--json"],
        vec![
            "render",
            rad.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "16",
        ],
    ] {
        let out = radiosity_ok(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("warning: nothing lights this scene") && stderr.contains("--lights"),
            "{}: {stderr}",
            args[0]
        );
    }
    // With lights, no warning.
    let lights = dir.path().join("l.json");
    std::fs::write(
        &lights,
        r#"{"lights":[{"type":"point","position":[0.5,0.5,0.5],"intensity":[1,1,1]}]}"#,
    )
    .unwrap();
    let out = radiosity_ok(&[
        "solve",
        rad.to_str().unwrap(),
        "--lights",
        lights.to_str().unwrap(),
        "--json",
    ]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning: nothing lights"));
}

#[test]
fn inspect_says_the_lighting_error_as_bake_does() {
    let dir = tempfile::tempdir().unwrap();
    let rad = dir.path().join("cb.rad");
    let out = radiosity_ok(&[
        "bake",
        repo("scenes/cornell-box/CornellBox-Original.obj")
            .to_str()
            .unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "100",
    ]);
    let percent = |text: &str, after: &str| -> String {
        let at = text
            .find(after)
            .unwrap_or_else(|| panic!("{after:?} in {text}"))
            + after.len();
        text[at..].split_whitespace().next().unwrap().to_owned()
    };
    let baked = String::from_utf8(out.stdout).unwrap();
    let b = percent(&baked, "lighting error from compression: ");
    let text = String::from_utf8(radiosity_ok(&["inspect", rad.to_str().unwrap()]).stdout).unwrap();
    let i = percent(&text, "relative L2 error ");
    assert!(b.ends_with('%'), "{b}");
    assert_eq!(b, i, "bake {baked}\ninspect {text}");
}

/// `bake` and `render` under `umask 027`: their files get 0640, what the umask gives any
/// new file (the demo's test checks 0644 under 022).
#[cfg(unix)]
#[test]
fn outputs_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let rad = dir.path().join("cb.rad");
    let png = dir.path().join("cb.png");
    let obj = repo("scenes/cornell-box/CornellBox-Original.obj");
    let sh = |args: &[&str]| {
        let out = std::process::Command::new("sh")
            .arg("-c")
            .arg(r#"umask 027 && exec "$0" "$@""#)
            .arg(env!("CARGO_BIN_EXE_radiosity"))
            .args(args)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    sh(&[
        "bake",
        obj.to_str().unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "60",
    ]);
    sh(&[
        "render",
        rad.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
    ]);
    for p in [&rad, &png] {
        let mode = std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640, "{}: {mode:o}", p.display());
    }
}
