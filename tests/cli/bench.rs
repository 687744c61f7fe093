//! `radiosity bench`: the JSON shape of `docs/contract.md` and sane values on a small Cornell box.

use super::{assert_one_line_error, radiosity, radiosity_ok};

/// The methods `docs/contract.md` names; a GPU row (`gpu-…`) may come on top where an adapter exists.
const METHODS: [&str; 8] = [
    "cpu-bc1",
    "cpu-bc4",
    "cpu-u8",
    "cpu-f16",
    "cpu-f32",
    "faer-dense-f32",
    "jacobi-8",
    "lu-per-frame",
];

#[test]
fn bench_json_has_every_method_with_sane_values() {
    // 256 patches and 3 timed runs per method keep this to a few seconds.
    let out = radiosity_ok(&["bench", "--patches", "256", "--runs", "3", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let n = v["patches"].as_u64().unwrap();
    // The voxel target is hit within ±10% (280 here); patches that see nothing leave the matrix.
    assert!((200..=282).contains(&n), "patches {n}");
    let rows = v["rows"].as_array().unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["method"].as_str().unwrap()).collect();
    for m in METHODS {
        assert!(names.contains(&m), "{m} missing from {names:?}");
    }
    for name in &names {
        assert!(
            METHODS.contains(name) || name.starts_with("gpu-"),
            "unexpected method {name}"
        );
    }
    let row = |name: &str| rows.iter().find(|r| r["method"] == name).unwrap();
    let num = |name: &str, field: &str| {
        row(name)[field]
            .as_f64()
            .unwrap_or_else(|| panic!("{name}.{field} is not a number: {}", row(name)))
    };
    for r in rows {
        let name = r["method"].as_str().unwrap();
        for field in [
            "ms",
            "bytes",
            "rel_error",
            "rel_error_random",
            "bound_ms",
            "fmas",
        ] {
            let x = num(name, field);
            assert!(x.is_finite() && x >= 0.0, "{name}.{field} = {x}");
        }
        assert!(num(name, "ms") > 0.0 && num(name, "bytes") > 0.0, "{r}");
        // GPU kernel time (timestamps) only on GPU rows. It is not compared with `ms`: the two
        // are medians of separate runs, and on a software rasteriser (CI's) both are CPU time
        // of emulated work that moves by 2× between runs.
        match r["kernel_ms"].as_f64() {
            Some(k) => assert!(
                name.starts_with("gpu-") && k > 0.0 && k.is_finite(),
                "{name}.kernel_ms = {k}: {r}"
            ),
            None => assert!(r["kernel_ms"].is_null(), "{name}: {r}"),
        }
        // The roofline is a lower bound up to timer resolution: nothing runs 2× faster.
        assert!(
            num(name, "ms") >= 0.5 * num(name, "bound_ms"),
            "{name} beats its roofline: {r}"
        );
    }
    let n2 = (n * n) as f64;
    // Every method does 3 multiply-adds per matrix entry (RGB) at least.
    assert_eq!(num("faer-dense-f32", "fmas"), 3.0 * n2);
    assert_eq!(num("faer-dense-f32", "bytes"), 12.0 * n2 + 24.0 * n as f64);
    assert_eq!(num("jacobi-8", "fmas"), 8.0 * 3.0 * n2);
    // BC1 stores 0.5 byte per entry against 12 for dense f32 RGB (24×). The sparse list costs
    // 16 bytes per entry and keeps at least each row's 4 largest: 64 B per row against the
    // row's 0.5·n = 140 B of blocks at this size (at 4096 patches it is the 1/8 budget), so
    // about 14× here: assert 10×.
    assert!(num("cpu-bc1", "bytes") < num("faer-dense-f32", "bytes") / 10.0);

    // Accuracy against the exact f64 solution. f32 storage rounds each entry by ≤ 6e-8
    // relative and f32 sums of ~256 positive terms add ≤ 256·6e-8 ≈ 1.5e-5 in the worst case
    // (a random walk in practice): 2e-5.
    for m in ["cpu-f32", "faer-dense-f32", "lu-per-frame"] {
        for field in ["rel_error", "rel_error_random"] {
            let e = num(m, field);
            assert!(e < 2e-5, "{m}.{field} = {e:e} ≥ 2e-5");
        }
    }
    // f16 has 11 significant bits: ≤ 2.4e-4 relative per entry.
    assert!(
        num("cpu-f16", "rel_error_random") < 5e-4,
        "{}",
        row("cpu-f16")
    );
    // u8: log codes 2.7% apart at most (ln 1000 / 255), so ≤ 1.4% per entry before any
    // averaging; measured 0.46% for the light, 0.06% for random exitance.
    assert!(num("cpu-u8", "rel_error") < 0.014, "{}", row("cpu-u8"));
    assert!(
        num("cpu-u8", "rel_error_random") < 0.014,
        "{}",
        row("cpu-u8")
    );
    // BC1 and BC4 share two endpoints per 16 entries; at this size the light covers a few
    // columns, so their block errors do not average out: measured 11% (BC1) and 5.4% (BC4) for
    // the light, 3.9% and 1.1% for random exitance (at 4096 patches the bake measures 2.25%
    // and 0.84%). 25% and 10% bound them with room and still catch a broken decode (≈ 100%).
    for m in ["cpu-bc1", "cpu-bc4"] {
        assert!(num(m, "rel_error") < 0.25, "{}", row(m));
        assert!(num(m, "rel_error_random") < 0.10, "{}", row(m));
    }
    // Eight Jacobi bounces leave out every later bounce: measured 5.3e-3 here (the box keeps
    // about half the energy per bounce, 0.5^8 ≈ 4e-3). A Jacobi that ran to convergence
    // (≈ 1e-7) or stopped after a bounce or two (> 10%) would leave the range.
    let e = num("jacobi-8", "rel_error");
    assert!((1e-4..0.1).contains(&e), "jacobi-8 rel_error {e:e}");

    // The speed-up ratios are reported with their targets.
    let ratios = v["ratios"].as_array().unwrap();
    for (against, target) in [("faer-dense-f32", 4.0), ("jacobi-8", 10.0)] {
        let q = ratios
            .iter()
            .find(|q| q["against"] == against)
            .unwrap_or_else(|| panic!("no ratio against {against}: {ratios:?}"));
        assert_eq!(q["method"], "cpu-bc1");
        assert_eq!(q["target"].as_f64().unwrap(), target);
        let s = q["speedup"].as_f64().unwrap();
        let expect = num(against, "ms") / num("cpu-bc1", "ms");
        assert!((s - expect).abs() <= 1e-9 * expect, "{s} vs {expect}");
    }
    // The host-device frame, on every adapter that runs it: CI has lavapipe, whose Vulkan
    // adapter has timestamps; each frame records the gather and the box's corner pass.
    let frames = v["host_frames"].as_array().unwrap();
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        assert!(!frames.is_empty(), "no host-device frame under CI");
    }
    // The box's probes at `--probes auto` (about 512 cells, those inside the blocks dropped),
    // timed on the CPU and, in each host-device frame, by the probe pass.
    let probes = &v["probes"];
    let count = probes["count"].as_u64().unwrap();
    assert!((400..=512).contains(&count), "{probes}");
    assert!(probes["weights"].as_u64().unwrap() > count, "{probes}");
    assert!(probes["cpu_ms"].as_f64().unwrap() > 0.0, "{probes}");
    for f in frames {
        assert_eq!(f["format"], "bc1", "{f}");
        assert!(f["corners"].as_u64().unwrap() >= 3, "{f}");
        assert_eq!(f["probes"].as_u64(), Some(count), "{f}");
        assert!(f["record_ms"].as_f64().unwrap() > 0.0, "{f}");
        for k in ["gather_ms", "corners_ms", "probes_ms"] {
            assert!(f[k].is_null() || f[k].as_f64().unwrap() > 0.0, "{f}");
        }
    }
    let roof = &v["roofline"];
    assert!(roof["bandwidth_gb_s"].as_f64().unwrap() > 0.1, "{roof}");
    assert!(roof["fma_gflop_s"].as_f64().unwrap() > 0.01, "{roof}");
}

