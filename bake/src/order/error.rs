//! Compression error of a patch order: `‖decode(encode(P M Pᵀ)) − P M Pᵀ‖_F / ‖M‖_F`, exactly
//! or estimated from a sample of blocks.
//!
//! The exact path encodes the whole permuted matrix with [`encode_dense`] and decodes it with
//! [`TransferMatrix::decode_dense`]; at n = 4096 with BC1 that is about 10 s on 2 cores, too
//! slow to compare several orders inside a bake. The estimate encodes only a sample of 4×4 block
//! positions with a [`BlockEncoder`], quantised with the per-tile scales of the FULL matrix (so
//! every sampled block is bit-identical, on the texels that count, to the block the full encode
//! writes), and sums their squared errors with Horvitz–Thompson weights: an unbiased estimate of
//! the squared error.
//!
//! What is measured is the first pass of the bake's encode: uniform weights and the sparse
//! entries of [`SparseRule`] ([`encode_dense`]). The bake's own encode then chooses
//! the sparse entries by error and weighs the scene's emitters, which no single block can
//! reproduce, and lowers the chosen order's error further (Cornell box, BC1, 4106 patches:
//! paper order 2.85% measured here, 2.61% as baked). All candidates are measured under the
//! same first pass, so they compare fairly.
//!
//! Sampling is Poisson (each block in independently) with probability proportional to a mix of
//! the block's squared norm and the mean: the log quantiser's error is relative, so a block's
//! squared error grows with its squared norm, and sampling in proportion to it is close to the
//! variance-optimal design. The uniform share bounds the weight `1/p` of any block. All-zero
//! blocks encode exactly (every format writes zero codes, which decode to exactly 0) and are
//! never sampled. The sparse entries are exact (the sparse list stores each one's exact value
//! minus its block's decoded value), so their texels count no error.

use super::DenseMatrix;
use crate::encode::correct;
use crate::encode::{
    BlockEncoder, EncodeError, EncodeParams, SPARSE_TEXEL, SparseRule, check_input, encode_dense,
    tile_scales,
};
use crate::rng::SplitMix64;
use radiosity_core::corrections::{multiple, scale};
use radiosity_core::{BlockDecoder, DecodeMode, LogScale, MatrixLayout, TransferMatrix};
use rayon::prelude::*;

/// How [`ErrorMeter::measure`] measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ErrorSampling {
    /// Every block: the exact error (up to f64 summation order).
    Exact,
    /// About `fraction` of the non-zero block positions, drawn with `seed`. Cost scales with
    /// `fraction`; the relative standard error of the squared error scales as
    /// `1/√(fraction · blocks)` (reported in [`ErrorEstimate::relative_std`]).
    Blocks {
        /// Expected share of the non-zero blocks encoded, in `(0, 1]`.
        fraction: f64,
        /// Seed of the sample.
        seed: u64,
    },
}

impl ErrorSampling {
    /// At most about `blocks` block positions (BC1 encodes ≈ 20–70 µs per block and core),
    /// exact when the matrix has no more than that. `n` patches.
    pub fn budget(n: usize, blocks: usize, seed: u64) -> Self {
        let total = n.div_ceil(4).pow(2);
        if total <= blocks {
            ErrorSampling::Exact
        } else {
            ErrorSampling::Blocks {
                fraction: blocks as f64 / total as f64,
                seed,
            }
        }
    }
}

/// A measured (or estimated) compression error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// `‖decode(encode(M)) − M‖_F / ‖M‖_F` (0 for an all-zero M).
    pub relative: f64,
    /// `‖decode(encode(M)) − M‖_F²`, unbiased when sampled.
    pub squared_error: f64,
    /// `‖M‖_F²`, exact.
    pub squared_norm: f64,
    /// Estimated standard deviation of `squared_error` over samples, relative to it (0 when
    /// exact). `relative` is then uncertain by about half of this, relatively.
    pub relative_std: f64,
    /// Block positions encoded (each covers every plane).
    pub blocks_encoded: usize,
    /// Non-zero block positions in the matrix.
    pub blocks_nonzero: usize,
    /// Whether every non-zero block was encoded.
    pub exact: bool,
    /// RMS error of the compressed log texture, in 8-bit codes, over all `n²·channels` entries
    /// (sparse entries count 0: the sparse list makes them exact); unbiased in its square when
    /// sampled. The measure of the paper's Fig. 4, which compares the compressed texture with
    /// the uncompressed one. It counts a code wrong on a tiny entry as much as on a large one,
    /// so it is much larger for `random` than the value error is (see [`code_rms`]). `None` for
    /// the float formats, which store no codes.
    pub code_rms: Option<f64>,
}

