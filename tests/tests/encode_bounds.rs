//! Encode → decode error bounds, per format, each bound derived from the format's arithmetic.

use radiosity_bake::encode::{
    Bc1Fit, EncodeParams, encode_bc1_block, encode_bc4_block, encode_dense,
};
use radiosity_core::{Bc1Block, DecodeMode, Format, decode_bc4_block};
use radiosity_tests::fixtures::{SplitMix64, transfer_like_matrix};

const N: usize = 45;

fn dense(channels: usize) -> Vec<f32> {
    transfer_like_matrix(N, channels, 11)
}

fn encode(format: Format, channels: usize, sparse_fraction: f32) -> (Vec<f32>, Vec<f32>) {
    let m = dense(channels);
    let params = EncodeParams {
        format,
        max_tile: 16,
        sparse_fraction,
        ..EncodeParams::default()
    };
    let t = encode_dense(N, channels, &m, &params).unwrap();
    t.validate().unwrap();
    (m, t.decode_dense(DecodeMode::D3d10))
}

#[test]
fn f32_is_exact_and_f16_within_half_an_ulp() {
    let (m, d) = encode(Format::F32, 3, 0.01);
    assert_eq!(m, d, "f32 stores values as they are");
    let (m, d) = encode(Format::F16, 3, 0.01);
    for (a, b) in m.iter().zip(&d) {
        // Round to nearest binary16: relative error ≤ 2^-11 for normal halves (≥ 2^-14),
        // absolute ≤ 2^-25 (half the subnormal step) below.
        let tol = (a.abs() * (2f32).powi(-11)).max((2f32).powi(-25));
        assert!(
            (a - b).abs() <= tol,
            "f16: {a} decoded as {b} (tolerance {tol})"
        );
    }
}

#[test]
fn u8_log_codes_within_half_a_step() {
    let params = EncodeParams::for_format(Format::U8);
    for channels in [1, 3] {
        let m = dense(channels);
        let p = EncodeParams {
            max_tile: 16,
            ..params
        };
        let t = encode_dense(N, channels, &m, &p).unwrap();
        let d = t.decode_dense(DecodeMode::D3d10);
        let mut exact = 0;
        for (e, (a, b)) in m.iter().zip(&d).enumerate() {
            let (row, col, ch) = (e / channels / N, e / channels % N, e % channels);
            let (tile, _, _) = t.layout.locate(row, col);
            let scale = t.scales[t.layout.scale_index(tile.index, ch)];
            // Each tile has its own log range (≤ p.shift): half of its code step, with slack
            // for f32 exp/ln.
            let half_step = (scale.shift / 255.0 / 2.0).exp() * (1.0 + 1e-5);
            // Values below the quantiser's floor (half a step above v_max·e^-s) may become 0.
            let floor = scale.v_max * (-scale.shift).exp() * half_step;
            if *a == 0.0 {
                assert_eq!(*b, 0.0, "zero must stay exactly zero");
            } else if *a == *b {
                exact += 1; // sparse entries are kept exactly
            } else if *a > floor {
                assert!(
                    b / a <= half_step && a / b <= half_step,
                    "({row},{col}) ch {ch}: {a} → {b}"
                );
            } else {
                assert!(
                    *b <= floor,
                    "below the floor decodes to 0 or the first code: {a} → {b}"
                );
            }
        }
        assert!(
            exact >= N * N * channels / 100,
            "about 1% of entries are sparse and exact"
        );
    }
}

#[test]
fn bc4_block_rms_within_range_over_fourteen() {
    // The encoder tries the eight-value fit with endpoints at the block's min and max: every
    // code is within half a palette step, (max − min)/14, plus one for integer truncation. It
    // keeps that fit or a better one (by squared error), so the RMS error is within the same
    // bound. (texpresso alone failed this: see `encode_bc4_block`.)
    let mut rng = SplitMix64(3);
    for _ in 0..50_000 {
        let base = (rng.next_u64() % 256) as i32;
        let spread = (rng.next_u64() % 256) as i32;
        let codes: [u8; 16] = core::array::from_fn(|_| {
            (base + (rng.next_u64() % (spread as u64 + 1)) as i32 - spread / 2).clamp(0, 255) as u8
        });
        let decoded = decode_bc4_block(&encode_bc4_block(&codes, 0xffff));
        let (lo, hi) = (codes.iter().min().unwrap(), codes.iter().max().unwrap());
        let bound = f64::from(hi - lo) / 14.0 + 1.0;
        let sse: f64 = codes
            .iter()
            .zip(&decoded)
            .map(|(a, b)| (f64::from(*a) - f64::from(*b)).powi(2))
            .sum();
        let rms = (sse / 16.0).sqrt();
        assert!(
            rms <= bound,
            "codes {codes:?} → {decoded:?}: rms {rms} > {bound}"
        );
    }
}

