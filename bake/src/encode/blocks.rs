//! Block fits: one 4×4 block of one plane from its target (BC1 with texpresso's fits and the
//! three-colour guard, BC4 from three candidates, both refined in value space; u8, f16 and
//! f32 as they are), the per-tile log scales the codes come from, and [`BlockEncoder`] for
//! single blocks of a matrix whose scales are known.

use super::refine::{self, BlockTarget};
use super::{EncodeParams, ErrorWeights};
use radiosity_core::half::f32_to_f16;
use radiosity_core::{Bc1Block, Bc4Block, DecodeMode, Format, LogScale, MatrixLayout, Tile};
use rayon::prelude::*;

/// The decode table of formats without codes (f16, f32): never read.
static NO_TABLE: [f32; 256] = [0.0; 256];

/// A block target with nothing to fit: every texel a don't-care, no decode tables. Callers fill
/// in the texels, weights and tables of their block.
pub(super) fn empty_target() -> BlockTarget<'static> {
    BlockTarget {
        values: [[0.0; 16]; 3],
        weights: [[0.0; 16]; 3],
        fit: 0,
        tables: [&NO_TABLE; 3],
        codes: [[0; 16]; 3],
    }
}

/// Encodes one plane of a block from its target: BC1 and BC4 fitted in code space and refined
/// in value space, u8 as codes (sparse texels too, so that their residual is small), f16/f32
/// as values. BC1 starts from texpresso's range fit; `thorough` adds its cluster fit as a
/// second start and keeps the one that refines to the lower error.
pub(super) fn encode_target(
    params: &EncodeParams,
    plane: usize,
    t: &BlockTarget<'_>,
    out: &mut [u8],
    thorough: bool,
) {
    match params.format {
        Format::Bc1 => {
            let codes: [[u8; 3]; 16] =
                core::array::from_fn(|i| [t.codes[0][i], t.codes[1][i], t.codes[2][i]]);
            let block = if codes.iter().all(|c| *c == [0; 3]) {
                encode_bc1_block(&codes, t.fit, Bc1Fit::Range)
            } else {
                let range = refine::refine_bc1(encode_bc1_block(&codes, t.fit, Bc1Fit::Range), t);
                if thorough {
                    let fit = if params.bc1_iterative {
                        Bc1Fit::IterativeCluster
                    } else {
                        Bc1Fit::Cluster
                    };
                    let cluster = refine::refine_bc1(encode_bc1_block(&codes, t.fit, fit), t);
                    if cluster.1 < range.1 {
                        cluster.0
                    } else {
                        range.0
                    }
                } else {
                    range.0
                }
            };
            out.copy_from_slice(&block.0);
        }
        Format::Bc4 => {
            let codes = &t.codes[plane];
            if codes.iter().all(|c| *c == 0) {
                out.fill(0);
            } else {
                out.copy_from_slice(&refine::refine_bc4(&bc4_candidates(codes, t.fit), t, plane));
            }
        }
        Format::U8 => {
            for i in 0..16 {
                out[i] = if t.fit & (1 << i) != 0 {
                    t.codes[plane][i]
                } else {
                    // Sparse texel: the code of its value when known (0 where unknown).
                    let table = t.tables[plane];
                    let v = t.values[plane][i];
                    if t.weights[plane][i] > 0.0 && v > 0.0 {
                        nearest_code(table, v)
                    } else {
                        0
                    }
                };
            }
        }
        Format::F16 => {
            for i in 0..16 {
                out[2 * i..2 * i + 2]
                    .copy_from_slice(&f32_to_f16(t.values[plane][i]).to_le_bytes());
            }
        }
        Format::F32 => {
            for i in 0..16 {
                out[4 * i..4 * i + 4].copy_from_slice(&t.values[plane][i].to_le_bytes());
            }
        }
    }
}

/// The code whose decoded value is nearest `v` (the table is increasing).
fn nearest_code(table: &[f32; 256], v: f32) -> u8 {
    let above = table.partition_point(|t| *t < v);
    if above == 0 {
        return 0;
    }
    if above == 256 {
        return 255;
    }
    if v - table[above - 1] <= table[above] - v {
        (above - 1) as u8
    } else {
        above as u8
    }
}

/// The value a `value(row, col, channel)` function gives for an entry the sparse list holds:
/// NaN, a don't-care. The BC fits leave such texels out (so large entries do not distort their
/// block), u8 writes code 0, and the sparse list stores the exact value *minus* whatever the
/// block decodes there, so block + sparse is exact under the reference decoder.
pub(crate) const SPARSE_TEXEL: f32 = f32::NAN;

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
/// [`BlockEncoder`] (e.g. to estimate the compression error from a sample of blocks, with the
/// same quantisation as the whole matrix).
pub(crate) fn tile_scales<V>(
    layout: &MatrixLayout,
    params: &EncodeParams,
    value: &V,
) -> Vec<LogScale>
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

/// Encodes single blocks of a matrix whose scales are known, exactly as the first pass of
/// [`encode_dense_with`] does with uniform weights and [`SparseSelection::Largest`]: the same
/// code-space fit and value-space refinement, so a block is bit-identical on every texel that
/// counts (sparse texels may get another index). Used to estimate compression errors from a
/// sample of blocks (`order::ErrorMeter`).
pub(crate) struct BlockEncoder<'a> {
    layout: &'a MatrixLayout,
    params: &'a EncodeParams,
    scales: &'a [LogScale],
    /// [`LogScale::table`] of every scale.
    tables: Vec<[f32; 256]>,
}

