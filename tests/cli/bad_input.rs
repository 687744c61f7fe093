//! Bad input never panics, hangs or half-writes.
//!
//! One file of 630-odd lines on purpose: every bad-input case of the command line stands beside
//! its siblings, so a new kind of bad input is added where the others are.
//!
//! Every file under `tests/bad/<kind>/` is run through the commands of its kind (the table in
//! `tests/bad/README.md`), so a file dropped there is picked up without touching this code.
//! Each run must end within [`LIMIT`], with a non-zero status that is not a panic's 101, exactly
//! one stderr line starting `error: ` (mentioning the file's needle from `tests/bad/EXPECT`,
//! when it has one), and nothing left in the output directory or beside the input: no
//! `out.rad`, no PNG, no DDS folder, no temporary file. Corrupted `.rad` files are also
//! generated afresh from a real bake of a small room (truncated at every section, a byte
//! flipped in every section, every section zeroed, counts made huge behind valid checksums),
//! so the checked-in ones (`tests/bad/rad/`, written by the same code, see
//! [`write_rad_corpus`]) cannot go stale without the test noticing.

use radiosity_core::container::{reseal, section_ranges};
use radiosity_core::{RadFile, SectionKind};
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Longest a bad input may take, per command. Every case measured finishes in well under a
/// second (a 24-patch bake at most); a minute only separates "slow debug build on a loaded
/// machine" from "hangs".
const LIMIT: Duration = Duration::from_secs(60);

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bad")
}

/// Runs the binary with a time limit, draining both pipes on their own threads (a chatty
/// process must not block on a full pipe and look hung).
fn run_limited(args: &[OsString], cwd: &Path) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_radiosity"))
        .args(args)
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            r.read_to_end(&mut v).ok();
            v
        })
    };
    let out = drain(Box::new(child.stdout.take().unwrap()));
    let err = drain(Box::new(child.stderr.take().unwrap()));
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > LIMIT {
            child.kill().ok();
            child.wait().ok();
            panic!("{args:?} did not finish within {LIMIT:?}: hangs");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output {
        status,
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// `tests/bad/EXPECT`: `kind/file  needle` lines (`#` comments).
fn needles() -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(corpus_dir().join("EXPECT")).unwrap();
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            let (k, v) = l.split_once(char::is_whitespace).expect("`file needle`");
            (k.to_owned(), v.trim().to_owned())
        })
        .collect()
}

/// Runs one bad input through one command line and checks the whole contract. Returns the
/// stderr line and how long the command took.
fn check(
    case: &str,
    args: Vec<OsString>,
    needle: Option<&str>,
    out_dir: &Path,
    input_dir: &Path,
) -> (String, Duration) {
    let before = listing(input_dir);
    let t = Instant::now();
    let out = run_limited(&args, out_dir);
    let took = t.elapsed();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let cmd = args
        .iter()
        .map(|a| a.to_string_lossy())
        .collect::<Vec<_>>()
        .join(" ");
    assert!(
        !out.status.success(),
        "{case}: `{cmd}` must fail; stderr {stderr:?}"
    );
    assert_ne!(
        out.status.code(),
        Some(101),
        "{case}: `{cmd}` panicked: {stderr}"
    );
    assert!(
        out.status.code().is_some(),
        "{case}: `{cmd}` was killed by a signal ({:?}): {stderr}",
        out.status
    );
    assert_eq!(
        stderr.lines().count(),
        1,
        "{case}: `{cmd}`: exactly one stderr line, got {stderr:?}"
    );
    assert!(stderr.starts_with("error: "), "{case}: `{cmd}`: {stderr:?}");
    // No cause said twice (an error quoting its source, then the source again).
    let parts: Vec<&str> = stderr.trim().split(": ").collect();
    assert!(
        parts.windows(2).all(|w| w[0] != w[1]),
        "{case}: `{cmd}`: a cause repeated in {stderr:?}"
    );
    if let Some(n) = needle {
        assert!(
            stderr.to_lowercase().contains(&n.to_lowercase()),
            "{case}: `{cmd}`: {stderr:?} should mention {n:?}"
        );
    }
    let left = listing(out_dir);
    assert!(
        left.is_empty(),
        "{case}: `{cmd}` left output behind: {left:?}"
    );
    assert_eq!(
        listing(input_dir),
        before,
        "{case}: `{cmd}` wrote beside its input"
    );
    eprintln!(
        "{case}: {:.0} ms: {}",
        took.as_secs_f64() * 1e3,
        stderr.trim()
    );
    (stderr.into_owned(), took)
}

