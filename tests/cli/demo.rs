//! `radiosity demo`, run as the README runs it: its pictures, the modes of the files it
//! writes, and the README's demo block (between `<!-- demo-output:begin -->` and
//! `<!-- demo-output:end -->`), which must say what `demo` prints.

use std::path::Path;
use std::process::{Command, Output};

/// Runs the binary under `umask 022`, as a user's shell would, through `sh`.
fn radiosity_umask_022(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(r#"umask 022 && exec "$0" "$@""#)
        .arg(env!("CARGO_BIN_EXE_radiosity"))
        .args(args)
        .output()
        .expect("sh runs")
}

/// The lines of the README's demo block, without the code fence.
fn readme_block() -> Vec<String> {
    let readme = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md"))
        .expect("README.md");
    let begin = readme
        .find("<!-- demo-output:begin -->")
        .expect("the README marks its demo block with <!-- demo-output:begin -->");
    let end = readme[begin..]
        .find("<!-- demo-output:end -->")
        .expect("the demo block ends with <!-- demo-output:end -->")
        + begin;
    readme[begin..end]
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty() && !l.starts_with("```"))
        .map(str::to_owned)
        .collect()
}

/// How a word of the demo's output may differ from the README's.
#[derive(Debug, PartialEq)]
enum Field {
    /// Words that must be the same.
    Exact,
    /// A time (`8.4 s`, `0.79 ms`): the machine's, not the program's.
    Time,
    /// The gather's name in the GIF line (`(cpu-bc1)`, `(gpu-…)`): the machine's backend.
    Backend,
    /// A count or size, equal within `rel`.
    Number { rel: f64 },
}

fn number(word: &str) -> Option<f64> {
    word.trim_matches(|c: char| !(c.is_ascii_digit() || c == '.'))
        .parse()
        .ok()
        .filter(|_| word.chars().any(|c| c.is_ascii_digit()))
}

/// What the `i`th word of a line is. Tolerances: the bake is deterministic on a machine (the
/// same file every run), so its figures move only where another CPU's SIMD paths (faer's LU,
/// the encoders) round differently and an encoder's choice flips here and there. The patch
/// count comes from the simplification, which does not depend on that rounding; the file's
/// size is set by the patch count (blocks, and sparse entries and corrected blocks as fixed
/// shares of them): 0.5% covers both and the ratios made of them, and still catches the
/// 2.31 → 2.34 MB of a stale block. The lighting error is a small difference of two large
/// sums, which such flips move more: 15%, which still catches 0.38% → 0.72%.
fn field(words: &[&str], i: usize) -> Field {
    let w = words[i];
    let next = words.get(i + 1).copied().unwrap_or("");
    if number(w).is_none() || w.contains('×') {
        if w.starts_with("(cpu-") || w.starts_with("(gpu-") || w.starts_with("(reference") {
            return Field::Backend;
        }
        return Field::Exact;
    }
    if matches!(next.trim_end_matches([',', ')']), "s" | "ms") {
        return Field::Time;
    }
    if w.ends_with('%') {
        return Field::Number { rel: 0.15 };
    }
    Field::Number { rel: 0.005 }
}

/// Compares one line of the demo's output with the README's.
fn same_line(readme: &str, printed: &str) -> Result<(), String> {
    let (a, b): (Vec<&str>, Vec<&str>) = (
        readme.split_whitespace().collect(),
        printed.split_whitespace().collect(),
    );
    if a.len() != b.len() {
        return Err("a different number of words".into());
    }
    for i in 0..a.len() {
        match field(&a, i) {
            Field::Exact if a[i] != b[i] => return Err(format!("{:?} vs {:?}", a[i], b[i])),
            Field::Number { rel } => {
                let (x, y) = (number(a[i]).unwrap(), number(b[i]).unwrap_or(f64::NAN));
                if !((x - y).abs() <= rel * x.abs()) {
                    return Err(format!("{} vs {} (more than {}%)", a[i], b[i], rel * 100.0));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[test]
fn demo_writes_its_pictures_and_the_readme_says_what_it_prints() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("assets");
    // The README's command: `demo --out assets`, every other setting its default.
    let out = radiosity_umask_022(&["demo", "--out", out_dir.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let png = image::open(out_dir.join("demo.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (512, 512));
    let gif = std::fs::read(out_dir.join("demo.gif")).unwrap();
    assert!(gif.starts_with(b"GIF89a"), "not a GIF");
    assert!(out_dir.join("demo.rad").exists());
    assert!(
        !stderr.contains("/tmp") && !stderr.contains(".tmp"),
        "{stderr}"
    );

    // Every output has the mode of a file created under the umask: 0666 & !022.
    #[cfg(unix)]
    for name in ["demo.rad", "demo.png", "demo.gif"] {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(out_dir.join(name))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o644, "{name}: mode {:o}", mode & 0o777);
    }

    // The README's block, with the output directory as the README names it.
    let printed: Vec<String> = stdout
        .lines()
        .map(|l| l.replace(out_dir.to_str().unwrap(), "assets"))
        .collect();
    let block = readme_block();
    let (backend, rest): (Vec<&String>, Vec<&String>) =
        block.iter().partition(|l| l.starts_with("backend: "));
    assert_eq!(
        backend.len(),
        1,
        "the block shows the backend line: {block:?}"
    );
    assert!(stderr.contains("backend: "), "{stderr}");
    assert_eq!(
        rest.len(),
        printed.len(),
        "README block {rest:#?}\nvs demo's output {printed:#?}"
    );
    for (r, p) in rest.iter().zip(&printed) {
        if let Err(why) = same_line(r, p) {
            panic!(
                "the README's demo block drifted from what `demo` prints ({why}):\n  README: {r}\n  demo:   {p}\nrun `cargo run --release -- demo --out assets` and copy its output between the markers"
            );
        }
    }
}

#[test]
fn the_line_comparison_ignores_times_and_backends_only() {
    let readme =
        "bake: 8.4 s, 1909 patches, bc1 paper order, \"infinite\" bounces, lighting error 0.72%";
    same_line(
        readme,
        "bake: 31.0 s, 1909 patches, bc1 paper order, \"infinite\" bounces, lighting error 0.70%",
    )
    .unwrap();
    for drifted in [
        "bake: 8.4 s, 2048 patches, bc1 paper order, \"infinite\" bounces, lighting error 0.72%",
        "bake: 8.4 s, 1909 patches, bc4 paper order, \"infinite\" bounces, lighting error 0.72%",
        "bake: 8.4 s, 1909 patches, bc1 paper order, \"infinite\" bounces, lighting error 0.38%",
    ] {
        assert!(same_line(readme, drifted).is_err(), "{drifted}");
    }
    let gif = "assets/demo.gif: 36 frames 256×256, per frame: gather 0.66 ms (cpu-bc1), direct light + gather 0.95 ms (medians)";
    same_line(
        gif,
        "assets/demo.gif: 36 frames 256×256, per frame: gather 0.05 ms (gpu-bc1), direct light + gather 0.31 ms (medians)",
    )
    .unwrap();
    assert!(same_line(gif, &gif.replace("256×256", "128×128")).is_err());
    let file =
        "file: assets/demo.rad (2.34 MB; a dense f32 RGB matrix would be 43.7 MB, 18.7x more)";
    assert!(same_line(file, &file.replace("2.34", "2.31")).is_err());
}
