//! Each patch's first bounce gathered where its rays land (the file's BOUNCE section,
//! [`radiosity_core::bounce`]; `docs/decisions/first-bounce-rows.md`).
//!
//! The matrix sends each patch's light as its mean over its area. A floor patch with a sunlit
//! strip by the window sends that strip's light to the far wall, which sees only the patch's
//! shaded part, and the wall then passes it on. A patch's row counts where [`BOUNCE_RAYS`]
//! cosine-weighted rays from its exposed surface first land, at the direct-light sample of the
//! hit patch nearest to each hit; at run time the row turns the senders' direct light at those
//! samples, less their means, into a correction of the patch's first bounce, which the frame
//! carries through every later bounce. Geometric: any light, moved without a re-bake.

use crate::geometry::Occluders;
use crate::part_rows::RowCaster;
use crate::patch::{Patches, Piece};
use crate::rng::SplitMix64;
use rayon::prelude::*;

/// Cosine-weighted rays cast from each patch. The correction is a mean over them of the
/// senders' spread of direct light about their means: its standard error is that spread's
/// (over the rays) over √1024, about 3% of a first bounce that comes all from a sunlit third
/// of one sender, and an object's figure averages it over its patches.
pub(crate) const BOUNCE_RAYS: u32 = 1024;

/// One patch's first-bounce row ([`bounce_rows`]): the weight of one ray (one over the
/// patch's rays that start exposed), and `(patch, sample, count)`, the rays whose first hit is
/// nearest to direct-light sample `sample` (its index among the hit patch's samples) of
/// `patch`, in increasing `(patch, sample)` order.
pub(crate) type BounceRow = (f64, Vec<(u32, u32, u16)>);

/// Per patch (simplification order), the row of [`BOUNCE_RAYS`] rays from its pieces, on the
/// senders [`keep_uneven`] keeps, for the patches in `live` (`None` for the rest, and for a patch no ray of which starts
/// exposed); `samples[j]` are patch `j`'s direct-light samples `(position, object, area)` as the
/// runtime mesh holds them. Deterministic: each patch's stream is seeded by its index.
pub(crate) fn bounce_rows(
    patches: &Patches,
    occ: &Occluders,
    live: &[usize],
    samples: &[Vec<(glam::DVec3, u32, f64)>],
    seed: u64,
) -> Vec<Option<BounceRow>> {
    let caster = RowCaster::new(patches, occ, samples);
    let mut is_live = vec![false; patches.len()];
    for &i in live {
        is_live[i] = true;
    }
    (0..patches.len())
        .into_par_iter()
        .map(|i| {
            if !is_live[i] {
                return None;
            }
            let pieces: Vec<Piece> = patches
                .pieces_of(i)
                .iter()
                .filter(|q| q.area > 0.0)
                .cloned()
                .collect();
            let mut rng =
                SplitMix64(seed ^ 0xb0_0c3e ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut cast = caster.cast(&pieces, BOUNCE_RAYS, &mut rng)?;
            // Pruned here, patch by patch, so that the raw counts never all stand at once.
            keep_uneven(&mut cast.entries, samples);
            Some((cast.each, cast.entries))
        })
        .collect()
}

/// Keeps a row's entries on each sender whose hits its samples share more unevenly than
/// chance alone would: where `C` rays land on a sender in proportion to its samples' areas
/// (expected `e_k = C·a_k/A` on sample `k`), its entries correct nothing on average, whatever
/// the light (the patch's mean is the same area-weighted mean), and add only noise and bytes.
/// A sender is kept where its counts' `χ² = Σ (c_k − e_k)²/e_k` exceeds its `K − 1` degrees
/// of freedom (the mean χ² of an even sender), with at least [`UNEVEN_HITS`] hits. On the house
/// this keeps 61% of the entries and 4.10% of the 3.97% error without the ground; three
/// standard deviations above it kept 27% and let the error grow to 5.17%
/// (`docs/decisions/first-bounce-rows.md`).
fn keep_uneven(entries: &mut Vec<(u32, u32, u16)>, samples: &[Vec<(glam::DVec3, u32, f64)>]) {
    let mut kept = Vec::with_capacity(entries.len());
    for run in entries.chunk_by(|a, b| a.0 == b.0) {
        let of = &samples[run[0].0 as usize];
        let hits: f64 = run.iter().map(|e| f64::from(e.2)).sum();
        let area: f64 = of.iter().map(|s| s.2).sum();
        let dof = of.len().saturating_sub(1) as f64;
        if dof == 0.0 || hits < UNEVEN_HITS || !(area > 0.0) {
            continue;
        }
        // Σ (c − e)²/e over every sample = Σ c²/e over those hit − C.
        let chi2 = run
            .iter()
            .map(|e| {
                let expected = hits * of[e.1 as usize].2 / area;
                let c = f64::from(e.2);
                if expected > 0.0 {
                    c * c / expected
                } else {
                    0.0
                }
            })
            .sum::<f64>()
            - hits;
        if chi2 > dof {
            kept.extend_from_slice(run);
        }
    }
    *entries = kept;
}

/// Fewer hits on a sender than this say nothing of how they share it ([`keep_uneven`]).
const UNEVEN_HITS: f64 = 4.0;
