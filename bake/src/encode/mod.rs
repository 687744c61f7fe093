//! Encoders: a dense transfer matrix → a [`TransferMatrix`] in any [`Format`].
//!
//! Steps: pick the first sparse set (the largest entries are kept exactly; the blocks treat
//! them as don't-cares), choose one [`LogScale`] per tile and channel from the tile's own
//! maximum, quantise to 8-bit log codes, then pack each 4×4 block: BC1 with texpresso's
//! cluster fit and BC4 with three candidate fits, both then refined in value space (`refine`),
//! u8 as is, f16/f32 without quantisation. BC1 blocks pass through [`guard_bc1`] so that none
//! decodes to transparent black by accident. The bake ([`encode_dense_with`]) then chooses the
//! sparse entries again by weighted error (`select`) and, when the scene emits, re-encodes the
//! blocks of the emitters' columns so that their errors cancel along each row ([`ErrorWeights`]).
//! The sparse list stores each kept entry's exact value minus what its block decodes there.

mod blocks;
pub(crate) mod correct;
mod emitters;
mod refine;
mod select;
mod source;
#[cfg(test)]
mod tests;
mod weights;

pub use blocks::{Bc1Fit, encode_bc1_block, encode_bc4_block};
pub use emitters::{EMITTER_ERROR_LIMIT, EXACT_EMITTERS_CAP, EmitterColumns, lighting_error};
pub use select::SparseSelection;
pub use weights::ErrorWeights;

pub(crate) use blocks::{BlockEncoder, SPARSE_TEXEL, tile_scales};
pub(crate) use select::{SparseRule, sparse_threshold};

use radiosity_core::{
    BlockCorrections, BlockDecoder, DEFAULT_MAX_TILE, DEFAULT_SHIFT, DecodeMode, Format,
    LayoutError, LogScale, MatrixLayout, SparseRows, TransferMatrix,
};
use rayon::prelude::*;
use select::build_sparse;
use source::Source;
use std::borrow::Cow;

/// How to encode. Every field trades size or time against accuracy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncodeParams {
    /// Storage format. BC1 needs three channels; one-channel (grey) matrices use BC4 instead.
    pub format: Format,
    /// Largest tile side (a multiple of 4). Smaller tiles give each its own log range (better
    /// precision for regions of small values) at 8 bytes of scale per tile and channel.
    pub max_tile: u32,
    /// Natural-log range `s` of the quantiser below each tile's maximum. Larger keeps smaller
    /// entries (which sum to real light in big scenes) but makes every code step coarser.
    pub shift: f32,
    /// Fraction of the non-zero entries, the largest ones, kept exactly in the sparse list (log
    /// formats only; float formats keep nothing sparse). Each kept entry costs 4 + 4·channels
    /// bytes, and each row's [`ROW_KEEP`] largest entries are kept as well. The default
    /// ([`default_sparse_fraction`]) spends a quarter of [`SPARSE_BUDGET`] on them.
    /// [`SparseSelection::ErrorDriven`] keeps as many entries, chosen by error instead of size.
    pub sparse_fraction: f32,
    /// Share of the block positions given a block correction ([`radiosity_core::BlockCorrections`],
    /// `4 + 9·channels` bytes each), those where it removes the most weighted error; BC1 and
    /// BC4 only. The default
    /// ([`default_correction_fraction`]) spends three quarters of [`SPARSE_BUDGET`] on them.
    pub corrections: f32,
    /// Share of BC1 blocks, those of largest error from the range-fit start, that the
    /// error-driven encode ([`SparseSelection::ErrorDriven`]) fits again from texpresso's
    /// cluster fit, keeping whichever start refines to the lower error ([`BC1_RETRY`]).
    pub bc1_retry: f32,
    /// Whether that second start is texpresso's iterative cluster fit (slower) instead of
    /// its cluster fit.
    pub bc1_iterative: bool,
    /// The largest relative error of the scene's own light (`y = M·E`) the blocks may leave
    /// before the emitting columns are kept exact in the sparse list ([`EmitterColumns`]): 0
    /// keeps them always, infinity never. Default [`EMITTER_ERROR_LIMIT`].
    pub emitter_error_limit: f32,
}