impl<'a> BlockEncoder<'a> {
    /// An encoder for `layout` under `params` with `scales` from [`tile_scales`].
    pub(crate) fn new(
        layout: &'a MatrixLayout,
        params: &'a EncodeParams,
        scales: &'a [LogScale],
    ) -> Self {
        Self {
            layout,
            params,
            scales,
            tables: scales.iter().map(LogScale::table).collect(),
        }
    }

    /// Encodes block (`br`, `bc`) of `plane` in `tile` into `out`
    /// (`params.format.block_bytes()` bytes): `value` as in [`tile_scales`], the scales from
    /// [`tile_scales`] with the same `value`. Texels beyond the last patch and sparse texels
    /// (NaN) are don't-cares.
    pub(crate) fn encode<V>(
        &self,
        tile: &Tile,
        plane: usize,
        br: usize,
        bc: usize,
        value: &V,
        out: &mut [u8],
    ) where
        V: Fn(usize, usize, usize) -> f32,
    {
        let (layout, params) = (self.layout, self.params);
        let n = layout.n();
        let (r0, c0) = (tile.row0 + br * 4, tile.col0 + bc * 4);
        let channels: &[usize] = if params.format == Format::Bc1 {
            &[0, 1, 2]
        } else {
            &[plane][..]
        };
        let log = params.format.is_log();
        let mut target = empty_target();
        if log {
            for &ch in channels {
                target.tables[ch] = &self.tables[layout.scale_index(tile.index, ch)];
            }
        }
        let uniform = ErrorWeights::uniform();
        for i in 0..16 {
            let (r, c) = (r0 + i / 4, c0 + i % 4);
            if r >= n || c >= n || channels.iter().any(|&ch| value(r, c, ch).is_nan()) {
                continue;
            }
            target.fit |= 1 << i;
            for &ch in channels {
                let v = value(r, c, ch);
                target.values[ch][i] = v;
                target.weights[ch][i] = uniform.weight(c, ch, layout.channels());
                if log {
                    target.codes[ch][i] = self.scales[layout.scale_index(tile.index, ch)].encode(v);
                }
            }
        }
        encode_target(params, plane, &target, out, false);
    }
}

/// Which of texpresso's BC1 fits [`encode_bc1_block`] runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bc1Fit {
    /// Endpoints from the texels' principal axis and extent (≈ 1 µs a block).
    Range,
    /// Best ordered partition of the texels along that axis (≈ 19 µs a block).
    Cluster,
    /// Cluster fit repeated with the axis re-estimated from its result (slowest).
    IterativeCluster,
}

/// Encodes 16 RGB code triples (row-major) as one BC1 block with texpresso, uniform channel
/// weights (the channels are data, not perceived colour), then [`guard_bc1`]. Texels whose bit
/// is clear in `mask` are don't-cares.
pub fn encode_bc1_block(codes: &[[u8; 3]; 16], mask: u32, fit: Bc1Fit) -> Bc1Block {
    if codes.iter().all(|c| *c == [0, 0, 0]) {
        // c0 = c1 = 0, all indices 0: exactly zero in every decoder.
        return Bc1Block([0; 8]);
    }
    let rgba: [[u8; 4]; 16] =
        core::array::from_fn(|i| [codes[i][0], codes[i][1], codes[i][2], 255]);
    let params = texpresso::Params {
        algorithm: match fit {
            Bc1Fit::Range => texpresso::Algorithm::RangeFit,
            Bc1Fit::Cluster => texpresso::Algorithm::ClusterFit,
            Bc1Fit::IterativeCluster => texpresso::Algorithm::IterativeClusterFit,
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
pub(crate) fn guard_bc1(block: Bc1Block, intended: &[[u8; 3]; 16], mask: u32) -> Bc1Block {
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
    bc4_candidates(codes, mask)
        .into_iter()
        .map(|(r0, r1)| bc4_with_best_indices(r0, r1, codes, mask))
        .min_by_key(|(_, sse)| *sse)
        .map(|(block, _)| block)
        .expect("three candidates")
}

/// The endpoint pairs [`encode_bc4_block`] chooses among: texpresso's, the eight-value min/max
/// fit and the six-value fit over the inner values.
pub(crate) fn bc4_candidates(codes: &[u8; 16], mask: u32) -> [(u8, u8); 3] {
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
    [
        (theirs[0], theirs[1]),
        // r0 > r1 selects eight values; equal endpoints fall back to the six-value mode, where
        // index 0 still decodes to the endpoint.
        (hi, lo),
        // r0 ≤ r1 selects six values plus the constants 0 and 255.
        (lo6, hi6),
    ]
}

/// The BC4 block with endpoints `r0`, `r1` and each texel's nearest palette index, with its
/// squared error over the texels in `mask`.
pub(crate) fn bc4_with_best_indices(r0: u8, r1: u8, codes: &[u8; 16], mask: u32) -> ([u8; 8], u32) {
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
