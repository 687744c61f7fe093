//! The distributed bake's steps on the command line: `bake-plan`, `bake-shard`,
//! `bake-assemble`, `compare`, and `bake --plan [--reuse]` (docs/distributed.md).

use super::{assert_one_line_error, radiosity, radiosity_ok};
use std::fmt::Write;
use std::path::Path;

/// A block of a town: four ground tiles and six boxes of different heights, each its own
/// object, `moved` shifting box 4 by (2.5, 0, -1.5): shade beside open ground, walls that
/// face each other across streets.
fn town(dir: &Path, moved: bool) -> std::path::PathBuf {
    let mut obj = String::new();
    let mut v = 0;
    let mut quad = |obj: &mut String, p: [[f64; 3]; 4]| {
        for c in p {
            writeln!(obj, "v {} {} {}", c[0], c[1], c[2]).unwrap();
        }
        writeln!(obj, "f {} {} {} {}", v + 1, v + 2, v + 3, v + 4).unwrap();
        v += 4;
    };
    for (k, (x, z)) in [(0.0, 0.0), (30.0, 0.0), (0.0, 30.0), (30.0, 30.0)]
        .into_iter()
        .enumerate()
    {
        writeln!(obj, "o tile{k}").unwrap();
        quad(
            &mut obj,
            [
                [x, 0.0, z],
                [x, 0.0, z + 30.0],
                [x + 30.0, 0.0, z + 30.0],
                [x + 30.0, 0.0, z],
            ],
        );
    }
    let boxes = [
        (5.0, 5.0, 8.0, 12.0),
        (20.0, 6.0, 6.0, 6.0),
        (40.0, 8.0, 9.0, 18.0),
        (8.0, 38.0, 7.0, 9.0),
        (27.0, 30.0, 8.0, 22.0),
        (45.0, 42.0, 6.0, 5.0),
    ];
    for (k, &(x0, z0, w, h)) in boxes.iter().enumerate() {
        let (x0, z0) = if moved && k == 4 {
            (x0 + 2.5, z0 - 1.5)
        } else {
            (x0, z0)
        };
        let (x1, z1) = (x0 + w, z0 + w);
        writeln!(obj, "o box{k}").unwrap();
        // Four walls facing out and a roof (counter-clockwise seen from outside).
        for face in [
            [[x0, 0.0, z0], [x1, 0.0, z0], [x1, h, z0], [x0, h, z0]],
            [[x1, 0.0, z0], [x1, 0.0, z1], [x1, h, z1], [x1, h, z0]],
            [[x1, 0.0, z1], [x0, 0.0, z1], [x0, h, z1], [x1, h, z1]],
            [[x0, 0.0, z1], [x0, 0.0, z0], [x0, h, z0], [x0, h, z1]],
            [[x0, h, z0], [x1, h, z0], [x1, h, z1], [x0, h, z1]],
        ] {
            quad(&mut obj, face);
        }
    }
    let path = dir.join(if moved { "moved.obj" } else { "town.obj" });
    std::fs::write(&path, obj).unwrap();
    path
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn json(out: &std::process::Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap()
}

fn same(a: &Path, b: &Path) {
    let out = radiosity_ok(&["compare", s(a), s(b)]);
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "same");
}

