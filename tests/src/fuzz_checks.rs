//! The bodies of the fuzz targets in `fuzz/fuzz_targets/`, shared with the stable replay test
//! `tests/tests/fuzz_corpus.rs` (STYLE 18): each `check_*` function takes the raw fuzz input and
//! panics, with a message that says what broke, when a property does not hold. The fuzz targets
//! are one-line calls to these; the replay test runs every committed corpus and regression file
//! through the same function, so a crash found by the fuzzer stays a failing plain `#[test]`
//! until it is fixed.
//!
//! The seed corpus is made here too ([`seed_corpus`]), deterministically, so that it can be
//! regenerated after a format change (see `fuzz/README.md`).

use radiosity_bake::encode::{
    EncodeError, EncodeParams, ErrorWeights, SparseSelection, encode_dense, encode_dense_with,
};
use radiosity_core::container::reseal;
use radiosity_core::half::f16_to_f32;
use radiosity_core::{
    Bounces, DEFAULT_SHIFT, DecodeMode, Format, Gather, Patch, PatchOrder, RadFile,
    ReferenceGather, Rgb, SectionKind, SparseRows, TransferMatrix, decode_bc1_block,
    decode_bc1_block_with, decode_bc4_block, decode_bc4_block_with,
};
use std::borrow::Cow;

/// A fuzz check: panics when its property fails for the input.
pub type Check = fn(&[u8]);

/// The fuzz targets, by the name of their file in `fuzz/fuzz_targets/` and of their corpus
/// folder, with the check each runs.
pub const TARGETS: [(&str, Check); 3] = [
    ("decode_blocks", check_decode_blocks),
    ("parse_container", check_parse_container),
    ("encode_roundtrip", check_encode_roundtrip),
];

// ---------------------------------------------------------------------------------------------
// decode_blocks

/// Largest difference between the [`DecodeMode::Mesa`] and [`DecodeMode::D3d10`] palettes on an
/// interpolated BC1 entry, per channel. Both round `e0 + (e1 − e0)·k` for k = 1/3, 2/3 (four
/// colours) or 1/2 (three colours): D3D10 with the exact fraction, Mesa with 85/256, 170/256
/// (off by at most 255·|1/3 − 85/256| < 0.34 and 255·|2/3 − 170/256| < 0.67 before flooring) or
/// with a rounded instead of a truncated midpoint, so the floors differ by at most 1. The replay
/// test checks this bound exhaustively over every pair of 8-bit endpoints and that it is reached.
pub const BC1_MESA_MAX_DIFF: u8 = 1;

/// The same bound for BC4, per palette entry `t`: the six-value mode (`r0 ≤ r1`, weights
/// `⌊255t/5⌋/256`) stays within 1, but the eight-value mode's weights `⌊255t/7⌋/256` fall short
/// of `t/7` by up to 0.0056 for t = 6 (218/256 against 6/7), 1.4 codes at a 255 span, so after
/// both floors the two modes differ by up to **2** (reached at t = 4 and t = 6; checked
/// exhaustively by the replay test). The endpoints and the constants 0 and 255 are equal.
pub fn bc4_mesa_max_diff(eight_value: bool, t: usize) -> u8 {
    match (eight_value, t) {
        (true, 4 | 6) => 2,
        _ => 1,
    }
}

/// Decodes each 8-byte chunk of `data` as a BC1 and as a BC4 block and compares with texpresso's
/// decoder (exact, RGBA for BC1; the R channel for BC4, texpresso splats it to G and B), then
/// compares the [`DecodeMode::Mesa`] palettes with the D3D10 ones within the documented bounds.
pub fn check_decode_blocks(data: &[u8]) {
    for chunk in data.chunks_exact(8) {
        let block: &[u8; 8] = chunk.try_into().expect("chunks_exact(8)");
        check_bc1_block(block);
        check_bc4_block(block);
    }
}

