//! `examples/gather.c` compiled with the system C compiler (`cc`, or `$CC`) against the
//! header and linked against the crate's shared library, run on a small bake of the Cornell
//! box and on sample files with and without a mesh. Its printed power per object is compared
//! with the same sums computed here from the reference gather, which are what
//! `radiosity solve --json` reports as `radiosity × area` (checked too when the CLI binary has
//! been built next to this test).

use radiosity_bake::pipeline::{BakeParams, Hooks, bake};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::{DecodeMode, Format, Gather, RadFile, ReferenceGather, Rgb, first_exitance};
use radiosity_tests::fixtures::sample_file;
use std::path::{Path, PathBuf};
use std::process::Command;

/// `target/<profile>`: this test runs from `target/<profile>/deps`.
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    let deps = exe.parent().expect("deps directory");
    deps.parent().expect("profile directory").to_path_buf()
}

/// The directory holding the crate's shared library. `cargo test` builds the library with all
/// its crate types into `deps/` (the freshest copy: `cargo build` writes there too before
/// copying it up); failing that, `cargo build -p radiosity-capi` is run.
fn library_dir() -> PathBuf {
    let name = format!(
        "{}radiosity_capi{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let profile = profile_dir();
    let deps = profile.join("deps");
    if deps.join(&name).exists() {
        return deps;
    }
    if !profile.join(&name).exists() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut build = Command::new(cargo);
        build.args(["build", "-p", "radiosity-capi"]);
        if profile.file_name().is_some_and(|p| p == "release") {
            build.arg("--release");
        }
        let status = build.status().expect("cargo runs");
        assert!(status.success(), "cargo build -p radiosity-capi failed");
    }
    assert!(
        profile.join(&name).exists(),
        "{name} not found in {}",
        profile.display()
    );
    profile
}

/// Compiles the example `examples/NAME.c` into `out`, returning the executable.
fn compile_example(out: &Path, name: &str) -> PathBuf {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = library_dir();
    let exe = out.join(name);
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let output = Command::new(&cc)
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-O1",
        ])
        .arg("-I")
        .arg(crate_dir.join("include"))
        .arg(crate_dir.join(format!("examples/{name}.c")))
        .arg("-L")
        .arg(&dir)
        .arg("-lradiosity_capi")
        .arg(format!("-Wl,-rpath,{}", dir.display()))
        .arg("-lm")
        .arg("-o")
        .arg(&exe)
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run the C compiler {cc:?} ({e}): scripts/test.sh installs gcc")
        });
    assert!(
        output.status.success(),
        "{cc} failed:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    exe
}

/// The reference gather's `y = M·x` for the file's own emitters (`x = E`), as the example
/// computes it.
fn reference_y(file: &RadFile<'_>) -> Vec<Rgb> {
    let n = file.n();
    let mut x = vec![Rgb::ZERO; n];
    first_exitance(&file.patches, &vec![Rgb::ZERO; n], &mut x);
    let mut y = vec![Rgb::ZERO; n];
    ReferenceGather::new(file.matrix.clone(), DecodeMode::D3d10)
        .gather(&x, &mut y)
        .unwrap();
    y
}

/// Power per object (W) lit by the file's own emitters, as `solve` computes it: radiosity
/// `B = E + ρ·y` with `y` from the reference gather, `Σ area·B` over the object's patches.
fn power_per_object(file: &RadFile<'_>) -> Vec<[f64; 3]> {
    let y = reference_y(file);
    let mut power = vec![[0f64; 3]; file.objects.len()];
    for (p, y) in file.patches.iter().zip(&y) {
        let b = p.emission + p.reflectance * *y;
        for k in 0..3 {
            power[p.object as usize][k] += f64::from(p.area) * f64::from(b.channel(k));
        }
    }
    power
}

/// The example's `power` lines: index → (name, [r, g, b]).
fn printed_power(stdout: &str) -> Vec<(String, [f64; 3])> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix("power\t"))
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(f.len(), 6, "power line {l:?}");
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (f[1].to_owned(), [v(3), v(4), v(5)])
        })
        .collect()
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-5 * scale.max(1e-12)
}