/// A small closed room with a lamp, written as OBJ + MTL into `dir`.
fn good_scene(dir: &Path) -> PathBuf {
    use radiosity_tests::scenes::{Material, closed_box, write_scene};
    let mats = [
        Material::new("wall", [0.6, 0.5, 0.4], [0.0; 3]),
        Material::new("lamp", [0.5; 3], [4.0; 3]),
    ];
    let quads = closed_box(1.0, 2, |face, i, j| {
        if face == "ceiling" && i == 0 && j == 0 {
            "lamp".into()
        } else {
            "wall".into()
        }
    });
    write_scene(dir, "room", &quads, &mats)
}

/// Bakes the good room with the command line: the base every `.rad` corruption starts from,
/// and the scene the lights and camera files are tried on.
fn good_rad(dir: &Path) -> PathBuf {
    let scene = good_scene(dir);
    let rad = dir.join("room.rad");
    let out = run_limited(
        &[
            "bake".into(),
            scene.into_os_string(),
            "-o".into(),
            rad.clone().into_os_string(),
            "--patches".into(),
            "30".into(),
        ],
        dir,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    rad
}

/// The commands each kind of bad file goes through (`FILE`, `GOOD` and `OUT` are replaced by
/// the bad file, the good bake and the output directory).
fn commands(kind: &str) -> &'static [&'static [&'static str]] {
    match kind {
        "obj" | "gltf" => &[
            &["bake", "FILE", "-o", "OUT/out.rad", "--patches", "24"],
            &["solve", "FILE", "--patches", "24", "--json"],
        ],
        "rad" => &[
            &["inspect", "FILE"],
            &["inspect", "FILE", "--json", "--export-dds", "OUT/dds"],
            &["solve", "FILE", "--json"],
            &[
                "render",
                "FILE",
                "-o",
                "OUT/out.png",
                "--width",
                "16",
                "--height",
                "16",
            ],
        ],
        "lights" => &[
            &["solve", "GOOD", "--lights", "FILE", "--json"],
            &[
                "render",
                "GOOD",
                "--lights",
                "FILE",
                "-o",
                "OUT/out.png",
                "--width",
                "16",
                "--height",
                "16",
            ],
        ],
        "camera" => &[&["render", "GOOD", "--camera", "FILE", "-o", "OUT/out.png"]],
        other => panic!("tests/bad/{other}: unknown kind; add it to `commands` and the README"),
    }
}

fn expand(template: &[&str], file: &Path, good: &Path, out: &Path) -> Vec<OsString> {
    template
        .iter()
        .map(|a| match *a {
            "FILE" => file.as_os_str().to_owned(),
            "GOOD" => good.as_os_str().to_owned(),
            s if s.starts_with("OUT/") => out.join(&s[4..]).into_os_string(),
            s => s.into(),
        })
        .collect()
}

/// Whether `path` is a case (not a helper such as an MTL or texture an OBJ case names).
fn is_case(kind: &str, path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    match kind {
        "obj" => ext == "obj",
        "gltf" => ext == "gltf" || ext == "glb",
        "rad" => ext == "rad",
        _ => ext == "json",
    }
}

#[test]
fn every_bad_file_fails_cleanly() {
    let needles = needles();
    let work = tempfile::tempdir().unwrap();
    let good = good_rad(work.path());
    let mut kinds: Vec<PathBuf> = std::fs::read_dir(corpus_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    kinds.sort();
    let mut cases = 0;
    for dir in &kinds {
        let kind = dir.file_name().unwrap().to_str().unwrap();
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| is_case(kind, p))
            .collect();
        files.sort();
        assert!(!files.is_empty(), "tests/bad/{kind} holds no case");
        for file in files {
            let name = format!("{kind}/{}", file.file_name().unwrap().to_string_lossy());
            for template in commands(kind) {
                let out = tempfile::tempdir().unwrap();
                let args = expand(template, &file, &good, out.path());
                check(
                    &name,
                    args,
                    needles.get(&name).map(String::as_str),
                    out.path(),
                    dir,
                );
            }
            cases += 1;
        }
    }
    // Every EXPECT line names a file that exists (a renamed case must not lose its needle).
    for name in needles.keys() {
        assert!(
            corpus_dir().join(name).is_file(),
            "tests/bad/EXPECT names {name}, which does not exist"
        );
    }
    assert!(cases >= 40, "the corpus shrank to {cases} cases");
}

/// Corruptions of a good `.rad` file: `(name, bytes, needle)`.
fn rad_variants(good: &[u8]) -> Vec<(String, Vec<u8>, &'static str)> {
    let mut v: Vec<(String, Vec<u8>, &'static str)> = Vec::new();
    let ranges = section_ranges(good).expect("a good file has sections");
    v.push(("empty".into(), Vec::new(), "truncated"));
    v.push(("header-only".into(), good[..32].to_vec(), "truncated"));
    v.push((
        "text".into(),
        b"not a transfer matrix\n".to_vec(),
        "not a .rad file",
    ));
    v.push((
        "truncated-by-one".into(),
        good[..good.len() - 1].to_vec(),
        "truncated",
    ));
    // An empty section (a closed scene's SKY) has no byte to truncate, flip or zero.
    for (kind, r) in ranges.iter().filter(|(_, r)| !r.is_empty()) {
        let s = kind.name().to_lowercase();
        v.push((
            format!("truncated-in-{s}"),
            good[..r.start + (r.end - r.start) / 2].to_vec(),
            "truncated",
        ));
        let mut b = good.to_vec();
        b[r.start + (r.end - r.start) / 3] ^= 0x40;
        v.push((format!("flipped-in-{s}"), b, "corrupt"));
        let mut b = good.to_vec();
        b[r.clone()].fill(0);
        v.push((format!("zeroed-{s}"), b, "corrupt"));
    }
    let mut b = good.to_vec();
    b[32..64].fill(0);
    v.push(("zeroed-section-table".into(), b, ""));
    let mut b = good.to_vec();
    // A version no reader knows (1 → 5: versions 1 to 3 are all read).
    b[8] ^= 0x04;
    v.push(("flipped-version".into(), b, "version"));
    // Semantic corruptions behind valid checksums.
    let at = |k: SectionKind| {
        ranges
            .iter()
            .find(|(s, _)| *s == k)
            .map(|(_, r)| r.start)
            .expect("section present")
    };
    let (meta, patches) = (at(SectionKind::Meta), at(SectionKind::Patches));
    let mut resealed = |name: &str, edit: &dyn Fn(&mut Vec<u8>)| {
        let mut b = good.to_vec();
        edit(&mut b);
        reseal(&mut b).expect("reseal");
        v.push((format!("resealed-{name}"), b, ""));
    };
    resealed("n-huge", &|b| {
        b[meta..meta + 4].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    resealed("n-zero", &|b| b[meta..meta + 4].fill(0));
    resealed("channels-7", &|b| {
        b[meta + 4..meta + 8].copy_from_slice(&7u32.to_le_bytes())
    });
    resealed("tile-huge", &|b| {
        b[meta + 12..meta + 16].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    resealed("object-count-huge", &|b| {
        b[meta + 24..meta + 28].copy_from_slice(&0x4000_0000u32.to_le_bytes())
    });
    resealed("sparse-count-huge", &|b| {
        b[meta + 28..meta + 32].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    resealed("nan-area", &|b| {
        b[patches + 12..patches + 16].copy_from_slice(&f32::NAN.to_le_bytes())
    });
    resealed("section-count-huge", &|b| {
        b[12..16].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    v
}

#[test]
fn generated_rad_corruptions_fail_cleanly() {
    let work = tempfile::tempdir().unwrap();
    let good = std::fs::read(good_rad(work.path())).unwrap();
    RadFile::parse(&good).expect("the base parses");
    let cases = tempfile::tempdir().unwrap();
    for (name, bytes, needle) in rad_variants(&good) {
        let file = cases.path().join(format!("{name}.rad"));
        std::fs::write(&file, &bytes).unwrap();
        // Render is left to the checked-in corpus: it parses through the same loader as solve.
        for template in &commands("rad")[..3] {
            let out = tempfile::tempdir().unwrap();
            check(
                &name,
                expand(template, &file, &file, out.path()),
                (!needle.is_empty()).then_some(needle),
                out.path(),
                cases.path(),
            );
        }
        std::fs::remove_file(&file).unwrap();
    }
}

/// Writes `tests/bad/rad/` from a bake of the good room (`RADIOSITY_WRITE_BAD_CORPUS=1`): the
/// checked-in corruptions, small enough to read in a hex dump.
#[test]
fn write_rad_corpus() {
    if std::env::var_os("RADIOSITY_WRITE_BAD_CORPUS").is_none() {
        return;
    }
    let work = tempfile::tempdir().unwrap();
    let good = std::fs::read(good_rad(work.path())).unwrap();
    let dir = corpus_dir().join("rad");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes, _) in rad_variants(&good) {
        std::fs::write(dir.join(format!("{name}.rad")), bytes).unwrap();
    }
}

#[test]
fn overflowing_emission_is_an_error_not_infinity() {
    // Ke = 1e37 at ρ = 0.95: the exitance π·Ke = 3.1e37 fits f32, so the scene loads and bakes,
    // but B = E/(1 − ρ) ≈ 6e38 does not: solve must say so instead of printing `null` (serde's
    // rendering of infinity). The gather has run by then, so the backend's own stderr line may
    // precede the error; the error itself is one line, the last.
    use radiosity_tests::scenes::{Material, closed_box, write_scene};
    let dir = tempfile::tempdir().unwrap();
    let mats = [Material::new("hot", [0.95; 3], [1e37; 3])];
    let scene = write_scene(
        dir.path(),
        "hot",
        &closed_box(1.0, 1, |_, _, _| "hot".into()),
        &mats,
    );
    let args: Vec<OsString> = vec![
        "solve".into(),
        scene.into_os_string(),
        "--patches".into(),
        "24".into(),
        "--backend".into(),
        "cpu".into(),
        "--json".into(),
    ];
    let out = run_limited(&args, dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert_ne!(out.status.code(), Some(101), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(
        stderr.lines().last().unwrap().contains("overflows f32"),
        "{stderr}"
    );
    assert!(out.stdout.is_empty(), "no partial JSON");
}

/// Flags and output paths refused at once, before any scene is loaded or any work done: one
/// line naming the flag or the path the user gave (never a temporary file's), nothing
/// written. `GOOD_OBJ`, `GOOD` and `OUT` as in [`commands`]; `MISSING` is a scene that does
/// not exist, so that a refusal that names the flag proves nothing was loaded first.
#[test]
fn bad_flags_and_output_paths_fail_at_once() {
    let work = tempfile::tempdir().unwrap();
    let good = good_rad(work.path());
    let good_obj = work.path().join("room.obj");
    let a_file = work.path().join("room.mtl");
    let missing = work.path().join("missing.obj");
    let mut cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["bake", "GOOD_OBJ", "-o", "OUT/out.rad", "--patches", "-5"],
            "at least 1",
        ),
        (
            vec!["bake", "GOOD_OBJ", "-o", "OUT/out.rad", "--patches=-5"],
            "at least 1",
        ),
        (
            vec!["bake", "GOOD_OBJ", "-o", "OUT/out.rad", "--bounces", "-1"],
            "--bounces must be a number",
        ),
        (
            vec!["bake", "GOOD_OBJ", "-o", "OUT/out.rad", "--bounces=-1"],
            "--bounces must be a number",
        ),
        (
            vec!["bake", "GOOD_OBJ", "-o", "OUT/out.rad", "--sparse", "-0.5"],
            "--sparse must be",
        ),
        (
            vec![
                "bake",
                "MISSING",
                "-o",
                "OUT/out.rad",
                "--patches",
                "10000000",
            ],
            "more than any bake can hold",
        ),
        (
            vec![
                "bake",
                "MISSING",
                "-o",
                "OUT/out.rad",
                "--patches",
                "60000",
                "--systems",
                "off",
            ],
            "more than one matrix can hold",
        ),
        (
            vec!["solve", "MISSING", "--patches", "10000000"],
            "more than any bake can hold",
        ),
        (
            vec!["demo", "--out", "OUT", "--patches", "10000000"],
            "more than any bake can hold",
        ),
        (
            vec!["check-rows", "MISSING", "--patches", "-1"],
            "at least 1",
        ),
        (
            vec!["solve", "GOOD", "--patches", "300"],
            "--patches do not apply",
        ),
        (
            vec!["solve", "GOOD", "--bounces", "2", "--format", "f32"],
            "--bounces, --format do not apply",
        ),
        (
            vec!["render", "GOOD", "--order", "none", "-o", "OUT/out.png"],
            "--order do not apply",
        ),
        (vec!["render", "GOOD", "-o", "OUT"], "is a directory"),
        (
            vec!["render", "GOOD", "-o", "/nonexistent/x.png"],
            "cannot write /nonexistent/x.png: directory /nonexistent does not exist",
        ),
        (
            vec!["render", "GOOD", "-o", "FILE/x.png"],
            "is not a directory",
        ),
        (vec!["bake", "GOOD_OBJ", "-o", "OUT"], "is a directory"),
        (
            vec!["pathtrace", "GOOD_OBJ", "-o", "/nonexistent/x.png"],
            "/nonexistent/x.png",
        ),
        (vec!["demo", "--out", "FILE"], "not a directory"),
        (
            vec!["inspect", "GOOD", "--export-dds", "FILE"],
            "not a directory",
        ),
    ];
    // A target too large for this machine's memory (when it has less than 120 GB; the
    // estimate of 57 000 patches is 126 GB): refused with the estimate and what fits.
    let mem_kib: Option<f64> = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("MemTotal:"))?
            .split_whitespace()
            .nth(1)?
            .parse()
            .ok()
    });
    if mem_kib.is_some_and(|k| k * 1024.0 < 120e9) {
        cases.push((
            vec![
                "bake",
                "MISSING",
                "-o",
                "OUT/out.rad",
                "--patches",
                "57000",
                "--systems",
                "off",
            ],
            "GB at the bake's peak",
        ));
    }
    // Cut into two systems of 28 500 patches the level needs about 41 GB, 38 GB of it the
    // largest system's dense transfer: refused by the level's own estimate.
    if mem_kib.is_some_and(|k| k * 1024.0 < 39e9) {
        cases.push((
            vec![
                "bake",
                "MISSING",
                "-o",
                "OUT/out.rad",
                "--patches",
                "57000",
                "--systems",
                "2",
            ],
            "in 2 systems needs about",
        ));
    }
    let mut said: BTreeMap<String, String> = BTreeMap::new();
    for (template, needle) in cases {
        let out = tempfile::tempdir().unwrap();
        let args: Vec<OsString> = template
            .iter()
            .map(|a| match *a {
                "GOOD" => good.clone().into_os_string(),
                "GOOD_OBJ" => good_obj.clone().into_os_string(),
                "MISSING" => missing.clone().into_os_string(),
                "OUT" => out.path().as_os_str().to_owned(),
                "FILE" => a_file.clone().into_os_string(),
                s if s.starts_with("OUT/") => out.path().join(&s[4..]).into_os_string(),
                s if s.starts_with("FILE/") => a_file.join(&s[5..]).into_os_string(),
                s => s.into(),
            })
            .collect();
        let name = template.join(" ");
        let (stderr, took) = check(&name, args, Some(needle), out.path(), work.path());
        // At once: a refusal, not work (none of these loads a scene or bakes; a debug build
        // on a loaded machine still answers in well under a second).
        assert!(took < Duration::from_secs(10), "{name}: {took:?}");
        assert!(
            !stderr.contains(".radiosity-") && !stderr.contains("temporary file"),
            "{name}: {stderr}"
        );
        said.insert(name, stderr);
    }
    // `--flag -N` says what `--flag=-N` says.
    for (spaced, joined) in [
        (
            "bake GOOD_OBJ -o OUT/out.rad --bounces -1",
            "bake GOOD_OBJ -o OUT/out.rad --bounces=-1",
        ),
        (
            "bake GOOD_OBJ -o OUT/out.rad --patches -5",
            "bake GOOD_OBJ -o OUT/out.rad --patches=-5",
        ),
    ] {
        assert_eq!(said[spaced], said[joined]);
    }
}

/// A `Kd` at or above 1 (white as exporters write it, or above) is no bad input: it bakes,
/// lowered to 0.95 with one warning saying how much of the surface it covers
/// (`tests/data/kd-one.obj`, `kd-above-one.obj`).
#[test]
fn a_white_kd_is_lowered_with_one_warning() {
    let work = tempfile::tempdir().unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    for (case, share) in [
        ("kd-one.obj", "100.0% of the surface"),
        ("kd-above-one.obj", "100.0% of the surface"),
    ] {
        let out = run_limited(
            &[
                "bake".into(),
                data.join(case).into_os_string(),
                "-o".into(),
                work.path().join("x.rad").into_os_string(),
                "--patches".into(),
                "24".into(),
            ],
            work.path(),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{case}: {stderr}");
        let lines: Vec<&str> = stderr
            .lines()
            .filter(|l| l.contains("lowered to 0.95"))
            .collect();
        assert_eq!(lines.len(), 1, "{case}: {stderr}");
        assert!(lines[0].contains(share), "{case}: {stderr}");
    }
}