impl Default for EncodeParams {
    fn default() -> Self {
        Self {
            format: Format::Bc1,
            max_tile: DEFAULT_MAX_TILE,
            shift: DEFAULT_SHIFT,
            sparse_fraction: default_sparse_fraction(Format::Bc1, 3),
            corrections: default_correction_fraction(Format::Bc1, 3),
            bc1_retry: BC1_RETRY,
            bc1_iterative: false,
            emitter_error_limit: EMITTER_ERROR_LIMIT,
        }
    }
}

impl EncodeParams {
    /// Defaults for `format`.
    pub fn for_format(format: Format) -> Self {
        Self {
            format,
            sparse_fraction: default_sparse_fraction(format, 3),
            corrections: default_correction_fraction(format, 3),
            ..Self::default()
        }
    }

    /// Highest quality the encoder offers: every BC1 block also fitted from the iterative
    /// cluster fit, 1% sparse.
    pub fn high_quality(format: Format) -> Self {
        Self {
            format,
            sparse_fraction: 0.01,
            bc1_retry: 1.0,
            bc1_iterative: true,
            ..Self::default()
        }
    }
}

/// Why a matrix could not be encoded.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum EncodeError {
    /// The dense input does not hold `n · n · channels` values.
    #[error("dense matrix has {actual} values, expected {expected} (n = {n}, {channels} channels)")]
    Length {
        /// Patches.
        n: usize,
        /// Channels.
        channels: usize,
        /// Values expected.
        expected: usize,
        /// Values given.
        actual: usize,
    },
    /// An entry is NaN, infinite or negative.
    #[error(
        "matrix entry ({row}, {col}) channel {channel} is {value}: entries must be finite and non-negative"
    )]
    Value {
        /// Row.
        row: usize,
        /// Column.
        col: usize,
        /// Channel.
        channel: usize,
        /// The value.
        value: f32,
    },
    /// The parameters are impossible.
    #[error("bad encode parameters: {0}")]
    Params(&'static str),
    /// The layout is impossible.
    #[error("{0}")]
    Layout(#[from] LayoutError),
    /// An entry exceeds what binary16 can hold.
    #[error("matrix entry {value} exceeds the f16 range (65504); use f32")]
    F16Range {
        /// The entry.
        value: f32,
    },
}

/// Share of the block bytes the sparse list and the block corrections may take together by
/// default: 1/8, which holds a 4096-patch BC1 Cornell box within 1/20 of the dense f32 RGB
/// matrix. Spent all on sparse entries, a BC1 matrix (0.5 byte per entry) would keep 0.4% of
/// its entries exact, a three-channel BC4 matrix 1.2%.
pub(crate) const SPARSE_BUDGET: f32 = 0.128;

/// Share of [`SPARSE_BUDGET`] spent on block corrections rather than sparse entries. A
/// correction (31 bytes in RGB) fixes a whole block for the price of two sparse entries, which
/// pays where the error is concentrated in few blocks, as it is in a good order. Measured on
/// the Cornell box at 4098 patches, BC1, paper order, the Frobenius error at shares 0 / 0.5 /
/// 0.7 / 0.8 / 0.85: 2.54 / 1.96 / 1.76 / 1.70 / 1.67%, lighting error 0.15 / 0.17 / 0.23 /
/// 0.26 / 0.27% (ARCHITECTURE.md, "Block corrections").
pub(crate) const CORRECTION_SHARE: f32 = 0.75;

/// Bytes of the block data per 4×4 block position for `format` with `channels`.
fn block_position_bytes(format: Format, channels: usize) -> f32 {
    let planes = if format == Format::Bc1 { 1 } else { channels };
    (planes * format.block_bytes()) as f32
}

/// Whether `format` takes block corrections (the block-compressed ones, BC1 and BC4).
pub(crate) fn takes_corrections(format: Format) -> bool {
    matches!(format, Format::Bc1 | Format::Bc4)
}

/// The default sparse fraction for `format` with `channels`: [`SPARSE_BUDGET`] of the block
/// bytes, at `4 + 4·channels` bytes per kept entry, less [`CORRECTION_SHARE`] of it for BC1
/// and BC4; 0 for the float formats.
pub fn default_sparse_fraction(format: Format, channels: usize) -> f32 {
    if !format.is_log() {
        return 0.0;
    }
    let share = if takes_corrections(format) {
        1.0 - CORRECTION_SHARE
    } else {
        1.0
    };
    let per_entry = block_position_bytes(format, channels) / 16.0;
    share * SPARSE_BUDGET * per_entry / (4 + 4 * channels) as f32
}

/// The default share of block positions corrected for `format` with `channels`:
/// [`CORRECTION_SHARE`] of [`SPARSE_BUDGET`] of the block bytes, at `4 + 9·channels` bytes per
/// correction; 0 for formats other than BC1 and BC4.
pub fn default_correction_fraction(format: Format, channels: usize) -> f32 {
    if !takes_corrections(format) {
        return 0.0;
    }
    CORRECTION_SHARE * SPARSE_BUDGET * block_position_bytes(format, channels)
        / (4 + 9 * channels) as f32
}

/// Encodes a dense row-major matrix (`n · n · channels` values, channels interleaved per entry)
/// in the matrix's final patch numbering, judging errors uniformly (every entry alike: the
/// Frobenius norm) with [`SparseRule`]'s sparse entries ([`SparseSelection::Largest`]): the
/// encode that a block-by-block estimate reproduces exactly ([`BlockEncoder`]). The bake encodes
/// with [`encode_dense_with`], weighing its own emitters and choosing the sparse entries by
/// error. Deterministic: the same input gives the same bytes on any thread count.
pub fn encode_dense(
    n: usize,
    channels: usize,
    dense: &[f32],
    params: &EncodeParams,
) -> Result<TransferMatrix<'static>, EncodeError> {
    encode_dense_with(
        n,
        channels,
        dense,
        params,
        &ErrorWeights::uniform(),
        SparseSelection::Largest,
    )
}

