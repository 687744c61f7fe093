//! Runtime lighting from the command line: `solve --lights` against closed-form irradiance,
//! shadows, `render` outputs (`demo` has its own file).

use super::{assert_one_line_error, radiosity, radiosity_ok};
use radiosity_tests::scenes::{Material, Quad, write_scene};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A 2×2 floor (y = 0, facing up, grey) and a black wall standing on its x = 1 edge: the wall
/// gives the floor something to see (a bake needs one) but reflects nothing back, so the
/// floor's irradiance is the lights' direct light alone. With `blocker`, a black plate at
/// y = 1 covers the floor's x < 0 half.
fn floor_scene(dir: &Path, blocker: bool) -> PathBuf {
    let mats = [
        Material::new("grey", [0.5; 3], [0.0; 3]),
        Material::new("black", [0.0; 3], [0.0; 3]),
    ];
    let mut quads = vec![
        Quad::facing(
            "floor",
            "grey",
            [[-1., 0., -1.], [1., 0., -1.], [1., 0., 1.], [-1., 0., 1.]],
            [0., 1., 0.],
        ),
        Quad::facing(
            "wall",
            "black",
            [[1., 0., -1.], [1., 2., -1.], [1., 2., 1.], [1., 0., 1.]],
            [0., 1., 0.],
        ),
    ];
    if blocker {
        quads.push(Quad::facing(
            "blocker",
            "black",
            [
                [-1.5, 1., -1.5],
                [0., 1., -1.5],
                [0., 1., 1.5],
                [-1.5, 1., 1.5],
            ],
            [0., 0., 0.],
        ));
    }
    write_scene(dir, if blocker { "shade" } else { "floor" }, &quads, &mats)
}

fn write_lights(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("lights.json");
    std::fs::write(&p, text).unwrap();
    p
}

