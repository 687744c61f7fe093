//! Choosing the block corrections ([`radiosity_core::BlockCorrections`]) of an encoded matrix.
//!
//! Every block's residual after the block fit and the sparse list is quantised to sixteen
//! signed 4-bit multiples per channel of the smallest scale step that covers its largest
//! residual; the blocks where that removes the most weighted squared error are kept, as many as
//! the budget allows. In a good order the error sits in few blocks, so a few corrections remove
//! much of it; in a random order it is spread and they remove little (ARCHITECTURE.md, "Block
//! corrections").

use super::ErrorWeights;
use radiosity_core::corrections::{EXPONENT_STEPS, ZERO_NIBBLE, scale};
use radiosity_core::{BlockCorrections, DecodeMode, LogScale, MatrixLayout, TransferMatrix};
use rayon::prelude::*;
use std::borrow::Cow;

/// The largest multiple a scale is chosen for: the block's largest residual maps to ±7, so
/// rounding never needs the −8 the nibble could hold.
const TOP_MULTIPLE: f32 = 7.0;

/// One block's candidate correction.
struct Candidate {
    /// Weighted squared error it removes.
    gain: f64,
    /// Block index, row-major over the padded matrix's block rows and columns.
    block: usize,
    exponents: [u8; 3],
    codes: [[u32; 2]; 3],
}

/// The best `count` corrections of `m` (blocks and sparse part already final) against the
/// exact `dense`, judged by `weights`. Blocks in a column block that holds an emitter get
/// none: the coupled pass (`refine::Coupling`) encoded them so that their errors cancel
/// along each block row for the scene's own light, and a correction fitted to one block
/// undoes that. Measured on the Cornell box at 4098 patches, BC1 paper order: with them
/// Frobenius 1.748%, own-light error 0.294%; without them 1.628%, 0.205% (their weighted gains
/// had drawn the budget to them).
pub(super) fn choose(
    m: &TransferMatrix<'_>,
    dense: &[f32],
    weights: &ErrorWeights,
    count: usize,
) -> BlockCorrections<'static> {
    let l = &m.layout;
    let (n, ch) = (l.n(), l.channels());
    let side = l.padded() / 4;
    if count == 0 || !super::takes_corrections(l.format()) {
        return BlockCorrections::empty(n);
    }
    let base = bases(l, &m.scales);
    // The coupled pass encoded the emitters' column blocks against their whole block row's
    // error; a correction fitted to one block alone would undo that.
    let coupled: Vec<bool> = (0..side)
        .map(|bc| weights.emits_in_column_block(bc, n))
        .collect();
    let decoder = m.decoder(DecodeMode::D3d10);
    let mut candidates: Vec<Candidate> = (0..side)
        .into_par_iter()
        .flat_map_iter(|br| {
            // The block row as decoded: blocks, then the sparse entries of its four rows (their
            // texels are exact and keep the zero multiple).
            let mut row = vec![([[0f32; 16]; 3], 0u16); side];
            for (bc, (vals, _)) in row.iter_mut().enumerate().filter(|(bc, _)| !coupled[*bc]) {
                let (tile, tbr, tbc) = l.locate(br * 4, bc * 4);
                decoder.decode(m, &tile, tbr, tbc, vals);
            }
            for r in br * 4..(br * 4 + 4).min(n) {
                for (c, v) in m.sparse.row(r, ch) {
                    let t = (r % 4) * 4 + c % 4;
                    let (vals, sparse) = &mut row[c / 4];
                    *sparse |= 1 << t;
                    for k in 0..ch {
                        vals[k][t] += v[k];
                    }
                }
            }
            let coupled = &coupled;
            (0..side).filter(|bc| !coupled[*bc]).filter_map(move |bc| {
                let (vals, sparse) = &row[bc];
                let tile = l.locate(br * 4, bc * 4).0;
                let ceiling = core::array::from_fn(|k| {
                    m.scales
                        .get(l.scale_index(tile.index, k))
                        .map_or(0.0, |s| s.v_max)
                });
                candidate(
                    br, bc, vals, *sparse, dense, n, ch, weights, &base, &ceiling,
                )
            })
        })
        .collect();
    let count = count.min(candidates.len());
    if count == 0 {
        return BlockCorrections::empty(n);
    }
    // The largest gains, ties broken by block index: the same choice on any thread count.
    let better =
        |a: &Candidate, b: &Candidate| b.gain.total_cmp(&a.gain).then(a.block.cmp(&b.block));
    candidates.select_nth_unstable_by(count - 1, better);
    candidates.truncate(count);
    candidates.sort_unstable_by_key(|c| c.block);

    let mut row_ptr = Vec::with_capacity(side + 1);
    let mut cols = Vec::with_capacity(count);
    let mut exponents = Vec::with_capacity(count * ch);
    let mut codes = Vec::with_capacity(count * ch * 2);
    row_ptr.push(0u32);
    let mut next = candidates.iter().peekable();
    for br in 0..side {
        while let Some(c) = next.next_if(|c| c.block / side == br) {
            cols.push((c.block % side) as u32);
            exponents.extend_from_slice(&c.exponents[..ch]);
            for words in &c.codes[..ch] {
                codes.extend_from_slice(words);
            }
        }
        row_ptr.push(cols.len() as u32);
    }
    BlockCorrections {
        row_ptr: Cow::Owned(row_ptr),
        cols: Cow::Owned(cols),
        exponents: Cow::Owned(exponents),
        codes: Cow::Owned(codes),
        base,
    }
}