fn check_bc1_block(block: &[u8; 8]) {
    let ours = decode_bc1_block(block);
    let theirs = texpresso::Format::Bc1.decompress_block(block);
    // texpresso's three-colour index 3 is [0, 0, 0, 0], as ours: compare all four channels.
    assert_eq!(ours, theirs, "BC1 block {block:02x?}: ours vs texpresso");

    let four = u16::from_le_bytes([block[0], block[1]]) > u16::from_le_bytes([block[2], block[3]]);
    let d3d = radiosity_core::Bc1Block(*block).palette(DecodeMode::D3d10);
    let mesa = radiosity_core::Bc1Block(*block).palette(DecodeMode::Mesa);
    assert_eq!(d3d[..2], mesa[..2], "BC1 {block:02x?}: endpoints differ");
    for k in 2..4 {
        for ch in 0..4 {
            let diff = d3d[k][ch].abs_diff(mesa[k][ch]);
            let bound = if ch == 3 || (k == 3 && !four) {
                0 // alpha, and three-colour transparent black, are exact
            } else {
                BC1_MESA_MAX_DIFF
            };
            assert!(
                diff <= bound,
                "BC1 {block:02x?}: palette[{k}][{ch}] D3D10 {} vs Mesa {} differ by {diff} > {bound}",
                d3d[k][ch],
                mesa[k][ch]
            );
        }
    }
    // The texels are the palette looked up by index in both modes.
    let texels = decode_bc1_block_with(block, DecodeMode::Mesa);
    let b = radiosity_core::Bc1Block(*block);
    for (i, t) in texels.iter().enumerate() {
        assert_eq!(
            *t,
            mesa[b.index(i) as usize],
            "BC1 {block:02x?} Mesa texel {i}"
        );
    }
}