fn floor_irradiance(json: &Value) -> f64 {
    let floor = json["objects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["name"] == "floor")
        .expect("a floor object");
    floor["irradiance"][0].as_f64().unwrap()
}

fn solve_json(args: &[&str]) -> Value {
    let out = radiosity(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn point_light_over_a_floor_matches_the_solid_angle() {
    let dir = tempfile::tempdir().unwrap();
    let scene = floor_scene(dir.path(), false);
    let lights = write_lights(
        dir.path(),
        r#"{"lights":[{"type":"point","position":[0,1,0],"intensity":[10,10,10]}]}"#,
    );
    let json = solve_json(&[
        "solve",
        scene.to_str().unwrap(),
        "--patches",
        "300",
        "--lights",
        lights.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(json["lights"], 1);
    // ∫ I cosθ / r² dA over the floor = I·Ω, Ω the solid angle of the 2×2 square seen from
    // height h = 1 above its centre: Ω = 4·asin(a·b / √((a²+h²)(b²+h²))) with a = b = 1.
    let omega = 4.0 * (1.0f64 / 2.0).asin();
    let expect = 10.0 * omega / 4.0;
    let got = floor_irradiance(&json);
    // The runtime samples direct light at piece centroids (a midpoint rule over ~150 floor
    // patches of side ~0.16): its error on this smooth integrand is well under 1%.
    assert!(
        (got - expect).abs() < 0.01 * expect,
        "floor irradiance {got} vs {expect}"
    );
}

#[test]
fn directional_light_is_cosine_weighted_and_a_blocker_casts_a_shadow() {
    let dir = tempfile::tempdir().unwrap();
    // Sun 60° from the vertical, travelling along +z (the wall at x = 1 is edge-on to it):
    // E = 3·cos 60° = 1.5 W/m² everywhere on the floor, exactly up to f32 rounding.
    let tilted = write_lights(
        dir.path(),
        r#"{"lights":[{"type":"directional","direction":[0,-0.5,0.8660254],"irradiance":[3,3,3]}]}"#,
    );
    let open = floor_scene(dir.path(), false);
    let json = solve_json(&[
        "solve",
        open.to_str().unwrap(),
        "--patches",
        "300",
        "--lights",
        tilted.to_str().unwrap(),
        "--json",
    ]);
    let got = floor_irradiance(&json);
    assert!((got - 1.5).abs() < 1e-4, "floor irradiance {got}");

    // Sun straight down over a plate covering x < 0: half the floor lit at 3 W/m², mean 1.5.
    // Direct light is sampled at 16 or more points a patch (`runtime_mesh::DIRECT_POINTS`), a
    // grid on each piece, so only the column of cells straddling the edge x = 0 can be
    // misassigned, by at most half a grid step: with 300 patches over 12.5 m² (floor, wall,
    // plate) cells are ~0.2 wide and the grid step ~0.05, so the mean may be off by
    // 0.025 m / 2 m · 3 W/m² ≈ 0.04 W/m² (2.5%). Without the shadow it would read 3; with one
    // point a piece (the centroid) it may be off by 0.15.
    let down = write_lights(
        dir.path(),
        r#"{"lights":[{"type":"directional","direction":[0,-1,0],"irradiance":[3,3,3]}]}"#,
    );
    let shaded = floor_scene(dir.path(), true);
    let json = solve_json(&[
        "solve",
        shaded.to_str().unwrap(),
        "--patches",
        "300",
        "--lights",
        down.to_str().unwrap(),
        "--json",
    ]);
    let got = floor_irradiance(&json);
    assert!((got - 1.5).abs() <= 0.04, "floor irradiance {got}");
}

#[test]
fn bad_lights_files_fail_before_baking() {
    let dir = tempfile::tempdir().unwrap();
    let scene = floor_scene(dir.path(), false);
    for (text, needle) in [
        (
            r#"{"lights":[{"type":"point","position":[0,1,0],"intensity":[-1,0,0]}]}"#,
            "negative",
        ),
        (r#"{"lights":[{"type":"laser"}]}"#, "unknown variant"),
        ("{", "EOF"),
    ] {
        let lights = write_lights(dir.path(), text);
        assert_one_line_error(
            &radiosity(&[
                "solve",
                scene.to_str().unwrap(),
                "--lights",
                lights.to_str().unwrap(),
            ]),
            needle,
        );
    }
    assert_one_line_error(
        &radiosity(&[
            "solve",
            scene.to_str().unwrap(),
            "--lights",
            "/nonexistent.json",
        ]),
        "cannot read lights file",
    );
}

#[test]
fn render_writes_a_png_of_the_camera_size() {
    let dir = tempfile::tempdir().unwrap();
    let scene = floor_scene(dir.path(), false);
    let rad = dir.path().join("floor.rad");
    radiosity_ok(&[
        "bake",
        scene.to_str().unwrap(),
        "-o",
        rad.to_str().unwrap(),
        "--patches",
        "200",
    ]);
    let lights = write_lights(
        dir.path(),
        r#"{"lights":[{"type":"point","position":[0,1,0],"intensity":[10,10,10]}]}"#,
    );
    let camera = dir.path().join("camera.json");
    std::fs::write(
        &camera,
        r#"{"position":[0,3,3],"look_at":[0,0,0],"fov_deg":50,"width":48,"height":32}"#,
    )
    .unwrap();
    let png = dir.path().join("out.png");
    radiosity_ok(&[
        "render",
        rad.to_str().unwrap(),
        "--lights",
        lights.to_str().unwrap(),
        "--camera",
        camera.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
    ]);
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (48, 32));
    // The lit floor fills the image centre; the sky above the wall is black.
    let centre = img.get_pixel(24, 20).0;
    assert!(centre.iter().all(|&c| c > 40), "centre {centre:?}");
    assert_eq!(img.get_pixel(24, 0).0, [0, 0, 0]);

    // A bad camera is a one-line error and writes nothing.
    std::fs::write(&camera, r#"{"position":[0,0,0],"look_at":[0,0,0]}"#).unwrap();
    let png2 = dir.path().join("never.png");
    assert_one_line_error(
        &radiosity(&[
            "render",
            rad.to_str().unwrap(),
            "--camera",
            camera.to_str().unwrap(),
            "-o",
            png2.to_str().unwrap(),
        ]),
        "equals its position",
    );
    assert!(!png2.exists());
}
