//! The command line end to end: exit status, one-line errors, JSON shapes.

use radiosity_core::Format;
use radiosity_tests::fixtures::sample_file;
use std::path::Path;
use std::process::{Command, Output};

fn radiosity(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_radiosity")).args(args).output().expect("binary runs")
}

/// Asserts the contract for bad input: non-zero exit (not a panic's 101), and stderr exactly
/// one line starting with `error: ` that mentions `needle`.
fn assert_one_line_error(out: &Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must fail: {stderr}");
    assert_ne!(out.status.code(), Some(101), "must not panic: {stderr}");
    assert_eq!(stderr.lines().count(), 1, "one line: {stderr:?}");
    assert!(stderr.starts_with("error: ") && stderr.contains(needle), "{stderr:?} should mention {needle:?}");
}

fn write_sample(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("sample.rad");
    std::fs::write(&path, sample_file(37, 3, Format::Bc1, 16).to_bytes().unwrap()).unwrap();
    path
}

#[test]
fn inspect_prints_text_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_sample(dir.path());
    let out = radiosity(&["inspect", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("patches      37") && text.contains("bc1"), "{text}");

    let out = radiosity(&["inspect", path.to_str().unwrap(), "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["patches"], 37);
    assert_eq!(v["channels"], 3);
    assert_eq!(v["format"], "bc1");
    assert_eq!(v["order"], "spatial");
    assert_eq!(v["bounces"], 4);
    let total = std::fs::metadata(&path).unwrap().len();
    assert_eq!(v["bytes"]["total"], total);
    assert!(v["bytes"]["blocks"].as_u64().unwrap() > 0 && v["bytes"]["sparse"].as_u64().unwrap() > 0);
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
    assert_one_line_error(&radiosity(&["inspect", missing.to_str().unwrap()]), "cannot read");

    let truncated = dir.path().join("truncated.rad");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    assert_one_line_error(&radiosity(&["inspect", truncated.to_str().unwrap()]), "truncated");

    let flipped = dir.path().join("flipped.rad");
    let mid = bytes.len() - 40;
    bytes[mid] ^= 0x10;
    std::fs::write(&flipped, &bytes).unwrap();
    assert_one_line_error(&radiosity(&["inspect", flipped.to_str().unwrap()]), "corrupt");

    let text = dir.path().join("text.rad");
    std::fs::write(&text, "hello, I am not a transfer matrix\n").unwrap();
    assert_one_line_error(&radiosity(&["inspect", text.to_str().unwrap()]), "not a .rad file");
}