#[test]
fn shards_assemble_into_the_one_process_bake_and_a_rebake_into_the_full_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = town(d, false);
    let plan = d.join("plan.json");
    // Draft form factors (1024 rays a patch) keep the test to seconds; the plan's steps are
    // the same at any ray count.
    let out = radiosity_ok(&[
        "bake-plan",
        s(&scene),
        "-o",
        s(&plan),
        "--patches",
        "900",
        "--systems",
        "3",
        "--form-factors",
        "draft",
        "--json",
    ]);
    let summary = json(&out);
    assert_eq!(summary["systems"], 3, "{summary}");
    assert_eq!(summary["shards"], 3);

    let one = d.join("one.rad");
    radiosity_ok(&["bake", s(&scene), "-o", s(&one), "--plan", s(&plan)]);
    assert!(
        d.join("one.rad.rows").exists(),
        "the cache beside the level"
    );

    // The shards in any order, one of them twice (a retried shard writes the same file).
    let rows = d.join("rows");
    for k in ["2", "0", "1", "1"] {
        let out = radiosity_ok(&[
            "bake-shard",
            s(&scene),
            "--plan",
            s(&plan),
            "--shard",
            k,
            "--out-dir",
            s(&rows),
        ]);
        let path = String::from_utf8_lossy(&out.stdout).trim().to_owned();
        assert!(path.contains(&format!("rows-{k}-")), "{path}");
    }
    let sharded = d.join("sharded.rad");
    radiosity_ok(&[
        "bake-assemble",
        s(&scene),
        "--plan",
        s(&plan),
        "--rows",
        s(&rows),
        "-o",
        s(&sharded),
    ]);
    same(&one, &sharded);
    // A different file is told apart (the guard on `compare` itself).
    let draft = d.join("other.rad");
    radiosity_ok(&[
        "bake",
        s(&scene),
        "-o",
        s(&draft),
        "--patches",
        "200",
        "--probes",
        "none",
    ]);
    let out = radiosity(&["compare", s(&one), s(&draft)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("differ"));

    // A rebake after one box moved: the same file as the full bake of the moved town, with
    // the systems away from the box taken over and most rows carried.
    let moved = town(d, true);
    let full = d.join("full.rad");
    radiosity_ok(&["bake", s(&moved), "-o", s(&full), "--plan", s(&plan)]);
    let again = d.join("again.rad");
    let out = radiosity_ok(&[
        "bake",
        s(&moved),
        "-o",
        s(&again),
        "--plan",
        s(&plan),
        "--reuse",
        s(&one),
        "--json",
    ]);
    same(&full, &again);
    let reuse = &json(&out)["reuse"];
    let (systems, reused) = (
        reuse["systems"].as_u64().unwrap(),
        reuse["reused"].as_u64().unwrap(),
    );
    assert!(reused >= 1 && reused < systems, "{reuse}");
    let rebaked = reuse["rebaked"].as_array().unwrap();
    assert_eq!(rebaked.len() as u64, systems - reused);
    // The system the box moved in says its patches changed.
    assert!(
        rebaked
            .iter()
            .any(|r| r["why"].as_str().unwrap().contains("its patches")),
        "{reuse}"
    );
    let carried = reuse["rows"]["carried"].as_u64().unwrap();
    assert!(
        carried * 2 > reuse["rows"]["rows"].as_u64().unwrap(),
        "{reuse}"
    );
    // Through the shards too: each shard carries its rows over, the assembly its systems.
    let rows2 = d.join("rows2");
    for k in ["0", "1", "2"] {
        radiosity_ok(&[
            "bake-shard",
            s(&moved),
            "--plan",
            s(&plan),
            "--shard",
            k,
            "--out-dir",
            s(&rows2),
            "--reuse",
            s(&one),
        ]);
    }
    let sharded2 = d.join("sharded2.rad");
    radiosity_ok(&[
        "bake-assemble",
        s(&moved),
        "--plan",
        s(&plan),
        "--rows",
        s(&rows2),
        "-o",
        s(&sharded2),
        "--reuse",
        s(&one),
    ]);
    same(&full, &sharded2);

    // Refusals, each one `error:` line naming what is wrong.
    let assemble = |dir: &Path| {
        radiosity(&[
            "bake-assemble",
            s(&scene),
            "--plan",
            s(&plan),
            "--rows",
            s(dir),
            "-o",
            s(&d.join("x.rad")),
        ])
    };
    // Shards of the moved town beside the plan of the first: stale.
    assert_one_line_error(&assemble(&rows2), "shard 0 is stale");
    let names: Vec<_> = std::fs::read_dir(&rows)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    let of = |k: &str| {
        names
            .iter()
            .find(|p| s(p).contains(&format!("rows-{k}-")))
            .unwrap()
    };
    let bytes = std::fs::read(of("0")).unwrap();
    let mut bad = bytes.clone();
    bad[100] ^= 0x40;
    std::fs::write(of("0"), &bad).unwrap();
    assert_one_line_error(&assemble(&rows), "shard 0");
    assert_one_line_error(&assemble(&rows), "corrupt");
    std::fs::write(of("0"), &bytes).unwrap();
    std::fs::remove_file(of("2")).unwrap();
    assert_one_line_error(&assemble(&rows), "shard 2 is missing");
    assert!(!d.join("x.rad").exists(), "nothing written on a refusal");
    // Flags that contradict the plan; a plan edited by hand.
    let out = radiosity(&[
        "bake",
        s(&scene),
        "-o",
        s(&d.join("y.rad")),
        "--plan",
        s(&plan),
        "--patches",
        "500",
    ]);
    assert_one_line_error(&out, "--patches contradicts the plan");
    let text =
        std::fs::read_to_string(&plan)
            .unwrap()
            .replacen("\"cell_size\": ", "\"cell_size\": 1", 1);
    std::fs::write(d.join("edited.json"), text).unwrap();
    let out = radiosity(&[
        "bake",
        s(&scene),
        "-o",
        s(&d.join("y.rad")),
        "--plan",
        s(&d.join("edited.json")),
    ]);
    assert_one_line_error(&out, "plan_hash does not match");
    let out = radiosity(&[
        "bake-shard",
        s(&scene),
        "--plan",
        s(&plan),
        "--shard",
        "7",
        "--out-dir",
        s(&rows),
    ]);
    assert_one_line_error(&out, "shard 7 does not exist");
    // --reuse of a file without its cache.
    std::fs::remove_file(d.join("one.rad.rows")).unwrap();
    let out = radiosity(&[
        "bake",
        s(&moved),
        "-o",
        s(&d.join("y.rad")),
        "--plan",
        s(&plan),
        "--reuse",
        s(&one),
    ]);
    assert_one_line_error(&out, "one.rad.rows");
}

