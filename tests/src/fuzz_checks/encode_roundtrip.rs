//! `encode_roundtrip`: encode a matrix drawn from the input, write it, parse it back and
//! gather with it.

use radiosity_bake::encode::{
    EMITTER_ERROR_LIMIT, EncodeError, EncodeParams, ErrorWeights, SparseSelection, encode_dense,
    encode_dense_with,
};
use radiosity_core::half::f16_to_f32;
use radiosity_core::{
    Bounces, DEFAULT_SHIFT, DecodeMode, Format, Gather, Patch, PatchOrder, RadFile,
    ReferenceGather, Rgb, SectionKind, SparseRows, TransferMatrix,
};
use std::borrow::Cow;

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
            emitter_error_limit: EMITTER_ERROR_LIMIT,
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
        patch_order,
        compression_rmse: Some(0.125),
        report: report.then_some(Cow::Borrowed("{\"fuzz\":true}")),
        ..RadFile::new(
            Cow::Owned(patches),
            Cow::Owned((0..n as u32).rev().collect()),
            matrix,
            vec![Cow::Borrowed("floor"), Cow::Borrowed("ceiling é")],
            bounces,
        )
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
pub(super) fn section_range(
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