/// The correction of block (`br`, `bc`) whose decoded values are `decoded` and whose texels
/// in the mask `sparse` are exact, if it removes any error.
fn candidate(
    br: usize,
    bc: usize,
    decoded: &[[f32; 16]; 3],
    sparse: u16,
    dense: &[f32],
    n: usize,
    ch: usize,
    weights: &ErrorWeights,
    base: &[f32; 3],
    ceiling: &[f32; 3],
) -> Option<Candidate> {
    let mut exact = [[f32::NAN; 16]; 3];
    for t in 0..16 {
        let (r, col) = (br * 4 + t / 4, bc * 4 + t % 4);
        if r < n && col < n && sparse & (1 << t) == 0 {
            for k in 0..ch {
                exact[k][t] = dense[(r * n + col) * ch + k];
            }
        }
    }
    let (gain, exponents, codes) = fit(decoded, &exact, ch, base, ceiling, |t, k| {
        weights.weight(bc * 4 + t % 4, k, ch)
    });
    (gain > 0.0).then_some(Candidate {
        gain,
        block: br * n.div_ceil(4) + bc,
        exponents,
        codes,
    })
}

/// Per channel, the scale of exponent 0: the largest `v_max` of any tile over 7. No residual
/// exceeds the largest decodable value (entries above their tile's `v_max` are sparse and
/// exact), so exponent 0 covers every block. Zero for the float formats (no scales).
pub(crate) fn bases(layout: &MatrixLayout, scales: &[LogScale]) -> [f32; 3] {
    let mut base = [0f32; 3];
    for (k, b) in base.iter_mut().enumerate().take(layout.channels()) {
        *b = (0..layout.tile_count())
            .map(|t| {
                scales
                    .get(layout.scale_index(t, k))
                    .map_or(0.0, |s| s.v_max)
            })
            .fold(0.0, f32::max)
            / TOP_MULTIPLE;
    }
    base
}

/// A block's correction: the weighted squared error it removes (`weight(texel, channel)`),
/// its exponents and its code words. `decoded` is what the block (and the sparse list)
/// decode to, `exact` the entries, NaN on texels that do not count (exact already, or beyond
/// the last patch), which keep the zero multiple. Every corrected value stays within
/// `[0, ceiling]` of its channel (the tile's `v_max`) as decoded (`decoded + multiple · scale`
/// in `f32`), so a corrected block keeps the promise of an uncorrected one.
pub(crate) fn fit(
    decoded: &[[f32; 16]; 3],
    exact: &[[f32; 16]; 3],
    ch: usize,
    base: &[f32; 3],
    ceiling: &[f32; 3],
    weight: impl Fn(usize, usize) -> f32,
) -> (f64, [u8; 3], [[u32; 2]; 3]) {
    debug_assert_eq!(ZERO_NIBBLE, 8);
    let mut gain = 0f64;
    let mut exponents = [0u8; 3];
    let mut codes = [[0x8888_8888u32; 2]; 3];
    for k in 0..ch {
        let counts = |t: &usize| !exact[k][*t].is_nan();
        let residual = |t: usize| exact[k][t] - decoded[k][t];
        let largest = (0..16)
            .filter(counts)
            .map(|t| residual(t).abs())
            .fold(0f32, f32::max);
        if !(largest > 0.0 && largest.is_finite()) {
            continue;
        }
        let e = exponent(base[k], largest / TOP_MULTIPLE);
        let s = scale(base[k], e);
        exponents[k] = e;
        for t in (0..16).filter(counts) {
            let res = residual(t);
            let mut q = (res / s).round().clamp(-8.0, 7.0);
            while q < 0.0 && decoded[k][t] + q * s < 0.0 {
                q += 1.0;
            }
            while q > 0.0 && decoded[k][t] + q * s > ceiling[k] {
                q -= 1.0;
            }
            let after = res - q * s;
            gain += f64::from(weight(t, k)) * (f64::from(res).powi(2) - f64::from(after).powi(2));
            let nibble = (q as i32 + ZERO_NIBBLE as i32) as u32;
            let word = &mut codes[k][t / 8];
            *word = (*word & !(15 << (4 * (t % 8)))) | nibble << (4 * (t % 8));
        }
    }
    (gain, exponents, codes)
}

