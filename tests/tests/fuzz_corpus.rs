//! Replays the fuzz corpora on stable: every file of `fuzz/corpus/<target>/` and
//! `fuzz/regressions/<target>/` goes through the same check as the fuzz target
//! (`radiosity_tests::fuzz_checks`). A regression file is committed for every crash the fuzzer
//! finds, so this test fails as long as the bug is there.
//!
//! Also here: the exhaustive proof of the Mesa-vs-D3D10 palette bounds the `decode_blocks`
//! target asserts, a measured bound on what `RadFile::parse` allocates, and the seed-corpus
//! writer (`RADIOSITY_WRITE_FUZZ_CORPUS=1 cargo test -p radiosity-tests --test fuzz_corpus`).

use radiosity_core::{Bc1Block, Bc4Block, DecodeMode, RadFile};
use radiosity_tests::fuzz_checks::{
    BC1_MESA_MAX_DIFF, TARGETS, bc4_mesa_max_diff, parse_allocation_bound, seed_corpus,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};

/// Counts, per thread, the largest single allocation since the last reset; forwards to
/// [`System`].
struct LargestAllocation;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    // `try_with`: the slot may be gone while the thread shuts down; nothing to record then.
    let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
}

// SAFETY: every method forwards to `System` with the caller's arguments unchanged, so it upholds
// exactly the contract `System` does; recording the size touches only a const-initialised
// thread-local `Cell` (no allocation, no destructor).
unsafe impl GlobalAlloc for LargestAllocation {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: forwarded from our caller, who met `GlobalAlloc::alloc`'s contract.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: as for `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` through this allocator with this `layout`.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        // SAFETY: as for `dealloc`; `new_size` is checked by our caller.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz")
}

/// The files of `dir`, sorted, without READMEs and dot-files. Empty when `dir` is missing.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.expect("read_dir entry").path())
        .filter(|p| p.is_file())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            !name.starts_with('.') && !name.starts_with("README")
        })
        .collect();
    files.sort();
    files
}

#[test]
fn corpus_and_regressions_pass_their_checks() {
    let mut failures = Vec::new();
    let mut checked = 0;
    for (target, check) in TARGETS {
        let corpus = files_in(&fuzz_dir().join("corpus").join(target));
        assert!(
            !corpus.is_empty(),
            "fuzz/corpus/{target}/ is missing or empty: regenerate it (fuzz/README.md)"
        );
        let regressions = files_in(&fuzz_dir().join("regressions").join(target));
        for path in corpus.iter().chain(&regressions) {
            let data = std::fs::read(path).expect("read corpus file");
            checked += 1;
            if std::panic::catch_unwind(|| check(&data)).is_err() {
                failures.push(path.display().to_string());
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {checked} fuzz inputs fail their check (messages above):\n  {}",
        failures.len(),
        failures.join("\n  ")
    );
}

#[test]
fn parse_allocates_no_more_than_the_input_justifies() {
    let mut inputs = Vec::new();
    for dir in ["corpus", "regressions"] {
        inputs.extend(files_in(&fuzz_dir().join(dir).join("parse_container")));
    }
    assert!(!inputs.is_empty(), "no parse_container inputs");
    for path in inputs {
        let mut data = std::fs::read(&path).expect("read corpus file");
        for pass in 0..2 {
            if pass == 1 && radiosity_core::container::reseal(&mut data).is_err() {
                break;
            }
            LARGEST.with(|l| l.set(0));
            let parsed = RadFile::parse(&data);
            let largest = LARGEST.with(Cell::get);
            drop(parsed);
            let bound = parse_allocation_bound(data.len());
            assert!(
                largest <= bound,
                "{} (pass {pass}): parse made a {largest}-byte allocation for {} bytes of input (bound {bound})",
                path.display(),
                data.len()
            );
        }
    }
}

/// The bounds `decode_blocks` asserts between the Mesa and D3D10 palettes hold, and are tight:
/// BC4 over every pair of endpoints; BC1 over every `c0` against 256 `c1` words spread over the
/// range (`k · 257`) and `c1 = c0`, which covers both modes and every 565 channel value on each
/// side. (Per channel the palette depends only on the two expanded endpoints and the mode.)
#[test]
fn mesa_palette_bounds_are_exhaustive_and_tight() {
    let mut bc1_max = 0u8;
    for c0 in 0..=u16::MAX {
        // The palette depends on the endpoints only; sweep c1 over a stride that still reaches
        // every 565 channel value, plus c1 = c0 (three-colour).
        for c1 in (0..=u16::MAX).step_by(257).chain([c0]) {
            let mut raw = [0u8; 8];
            raw[..2].copy_from_slice(&c0.to_le_bytes());
            raw[2..4].copy_from_slice(&c1.to_le_bytes());
            let b = Bc1Block(raw);
            let (d, m) = (b.palette(DecodeMode::D3d10), b.palette(DecodeMode::Mesa));
            assert_eq!(d[..2], m[..2]);
            for k in 2..4 {
                for ch in 0..3 {
                    bc1_max = bc1_max.max(d[k][ch].abs_diff(m[k][ch]));
                }
                assert_eq!(d[k][3], m[k][3]);
            }
        }
    }
    assert_eq!(bc1_max, BC1_MESA_MAX_DIFF, "BC1 bound not tight");

    let mut bc4_max = [[0u8; 8]; 2];
    for r0 in 0..=255u8 {
        for r1 in 0..=255u8 {
            let b = Bc4Block([r0, r1, 0, 0, 0, 0, 0, 0]);
            let eight = b.is_eight_value();
            let (d, m) = (b.palette(DecodeMode::D3d10), b.palette(DecodeMode::Mesa));
            assert_eq!(d[..2], m[..2]);
            if !eight {
                assert_eq!(d[6..], m[6..]);
            }
            let steps = if eight { 7 } else { 5 };
            for t in 1..steps {
                let diff = d[1 + t].abs_diff(m[1 + t]);
                let slot = &mut bc4_max[usize::from(eight)][t];
                *slot = (*slot).max(diff);
            }
        }
    }
    for (eight, steps) in [(false, 5), (true, 7)] {
        for t in 1..steps {
            assert_eq!(
                bc4_max[usize::from(eight)][t],
                bc4_mesa_max_diff(eight, t),
                "BC4 bound for eight_value={eight}, t={t} is not the measured maximum"
            );
        }
    }
}

/// Writes the seed corpus when `RADIOSITY_WRITE_FUZZ_CORPUS=1` (replacing the files of
/// `fuzz/corpus/<target>/`); otherwise only checks that the generator runs and covers every
/// target.
#[test]
fn seed_corpus_generator() {
    let seeds = seed_corpus();
    if std::env::var_os("RADIOSITY_WRITE_FUZZ_CORPUS").is_some_and(|v| v == "1") {
        for (target, _) in TARGETS {
            let dir = fuzz_dir().join("corpus").join(target);
            std::fs::create_dir_all(&dir).expect("create corpus dir");
            for old in files_in(&dir) {
                std::fs::remove_file(old).expect("remove old seed");
            }
        }
        for s in &seeds {
            let path = fuzz_dir().join("corpus").join(s.target).join(&s.name);
            std::fs::write(&path, &s.bytes).expect("write seed");
        }
        eprintln!("wrote {} seeds under {}", seeds.len(), fuzz_dir().display());
    }
    for (target, _) in TARGETS {
        assert!(
            seeds.iter().any(|s| s.target == target),
            "no seed for {target}"
        );
    }
}