/// [`encode_dense`] with an explicit error weighting ([`ErrorWeights`]: which columns matter
/// how much) and sparse selection. What the bake calls.
///
/// Steps for the log formats:
///
/// 1. The first sparse set is [`SparseRule`]'s (the largest entries and each row's
///    [`ROW_KEEP`] largest); with [`SparseSelection::ErrorDriven`] only at
///    [`FIRST_PASS_SHARE`] of the fraction. One [`LogScale`] per tile and channel from what
///    that leaves in the blocks ([`tile_scales`]).
/// 2. Every block is fitted in code space (texpresso for BC1, three candidates for BC4) and
///    refined in value space under the diagonal weights (`refine`).
/// 3. [`SparseSelection::ErrorDriven`]: as many entries as [`SparseRule`] keeps at the full
///    fraction (so the file size is unchanged), chosen by weighted squared error as decoded
///    (`select`); the blocks whose sparse texels changed are encoded again with the same
///    scales, [`SELECT_ROUNDS`] times. Entries above their tile's `v_max` always stay sparse.
/// 4. With emitters: the coupled pass ([`ErrorWeights`], `refine::Coupling`) along each block
///    row, over the blocks that hold an emitting column.
/// 5. The sparse list: each kept entry's exact value minus what its block decodes there.
/// 6. The block corrections (BC1, BC4): `params.corrections` of the block positions, those
///    where a correction removes the most weighted error (`correct`).
/// 7. With emitters: where the scene's own light through the result is more than
///    `params.emitter_error_limit` off, the emitting columns move whole into the sparse list
///    and the corrections are chosen again ([`EmitterColumns`]).
///
/// Float formats keep nothing sparse and are stored as they are. Deterministic: the same input
/// gives the same bytes on any thread count (per-block work is independent, the coupled pass
/// runs each block row in order, the selection cut is an order statistic).
pub fn encode_dense_with(
    n: usize,
    channels: usize,
    dense: &[f32],
    params: &EncodeParams,
    weights: &ErrorWeights,
    selection: SparseSelection,
) -> Result<TransferMatrix<'static>, EncodeError> {
    encode_dense_noting(n, channels, dense, params, weights, selection).map(|(m, _)| m)
}