/// Runs the example on `file` written to `dir/name`, checks it passed and its power, and
/// returns its output.
fn run_example(exe: &Path, dir: &Path, name: &str, file: &RadFile<'_>) -> String {
    let path = dir.join(name);
    std::fs::write(&path, file.to_bytes().unwrap()).unwrap();
    let output = Command::new(exe)
        .arg(&path)
        .arg(dir.join(format!("{name}.garbage")))
        // A headless host that set nothing: the library keeps Mesa's device-select layer quiet.
        .env_remove("NODEVICE_SELECT")
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .expect("the example runs");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "gather {name} failed ({}):\n{stdout}\n{stderr}",
        output.status
    );
    assert_eq!(stdout.lines().last(), Some("ok"), "{stdout}");
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
    let want = power_per_object(file);
    let got = printed_power(&stdout);
    assert_eq!(got.len(), file.objects.len(), "{stdout}");
    let scale = want.iter().flatten().fold(0f64, |m, v| m.max(v.abs()));
    for (o, ((name, g), w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(name, file.objects[o].as_ref());
        for k in 0..3 {
            assert!(
                close(g[k], w[k], scale),
                "object {o} ({name}) channel {k}: example {} here {}",
                g[k],
                w[k]
            );
        }
    }
    // Every bad input was refused with a message (the example exits 1 otherwise).
    let refused = stdout
        .lines()
        .filter(|l| l.starts_with("refused\t"))
        .count();
    assert!(refused >= 30, "only {refused} refusals:\n{stdout}");
    stdout
}

/// When the CLI binary sits next to this test, `solve --json --backend reference` must report
/// the same power: its per-object mean radiosity times its area.
fn compare_with_solve(path: &Path, power: &[(String, [f64; 3])]) {
    let cli = profile_dir().join(format!("radiosity{}", std::env::consts::EXE_SUFFIX));
    if !cli.exists() {
        eprintln!(
            "note: {} not built; solve --json comparison skipped",
            cli.display()
        );
        return;
    }
    let json = solve_json(
        &cli,
        &["--backend".as_ref(), "reference".as_ref(), path.as_os_str()],
    );
    let objects = json["objects"].as_array().expect("objects");
    assert_eq!(objects.len(), power.len());
    let scale = power
        .iter()
        .flat_map(|p| p.1)
        .fold(0f64, |m, v| m.max(v.abs()));
    for (o, (name, p)) in objects.iter().zip(power) {
        assert_eq!(o["name"].as_str(), Some(name.as_str()));
        let area = o["area"].as_f64().unwrap();
        for k in 0..3 {
            let b = o["radiosity"][k].as_f64().unwrap();
            assert!(
                close(b * area, p[k], scale),
                "{name} channel {k}: solve {} example {}",
                b * area,
                p[k]
            );
        }
    }
}