/// How many blocks `params` corrects in a matrix of `side²` block positions.
pub(crate) fn count(params: &super::EncodeParams, side: usize) -> usize {
    if super::takes_corrections(params.format) {
        (f64::from(params.corrections) * (side * side) as f64) as usize
    } else {
        0
    }
}

/// The largest exponent whose scale still covers `needed` (at least `needed`), 0 to 255.
fn exponent(base: f32, needed: f32) -> u8 {
    let guess = (f64::from(EXPONENT_STEPS) * (f64::from(base) / f64::from(needed)).log2()).floor();
    let mut e = guess.clamp(0.0, 255.0) as u8;
    while e > 0 && scale(base, e) < needed {
        e -= 1;
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exponent_is_the_finest_scale_that_covers() {
        for needed in [1e-9f32, 3.7e-5, 0.01, 0.3, 0.999, 1.0] {
            let e = exponent(1.0, needed);
            assert!(scale(1.0, e) >= needed || e == 0, "{needed}");
            if e < 255 {
                assert!(
                    scale(1.0, e + 1) < needed,
                    "{needed}: e = {e} is not the finest"
                );
            }
        }
        // Beyond 32 octaves the finest scale is the last one.
        assert_eq!(exponent(1.0, 1e-12), 255);
    }

    /// With every block allowed a correction, the column blocks of emitters still get none,
    /// most other blocks do, and the corrections lower the error.
    #[test]
    fn emitter_columns_keep_their_coupled_encode() {
        use crate::encode::{EncodeParams, SparseSelection, encode_dense_with};
        use radiosity_core::{Format, Rgb};
        let n = 24;
        let dense: Vec<f32> = (0..n * n * 3)
            .map(|i| {
                let (e, k) = (i / 3, i % 3);
                let (r, c) = ((e / n) as f32, (e % n) as f32);
                (0.02 + 0.5 / (1.0 + (r - c).abs())) * (1.0 + 0.1 * k as f32)
            })
            .collect();
        let mut emission = vec![Rgb::ZERO; n];
        emission[5] = Rgb::new(10.0, 10.0, 10.0);
        let params = EncodeParams {
            format: Format::Bc1,
            corrections: 1.0,
            ..EncodeParams::default()
        };
        let weights = ErrorWeights::for_emitters(&emission);
        let m = encode_dense_with(
            n,
            3,
            &dense,
            &params,
            &weights,
            SparseSelection::ErrorDriven,
        )
        .expect("encodes");
        let side = n / 4;
        let mut corrected = 0;
        for br in 0..side {
            for (bc, _) in m.corrections.row(br) {
                assert_ne!(bc, 1, "block ({br}, 1) holds emitter column 5");
                corrected += 1;
            }
        }
        assert!(corrected > side * (side - 1) / 2, "{corrected} corrections");
        let error = |m: &TransferMatrix<'_>| -> f64 {
            let d = m.decode_dense(DecodeMode::D3d10);
            d.iter()
                .zip(&dense)
                .map(|(a, b)| f64::from(a - b).powi(2))
                .sum()
        };
        let mut bare = m.clone();
        bare.corrections = BlockCorrections::empty(n);
        // Each kept correction removes error (its gain is positive), so the whole must too.
        assert!(
            error(&m) < error(&bare),
            "{} !< {}",
            error(&m),
            error(&bare)
        );
    }
}
