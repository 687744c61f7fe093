//! Encoders: a dense transfer matrix → a [`TransferMatrix`] in any [`Format`].
//!
//! Steps: pick the sparse threshold (the largest entries are kept exactly and zeroed in the
//! blocks), choose one [`LogScale`] per tile and channel from the tile's own maximum, quantise to
//! 8-bit log codes, then pack each 4×4 block: BC1 and BC4 with texpresso's cluster fit, u8 as
//! is, f16/f32 without quantisation. BC1 blocks pass through [`guard_bc1`] so that none decodes
//! to transparent black by accident.

use radiosity_core::half::f32_to_f16;
use radiosity_core::{
    Bc1Block, Bc4Block, DEFAULT_MAX_TILE, DEFAULT_SHIFT, DecodeMode, Format, LayoutError, LogScale,
    MatrixLayout, SparseRows, Tile, TransferMatrix,
};
use rayon::prelude::*;
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
    /// bytes; with each row's [`ROW_KEEP`] largest entries also kept, the default 0.4% keeps a
    /// 4096-patch BC1 Cornell box within 1/20 of the dense f32 RGB matrix (measured: 1% made it
    /// 1/18).
    pub sparse_fraction: f32,
    /// texpresso's fit for BC1: cluster fit (default) or the slower iterative cluster fit.
    pub bc1_iterative: bool,
}

impl Default for EncodeParams {
    fn default() -> Self {
        Self {
            format: Format::Bc1,
            max_tile: DEFAULT_MAX_TILE,
            shift: DEFAULT_SHIFT,
            sparse_fraction: 0.004,
            bc1_iterative: false,
        }
    }
}

impl EncodeParams {
    /// Defaults for `format`.
    pub fn for_format(format: Format) -> Self {
        Self {
            format,
            sparse_fraction: default_sparse_fraction(format, 3),
            ..Self::default()
        }
    }

