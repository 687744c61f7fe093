//! `parse_container`: `RadFile::parse` on any bytes, and what a parsed file must satisfy.

use radiosity_core::container::reseal;
use radiosity_core::{DecodeMode, Gather, RadFile, ReferenceGather, Rgb};

/// `RadFile::parse` must answer every input without a panic; so must it after
/// [`reseal`] recomputed the checksums (which lets mutations reach the semantic checks behind
/// them). Whatever parses must serialise, and the bytes must parse back to an equal file that
/// a [`ReferenceGather`] can gather from.
pub fn check_parse_container(data: &[u8]) {
    check_parsed(data);
    let mut copy = data.to_vec();
    if reseal(&mut copy).is_ok() {
        check_parsed(&copy);
    }
}

fn check_parsed(bytes: &[u8]) {
    let Ok(file) = RadFile::parse(bytes) else {
        return;
    };
    let out = file
        .to_bytes()
        .unwrap_or_else(|e| panic!("a parsed file does not serialise: {e}"));
    let again = RadFile::parse(&out).unwrap_or_else(|e| panic!("written file does not parse: {e}"));
    assert_eq!(again, file, "written file parses to a different RadFile");
    // Writing is a function of the parsed value: writing the re-parsed file gives the same bytes.
    assert_eq!(again.to_bytes().ok(), Some(out), "second write differs");
    // A parsed file is ready to gather from (DESIGN: validated, so no decode can go wrong): a
    // level file through each of its systems' files.
    match &file.systems {
        Some(systems) => {
            for s in 0..systems.count() {
                let one = systems
                    .system(&file, s)
                    .unwrap_or_else(|e| panic!("a parsed level's system {s} fails: {e}"));
                check_gather(one.into_owned());
            }
        }
        None => check_gather(file),
    }
}

/// Gathers ones through `file`'s matrix and checks the light.
fn check_gather(file: RadFile<'_>) {
    let n = file.n();
    // Block entries decode to finite, non-negative values; sparse values are only required to
    // be finite, because they store exact minus decoded and may be negative. So the sum of a
    // gather of x ≥ 0 is never NaN, and it is non-negative when no sparse value is negative.
    // (The fuzzer found a resealed file with a sparse value of -165: parsing is right to accept
    // it, and the earlier assertion that every output is non-negative was too strong.)
    let sparse_non_negative = file.matrix.sparse.values.iter().all(|v| *v >= 0.0);
    let mut gather = ReferenceGather::new(file.matrix, DecodeMode::D3d10);
    let x = vec![Rgb::ONE; n];
    let mut y = vec![Rgb::ZERO; n];
    gather
        .gather(&x, &mut y)
        .unwrap_or_else(|e| panic!("gather over a parsed file failed: {e}"));
    for (i, v) in y.iter().enumerate() {
        // Sums of finite values may overflow f32 to ±inf, never to NaN.
        assert!(
            v.to_array().iter().all(|c| !c.is_nan()),
            "gather over a parsed file: patch {i} has {v:?}"
        );
        if sparse_non_negative {
            assert!(
                v.to_array().iter().all(|c| *c >= 0.0),
                "gather over a parsed file without negative sparse values: patch {i} has {v:?}"
            );
        }
    }
}

/// The most bytes a single allocation made by [`RadFile::parse`] may take for an input of `len`
/// bytes: every allocation of the parser is a copy of a section already checked against the
/// input, the section table, a bit set of `n / 8` bytes, or the object list (24 bytes of
/// `Cow<str>` per 4-byte offset). The replay test measures it; libFuzzer's `-malloc_limit_mb` in
/// `fuzz/run.sh` enforces a coarser version of it.
pub fn parse_allocation_bound(len: usize) -> usize {
    8 * len + 4096
}