#[test]
fn bc1_grey_block_rms_within_bound_and_never_black() {
    // Grey codes (R = G = B) along a line: a four-colour fit with endpoints at min and max is
    // off by at most a sixth of the range (half the palette spacing), plus 565 endpoint rounding
    // (half a 5-bit step: 255/31/2 ≈ 4.1) and one for truncation. Cluster fit minimises squared
    // error over orderings, so its RMS is within the same bound. The adversarial blocks (all
    // within ±2 of one value) are where endpoints collapse to one 565 colour: the guard must keep
    // every texel opaque, i.e. never the transparent index of a three-colour block.
    let mut rng = SplitMix64(5);
    for i in 0..50_000 {
        let base = (rng.next_u64() % 256) as i32;
        let spread = if i % 2 == 0 {
            4
        } else {
            (rng.next_u64() % 256) as i32
        };
        let codes: [[u8; 3]; 16] = core::array::from_fn(|_| {
            let v = (base + (rng.next_u64() % (spread as u64 + 1)) as i32 - spread / 2)
                .clamp(0, 255) as u8;
            [v, v, v]
        });
        let block: Bc1Block = encode_bc1_block(&codes, 0xffff, Bc1Fit::Cluster);
        let decoded = block.decode(DecodeMode::D3d10);
        assert!(
            decoded.iter().all(|t| t[3] == 255),
            "transparent texel: {codes:?} → {block:?}"
        );
        let (lo, hi) = (
            codes.iter().map(|c| c[0]).min().unwrap(),
            codes.iter().map(|c| c[0]).max().unwrap(),
        );
        let bound = f64::from(hi - lo) / 6.0 + 255.0 / 31.0 / 2.0 + 1.0;
        for ch in 0..3 {
            let sse: f64 = codes
                .iter()
                .zip(&decoded)
                .map(|(a, b)| (f64::from(a[ch]) - f64::from(b[ch])).powi(2))
                .sum();
            let rms = (sse / 16.0).sqrt();
            assert!(
                rms <= bound,
                "channel {ch}: {codes:?} → {decoded:?}: rms {rms} > {bound}"
            );
        }
    }
}

#[test]
fn bc1_coloured_blocks_are_never_transparent() {
    // Arbitrary colours (not on a line) can be poorly fit, but never decode to transparent black.
    let mut rng = SplitMix64(9);
    for _ in 0..50_000 {
        let codes: [[u8; 3]; 16] = core::array::from_fn(|_| {
            let b = rng.next_bytes();
            [b[0] | 1, b[1] | 1, b[2] | 1] // non-zero codes: no texel means "zero"
        });
        let block = encode_bc1_block(&codes, 0xffff, Bc1Fit::Cluster);
        assert!(
            block.decode(DecodeMode::D3d10).iter().all(|t| t[3] == 255),
            "{codes:?} → {block:?}"
        );
    }
}

#[test]
fn whole_matrix_errors_are_ordered_and_small() {
    // Relative Frobenius error of the decoded matrix on a deliberately noisy transfer-like
    // matrix (45 patches, ±20% noise between neighbours, tiles of 16, 1% sparse). One log code
    // step is e^(s/255) ≈ 2.7%, and a BC1 565 endpoint is 4–8 codes coarse, so per-entry errors
    // of 10–20% are expected for BC1 on noise; real form-factor matrices are smoother and the
    // gather averages errors out (lighting error is the bake's measure). The bounds sit ~1.5×
    // above the values measured when this test was written and, more to the point, require the
    // order the formats promise: u8 (pure quantisation) beats bc4, which beats bc1.
    let rel = |format, channels| {
        let (m, d) = encode(format, channels, 0.01);
        let num: f64 = m
            .iter()
            .zip(&d)
            .map(|(a, b)| f64::from(a - b).powi(2))
            .sum();
        let den: f64 = m.iter().map(|a| f64::from(*a).powi(2)).sum();
        (num / den).sqrt()
    };
    let (u8e, bc4e, bc1e) = (rel(Format::U8, 3), rel(Format::Bc4, 3), rel(Format::Bc1, 3));
    eprintln!("relative Frobenius error: u8 {u8e:.4}, bc4 {bc4e:.4}, bc1 {bc1e:.4}");
    assert!(
        u8e < bc4e && bc4e < bc1e,
        "u8 {u8e} < bc4 {bc4e} < bc1 {bc1e}"
    );
    assert!(
        u8e < 0.0075 && bc4e < 0.06 && bc1e < 0.30,
        "u8 {u8e}, bc4 {bc4e}, bc1 {bc1e}"
    );
    // Keeping the largest entries exact must help.
    let (m, d) = encode(Format::Bc1, 3, 0.0);
    let no_sparse: f64 = m
        .iter()
        .zip(&d)
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum::<f64>()
        .sqrt()
        / m.iter().map(|a| f64::from(*a).powi(2)).sum::<f64>().sqrt();
    assert!(
        no_sparse > bc1e,
        "sparse 1% ({bc1e}) must beat none ({no_sparse})"
    );
}

#[test]
fn grey_matrices_use_one_channel_and_bc1_refuses_them() {
    let m = dense(1);
    let t = encode_dense(N, 1, &m, &EncodeParams::for_format(Format::Bc4)).unwrap();
    assert_eq!(t.layout.planes(), 1);
    let three = encode_dense(N, 3, &dense(3), &EncodeParams::for_format(Format::Bc4)).unwrap();
    assert_eq!(
        three.blocks.len(),
        3 * t.blocks.len(),
        "one channel stores a third of the blocks"
    );
    assert!(encode_dense(N, 1, &m, &EncodeParams::for_format(Format::Bc1)).is_err());
}

#[test]
fn bad_input_is_refused() {
    let mut m = dense(1);
    m[5] = f32::NAN;
    assert!(matches!(
        encode_dense(N, 1, &m, &EncodeParams::for_format(Format::U8)),
        Err(radiosity_bake::encode::EncodeError::Value { row: 0, col: 5, .. })
    ));
    assert!(encode_dense(N, 1, &m[..10], &EncodeParams::for_format(Format::U8)).is_err());
    let p = EncodeParams {
        shift: 0.0,
        ..EncodeParams::for_format(Format::U8)
    };
    assert!(encode_dense(N, 1, &dense(1), &p).is_err());
}
