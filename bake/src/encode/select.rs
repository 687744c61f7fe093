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

use rayon::prelude::*;

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