/// [`encode_dense_with`], and what step 7 did with the emitters' columns (`None` without
/// emitters or for the float formats): what the bake reports as its `exact_emitters` effect.
pub fn encode_dense_noting(
    n: usize,
    channels: usize,
    dense: &[f32],
    params: &EncodeParams,
    weights: &ErrorWeights,
    selection: SparseSelection,
) -> Result<(TransferMatrix<'static>, Option<EmitterColumns>), EncodeError> {
    let layout = check_input(n, channels, dense, params)?;
    weights.check(n)?;
    let fraction = if params.format.is_log() {
        params.sparse_fraction
    } else {
        0.0
    };
    let selecting = selection == SparseSelection::ErrorDriven && fraction > 0.0;
    let rule = SparseRule::new(dense, n, channels, fraction);
    // With error-driven selection the first pass keeps only part of the budget by size, so
    // that the scales leave room for large entries the error may not need in the list.
    let (first_rule, budget) = if selecting {
        let budget = rule.count(dense, n, channels);
        let threshold = sparse_threshold(dense, channels, fraction * FIRST_PASS_SHARE);
        (SparseRule { threshold, ..rule }, budget)
    } else {
        (rule, 0)
    };
    let side = layout.padded() / 4;
    // The first sparse set, one 16-bit texel mask per 4×4 block of the padded matrix
    // (row-major over block rows and columns; bit `4·(row % 4) + col % 4`).
    let first: Vec<u16> = (0..side * side)
        .into_par_iter()
        .map(|b| {
            block_texels(b, side, n).fold(0u16, |m, (i, r, c)| {
                let e = r * n + c;
                if first_rule.keeps(r, &dense[e * channels..(e + 1) * channels]) {
                    m | 1 << i
                } else {
                    m
                }
            })
        })
        .collect();
    let sparse_at = |masks: &[u16], r: usize, c: usize| {
        masks[r / 4 * side + c / 4] & (1 << ((r % 4) * 4 + c % 4)) != 0
    };
    // What the blocks see for the scales: NaN (a don't-care, [`SPARSE_TEXEL`]) where the
    // sparse list holds the entry, 0 beyond the last patch.
    let value = |row: usize, col: usize, ch: usize| -> f32 {
        if row >= n || col >= n {
            return 0.0;
        }
        if sparse_at(&first, row, col) {
            SPARSE_TEXEL
        } else {
            dense[(row * n + col) * channels + ch]
        }
    };
    let scales = tile_scales(&layout, params, &value);
    let source = Source {
        layout: &layout,
        params,
        dense,
        weights,
        tables: scales.iter().map(LogScale::table).collect(),
        decoder: BlockDecoder::from_scales(&scales, DecodeMode::D3d10),
        scales: &scales,
    };

    let bb = params.format.block_bytes();
    let per_block = layout.planes() * bb;
    let (mut encoded, masks) = first_encode(&source, first, selection, selecting, budget, side);

    if weights.has_emitters() && matches!(params.format, Format::Bc1 | Format::Bc4) {
        // The endpoint search of the coupled pass costs ≈ 35 µs per BC1 block (measured on
        // the Cornell box), so it is reserved for scenes whose emitters fill few column blocks
        // (a lamp, not a glowing room); the others get the coupled index choice alone (≈ 5 µs).
        let emitting = (0..side)
            .filter(|&bc| weights.emits_in_column_block(bc, n))
            .count();
        let search = emitting * COUPLED_SEARCH_SHARE <= side;
        encoded
            .par_chunks_exact_mut(side * per_block)
            .enumerate()
            .for_each(|(row, out)| source.couple_row(row, &masks, out, search));
    }

    // Scatter the blocks (global block order, planes together) into the layout's order (per
    // tile, per plane, block-row-major).
    let mut blocks = vec![0u8; layout.block_bytes() as usize];
    for (b, raw) in encoded.chunks_exact(per_block).enumerate() {
        let (tile, br, bc) = layout.locate(b / side * 4, b % side * 4);
        for plane in 0..layout.planes() {
            let off = layout.block_offset(&tile, plane, br, bc);
            blocks[off..off + bb].copy_from_slice(&raw[plane * bb..(plane + 1) * bb]);
        }
    }
    let mut matrix = TransferMatrix {
        layout,
        scales: Cow::Owned(scales.clone()),
        blocks: Cow::Owned(blocks),
        sparse: SparseRows::empty(n),
        corrections: BlockCorrections::empty(n),
    };
    matrix.sparse = build_sparse(&matrix, dense, &|e| sparse_at(&masks, e / n, e % n));
    let count = correct::count(params, side);
    matrix.corrections = correct::choose(&matrix, dense, weights, count);
    let emitters = emitters::review(&mut matrix, dense, weights, params);
    Ok((matrix, emitters))
}