fn check_bc4_block(block: &[u8; 8]) {
    let ours = decode_bc4_block(block);
    let theirs = texpresso::Format::Bc4.decompress_block(block);
    for i in 0..16 {
        assert_eq!(
            ours[i], theirs[i][0],
            "BC4 block {block:02x?} texel {i}: ours {} vs texpresso {}",
            ours[i], theirs[i][0]
        );
    }

    let b = radiosity_core::Bc4Block(*block);
    let eight = b.is_eight_value();
    let d3d = b.palette(DecodeMode::D3d10);
    let mesa = b.palette(DecodeMode::Mesa);
    assert_eq!(d3d[..2], mesa[..2], "BC4 {block:02x?}: endpoints differ");
    if !eight {
        assert_eq!((mesa[6], mesa[7]), (0, 255), "BC4 {block:02x?}: constants");
        assert_eq!(d3d[6..], mesa[6..], "BC4 {block:02x?}: constants differ");
    }
    let steps = if eight { 7 } else { 5 };
    for t in 1..steps {
        let diff = d3d[1 + t].abs_diff(mesa[1 + t]);
        let bound = bc4_mesa_max_diff(eight, t);
        assert!(
            diff <= bound,
            "BC4 {block:02x?}: palette[{}] D3D10 {} vs Mesa {} differ by {diff} > {bound}",
            1 + t,
            d3d[1 + t],
            mesa[1 + t]
        );
    }
    let texels = decode_bc4_block_with(block, DecodeMode::Mesa);
    for (i, t) in texels.iter().enumerate() {
        assert_eq!(
            *t,
            mesa[b.index(i) as usize],
            "BC4 {block:02x?} Mesa texel {i}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// parse_container

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
    // A parsed file is ready to gather from (DESIGN: validated, so no decode can go wrong).
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

// ---------------------------------------------------------------------------------------------
// encode_roundtrip

/// A small dense matrix and encoder settings, decoded from fuzz bytes by [`EncodeCase::from_bytes`].
#[derive(Clone, Debug)]
pub struct EncodeCase {
    /// Patches, 1..=24.
    pub n: usize,
    /// 1 or 3.
    pub channels: usize,
    /// Encoder parameters (format, small `max_tile`, shift, sparse fraction, BC1 fit).
    pub params: EncodeParams,
    /// `n · n · channels` finite non-negative values, row-major, channels interleaved.
    pub dense: Vec<f32>,
    /// A first exitance to gather with.
    pub exitance: Vec<Rgb>,
    /// Container fields around the matrix.
    pub bounces: Bounces,
    /// Container field.
    pub patch_order: PatchOrder,
    /// Whether the file carries a report section.
    pub report: bool,
}

impl EncodeCase {
    /// Layout of the input: byte 0 picks n (`1 + b % 24`) and the share of blocks corrected
    /// (`[0, 0.1, 1][b / 24 % 3]`; with corrections the encode is the bake's error-driven one);
    /// byte 1: bit 0 three channels, bits
    /// 1..=3 the format (BC1 only with three channels), bits 4..=5 `max_tile` (4, 8, 16, 8),
    /// bits 6..=7 the sparse fraction (0, 1%, 10%, 100%); byte 2: bits 0..=1 the shift (ln 1000,
    /// 1, 4, 30), bit 2 the iterative BC1 fit, bits 3..=4 the patch order, bit 5 a report, bit
    /// 6 finite bounces, bit 7 a narrow value range. The rest, read cyclically two bytes per
    /// value, gives the entries (see [`value_from`]) and the exitance.
    pub fn from_bytes(data: &[u8]) -> Self {
        let byte = |i: usize| data.get(i).copied().unwrap_or(0);
        let (b0, b1, b2) = (byte(0), byte(1), byte(2));
        let n = 1 + usize::from(b0) % 24;
        let channels = if b1 & 1 != 0 { 3 } else { 1 };
        let sel = usize::from((b1 >> 1) & 7);
        let format = if channels == 3 {
            Format::ALL[sel % 5]
        } else {
            [Format::Bc4, Format::U8, Format::F16, Format::F32][sel % 4]
        };
        let max_tile = [4, 8, 16, 8][usize::from((b1 >> 4) & 3)];
        let sparse_fraction = [0.0, 0.01, 0.1, 1.0][usize::from(b1 >> 6)];
        let shift = [DEFAULT_SHIFT, 1.0, 4.0, 30.0][usize::from(b2 & 3)];
        let params = EncodeParams {
            format,
            max_tile,
            shift,
            sparse_fraction,
            bc1_retry: [0.0, 0.05, 0.5, 1.0][usize::from((b2 >> 3) & 3)],
            bc1_iterative: b2 & 4 != 0,
            corrections: [0.0, 0.1, 1.0][usize::from(b0 / 24) % 3],
        };
        let narrow = b2 & 0x80 != 0;
        let body = data.get(3..).unwrap_or(&[]);
        let pair = |k: usize| -> (u8, u8) {
            if body.is_empty() {
                (0, 0)
            } else {
                (body[(2 * k) % body.len()], body[(2 * k + 1) % body.len()])
            }
        };
        let count = n * n * channels;
        let dense: Vec<f32> = (0..count)
            .map(|k| {
                let (a, b) = pair(k);
                value_from(a, b, narrow)
            })
            .collect();
        let exitance = (0..n)
            .map(|j| {
                let (a, b) = pair(count + j);
                // 0, 0.5, …, 3.5 per channel: small and exact, so products cannot overflow.
                Rgb::new(
                    f32::from(a & 7) * 0.5,
                    f32::from((a >> 3) & 7) * 0.5,
                    f32::from(b & 7) * 0.5,
                )
            })
            .collect();
        EncodeCase {
            n,
            channels,
            params,
            dense,
            exitance,
            bounces: if b2 & 0x40 != 0 {
                Bounces::Finite(1 + u32::from(b0 >> 5))
            } else {
                Bounces::Infinite
            },
            patch_order: PatchOrder::ALL[usize::from((b2 >> 3) & 3)],
            report: b2 & 0x20 != 0,
        }
    }
}

/// One matrix entry from two bytes: `a < 24` gives 0 (about one entry in ten); `a < 28` a
/// subnormal; otherwise `(1 + b/256) · 2^e` with `e` in −120..=107 (a range of 2^227, wider than
/// any shift can hold) or, when `narrow`, in −8..=7.
pub fn value_from(a: u8, b: u8, narrow: bool) -> f32 {
    match a {
        0..24 => 0.0,
        24..28 => f32::from_bits((u32::from(b) << (4 * u32::from(a - 24))) | 1),
        _ => {
            let e = if narrow {
                i32::from(a % 16) - 8
            } else {
                i32::from(a - 28) - 120
            };
            (1.0 + f32::from(b) / 256.0) * 2f32.powi(e)
        }
    }
}

/// Wraps `matrix` in a valid [`RadFile`]: unit-area patches along x facing +z, a reversed
/// order, two objects.
pub fn rad_file_around(
    matrix: TransferMatrix<'static>,
    bounces: Bounces,
    patch_order: PatchOrder,
    report: bool,
) -> RadFile<'static> {
    let n = matrix.layout.n();
    let patches = (0..n)
        .map(|i| Patch {
            centre: [i as f32, 0.5, -1.0],
            area: 0.25 + i as f32,
            normal: [0.0, 0.0, 1.0],
            object: (i % 2) as u32,
            reflectance: Rgb::new(0.5, 0.25, 0.0),
            emission: if i == 0 { Rgb::splat(3.0) } else { Rgb::ZERO },
        })
        .collect();
    RadFile {
        patches: Cow::Owned(patches),
        order: Cow::Owned((0..n as u32).rev().collect()),
        matrix,
        objects: vec![Cow::Borrowed("floor"), Cow::Borrowed("ceiling é")],
        bounces,
        patch_order,
        compression_rmse: Some(0.125),
        lighting_error: None,
        report: report.then_some(Cow::Borrowed("{\"fuzz\":true}")),
        mesh: None,
    }
}

/// Encodes [`EncodeCase::from_bytes`]`(data)`, wraps it in a file, writes and parses it back
/// (equal), then checks the decoded matrix against the input per format (see the body) and the
/// reference gather against a dense f64 mat-vec of the decoded matrix.
pub fn check_encode_roundtrip(data: &[u8]) {
    let case = EncodeCase::from_bytes(data);
    let (n, ch) = (case.n, case.channels);
    let format = case.params.format;
    let f16_overflow = format == Format::F16 && case.dense.iter().any(|v| *v > F16_MAX);
    let encoded = if case.params.corrections > 0.0 {
        encode_dense_with(
            n,
            ch,
            &case.dense,
            &case.params,
            &ErrorWeights::uniform(),
            SparseSelection::ErrorDriven,
        )
    } else {
        encode_dense(n, ch, &case.dense, &case.params)
    };
    let matrix = match encoded {
        Ok(m) => {
            assert!(!f16_overflow, "f16 accepted a value above {F16_MAX}");
            m
        }
        // Refusing values binary16 cannot hold is the correct answer; storing them wrong is not.
        Err(EncodeError::F16Range { .. }) if f16_overflow => return,
        Err(e) => panic!("encode_dense refused a valid input ({format}): {e}"),
    };
    let file = rad_file_around(matrix, case.bounces, case.patch_order, case.report);
    let bytes = file
        .to_bytes()
        .unwrap_or_else(|e| panic!("encoded {format} matrix does not serialise: {e}"));
    let parsed =
        RadFile::parse(&bytes).unwrap_or_else(|e| panic!("written file does not parse: {e}"));
    assert_eq!(
        parsed, file,
        "{format}: file changed through to_bytes → parse"
    );

    let m = &parsed.matrix;
    let decoded = m.decode_dense(DecodeMode::D3d10);
    assert_eq!(decoded.len(), n * n * ch);
    let sparse = sparse_mask(&m.sparse, n, ch);
    let fixes = correction_dense(m);
    if !format.is_log() {
        assert_eq!(
            m.sparse.nnz(),
            0,
            "{format}: float formats keep nothing sparse"
        );
    }
    for r in 0..n {
        for c in 0..n {
            for k in 0..ch {
                let i = (r * n + c) * ch + k;
                let (v, d) = (case.dense[i], decoded[i]);
                let at = || format!("{format} n={n} ch={ch} entry ({r}, {c}) channel {k}");
                assert!(
                    d.is_finite() && d >= 0.0,
                    "{}: decoded {d} not finite and non-negative",
                    at()
                );
                let fix = fixes[i];
                if sparse[r * n + c] {
                    assert_eq!(fix, 0.0, "{}: a sparse texel was corrected", at());
                    // Sparse entries are exact: the list stores the entry minus its block's
                    // decoded value, and decode_dense adds the two back in f32, which rounds
                    // once: within 2^-23 of the larger of the entry and the tile's v_max.
                    let (tile, _, _) = m.layout.locate(r, c);
                    let v_max = m
                        .scales
                        .get(m.layout.scale_index(tile.index, k))
                        .map_or(0.0, |s| s.v_max);
                    let tol = f64::from(v.abs().max(v_max)) * f64::from(f32::EPSILON);
                    assert!(
                        (f64::from(d) - f64::from(v)).abs() <= tol,
                        "{}: sparse entry decoded {d}, stored {v} (tolerance {tol})",
                        at()
                    );
                    continue;
                }
                match format {
                    Format::F32 => assert_eq!(d, v, "{}: f32 must be exact", at()),
                    Format::F16 => check_f16(v, d, &at),
                    Format::U8 | Format::Bc1 | Format::Bc4 => {
                        let (tile, _, _) = m.layout.locate(r, c);
                        let scale = m.scales[m.layout.scale_index(tile.index, k)];
                        if format == Format::U8 {
                            check_u8(v, d, scale.v_max, scale.shift, &at);
                        } else {
                            // Block corrections keep a texel within [0, v_max] as well.
                            assert!(
                                d <= scale.v_max,
                                "{}: decoded {d} above the tile's v_max {} (corrected by {fix})",
                                at(),
                                scale.v_max
                            );
                        }
                    }
                }
            }
        }
    }
    check_gather(m, &decoded, &case.exitance);
}

/// The largest finite binary16 value.
const F16_MAX: f32 = 65504.0;

/// The block corrections alone as a dense `n · n · channels` matrix.
fn correction_dense(m: &TransferMatrix<'_>) -> Vec<f32> {
    let (n, ch) = (m.layout.n(), m.layout.channels());
    let mut out = vec![0f32; n * n * ch];
    m.for_each_correction(|r, c, v| out[(r * n + c) * ch..][..ch].copy_from_slice(&v[..ch]));
    out
}

/// The byte range of section `kind` among `ranges` ([`radiosity_core::container::section_ranges`]).
fn section_range(
    ranges: &[(SectionKind, std::ops::Range<usize>)],
    kind: SectionKind,
) -> std::ops::Range<usize> {
    ranges
        .iter()
        .find(|(k, _)| *k == kind)
        .map(|(_, r)| r.clone())
        .expect("section present")
}

/// Marks the entries held by the sparse list.
fn sparse_mask(sp: &SparseRows<'_>, n: usize, channels: usize) -> Vec<bool> {
    let mut mask = vec![false; n * n];
    for r in 0..n {
        for (c, _) in sp.row(r, channels) {
            mask[r * n + c] = true;
        }
    }
    mask
}

/// f16: round to nearest, so within half an ulp: 2^-11 relative for normal halves, 2^-25
/// absolute in the subnormal range (ulp 2^-24); values up to 65504 (the largest half) must stay
/// finite.
fn check_f16(v: f32, d: f32, at: &dyn Fn() -> String) {
    let tol = (v * (1.0 / 2048.0)).max(1.0 / 33_554_432.0);
    assert!(
        (d - v).abs() <= tol,
        "{}: f16 decoded {d}, stored {v}, |diff| {} > {tol}",
        at(),
        (d - v).abs()
    );
    // d is a half: check it is one (its conversion back is exact).
    assert_eq!(
        f16_to_f32(radiosity_core::half::f32_to_f16(d)),
        d,
        "{}: not a half",
        at()
    );
}

/// u8 log codes: zero stays zero; above the quantiser's floor (the value that rounds to code 1,
/// `v_max · e^(−s + s/510)`) within half a code step, a factor `e^(s/510)`; below it, zero. A
/// relative 1e-4 of slack covers f32 `ln`/`exp` at the rounding boundaries.
fn check_u8(v: f32, d: f32, v_max: f32, s: f32, at: &dyn Fn() -> String) {
    if v == 0.0 {
        assert_eq!(d, 0.0, "{}: zero decoded as {d}", at());
        return;
    }
    let half_step = f64::from(s / 510.0).exp() * (1.0 + 1e-4);
    let floor = f64::from(v_max) * f64::from(-s + s / 510.0).exp();
    let (v64, d64) = (f64::from(v), f64::from(d));
    if v64 >= floor * (1.0 + 1e-4) {
        assert!(
            d64 > 0.0 && d64 / v64 <= half_step && v64 / d64 <= half_step,
            "{}: u8 decoded {d}, stored {v}: ratio {} outside half a step {half_step} (v_max {v_max}, s {s})",
            at(),
            d64 / v64
        );
    } else if v64 < floor * (1.0 - 1e-4) {
        assert_eq!(
            d,
            0.0,
            "{}: {v} is below the floor {floor} but decoded {d}",
            at()
        );
    }
}

/// The reference gather against a dense mat-vec of `decode_dense`, both in f64.
///
/// Tolerance, per output channel, with `S = Σ_j |m_ij · x_j| + 2·Σ_{sparse j} |s_ij · x_j|`:
/// every product of two f32 is exact in f64 and ≤ 48 terms are summed in f64 (relative error
/// below 48·2^-53 < 2^-47 of S) on both sides; `decode_dense` adds a sparse value `s` to its
/// block texel `b` in f32 where the gather adds them in f64, an error of at most 2^-24 of
/// `|b + s|`'s operands, `|b| + |s| ≤ |m| + 2|s|` (the sparse value stores exact minus decoded,
/// so `b` and `s` can cancel: the fuzzer found a row that the gather sums to 0 and the dense
/// decode to 2.6e-19, a rounding residue of that f32 addition, `regressions/encode_roundtrip/
/// sparse-residual-cancels-block-texel.bin`); each side rounds its f64
/// sum to f32 once (≤ 2^-24 of S each). So the difference is below 4·2^-24·S, plus two
/// half-ulps of the smallest subnormal where the result underflows.
fn check_gather(m: &TransferMatrix<'_>, decoded: &[f32], x: &[Rgb]) {
    let (n, ch) = (m.layout.n(), m.layout.channels());
    let mut gather = ReferenceGather::new(m.clone(), DecodeMode::D3d10);
    let mut y = vec![Rgb::ZERO; n];
    gather.gather(x, &mut y).expect("gather");
    // A corrected entry is decoded as one f32 sum but gathered as two terms, like a sparse one.
    let fixes = correction_dense(m);
    for r in 0..n {
        for k in 0..3 {
            let (mut sum, mut s) = (0f64, 0f64);
            for c in 0..n {
                let e = decoded[(r * n + c) * ch + if ch == 1 { 0 } else { k }];
                let t = f64::from(e) * f64::from(x[c].channel(k));
                sum += t;
                s += t.abs();
            }
            let sp = &m.sparse;
            for idx in sp.row_ptr[r] as usize..sp.row_ptr[r + 1] as usize {
                let c = sp.cols[idx] as usize;
                let v = sp.values[idx * ch + if ch == 1 { 0 } else { k }];
                s += 2.0 * (f64::from(v) * f64::from(x[c].channel(k))).abs();
            }
            for c in 0..n {
                let f = fixes[(r * n + c) * ch + if ch == 1 { 0 } else { k }];
                s += 2.0 * (f64::from(f) * f64::from(x[c].channel(k))).abs();
            }
            let (got, want) = (y[r].channel(k), sum as f32);
            let tol = 4.0 * s / 16_777_216.0 + 2.0 * f64::from(f32::from_bits(1));
            let diff = (f64::from(got) - f64::from(want)).abs();
            assert!(
                diff <= tol,
                "gather row {r} channel {k}: reference {got}, dense {want}, |diff| {diff} > {tol}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// seed corpus

/// One seed file: the target's corpus folder, a file name, the bytes.
#[derive(Clone, Debug)]
pub struct Seed {
    /// Target (corpus folder) name.
    pub target: &'static str,
    /// File name within it.
    pub name: String,
    /// Contents.
    pub bytes: Vec<u8>,
}

/// A tiny xorshift generator: the corpus must be the same on every machine.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn bytes(&mut self, len: usize) -> Vec<u8> {
        (0..len).map(|_| self.next() as u8).collect()
    }
}

/// The encode-roundtrip input that selects `n`, channels, format and so on (see
/// [`EncodeCase::from_bytes`]), followed by `body`.
fn encode_input(
    n: usize,
    three: bool,
    format_sel: u8,
    b1_high: u8,
    b2: u8,
    body: &[u8],
) -> Vec<u8> {
    let mut v = vec![
        (n - 1) as u8,
        u8::from(three) | (format_sel << 1) | b1_high,
        b2,
    ];
    v.extend_from_slice(body);
    v
}

/// The whole seed corpus, deterministic. Written to `fuzz/corpus/<target>/` by the replay
/// test when `RADIOSITY_WRITE_FUZZ_CORPUS=1` (see `fuzz/README.md`).
pub fn seed_corpus() -> Vec<Seed> {
    let mut seeds = Vec::new();
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);

    // decode_blocks: the special cases, then random blocks.
    let special: [(&str, [u8; 8]); 10] = [
        ("zero", [0; 8]),
        ("ones", [0xff; 8]),
        (
            "bc1-c0-gt-c1",
            [0x00, 0xf8, 0xe0, 0x07, 0xe4, 0xe4, 0x1b, 0x1b],
        ),
        (
            "bc1-c0-eq-c1",
            [0x10, 0x84, 0x10, 0x84, 0xff, 0x00, 0xe4, 0x1b],
        ),
        (
            "bc1-c0-lt-c1",
            [0x41, 0x08, 0x9e, 0xf7, 0xff, 0xe4, 0x1b, 0x00],
        ),
        (
            "bc1-black-white",
            [0x00, 0x00, 0xff, 0xff, 0x1b, 0x1b, 0xe4, 0xe4],
        ),
        ("bc4-r0-gt-r1", [255, 0, 0x88, 0xc6, 0xfa, 0x88, 0xc6, 0xfa]),
        ("bc4-r0-lt-r1", [0, 255, 0x88, 0xc6, 0xfa, 0x88, 0xc6, 0xfa]),
        (
            "bc4-r0-eq-r1",
            [128, 128, 0xff, 0xff, 0xff, 0x00, 0x00, 0x00],
        ),
        ("bc4-near", [201, 200, 0x39, 0x77, 0x05, 0xaf, 0x3b, 0x12]),
    ];
    for (name, block) in special {
        seeds.push(Seed {
            target: "decode_blocks",
            name: format!("{name}.bin"),
            bytes: block.to_vec(),
        });
    }
    for i in 0..6 {
        seeds.push(Seed {
            target: "decode_blocks",
            name: format!("random-{i}.bin"),
            bytes: rng.bytes(64),
        });
    }

    // encode_roundtrip: every format and channel count, edge sizes, zeros, both ranges.
    let mut enc: Vec<(String, Vec<u8>)> = Vec::new();
    let names = ["bc1", "bc4", "u8", "f16", "f32"];
    for (sel, name) in names.iter().enumerate() {
        for (n, three) in [(1, true), (5, true), (17, false), (24, true)] {
            if sel == 0 && !three {
                continue;
            }
            let format_sel = if three {
                sel as u8
            } else {
                (sel as u8).saturating_sub(1)
            };
            // narrow range, 1% sparse, tiles of 8
            let body = rng.bytes(2 * n * n * if three { 3 } else { 1 } + 2 * n);
            enc.push((
                format!("{name}-n{n}-ch{}-narrow.bin", if three { 3 } else { 1 }),
                encode_input(n, three, format_sel, 0x40 | 0x10, 0x80, &body),
            ));
        }
        // wide range, 10% sparse, tiles of 4, shift 4, with a report and finite bounces
        enc.push((
            format!("{name}-n9-wide.bin"),
            encode_input(
                9,
                true,
                sel as u8,
                0x80,
                0x62,
                &rng.bytes(2 * 9 * 9 * 3 + 18),
            ),
        ));
    }
    enc.push((
        "all-zero.bin".into(),
        encode_input(12, true, 0, 0x40, 0, &[0; 8]),
    ));
    enc.push(("empty.bin".into(), Vec::new()));
    enc.push((
        "bc1-all-sparse.bin".into(),
        encode_input(7, true, 0, 0xc0, 0x80, &rng.bytes(40)),
    ));
    for (name, bytes) in enc {
        seeds.push(Seed {
            target: "encode_roundtrip",
            name,
            bytes,
        });
    }

    // parse_container: real files, then truncated, flipped and resealed variants.
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for (name, input) in [
        (
            "bc1-n6",
            encode_input(6, true, 0, 0x40 | 0x10, 0x80, &rng.bytes(60)),
        ),
        (
            "bc4-n5-grey",
            encode_input(5, false, 0, 0x80, 0xa0, &rng.bytes(50)),
        ),
        (
            "u8-n9-tiles4",
            encode_input(9, true, 2, 0x40, 0x80, &rng.bytes(60)),
        ),
        ("f16-n3", encode_input(3, false, 2, 0, 0x80, &rng.bytes(20))),
        ("f32-n2", encode_input(2, true, 4, 0, 0x60, &rng.bytes(20))),
    ] {
        let case = EncodeCase::from_bytes(&input);
        let m =
            encode_dense(case.n, case.channels, &case.dense, &case.params).expect("seed encodes");
        let file = rad_file_around(m, case.bounces, case.patch_order, case.report);
        files.push((name.into(), file.to_bytes().expect("seed writes")));
    }
    for (name, bytes) in &files {
        seeds.push(Seed {
            target: "parse_container",
            name: format!("{name}.rad"),
            bytes: bytes.clone(),
        });
    }
    let (_, base) = &files[0];
    let ranges = radiosity_core::container::section_ranges(base).expect("seed has sections");
    for (kind, range) in &ranges {
        // Truncated at the start of each section, and one byte into it.
        seeds.push(Seed {
            target: "parse_container",
            name: format!("truncated-at-{}.rad", kind.name().to_lowercase()),
            bytes: base[..range.start].to_vec(),
        });
    }
    seeds.push(Seed {
        target: "parse_container",
        name: "header-only.rad".into(),
        bytes: base[..32].to_vec(),
    });
    for (i, at) in [0usize, 9, 20, 40, 70, base.len() - 1]
        .into_iter()
        .enumerate()
    {
        let mut b = base.clone();
        b[at] ^= 1 << (i % 8);
        seeds.push(Seed {
            target: "parse_container",
            name: format!("flipped-{at}.rad"),
            bytes: b,
        });
    }
    // Semantic corruptions behind valid checksums: a NaN value, a bad count, a repeated order
    // entry, a huge object count.
    let find = |kind: SectionKind| section_range(&ranges, kind);
    let mut resealed = |name: &str, edit: &dyn Fn(&mut Vec<u8>)| {
        let mut b = base.clone();
        edit(&mut b);
        reseal(&mut b).expect("reseal");
        seeds.push(Seed {
            target: "parse_container",
            name: format!("resealed-{name}.rad"),
            bytes: b,
        });
    };
    let meta = find(SectionKind::Meta);
    let patches = find(SectionKind::Patches);
    let order = find(SectionKind::Order);
    let scales = find(SectionKind::Scales);
    let objects = find(SectionKind::Objects);
    resealed("nan-area", &|b| {
        b[patches.start + 12..patches.start + 16].copy_from_slice(&f32::NAN.to_le_bytes())
    });
    resealed("zero-scale", &|b| b[scales.start..scales.start + 4].fill(0));
    resealed("order-repeat", &|b| {
        let first: [u8; 4] = b[order.start..order.start + 4].try_into().unwrap();
        b[order.start + 4..order.start + 8].copy_from_slice(&first);
    });
    resealed("n-huge", &|b| {
        b[meta.start..meta.start + 4].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    resealed("object-count-huge", &|b| {
        b[meta.start + 24..meta.start + 28].copy_from_slice(&0x4000_0000u32.to_le_bytes())
    });
    resealed("object-offset-past-end", &|b| {
        b[objects.start + 4..objects.start + 8].copy_from_slice(&1000u32.to_le_bytes())
    });
    resealed("section-count-11", &|b| b[12] = 11);
    seeds.push(Seed {
        target: "parse_container",
        name: "empty.rad".into(),
        bytes: Vec::new(),
    });

    // A file with block corrections (every block that gains), 10 patches so that the last
    // block row and column hold padding, and two corruptions of its corrections.
    let mut input = encode_input(10, true, 0, 0x40, 0x80, &rng.bytes(80));
    input[0] += 48;
    let case = EncodeCase::from_bytes(&input);
    assert_eq!(
        case.params.corrections, 1.0,
        "the seed asks for corrections"
    );
    let m = encode_dense(case.n, case.channels, &case.dense, &case.params).expect("seed encodes");
    assert!(!m.corrections.is_empty(), "the seed has corrections");
    let corrected = rad_file_around(m, case.bounces, case.patch_order, case.report)
        .to_bytes()
        .expect("seed writes");
    let ranges = radiosity_core::container::section_ranges(&corrected).expect("sections");
    let find = |kind: SectionKind| section_range(&ranges, kind);
    let (cols, codes) = (
        find(SectionKind::CorrectionCols),
        find(SectionKind::CorrectionCodes),
    );
    let mut variants = vec![("bc1-n10-corrected.rad", corrected.clone())];
    let mut b = corrected.clone();
    b[cols.start..cols.start + 4].copy_from_slice(&3u32.to_le_bytes());
    variants.push(("resealed-correction-column-past-end.rad", b));
    let mut b = corrected.clone();
    b[codes.start..codes.end].fill(0x11);
    variants.push(("resealed-correction-codes-all-minus-7.rad", b));
    for (name, mut bytes) in variants {
        if name.starts_with("resealed") {
            reseal(&mut bytes).expect("reseal");
        }
        seeds.push(Seed {
            target: "parse_container",
            name: name.into(),
            bytes,
        });
    }
    let mut input = encode_input(9, false, 0, 0x40, 0x80, &rng.bytes(60));
    input[0] += 24;
    seeds.push(Seed {
        target: "encode_roundtrip",
        name: "bc4-grey-corrected.bin".into(),
        bytes: input,
    });
    seeds
}
