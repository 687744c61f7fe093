//! Error-driven choice of the sparse entries.
//!
//! The sparse list makes an entry exact, so the best use of its fixed size is the entries the
//! blocks get most wrong in the weighted error ([`super::ErrorWeights`]), not the largest ones:
//! a large entry in a smooth block may decode within a code step while a smaller one beside an
//! emitter column or in a block that mixes near and far patches is off by a tenth. After a
//! first encode (with [`super::SparseRule`]'s set as don't-cares), each texel's score is its
//! weighted squared error as decoded; for an entry the first set made sparse it is the error of
//! what its block decodes there (each index is the nearest to the entry's value), i.e. what it
//! would cost to leave it to the block. The highest scores fill the list.

use radiosity_core::{DecodeMode, SparseRows, TransferMatrix};
use rayon::prelude::*;
use std::borrow::Cow;

/// The new sparse masks (one per 4×4 block, as `scores`): every bit of `forced`, then the
/// highest-scoring other texels until `budget` texels are kept in all. Texels with score 0
/// (exact as decoded, or beyond the matrix) are never chosen. Ties at the cut are all left out,
/// so at most `budget` are kept (more only if `forced` alone exceeds it). Deterministic: the
/// cut is an order statistic of the scores.
pub(super) fn by_score(scores: &[[f32; 16]], forced: &[u16], budget: usize) -> Vec<u16> {
    let forced_count: usize = forced.iter().map(|m| m.count_ones() as usize).sum();
    let room = budget.saturating_sub(forced_count);
    let mut free: Vec<f32> = scores
        .par_iter()
        .zip(forced.par_iter())
        .flat_map_iter(|(s, &f)| {
            (0..16)
                .filter(move |&i| f & (1 << i) == 0 && s[i] > 0.0)
                .map(move |i| s[i])
        })
        .collect();
    // Scores strictly above `cut` are kept: `cut` is the (room + 1)-th largest free score.
    let cut = if room == 0 {
        f32::INFINITY
    } else if room >= free.len() {
        0.0
    } else {
        let k = free.len() - room - 1;
        *free.select_nth_unstable_by(k, f32::total_cmp).1
    };
    scores
        .par_iter()
        .zip(forced.par_iter())
        .map(|(s, &f)| (0..16).fold(f, |m, i| if s[i] > cut { m | 1 << i } else { m }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_forced_then_the_highest_scores_within_the_budget() {
        let mut scores = vec![[0f32; 16]; 3];
        scores[0][..4].copy_from_slice(&[5.0, 1.0, 9.0, 0.0]);
        scores[1][..3].copy_from_slice(&[7.0, 3.0, 3.0]);
        scores[2][0] = 2.0;
        // Texel 3 of block 0 is forced although its score is 0.
        let forced = [1 << 3, 0, 0];
        // Budget 4: the forced texel, then 9, 7, 5.
        assert_eq!(
            by_score(&scores, &forced, 4),
            vec![1 << 3 | 1 | 1 << 2, 1, 0]
        );
        // Budget 5 cuts between the two tied 3s: neither is taken, never more than the budget.
        assert_eq!(
            by_score(&scores, &forced, 5),
            vec![1 << 3 | 1 | 1 << 2, 1, 0]
        );
        // Budget 6 takes both 3s.
        assert_eq!(
            by_score(&scores, &forced, 6),
            vec![1 << 3 | 1 | 1 << 2, 0b111, 0]
        );
        // A budget beyond every non-zero score takes them all and no zero score.
        assert_eq!(by_score(&scores, &forced, 100), vec![0b1111, 0b111, 1]);
        // Forced texels beyond the budget are still kept.
        assert_eq!(by_score(&scores, &forced, 0), vec![1 << 3, 0, 0]);
    }
}

/// How the sparse list's entries are chosen (its size is [`SparseRule`]'s either way).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SparseSelection {
    /// [`SparseRule`]: the largest entries and each row's [`ROW_KEEP`] largest. What a single
    /// block can be encoded with ([`BlockEncoder`]), so what order estimates measure.
    Largest,
    /// The entries whose weighted squared error after a first encode (with [`SparseRule`]'s
    /// set) is largest, as many as [`SparseRule`] keeps; see `select`.
    ErrorDriven,
}

/// Entries of each row kept exact whatever the global threshold: a row's irradiance is often
/// dominated by its few nearest neighbours, whose block errors do not average out (measured: a
/// 96-patch furnace at ρ = 0.5 was 1.1% off in BC4 with a global threshold alone). With
/// error-driven selection they are part of the first pass only: the selection keeps them when
/// their error says so (forcing them into the final list cost the Cornell box's BC1 Frobenius
/// error 2.61% → 2.65% and gained no lighting accuracy).
pub(crate) const ROW_KEEP: usize = 4;

/// Which entries the sparse list keeps: those whose largest channel exceeds a global threshold
/// (about `fraction` of the non-zero entries, [`sparse_threshold`]), plus each row's
/// [`ROW_KEEP`] largest. Depends only on the matrix, not on the patch order.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SparseRule {
    /// The global threshold.
    pub threshold: f32,
    /// Per row (matrix numbering as given), the [`ROW_KEEP`]-th largest non-zero entry; rows
    /// with fewer non-zero entries keep all of them.
    pub row_floor: Vec<f32>,
}

impl SparseRule {
    /// The rule for a dense matrix (`n · n · channels`); `fraction` 0 keeps nothing.
    pub(crate) fn new(dense: &[f32], n: usize, channels: usize, fraction: f32) -> Self {
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

    /// How many entries of the dense matrix (`n · n · channels`) the rule keeps.
    pub(crate) fn count(&self, dense: &[f32], n: usize, channels: usize) -> usize {
        (0..n)
            .into_par_iter()
            .map(|r| {
                dense[r * n * channels..(r + 1) * n * channels]
                    .chunks_exact(channels)
                    .filter(|e| self.keeps(r, e))
                    .count()
            })
            .sum()
    }

    /// Whether entry `entry` of row `row` is kept.
    #[inline]
    pub(crate) fn keeps(&self, row: usize, entry: &[f32]) -> bool {
        let v = entry.iter().copied().fold(0f32, f32::max);
        v > self.threshold || (v > 0.0 && v >= self.row_floor[row])
    }
}

/// The value above which an entry (its largest channel) goes to the sparse list, so that about
/// `fraction` of the non-zero entries do. `f32::INFINITY` keeps none. Independent of the patch
/// order. `dense` holds `channels` values per entry.
pub(crate) fn sparse_threshold(dense: &[f32], channels: usize, fraction: f32) -> f32 {
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
pub(super) fn build_sparse(
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