/// Steps 2 and 3 of [`encode_dense_with`]: every block encoded with the `first` sparse masks
/// (one per block of the `side × side` block grid), then, with
/// [`SparseSelection::ErrorDriven`], scored, the worst BC1 blocks fitted again, and the sparse
/// entries chosen by score (`budget` of them, when `selecting`). Returns the blocks (planes
/// together, global block order) and the final masks.
fn first_encode(
    source: &Source<'_>,
    first: Vec<u16>,
    selection: SparseSelection,
    selecting: bool,
    budget: usize,
    side: usize,
) -> (Vec<u8>, Vec<u16>) {
    let params = source.params;
    let per_block = source.layout.planes() * params.format.block_bytes();
    let mut encoded = vec![0u8; side * side * per_block];
    let scoring = selection == SparseSelection::ErrorDriven;
    let masks = if scoring {
        let mut scores = vec![[0f32; 16]; side * side];
        encoded
            .par_chunks_exact_mut(per_block)
            .zip(scores.par_iter_mut())
            .enumerate()
            .for_each(|(b, (out, score))| source.encode(b, first[b], out, Some(score), false));
        // The blocks of largest error get a second BC1 start (cluster fit).
        let thorough = retry_blocks(&scores, params);
        encoded
            .par_chunks_exact_mut(per_block)
            .zip(scores.par_iter_mut())
            .enumerate()
            .filter(|(b, _)| thorough[*b])
            .for_each(|(b, (out, score))| source.encode(b, first[b], out, Some(score), true));
        let mut masks = first;
        if selecting {
            let forced: Vec<u16> = (0..side * side)
                .into_par_iter()
                .map(|b| source.must_stay_sparse(b))
                .collect();
            for _ in 0..SELECT_ROUNDS {
                let next = select::by_score(&scores, &forced, budget);
                encoded
                    .par_chunks_exact_mut(per_block)
                    .zip(scores.par_iter_mut())
                    .enumerate()
                    .filter(|(b, _)| next[*b] != masks[*b])
                    .for_each(|(b, (out, score))| {
                        source.encode(b, next[b], out, Some(score), thorough[b])
                    });
                masks = next;
            }
        }
        masks
    } else {
        encoded
            .par_chunks_exact_mut(per_block)
            .enumerate()
            .for_each(|(b, out)| source.encode(b, first[b], out, None, false));
        first
    };
    (encoded, masks)
}

/// Which blocks get a second BC1 start: the `params.bc1_retry` share of blocks (rounded
/// down) whose summed weighted error after the first start is largest, ties broken by block
/// index so that the choice is the same on any thread count. None for other formats.
fn retry_blocks(scores: &[[f32; 16]], params: &EncodeParams) -> Vec<bool> {
    let mut chosen = vec![false; scores.len()];
    if params.format != Format::Bc1 {
        return chosen;
    }
    let count = (f64::from(params.bc1_retry) * scores.len() as f64) as usize;
    let mut by_error: Vec<(f32, usize)> = scores
        .iter()
        .enumerate()
        .map(|(b, s)| (s.iter().sum::<f32>(), b))
        .filter(|(e, _)| *e > 0.0)
        .collect();
    let count = count.min(by_error.len());
    if count == 0 {
        return chosen;
    }
    let worst = |a: &(f32, usize), b: &(f32, usize)| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1));
    by_error.select_nth_unstable_by(count - 1, worst);
    for &(_, b) in &by_error[..count] {
        chosen[b] = true;
    }
    chosen
}