    /// Highest quality the encoder offers: iterative BC1 fit, 1% sparse.
    pub fn high_quality(format: Format) -> Self {
        Self {
            format,
            sparse_fraction: 0.01,
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

/// Share of the block bytes the sparse list may take by default: 1/8. A BC1 matrix (0.5 byte
/// per entry) then keeps 0.4% of its entries exact, which holds a 4096-patch Cornell box within
/// 1/20 of the dense f32 RGB matrix; a three-channel BC4 matrix, three times larger, keeps 1.2%
/// (measured lighting error 0.84% at 1% against 1.03% at 0.4%).
pub const SPARSE_BUDGET: f32 = 0.128;

/// The default sparse fraction for `format` with `channels`: [`SPARSE_BUDGET`] of the block
/// bytes, at `4 + 4·channels` bytes per kept entry; 0 for the float formats.
pub fn default_sparse_fraction(format: Format, channels: usize) -> f32 {
    if !format.is_log() {
        return 0.0;
    }
    let planes = if format == Format::Bc1 { 1 } else { channels };
    let block_bytes_per_entry = (planes * format.block_bytes()) as f32 / 16.0;
    SPARSE_BUDGET * block_bytes_per_entry / (4 + 4 * channels) as f32
}

/// Encodes a dense row-major matrix (`n · n · channels` values, channels interleaved per entry)
/// in the matrix's final patch numbering.
pub fn encode_dense(
    n: usize,
    channels: usize,
    dense: &[f32],
    params: &EncodeParams,
) -> Result<TransferMatrix<'static>, EncodeError> {
    let layout = check_input(n, channels, dense, params)?;

    let fraction = if params.format.is_log() {
        params.sparse_fraction
    } else {
        0.0
    };
    let rule = SparseRule::new(dense, n, channels, fraction);
    let is_sparse = |e: usize| rule.keeps(e / n, &dense[e * channels..(e + 1) * channels]);
    // What the blocks see: NaN (a don't-care, [`SPARSE_TEXEL`]) where the sparse list holds the
    // entry, 0 beyond the last patch.
    let value = |row: usize, col: usize, ch: usize| -> f32 {
        if row >= n || col >= n {
            return 0.0;
        }
        let e = row * n + col;
        if is_sparse(e) {
            SPARSE_TEXEL
        } else {
            dense[e * channels + ch]
        }
    };

    let scales = tile_scales(&layout, params, &value);
    let tiles: Vec<Tile> = layout.tiles().collect();
    let mut blocks = vec![0u8; layout.block_bytes() as usize];
    let bb = params.format.block_bytes();
    for tile in &tiles {
        let plane_bytes = tile.blocks_high() * tile.blocks_wide() * bb;
        let tile_bytes = &mut blocks[tile.offset..tile.offset + plane_bytes * layout.planes()];
        for (plane, plane_out) in tile_bytes.chunks_exact_mut(plane_bytes).enumerate() {
            plane_out
                .par_chunks_exact_mut(bb)
                .enumerate()
                .for_each(|(b, out)| {
                    let (br, bc) = (b / tile.blocks_wide(), b % tile.blocks_wide());
                    encode_block(&layout, params, &scales, tile, plane, br, bc, &value, out);
                });
        }
    }
    let mut matrix = TransferMatrix {
        layout,
        scales: Cow::Owned(scales),
        blocks: Cow::Owned(blocks),
        sparse: SparseRows::empty(n),
    };
    matrix.sparse = build_sparse(&matrix, dense, &is_sparse);
    Ok(matrix)
}

/// The value a `value(row, col, channel)` function gives for an entry the sparse list holds:
/// NaN, a don't-care. The BC fits leave such texels out (so large entries do not distort their
/// block), u8 writes code 0, and the sparse list stores the exact value *minus* whatever the
/// block decodes there, so block + sparse is exact under the reference decoder.
pub const SPARSE_TEXEL: f32 = f32::NAN;

/// Checks what [`encode_dense`] checks before encoding anything (length, parameters, layout,
/// finite non-negative entries) and returns the layout the matrix will have.
pub fn check_input(
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

/// One [`LogScale`] per tile and channel ([`MatrixLayout::scale_index`] order), each from the
/// values its tile holds in the blocks; empty for the float formats.
///
/// `v_max` is the tile's largest value. The log range is the tile's own when that is narrower
/// than `params.shift`: `s = ln(v_max / v_min) · 255/254` (so `v_min`, the smallest non-zero
/// value, still gets code 1), never more than `params.shift` (values below `v_max·e^(−shift)`
/// become 0) and at least 1e-3. A tile whose values span a factor of 2 thus gets code steps of
/// 0.27% instead of 2.7%: the white furnace at ρ = 0.999, whose transfer matrix is nearly
/// constant, needs that to stay within 0.5%.
///
/// `value(row, col, channel)` is what the blocks see: the matrix in its final numbering,
/// [`SPARSE_TEXEL`] where the sparse list holds the entry, and 0 beyond the last patch.
/// [`encode_dense`] uses this, and so can a caller that encodes single blocks with
/// [`encode_block`] (e.g. to estimate the compression error from a sample of blocks, with the
/// same quantisation as the whole matrix).
pub fn tile_scales<V>(layout: &MatrixLayout, params: &EncodeParams, value: &V) -> Vec<LogScale>
where
    V: Fn(usize, usize, usize) -> f32 + Sync,
{
    if !params.format.is_log() {
        return Vec::new();
    }
    let channels = layout.channels();
    let tiles: Vec<Tile> = layout.tiles().collect();
    tiles
        .par_iter()
        .flat_map_iter(|t| {
            (0..channels).map(move |ch| {
                let (mut v_max, mut v_min) = (0f32, f32::INFINITY);
                for r in t.row0..t.row0 + t.rows {
                    for c in t.col0..t.col0 + t.cols {
                        let v = value(r, c, ch);
                        // `> 0` skips zeros and the NaN of sparse texels.
                        if v > 0.0 {
                            v_max = v_max.max(v);
                            v_min = v_min.min(v);
                        }
                    }
                }
                if v_max > 0.0 {
                    let own = f64::from(v_max / v_min).ln() * 255.0 / 254.0;
                    LogScale::new(v_max, (own as f32).clamp(1e-3, params.shift))
                } else {
                    // An all-zero tile still needs a valid scale; every code will be 0.
                    LogScale::new(1.0, params.shift)
                }
            })
        })
        .collect()
}

/// Encodes block (`br`, `bc`) of `plane` in `tile` into `out` (`params.format.block_bytes()`
/// bytes), exactly as [`encode_dense`] does: `value` as in [`tile_scales`], `scales` from
/// [`tile_scales`] with the same `value`. Texels beyond the last patch and sparse texels are
/// don't-cares.
pub fn encode_block<V>(
    layout: &MatrixLayout,
    params: &EncodeParams,
    scales: &[LogScale],
    tile: &Tile,
    plane: usize,
    br: usize,
    bc: usize,
    value: &V,
    out: &mut [u8],
) where
    V: Fn(usize, usize, usize) -> f32,
{
    let n = layout.n();
    let (r0, c0) = (tile.row0 + br * 4, tile.col0 + bc * 4);
    let texel = |i: usize, ch: usize| value(r0 + i / 4, c0 + i % 4, ch);
    let code =
        |i: usize, ch: usize| scales[layout.scale_index(tile.index, ch)].encode(texel(i, ch));
    // Texels beyond the last patch and sparse texels (NaN) are don't-cares, left out of BC fits.
    let planes_channels = if params.format == Format::Bc1 {
        0..3
    } else {
        plane..plane + 1
    };
    let mask = (0..16)
        .filter(|i| r0 + i / 4 < n && c0 + i % 4 < n)
        .filter(|&i| planes_channels.clone().all(|ch| !texel(i, ch).is_nan()))
        .fold(0u32, |m, i| m | 1 << i);
    match params.format {
        Format::Bc1 => {
            let codes: [[u8; 3]; 16] =
                core::array::from_fn(|i| [code(i, 0), code(i, 1), code(i, 2)]);
            out.copy_from_slice(&encode_bc1_block(&codes, mask, params.bc1_iterative).0);
        }
        Format::Bc4 => {
            let codes: [u8; 16] = core::array::from_fn(|i| code(i, plane));
            out.copy_from_slice(&encode_bc4_block(&codes, mask));
        }
        Format::U8 => {
            for i in 0..16 {
                out[i] = code(i, plane);
            }
        }
        Format::F16 => {
            for i in 0..16 {
                out[2 * i..2 * i + 2].copy_from_slice(&f32_to_f16(texel(i, plane)).to_le_bytes());
            }
        }
        Format::F32 => {
            for i in 0..16 {
                out[4 * i..4 * i + 4].copy_from_slice(&texel(i, plane).to_le_bytes());
            }
        }
    }
}

/// Whether an entry (its `channels` values) goes to the sparse list under `threshold`: its
/// largest channel exceeds it.
#[inline]
pub fn kept_sparse(entry: &[f32], threshold: f32) -> bool {
    entry.iter().copied().fold(0f32, f32::max) > threshold
}

/// Entries of each row kept exact whatever the global threshold: a row's irradiance is often
/// dominated by its few nearest neighbours, whose block errors do not average out (measured: a
/// 96-patch furnace at ρ = 0.5 was 1.1% off in BC4 with a global threshold alone).
pub const ROW_KEEP: usize = 4;

/// Which entries the sparse list keeps: those whose largest channel exceeds a global threshold
/// (about `fraction` of the non-zero entries, [`sparse_threshold`]), plus each row's
/// [`ROW_KEEP`] largest. Depends only on the matrix, not on the patch order.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseRule {
    /// The global threshold.
    pub threshold: f32,
    /// Per row (matrix numbering as given), the [`ROW_KEEP`]-th largest non-zero entry; rows
    /// with fewer non-zero entries keep all of them.
    pub row_floor: Vec<f32>,
}

impl SparseRule {
    /// The rule for a dense matrix (`n · n · channels`); `fraction` 0 keeps nothing.
    pub fn new(dense: &[f32], n: usize, channels: usize, fraction: f32) -> Self {
        if fraction <= 0.0 {
            return Self {
                threshold: f32::INFINITY,
                row_floor: vec![f32::INFINITY; n],
            };
        }
        let threshold = sparse_threshold(dense, channels, fraction);
        let row_floor = (0..n)
            .into_par_iter()
            .map(|r| {
                let mut top = [0f32; ROW_KEEP];
                for e in dense[r * n * channels..(r + 1) * n * channels].chunks_exact(channels) {
                    let v = e.iter().copied().fold(0f32, f32::max);
                    if v > top[ROW_KEEP - 1] {
                        top[ROW_KEEP - 1] = v;
                        top.sort_by(|a, b| b.total_cmp(a));
                    }
                }
                let floor = top
                    .iter()
                    .copied()
                    .filter(|v| *v > 0.0)
                    .fold(f32::INFINITY, f32::min);
                if floor.is_finite() {
                    floor
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        Self {
            threshold,
            row_floor,
        }
    }

    /// Whether entry `entry` of row `row` is kept.
    #[inline]
    pub fn keeps(&self, row: usize, entry: &[f32]) -> bool {
        let v = entry.iter().copied().fold(0f32, f32::max);
        v > self.threshold || (v > 0.0 && v >= self.row_floor[row])
    }
}

/// The value above which an entry (its largest channel) goes to the sparse list, so that about
/// `fraction` of the non-zero entries do. `f32::INFINITY` keeps none. Independent of the patch
/// order. `dense` holds `channels` values per entry.
pub fn sparse_threshold(dense: &[f32], channels: usize, fraction: f32) -> f32 {
    if fraction <= 0.0 {
        return f32::INFINITY;
    }
    let mut maxima: Vec<f32> = dense
        .chunks_exact(channels)
        .map(|v| v.iter().copied().fold(0f32, f32::max))
        .filter(|v| *v > 0.0)
        .collect();
    let keep = ((maxima.len() as f64) * f64::from(fraction)).round() as usize;
    if keep == 0 {
        return f32::INFINITY;
    }
    if keep >= maxima.len() {
        return 0.0;
    }
    // The (len − keep)-th smallest is the largest value that stays in the blocks.
    let k = maxima.len() - keep - 1;
    let (_, kth, _) = maxima.select_nth_unstable_by(k, f32::total_cmp);
    *kth
}

/// The sparse list of `m` (whose blocks are already encoded): for each entry `is_sparse` keeps,
/// its exact value minus what the block decodes there (D3D10 rules), so the gather's
/// block + sparse sum is exact. The residual is at least the entry's value minus the tile's
/// `v_max` in the channel that made it sparse, and can be negative in another channel.
fn build_sparse(
    m: &TransferMatrix<'_>,
    dense: &[f32],
    is_sparse: &dyn Fn(usize) -> bool,
) -> SparseRows<'static> {
    let l = &m.layout;
    let (n, channels) = (l.n(), l.channels());
    let decoder = m.decoder(DecodeMode::D3d10);
    let mut block_values = [[0f32; 16]; 3];
    let mut cached: Option<(usize, usize, usize)> = None;
    let mut row_ptr = Vec::with_capacity(n + 1);
    let mut cols = Vec::new();
    let mut values = Vec::new();
    row_ptr.push(0u32);
    for r in 0..n {
        for c in 0..n {
            let e = r * n + c;
            if !is_sparse(e) {
                continue;
            }
            let (tile, br, bc) = l.locate(r, c);
            if cached != Some((tile.index, br, bc)) {
                decoder.decode(m, &tile, br, bc, &mut block_values);
                cached = Some((tile.index, br, bc));
            }
            let texel = ((r - tile.row0) % 4) * 4 + (c - tile.col0) % 4;
            cols.push(c as u32);
            for ch in 0..channels {
                values.push(dense[e * channels + ch] - block_values[ch][texel]);
            }
        }
        row_ptr.push(cols.len() as u32);
    }
    SparseRows {
        row_ptr: Cow::Owned(row_ptr),
        cols: Cow::Owned(cols),
        values: Cow::Owned(values),
    }
}

/// Encodes 16 RGB code triples (row-major) as one BC1 block with texpresso, uniform channel
/// weights (the channels are data, not perceived colour), then [`guard_bc1`]. Texels whose bit
/// is clear in `mask` are don't-cares.
pub fn encode_bc1_block(codes: &[[u8; 3]; 16], mask: u32, iterative: bool) -> Bc1Block {
    if codes.iter().all(|c| *c == [0, 0, 0]) {
        // c0 = c1 = 0, all indices 0: exactly zero in every decoder.
        return Bc1Block([0; 8]);
    }
    let rgba: [[u8; 4]; 16] =
        core::array::from_fn(|i| [codes[i][0], codes[i][1], codes[i][2], 255]);
    let params = texpresso::Params {
        algorithm: if iterative {
            texpresso::Algorithm::IterativeClusterFit
        } else {
            texpresso::Algorithm::ClusterFit
        },
        weights: texpresso::COLOUR_WEIGHTS_UNIFORM,
        weigh_colour_by_alpha: false,
    };
    let mut out = [0u8; 8];
    texpresso::Format::Bc1.compress_block_masked(rgba, mask, params, &mut out);
    guard_bc1(Bc1Block(out), codes, mask)
}

/// Makes sure a BC1 block of opaque data never decodes to transparent black.
///
/// A block is in three-colour mode when `c0 ≤ c1` as 16-bit words; there index 3 means
/// transparent black, i.e. code 0, i.e. a zero matrix entry. Encoders reach that mode by accident
/// when two different endpoints round to the same 565 value. If a three-colour block uses index
/// 3 for a texel in `mask`: with equal endpoints every palette entry but 3 is the same colour, so
/// index 3 becomes 0; otherwise the endpoints are swapped into four-colour mode and every texel
/// re-indexed to its nearest palette entry.
pub fn guard_bc1(block: Bc1Block, intended: &[[u8; 3]; 16], mask: u32) -> Bc1Block {
    if block.is_four_colour() {
        return block;
    }
    let uses_black = (0..16).any(|i| mask & (1 << i) != 0 && block.index(i) == 3);
    if !uses_black {
        return block;
    }
    let mut raw = block.0;
    if block.c0() == block.c1() {
        let mut bits = u32::from_le_bytes([raw[4], raw[5], raw[6], raw[7]]);
        for i in 0..16 {
            if (bits >> (2 * i)) & 3 == 3 {
                bits &= !(3 << (2 * i));
            }
        }
        raw[4..].copy_from_slice(&bits.to_le_bytes());
        return Bc1Block(raw);
    }
    raw.swap(0, 2);
    raw.swap(1, 3);
    reindex_bc1(Bc1Block(raw), intended)
}

/// Re-chooses every index of `block` as the palette entry nearest (squared error) to the
/// intended codes, never the transparent entry.
fn reindex_bc1(block: Bc1Block, intended: &[[u8; 3]; 16]) -> Bc1Block {
    let palette = block.palette(DecodeMode::D3d10);
    let usable = if block.is_four_colour() { 4 } else { 3 };
    let mut bits = 0u32;
    for (i, want) in intended.iter().enumerate() {
        let dist = |p: &[u8; 4]| {
            (0..3)
                .map(|c| (i32::from(p[c]) - i32::from(want[c])).pow(2))
                .sum::<i32>()
        };
        let best = (0..usable)
            .min_by_key(|&k| dist(&palette[k]))
            .expect("palette not empty");
        bits |= (best as u32) << (2 * i);
    }
    let mut raw = block.0;
    raw[4..].copy_from_slice(&bits.to_le_bytes());
    Bc1Block(raw)
}

/// Encodes 16 codes (row-major) as one BC4 block. Texels whose bit is clear in `mask` are
/// don't-cares.
///
/// Candidates: texpresso's block, the eight-value fit with endpoints at the block's min and max,
/// and the six-value fit over the values strictly between 0 and 255 (which keeps 0 = "zero
/// entry" exact). Each is re-indexed to the nearest palette entry under the reference decoder
/// and the one with the least squared error wins. texpresso alone is not enough: measured on
/// random blocks that contain a 0, its six-value fit sometimes maps values near the low endpoint
/// to 0 (e.g. 38 → 0 with an endpoint at 24), an RMS error of 19 where min/max gives 13.
pub fn encode_bc4_block(codes: &[u8; 16], mask: u32) -> [u8; 8] {
    if codes.iter().all(|c| *c == 0) {
        return [0; 8];
    }
    let rgba: [[u8; 4]; 16] = core::array::from_fn(|i| [codes[i], 0, 0, 255]);
    let mut theirs = [0u8; 8];
    texpresso::Format::Bc4.compress_block_masked(
        rgba,
        mask,
        texpresso::Params::default(),
        &mut theirs,
    );
    let live = |i: &usize| mask & (1 << *i) != 0;
    let values = || (0..16).filter(live).map(|i| codes[i]);
    let (lo, hi) = (values().min().unwrap_or(0), values().max().unwrap_or(0));
    let inner = || values().filter(|v| *v != 0 && *v != 255);
    let (lo6, hi6) = (inner().min().unwrap_or(lo), inner().max().unwrap_or(hi));
    let candidates = [
        (theirs[0], theirs[1]),
        // r0 > r1 selects eight values; equal endpoints fall back to the six-value mode, where
        // index 0 still decodes to the endpoint.
        (hi, lo),
        // r0 ≤ r1 selects six values plus the constants 0 and 255.
        (lo6, hi6),
    ];
    candidates
        .into_iter()
        .map(|(r0, r1)| bc4_with_best_indices(r0, r1, codes, mask))
        .min_by_key(|(_, sse)| *sse)
        .map(|(block, _)| block)
        .expect("three candidates")
}

/// The BC4 block with endpoints `r0`, `r1` and each texel's nearest palette index, with its
/// squared error over the texels in `mask`.
fn bc4_with_best_indices(r0: u8, r1: u8, codes: &[u8; 16], mask: u32) -> ([u8; 8], u32) {
    let palette = Bc4Block([r0, r1, 0, 0, 0, 0, 0, 0]).palette(DecodeMode::D3d10);
    let mut bits = 0u64;
    let mut sse = 0u32;
    for (i, &want) in codes.iter().enumerate() {
        let err = |k: usize| {
            (i32::from(palette[k]) - i32::from(want))
                .unsigned_abs()
                .pow(2)
        };
        let best = (0..8).min_by_key(|&k| err(k)).expect("eight entries");
        bits |= (best as u64) << (3 * i);
        if mask & (1 << i) != 0 {
            sse += err(best);
        }
    }
    let mut block = [0u8; 8];
    block[0] = r0;
    block[1] = r1;
    block[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
    (block, sse)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guard_repairs_equal_endpoints() {
        // c0 = c1 (three-colour), texels use index 3 and 0: all must decode to the endpoint.
        let c = 0x8410u16.to_le_bytes();
        let block = Bc1Block([c[0], c[1], c[0], c[1], 0b0000_0011, 0xff, 0, 0]);
        let intended = [[132u8, 130, 132]; 16];
        let fixed = guard_bc1(block, &intended, 0xffff);
        let texels = fixed.decode(DecodeMode::D3d10);
        assert!(
            texels
                .iter()
                .all(|t| t[3] == 255 && t[..3] == radiosity_core::expand_565(0x8410))
        );
    }

    #[test]
    fn guard_repairs_three_colour_black() {
        // c0 < c1, index 3 used: swapped to four-colour and re-indexed.
        let (lo, hi) = (0x0841u16.to_le_bytes(), 0xf79eu16.to_le_bytes());
        let block = Bc1Block([lo[0], lo[1], hi[0], hi[1], 0xff, 0xff, 0xff, 0xff]);
        let intended = [[200u8, 200, 200]; 16];
        let fixed = guard_bc1(block, &intended, 0xffff);
        assert!(fixed.is_four_colour());
        assert!(
            fixed
                .decode(DecodeMode::D3d10)
                .iter()
                .all(|t| t[3] == 255 && t[0] > 150)
        );
    }

    #[test]
    fn threshold_keeps_the_requested_fraction() {
        let dense: Vec<f32> = (0..1000).map(|i| i as f32).collect(); // 999 non-zero
        let t = sparse_threshold(&dense, 1, 0.01);
        let kept = dense.iter().filter(|v| **v > t).count();
        assert_eq!(kept, 10);
        assert_eq!(sparse_threshold(&dense, 1, 0.0), f32::INFINITY);
    }
}
