//! Memory: a bake of a finely modelled part (railings of round balusters beside two thick
//! pitched roofs, the kind of BIM part that grew to 23 GB) stays small under an address-space
//! cap.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

/// Two pitched roofs of 0.25 m slabs, a ground, and two railings of `balusters` round posts
/// (twelve facets each) 2 cm across: thousands of small pieces in a few coarse patches.
fn railings_and_roofs(dir: &Path, balusters: usize) -> std::path::PathBuf {
    let mut v: Vec<[f64; 3]> = Vec::new();
    let mut f: Vec<(&str, [usize; 3])> = Vec::new();
    let mut quad = |g: &'static str, q: [[f64; 3]; 4]| {
        let i = v.len() + 1;
        v.extend(q);
        f.push((g, [i, i + 1, i + 2]));
        f.push((g, [i, i + 2, i + 3]));
    };
    quad(
        "ground",
        [
            [-20.0, 0.0, 20.0],
            [20.0, 0.0, 20.0],
            [20.0, 0.0, -20.0],
            [-20.0, 0.0, -20.0],
        ],
    );
    let (c, s) = (35f64.to_radians().cos(), 35f64.to_radians().sin());
    for (roof, x0) in [("roofA", -7.0), ("roofB", 7.0)] {
        for side in [1.0, -1.0] {
            // A slope from the ridge (y = 6 + 6 sin 35°) down to the eave (y = 6), facing
            // up and out along n; its underside 0.25 m below, facing −n.
            let n = [0.0, c, side * s];
            let at = |x: f64, t: f64, lift: f64| {
                [
                    x + lift * n[0],
                    6.0 + 6.0 * s * (1.0 - t) + lift * n[1],
                    side * 6.0 * c * t + lift * n[2],
                ]
            };
            let (a, b) = (x0 - 6.0, x0 + 6.0);
            for (lift, facing) in [(0.0, 1.0), (-0.25, -1.0)] {
                let mut q = [
                    at(a, 0.0, lift),
                    at(b, 0.0, lift),
                    at(b, 1.0, lift),
                    at(a, 1.0, lift),
                ];
                if facing * winding_normal(&q, n) < 0.0 {
                    q.reverse();
                }
                quad(roof, q);
            }
        }
    }
    for (rail, z) in [("railA", 9.0), ("railB", -9.0)] {
        for i in 0..balusters {
            let x = -12.0 + 0.2 * i as f64;
            let at = |k: usize, y: f64| {
                let a = std::f64::consts::TAU * k as f64 / 12.0;
                [x + 0.02 * a.cos(), y, z + 0.02 * a.sin()]
            };
            for k in 0..12 {
                quad(
                    rail,
                    [at(k + 1, 0.0), at(k, 0.0), at(k, 1.0), at(k + 1, 1.0)],
                );
            }
        }
    }
    let mut obj = String::from("mtllib part.mtl\n");
    for p in &v {
        writeln!(obj, "v {} {} {}", p[0], p[1], p[2]).unwrap();
    }
    let mut group = "";
    for (g, t) in &f {
        if *g != group {
            writeln!(obj, "g {g}\nusemtl grey").unwrap();
            group = g;
        }
        writeln!(obj, "f {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    std::fs::write(dir.join("part.mtl"), "newmtl grey\nKd 0.5 0.5 0.5\n").unwrap();
    let path = dir.join("part.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

/// The sign of quad `q`'s counter-clockwise normal along `n`.
fn winding_normal(q: &[[f64; 3]; 4], n: [f64; 3]) -> f64 {
    let (u, w) = (
        [0, 1, 2].map(|k| q[1][k] - q[0][k]),
        [0, 1, 2].map(|k| q[2][k] - q[0][k]),
    );
    let x = [
        u[1] * w[2] - u[2] * w[1],
        u[2] * w[0] - u[0] * w[2],
        u[0] * w[1] - u[1] * w[0],
    ];
    x[0] * n[0] + x[1] * n[1] + x[2] * n[2]
}

/// At 64 patches each patch of a railing holds hundreds of facets, and an exact pair of two
/// such patches sampled as a whole kept one 88-byte entry per quadrature leaf and target
/// piece: 2.1 GB resident for 40 balusters a railing, 5.9 GB asked in one list for 120. The
/// list now stops at a million entries and the pair streams its contributions again (0.30 GB
/// resident for 40, 80 or 120). The cap is on address space (`ulimit -v`), which counts what
/// faer reserves for its products (0.5 GB) and the threads' stacks: 3 GB passes now, and the
/// 4 GB the old list wanted for 60 balusters a railing did not fit it.
#[test]
fn a_part_of_fine_railings_and_roofs_bakes_under_a_memory_cap() {
    let dir = tempfile::tempdir().unwrap();
    let scene = railings_and_roofs(dir.path(), 60);
    let out = dir.path().join("part.rad");
    let status = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 3000000 && exec \"$0\" bake \"$1\" -o \"$2\" --patches 64 --probes none")
        .arg(env!("CARGO_BIN_EXE_radiosity"))
        .arg(&scene)
        .arg(&out)
        .output()
        .expect("sh runs");
    assert!(
        status.status.success(),
        "the bake failed under a 3 GB cap: {}",
        String::from_utf8_lossy(&status.stderr)
    );
    assert!(out.exists());
}

/// `--memory-budget GB` bounds the bake's estimated peak in place of the machine's memory: a
/// target above it is refused at once in one line that names the budget and what fits, and
/// writes nothing; a budget that is not a positive number is refused the same way.
#[test]
fn a_memory_budget_refuses_a_target_above_it_before_loading() {
    let dir = tempfile::tempdir().unwrap();
    let scene = railings_and_roofs(dir.path(), 2);
    let out = dir.path().join("x.rad");
    let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
    // 8000 patches: 32 bytes a pair of up to 8800, 2.5 GB, over a budget of 1 GB.
    let run = super::radiosity(&[
        "bake",
        s,
        "-o",
        o,
        "--patches",
        "8000",
        "--memory-budget",
        "1",
    ]);
    super::assert_one_line_error(&run, "more than the --memory-budget of 1.0 GB");
    assert!(String::from_utf8_lossy(&run.stderr).contains("at most 5000 patches fit"));
    for bad in ["0", "-2", "nan"] {
        let run = super::radiosity(&["bake", s, "-o", o, "--memory-budget", bad]);
        super::assert_one_line_error(&run, "--memory-budget must be a positive number of GB");
    }
    assert!(!out.exists(), "a refused bake wrote its file");
}