/// `bake-plan` takes every flag `bake` takes, the probes' among them; a planned bake (a level)
/// has the probes its plan says, lit at `solve --points` like its patches; `bake --plan` with
/// probes the plan does not say is refused.
#[test]
fn a_plan_carries_the_probes_and_its_level_has_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = town(d, false);
    let plan = d.join("plan.json");
    radiosity_ok(&[
        "bake-plan",
        s(&scene),
        "-o",
        s(&plan),
        "--patches",
        "600",
        "--systems",
        "2",
        "--form-factors",
        "draft",
        "--probes",
        "8",
        "--probe-rank",
        "full",
    ]);
    let level = d.join("level.rad");
    let report = json(&radiosity_ok(&[
        "bake",
        s(&scene),
        "-o",
        s(&level),
        "--plan",
        s(&plan),
        "--json",
    ]));
    assert_eq!(report["systems"]["count"], 2, "{}", report["systems"]);
    let placed = report["probes"]["placed"].as_u64().unwrap_or(0);
    assert!(placed > 0, "{}", report["probes"]);
    assert_eq!(report["probes"]["rank"], serde_json::Value::Null);

    // A point above the town's ground in the sun (no box stands between it and the sun): its
    // probe irradiance is the direct light plus what the probes gather from the level's lit
    // patches.
    let lights = d.join("lights.json");
    std::fs::write(
        &lights,
        r#"{"lights":[{"type":"directional","direction":[0.3,-1,0.2],"irradiance":[3,3,3]}]}"#,
    )
    .unwrap();
    let points = d.join("points.json");
    std::fs::write(
        &points,
        r#"{"points":[{"position":[20,1,50],"normal":[0,1,0]}]}"#,
    )
    .unwrap();
    let solved = json(&radiosity_ok(&[
        "solve",
        s(&level),
        "--lights",
        s(&lights),
        "--points",
        s(&points),
        "--json",
    ]));
    let p = &solved["points"][0];
    assert_eq!(p["status"], "ok", "{p}");
    let total = |k: &str| -> f64 {
        p[k].as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .sum()
    };
    // The sun's own light reaches it, and the probes add the light the lit walls and ground
    // reflect (order-2 SH may ring below zero in shade, never by the sun's size).
    let (direct, probed) = (total("irradiance"), total("probe_irradiance"));
    assert!(direct > 0.0, "{p}");
    assert!(probed.is_finite() && probed > 0.5 * direct, "{p}");

    // Probes the plan does not say: refused, naming the flag; nothing written.
    let other = d.join("other.rad");
    let out = radiosity(&[
        "bake",
        s(&scene),
        "-o",
        s(&other),
        "--plan",
        s(&plan),
        "--probes",
        "none",
    ]);
    assert_one_line_error(&out, "--probes contradicts the plan");
    assert!(!other.exists());
}