/// `radiosity solve --json ARGS` with the CLI at `cli`, its JSON output (the run must succeed).
fn solve_json(cli: &Path, args: &[&std::ffi::OsStr]) -> serde_json::Value {
    let output = Command::new(cli)
        .args(["solve", "--json"])
        .args(args)
        .output()
        .expect("radiosity runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

/// The example's `probes` line against the core: the reflected irradiance facing +z at the
/// first probe, from `P·(ρ∘y)` with `y` the reference gather of the file's own emitters.
fn check_probes(stdout: &str, file: &RadFile<'_>) {
    let line = stdout
        .lines()
        .find_map(|l| l.strip_prefix("probes\t"))
        .unwrap_or_else(|| panic!("no probes line:\n{stdout}"));
    let f: Vec<f64> = line.split('\t').map(|v| v.parse().unwrap()).collect();
    let Some(probes) = file.probes.as_ref().filter(|p| !p.is_empty()) else {
        assert_eq!(f, [0.0], "{stdout}");
        return;
    };
    assert_eq!(f[0] as usize, probes.len());
    let y = reference_y(file);
    let reflected: Vec<Rgb> = file
        .patches
        .iter()
        .zip(&y)
        .map(|(p, y)| p.reflectance * *y)
        .collect();
    let up = [0.0, 0.0, 1.0];
    let mut weights = Vec::new();
    assert!(probes.interpolation_weights(probes.positions[0], Some(up), |_| true, &mut weights));
    let decoded = radiosity_core::DecodedProbes::new(probes);
    let e = weights.iter().fold(Rgb::ZERO, |e, &(i, w)| {
        e + radiosity_core::sh_irradiance(&decoded.gather_probe(i, &reflected), up) * w
    });
    assert!(
        e.channel(0) != 0.0,
        "a probe that sees nothing tests nothing"
    );
    for k in 0..3 {
        // %.9g prints f32 exactly enough; the sums are the same code in the same order.
        let want = f64::from(e.channel(k));
        assert!(
            close(f[1 + k], want, want.abs()),
            "probe channel {k}: example {} here {want}",
            f[1 + k]
        );
    }
}

#[test]
fn c_example_on_a_baked_cornell_box() {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile_example(dir.path(), "gather");
    let obj =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/CornellBox-Original.obj");
    let scene = Scene::load_obj(&obj).expect("Cornell box loads");
    let params = BakeParams {
        voxel: VoxelParams::with_patches(150),
        ..BakeParams::fast()
    };
    let out = bake(&scene, &params, Hooks::default()).expect("bakes");
    assert!(out.file.mesh.is_some(), "the bake stores the mesh");
    let stdout = run_example(&exe, dir.path(), "cornell.rad", &out.file);
    assert!(stdout.contains("backend\tcpu\tcpu\tcpu-"), "{stdout}");
    assert!(
        stdout.lines().any(|l| l.starts_with("corners\t")),
        "{stdout}"
    );
    check_probes(&stdout, &out.file);
    compare_with_solve(&dir.path().join("cornell.rad"), &printed_power(&stdout));
}

#[test]
fn c_example_on_sample_files_with_and_without_a_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile_example(dir.path(), "gather");
    let with_mesh = sample_file(70, 3, Format::Bc1, 32);
    let stdout = run_example(&exe, dir.path(), "sample.rad", &with_mesh);
    assert!(stdout.contains("scene\t70\t2\t2\n"), "{stdout}");
    check_probes(&stdout, &with_mesh);
    let mut grey = sample_file(40, 1, Format::Bc4, 16);
    grey.mesh = None;
    // Part and first-bounce rows name the mesh's samples, coverage its triangles: a file
    // without a mesh has none of them.
    grey.parts = None;
    grey.bounce = None;
    grey.coverage = None;
    let stdout = run_example(&exe, dir.path(), "grey.rad", &grey);
    assert!(stdout.contains("scene\t40\t2\t0\n"), "{stdout}");
    assert!(!stdout.contains("corners\t"), "{stdout}");
}

/// The tab-separated fields after `tag` of each line of `stdout` that starts with it.
fn lines_of<'a>(stdout: &'a str, tag: &str) -> Vec<Vec<&'a str>> {
    stdout
        .lines()
        .filter_map(|l| l.strip_prefix(tag)?.strip_prefix('\t'))
        .map(|l| l.split('\t').collect())
        .collect()
}