#[test]
fn bench_refuses_bad_patch_counts() {
    assert_one_line_error(&radiosity(&["bench", "--patches", "0"]), "--patches");
    assert_one_line_error(&radiosity(&["bench", "--patches", "1000000"]), "--patches");
    assert_one_line_error(&radiosity(&["bench", "--runs", "0"]), "--runs");
}

/// `radiosity report --quick`: every sweep in the CSV with a measured time and finite errors
/// (the CPU times are filled in after each patch count's gathers are timed in turns: a row left
/// unfilled is NaN), the Pareto front in REPORT.md, and the plots written.
#[test]
fn report_quick_writes_every_sweep_timed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    radiosity_ok(&["report", "--quick", "-o", out.to_str().unwrap()]);
    let csv = std::fs::read_to_string(out.join("report.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (sweep, cpu, exact, pt) = (
        col("sweep"),
        col("cpu_gather_ms"),
        col("error_vs_exact"),
        col("error_vs_pathtracer"),
    );
    let mut per_sweep = std::collections::BTreeMap::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        *per_sweep.entry(f[sweep].to_string()).or_insert(0) += 1;
        let num = |i: usize| f[i].parse::<f64>().unwrap_or(f64::NAN);
        assert!(num(cpu) > 0.0 && num(cpu) < 1e4, "cpu time in {line}");
        assert!(
            num(exact).is_finite() && num(pt).is_finite(),
            "errors in {line}"
        );
    }
    // The quick plan: 3 sizes × 5 formats, K ∈ {1, 2, 4, 8}, 2 formats × 4 orders, 4 sparse
    // fractions, 3 shares of corrected blocks.
    let want: std::collections::BTreeMap<String, usize> = [
        ("n", 15),
        ("bounces", 4),
        ("order", 8),
        ("sparse", 4),
        ("corrections", 3),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    assert_eq!(per_sweep, want);
    // More corrected blocks, a larger file (31 bytes each) and no larger compression error.
    let (corr, bytes, rmse) = (
        col("corrections"),
        col("file_bytes"),
        col("compression_rmse"),
    );
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .filter(|f: &Vec<String>| f[sweep] == "corrections")
        .collect();
    for w in rows.windows(2) {
        let num = |f: &Vec<String>, i: usize| f[i].parse::<f64>().unwrap();
        assert!(num(&w[1], corr) > num(&w[0], corr), "{w:?}");
        assert!(num(&w[1], bytes) > num(&w[0], bytes), "{w:?}");
        assert!(num(&w[1], rmse) <= num(&w[0], rmse), "{w:?}");
    }
    let md = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(md.contains("Pareto front"), "{md}");
    assert!(md.contains("timed in turns"), "{md}");
    for png in [
        "error_vs_time.png",
        "error_vs_memory.png",
        "gather_time_vs_n.png",
    ] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"), "{png}");
    }
}