/// Share of BC1 blocks the error-driven encode fits twice (default of
/// [`EncodeParams::bc1_retry`]). Every block starts from texpresso's range fit, refined in
/// value space; the blocks of largest error after that are fitted again from its cluster fit
/// (≈ 19 µs a block against ≈ 1 µs) and keep the better of the two. The blocks of a transfer
/// matrix in a good order hold their error in few blocks, so few retries recover most of what
/// the cluster fit gives.
pub(crate) const BC1_RETRY: f32 = 0.05;

/// Share of the sparse budget the first pass of error-driven selection keeps by size
/// ([`SparseRule`] at this share of the fraction); the scales come from what that leaves in the
/// blocks. The whole budget then goes by error. At 1 the scales' `v_max` sits just below the
/// budget's smallest kept entry, so nearly every entry the rule keeps is above `v_max` and must
/// stay in the list (a block cannot decode above it): the selection could only move the few
/// row-keep entries. Measured on the 4106-patch Cornell box (uniform weights, relative Frobenius
/// error): 2.66% at 1, 2.57% at 0.75, 2.55% at 0.5, 2.56% at 0.25; BC4 0.79%, 0.70% (0.5),
/// 0.71% (0.25).
pub(crate) const FIRST_PASS_SHARE: f32 = 0.5;

/// Rounds of error-driven selection: select, re-encode the blocks whose sparse texels changed,
/// score again. Measured on the 4106-patch Cornell box (BC1, uniform weights): the first round
/// changes ~16k blocks and gives 2.59% Frobenius error, the second changes ~5k more and gives
/// 2.55% (BC4: 0.714%, 0.699%); four rounds give 2.54%.
pub(crate) const SELECT_ROUNDS: usize = 2;

/// The coupled pass searches endpoints only when at most one column block in this many holds
/// an emitter; see [`encode_dense_with`].
pub(crate) const COUPLED_SEARCH_SHARE: usize = 8;

/// Texels of global block `b` (`side` blocks per row) inside the `n × n` matrix: (bit, row,
/// column).
fn block_texels(b: usize, side: usize, n: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    let (r0, c0) = (b / side * 4, b % side * 4);
    (0..16)
        .map(move |i| (i, r0 + i / 4, c0 + i % 4))
        .filter(move |&(_, r, c)| r < n && c < n)
}

/// Checks what [`encode_dense`] checks before encoding anything (length, parameters, layout,
/// finite non-negative entries) and returns the layout the matrix will have.
pub(crate) fn check_input(
    n: usize,
    channels: usize,
    dense: &[f32],
    params: &EncodeParams,
) -> Result<MatrixLayout, EncodeError> {
    let expected = n
        .checked_mul(n)
        .and_then(|v| v.checked_mul(channels))
        .unwrap_or(usize::MAX);
    if dense.len() != expected {
        return Err(EncodeError::Length {
            n,
            channels,
            expected,
            actual: dense.len(),
        });
    }
    if !(params.shift.is_finite() && params.shift > 0.0) {
        return Err(EncodeError::Params("shift must be finite and positive"));
    }
    if !(0.0..=1.0).contains(&params.sparse_fraction) {
        return Err(EncodeError::Params("sparse_fraction must be in [0, 1]"));
    }
    if !(0.0..=1.0).contains(&params.corrections) {
        return Err(EncodeError::Params("corrections must be in [0, 1]"));
    }
    if !(0.0..=1.0).contains(&params.bc1_retry) {
        return Err(EncodeError::Params("bc1_retry must be in [0, 1]"));
    }
    let n32 = u32::try_from(n).map_err(|_| EncodeError::Params("more than 2^32 patches"))?;
    let layout = MatrixLayout::new(n32, channels as u32, params.format, params.max_tile)?;
    if let Some(i) = dense.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
        let (e, channel) = (i / channels, i % channels);
        return Err(EncodeError::Value {
            row: e / n,
            col: e % n,
            channel,
            value: dense[i],
        });
    }
    if params.format == Format::F16
        && let Some(value) = dense.iter().copied().find(|v| *v > 65504.0)
    {
        return Err(EncodeError::F16Range { value });
    }
    Ok(layout)
}
