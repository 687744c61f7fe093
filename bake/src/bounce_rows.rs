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

/// Per patch (simplification order), the row of [`BOUNCE_RAYS`] rays from its pieces, for
/// the patches in `live` (`None` for the rest, and for a patch no ray of which starts
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
            let cast = caster.cast(&pieces, BOUNCE_RAYS, &mut rng)?;
            Some((cast.each, cast.entries))
        })
        .collect()
}