/// [`ErrorEstimate::code_rms`] of a whole matrix: `exact` and `decoded` are its `n·n·channels`
/// values before and after compression (decoded with the sparse list), each turned into the
/// code of its tile's [`LogScale`]. `None` for the float formats.
pub fn code_rms(matrix: &TransferMatrix<'_>, exact: &[f32], decoded: &[f32]) -> Option<f64> {
    let l = &matrix.layout;
    if !l.format().is_log() {
        return None;
    }
    let (n, channels) = (l.n(), l.channels());
    assert_eq!(exact.len(), n * n * channels, "exact matrix of side {n}");
    assert_eq!(decoded.len(), exact.len(), "decoded matrix of side {n}");
    let sum: f64 = (0..n)
        .into_par_iter()
        .map(|r| {
            let mut sum = 0f64;
            for c in 0..n {
                let tile = l.locate(r, c).0.index;
                for ch in 0..channels {
                    let scale = &matrix.scales[l.scale_index(tile, ch)];
                    let e = (r * n + c) * channels + ch;
                    let d = i32::from(scale.encode(decoded[e])) - i32::from(scale.encode(exact[e]));
                    sum += f64::from(d * d);
                }
            }
            sum
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum();
    Some((sum / (n * n * channels).max(1) as f64).sqrt())
}

/// Share of the sampling weight spread uniformly over non-zero blocks (the rest goes by squared
/// norm). Pure norm weighting is variance-optimal when a block's squared error is proportional
/// to its squared norm; a quarter uniform caps `1/p` at 4× the uniform design for blocks whose
/// error outgrows their norm. With it the relative standard error on the Cornell box is
/// ≈ 0.1–0.7% from 65 536 blocks (n = 1938 and 4175); uniform sampling was not measured.
const UNIFORM_SHARE: f64 = 0.25;

/// Measures compression errors of one matrix under one set of encode parameters, for any
/// number of orders: the sparse rule and `‖M‖_F` are computed once (they do not depend
/// on the order), the per-tile scales once when the matrix has a single tile.
pub struct ErrorMeter<'a> {
    m: DenseMatrix<'a>,
    params: EncodeParams,
    layout: MatrixLayout,
    rule: SparseRule,
    squared_norm: f64,
    /// Per-tile scales when they cannot depend on the order (a single tile).
    shared_scales: Option<Vec<LogScale>>,
}

impl<'a> ErrorMeter<'a> {
    /// Checks the input as [`encode_dense`] would and prepares the order-independent parts.
    pub fn new(m: DenseMatrix<'a>, params: &EncodeParams) -> Result<Self, EncodeError> {
        let layout = check_input(m.n, m.channels, m.values, params)?;
        let fraction = if params.format.is_log() {
            params.sparse_fraction
        } else {
            0.0
        };
        let rule = SparseRule::new(m.values, m.n, m.channels, fraction);
        // Chunk sums are collected and added in order here and below: rayon's `sum` associates
        // as the work was stolen, and the estimates (in the report, and deciding `best`) must
        // not change from run to run.
        let squared_norm = m
            .values
            .par_chunks(4096)
            .map(|c| c.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>())
            .collect::<Vec<f64>>()
            .iter()
            .sum();
        let mut meter = Self {
            m,
            params: *params,
            layout,
            rule,
            squared_norm,
            shared_scales: None,
        };
        if layout.tile_count() == 1 {
            let scales = {
                let identity = |r: usize, c: usize, k: usize| meter.seen(None, r, c, k);
                tile_scales(&layout, params, &identity)
            };
            meter.shared_scales = Some(scales);
        }
        Ok(meter)
    }

    /// The encode parameters measured with.
    pub fn params(&self) -> &EncodeParams {
        &self.params
    }

    /// The value the blocks see at (`row`, `col`) of the permuted matrix: 0 beyond the last
    /// patch, [`SPARSE_TEXEL`] (NaN) where the sparse list holds the entry.
    #[inline]
    fn seen(&self, perm: Option<&[u32]>, row: usize, col: usize, ch: usize) -> f32 {
        let (n, channels) = (self.m.n, self.m.channels);
        if row >= n || col >= n {
            return 0.0;
        }
        let (r, c) = match perm {
            Some(p) => (p[row] as usize, p[col] as usize),
            None => (row, col),
        };
        let e = (r * n + c) * channels;
        let entry = &self.m.values[e..e + channels];
        if self.rule.keeps(r, entry) {
            SPARSE_TEXEL
        } else {
            entry[ch]
        }
    }

    /// The exact error through the real encoder and decoder: permutes the matrix, calls
    /// [`encode_dense`] (uniform weights, the sparse entries of [`SparseRule`]: the encode a
    /// block-by-block estimate reproduces) and [`TransferMatrix::decode_dense`] (D3D10 decode).
    /// The oracle for [`ErrorMeter::measure`]; allocates two more copies of the matrix.
    pub fn exact_full(&self, perm: Option<&[u32]>) -> Result<ErrorEstimate, EncodeError> {
        let (n, channels) = (self.m.n, self.m.channels);
        let permuted;
        let values = match perm {
            Some(p) => {
                permuted = super::permute(self.m.values, n, channels, p);
                &permuted[..]
            }
            None => self.m.values,
        };
        let t: TransferMatrix<'static> = encode_dense(n, channels, values, &self.params)?;
        let decoded = t.decode_dense(DecodeMode::D3d10);
        let squared_error: f64 = decoded
            .par_chunks(4096)
            .zip(values.par_chunks(4096))
            .map(|(d, v)| {
                d.iter()
                    .zip(v)
                    .map(|(a, b)| (f64::from(*a) - f64::from(*b)).powi(2))
                    .sum::<f64>()
            })
            .collect::<Vec<f64>>()
            .iter()
            .sum();
        let blocks = self
            .block_weights(perm)
            .iter()
            .filter(|w| **w > 0.0)
            .count();
        let mut e = self.estimate(squared_error, 0.0, 0.0, blocks, blocks, true);
        e.code_rms = code_rms(&t, values, &decoded);
        Ok(e)
    }

    /// The error of the matrix renumbered by `perm` (`perm[new] = old`; `None` = as given),
    /// measured on every block or a sample ([`ErrorSampling`]) without permuting a copy.
    pub fn measure(&self, perm: Option<&[u32]>, sampling: ErrorSampling) -> ErrorEstimate {
        if let Some(p) = perm {
            assert_eq!(p.len(), self.m.n, "permutation of the wrong length");
        }
        let layout = &self.layout;
        let seen = |r: usize, c: usize, k: usize| self.seen(perm, r, c, k);
        let own_scales;
        let scales = match &self.shared_scales {
            Some(s) => s,
            None => {
                own_scales = tile_scales(layout, &self.params, &seen);
                &own_scales
            }
        };
        let decoder = BlockDecoder::from_scales(scales, DECODE);
        let encoder = BlockEncoder::new(layout, &self.params, scales);
        let weights = self.block_weights(perm);
        let nonzero = weights.iter().filter(|w| **w > 0.0).count();
        let probability = inclusion_probabilities(&weights, nonzero, sampling);
        let seed = match sampling {
            ErrorSampling::Exact => 0,
            ErrorSampling::Blocks { seed, .. } => seed,
        };
        let side = layout.padded() / 4;
        let base = correct::bases(layout, scales);
        let corrected = correct::count(&self.params, side);
        // Per sampled block: squared error / p, its variance term, squared code error / p,
        // what a correction would remove from the first and the third, and the weight 1/p.
        let sampled: Vec<Sampled> = (0..weights.len())
            .into_par_iter()
            .filter_map(|b| {
                let p = probability(weights[b]);
                if p <= 0.0 {
                    return None;
                }
                if p < 1.0 {
                    // One independent draw per block, from the seed and the block index only:
                    // the same sample whatever the thread count.
                    let u = SplitMix64(seed ^ (b as u64).wrapping_mul(0xd1b5_4a32_d192_ed03))
                        .next_f64();
                    if u >= p {
                        return None;
                    }
                }
                let (row, col) = (b / side * 4, b % side * 4);
                let (err, code, gain) =
                    self.block_error(&seen, &encoder, &decoder, scales, &base, row, col);
                Some(Sampled {
                    error: err / p,
                    variance: err * err * (1.0 - p) / (p * p),
                    codes: code / p,
                    gain,
                    weight: 1.0 / p,
                    block: b,
                })
            })
            .collect();
        let count = sampled.len();
        let (mut sum, var, mut codes) = sampled.iter().fold((0.0, 0.0, 0.0), |a, s| {
            (a.0 + s.error, a.1 + s.variance, a.2 + s.codes)
        });
        let removed = corrected_gain(&sampled, corrected);
        sum -= removed[0];
        codes -= removed[1];
        let exact = count == nonzero;
        self.estimate(sum.max(0.0), var, codes.max(0.0), count, nonzero, exact)
    }

    fn estimate(
        &self,
        squared_error: f64,
        variance: f64,
        code_squared_error: f64,
        encoded: usize,
        nonzero: usize,
        exact: bool,
    ) -> ErrorEstimate {
        let entries = (self.m.n * self.m.n * self.m.channels).max(1) as f64;
        let relative = if self.squared_norm > 0.0 {
            (squared_error / self.squared_norm).sqrt()
        } else {
            0.0
        };
        ErrorEstimate {
            relative,
            squared_error,
            squared_norm: self.squared_norm,
            relative_std: if squared_error > 0.0 {
                variance.sqrt() / squared_error
            } else {
                0.0
            },
            blocks_encoded: encoded,
            blocks_nonzero: nonzero,
            exact,
            code_rms: self
                .params
                .format
                .is_log()
                .then(|| (code_squared_error / entries).sqrt()),
        }
    }

    /// Squared norm of the values the blocks see, per 4×4 block position of the padded
    /// matrix (row-major over block rows), all channels together.
    fn block_weights(&self, perm: Option<&[u32]>) -> Vec<f64> {
        let side = self.layout.padded() / 4;
        let (n, channels) = (self.m.n, self.m.channels);
        let mut weights = vec![0f64; side * side];
        weights
            .par_chunks_mut(side)
            .enumerate()
            .for_each(|(block_row, out)| {
                for r in block_row * 4..(block_row * 4 + 4).min(n) {
                    for c in 0..n {
                        // Sparse texels (NaN) are exact: no weight.
                        let s: f64 = (0..channels)
                            .map(|k| f64::from(self.seen(perm, r, c, k)))
                            .filter(|v| !v.is_nan())
                            .map(|v| v * v)
                            .sum();
                        out[c / 4] += s;
                    }
                }
            });
        weights
    }

    /// Squared error of the block position whose top-left texel is (`row`, `col`), over every
    /// plane, decoded as the reference decoder does (D3D10): in value, in log codes of the
    /// tile's `scales` (0 for the float formats), and what a block correction with exponent
    /// bases `base` would remove from each (chosen for the first, with uniform weights).
    fn block_error<V>(
        &self,
        seen: &V,
        encoder: &BlockEncoder<'_>,
        decoder: &BlockDecoder,
        scales: &[LogScale],
        base: &[f32; 3],
        row: usize,
        col: usize,
    ) -> (f64, f64, [f64; 2])
    where
        V: Fn(usize, usize, usize) -> f32,
    {
        let layout = &self.layout;
        let (tile, br, bc) = layout.locate(row, col);
        let format = self.params.format;
        let mut raw = [0u8; 64];
        let raw = &mut raw[..format.block_bytes()];
        let mut decoded = [[0f32; 16]; 3];
        for plane in 0..layout.planes() {
            encoder.encode(&tile, plane, br, bc, seen, raw);
            decoder.decode_plane(layout, tile.index, plane, raw, &mut decoded);
        }
        let n = self.m.n;
        let (mut err, mut code_err) = (0f64, 0f64);
        let mut exact = [[f32::NAN; 16]; 3];
        for i in 0..16 {
            let (r, c) = (row + i / 4, col + i % 4);
            if r >= n || c >= n {
                continue;
            }
            for ch in 0..self.m.channels {
                let want = seen(r, c, ch);
                // A sparse texel is exact: the sparse list corrects whatever the block holds.
                if want.is_nan() {
                    continue;
                }
                let got = decoded[ch][i];
                exact[ch][i] = want;
                err += (f64::from(got) - f64::from(want)).powi(2);
                if let Some(scale) = scales.get(layout.scale_index(tile.index, ch)) {
                    let d = i32::from(scale.encode(got)) - i32::from(scale.encode(want));
                    code_err += f64::from(d * d);
                }
            }
        }
        if !(crate::encode::takes_corrections(self.params.format) && self.params.corrections > 0.0)
        {
            return (err, code_err, [0.0; 2]);
        }
        let ceiling = core::array::from_fn(|k| {
            scales
                .get(layout.scale_index(tile.index, k))
                .map_or(0.0, |s| s.v_max)
        });
        let (gain, exponents, words) =
            correct::fit(&decoded, &exact, self.m.channels, base, &ceiling, |_, _| {
                1.0
            });
        // The code error the correction removes, from the values it decodes to.
        let mut code_after = 0f64;
        for (ch, want) in exact.iter().enumerate().take(self.m.channels) {
            let step = scale(base[ch], exponents[ch]);
            let scale_of = &scales[layout.scale_index(tile.index, ch)];
            for (i, want) in want.iter().enumerate().filter(|(_, w)| !w.is_nan()) {
                let got = decoded[ch][i] + multiple(&words[ch], i) as f32 * step;
                let d = i32::from(scale_of.encode(got)) - i32::from(scale_of.encode(*want));
                code_after += f64::from(d * d);
            }
        }
        let code_gain = code_err - code_after;
        (err, code_err, [gain, code_gain])
    }
}

/// One sampled block of [`ErrorMeter::measure`].
struct Sampled {
    /// Squared error over the inclusion probability p.
    error: f64,
    /// Its variance term.
    variance: f64,
    /// Squared code error over p.
    codes: f64,
    /// What a block correction removes from the squared error and the squared code error.
    gain: [f64; 2],
    /// 1/p: how many blocks this one stands for.
    weight: f64,
    /// Block index.
    block: usize,
}

/// The squared error and squared code error the encoder's block corrections remove, estimated
/// from the sampled blocks: the encoder corrects the `corrected` blocks of largest gain (ties
/// by index), so the sample's blocks are taken in that order, each standing for `1/p` blocks,
/// until `corrected` blocks are accounted for. Exact when every block is sampled.
fn corrected_gain(sampled: &[Sampled], corrected: usize) -> [f64; 2] {
    let mut by_gain: Vec<&Sampled> = sampled.iter().filter(|s| s.gain[0] > 0.0).collect();
    by_gain.sort_unstable_by(|a, b| b.gain[0].total_cmp(&a.gain[0]).then(a.block.cmp(&b.block)));
    let mut left = corrected as f64;
    let mut removed = [0.0; 2];
    for s in by_gain {
        if left <= 0.0 {
            break;
        }
        let take = s.weight.min(left);
        removed[0] += s.gain[0] * take;
        removed[1] += s.gain[1] * take;
        left -= take;
    }
    removed
}

/// The decode mode errors are measured under (the reference decoder's exact-integer mode).
const DECODE: DecodeMode = DecodeMode::D3d10;

/// The inclusion probability of a block as a function of its weight: `p = min(1, λ·(w + a))`
/// for non-zero weights, with `a` the uniform share and `λ` set so that the expected sample
/// size is the requested fraction of the non-zero blocks.
fn inclusion_probabilities(
    weights: &[f64],
    nonzero: usize,
    sampling: ErrorSampling,
) -> Box<dyn Fn(f64) -> f64 + Sync> {
    let fraction = match sampling {
        ErrorSampling::Exact => 1.0,
        ErrorSampling::Blocks { fraction, .. } => {
            assert!(
                fraction > 0.0 && fraction <= 1.0,
                "sample fraction {fraction} not in (0, 1]"
            );
            fraction
        }
    };
    let total: f64 = weights.iter().sum();
    if fraction >= 1.0 || nonzero == 0 {
        return Box::new(|w: f64| if w > 0.0 { 1.0 } else { 0.0 });
    }
    let mean = total / nonzero as f64;
    // Mixed weight w' = (1 − u)·w + u·mean sums to `total` over the non-zero blocks.
    let mixed = move |w: f64| (1.0 - UNIFORM_SHARE) * w + UNIFORM_SHARE * mean;
    let target = fraction * nonzero as f64;
    let expected = |lambda: f64| -> f64 {
        weights
            .iter()
            .filter(|w| **w > 0.0)
            .map(|w| (lambda * mixed(*w)).min(1.0))
            .sum()
    };
    // Σ min(1, λ w') is increasing in λ; at λ0 = target / total it is ≤ target.
    let (mut lo, mut hi) = (target / total, target / total);
    while expected(hi) < target {
        hi *= 2.0;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if expected(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Box::new(move |w: f64| {
        if w > 0.0 {
            (hi * mixed(w)).min(1.0)
        } else {
            0.0
        }
    })
}