/// `examples/engine.c`, an engine's whole loop: a bake with progress (monotone, reaching 1) and
/// one cancelled (no file), direct light with shadows through `rad_scene_direct`, a gather and
/// two points, and bad input. Its direct light equals the runtime's; its points equal `radiosity
/// solve --points` on the same file and lights (the same code and seeds: to 1e-4 relative).
#[test]
fn c_engine_loop_bakes_lights_and_answers_points_as_the_library() {
    let dir = tempfile::tempdir().unwrap();
    let exe = compile_example(dir.path(), "engine");
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/CornellBox-Original.obj");
    let rad = dir.path().join("box.rad");
    let output = Command::new(&exe)
        .arg(&scene)
        .arg(&rad)
        .env("NODEVICE_SELECT", "1")
        .output()
        .expect("the example runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success() && stdout.ends_with("ok\n"),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(!dir.path().join("box.rad.cancelled").exists());
    // 17 refusals (the cancelled bake and 16 bad inputs), each with its code and message.
    assert_eq!(lines_of(&stdout, "refused").len(), 17, "{stdout}");

    let bytes = std::fs::read(&rad).unwrap();
    let file = RadFile::parse(&bytes).unwrap().into_owned();
    let n = file.n();
    let light = radiosity_core::Light::Point {
        position: glam_vec(0.0, 1.0, 0.0),
        intensity: Rgb::splat(2.0),
    };
    let rt = radiosity_runtime::BakedScene::new(file);
    // The C frame's direct light is the light alone, without the first bounce's correction
    // (`rad_scene_direct`, docs/contract.md).
    let want = rt
        .direct_with_samples(std::slice::from_ref(&light))
        .unwrap()
        .0;
    let got = lines_of(&stdout, "direct");
    assert_eq!(got.len(), n);
    let parse = |f: &[&str]| [f[1], f[2], f[3]].map(|v| v.parse::<f64>().unwrap());
    // Printed with 9 significant digits: the same f32 values.
    for (g, w) in got.iter().zip(&want) {
        let g = parse(g);
        for k in 0..3 {
            let w = f64::from(w.channel(k));
            assert!((g[k] - w).abs() <= 1e-7 * w.abs().max(1e-30), "{g:?} {w}");
        }
    }
    assert!(
        want.iter().any(|d| d.max_channel() > 0.0),
        "the light reaches the room"
    );
    assert!(
        want.iter().any(|d| d.max_channel() == 0.0),
        "and its shadows do not"
    );

    // The points against the library's answer to the same frame as the C loop lights it: the
    // direct light alone sent on and added (`radiosity solve` adds the first bounce's
    // correction, which the C frame does not carry).
    let mut x = vec![Rgb::ZERO; n];
    first_exitance(&rt.file.patches, &want, &mut x);
    let mut y = vec![Rgb::ZERO; n];
    ReferenceGather::new(rt.file.matrix.clone(), DecodeMode::D3d10)
        .gather(&x, &mut y)
        .unwrap();
    let h: Vec<Rgb> = want.iter().zip(&y).map(|(d, y)| *d + *y).collect();
    let query = |p: [f64; 3]| radiosity_runtime::points::Point {
        position: glam::DVec3::from(p),
        normal: glam::DVec3::Y,
        given_normal: glam::DVec3::Y,
    };
    let answers = radiosity_runtime::points::answer(
        &rt,
        &y,
        &h,
        &[light],
        &[query([0.0, 0.5, 0.0]), query([100.0, 100.0, 100.0])],
    )
    .unwrap();
    let got = lines_of(&stdout, "point");
    assert_eq!(got[0][1], "0");
    let radiosity_runtime::points::Answer::Irradiance { total, .. } = answers[0] else {
        panic!("point 0: {:?}", answers[0]);
    };
    let g = [got[0][2], got[0][3], got[0][4]].map(|v| v.parse::<f64>().unwrap());
    for k in 0..3 {
        // The C loop gathers on the CPU backend, the library here on the reference gather:
        // the same sums in another order, well inside 1e-4.
        let w = f64::from(total.channel(k));
        assert!(
            (g[k] - w).abs() <= 1e-4 * w.abs(),
            "point 0 channel {k}: C {} library {w}",
            g[k]
        );
    }
    assert_eq!(got[1][1], "2");
    assert_eq!(answers[1], radiosity_runtime::points::Answer::Outside);
}

fn glam_vec(x: f32, y: f32, z: f32) -> glam::Vec3 {
    glam::Vec3::new(x, y, z)
}
