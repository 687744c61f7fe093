//! The burial survey: which ray starts of each patch other objects bury (no light reaches
//! or leaves them), asked once and shared by the ray-cast rows ([`super::cast`]) and the
//! buried surface taken out of the patches (`crate::exposure`).

use super::Starts;
use crate::geometry::Occluders;
use crate::patch::Patches;
use rayon::prelude::*;

/// Points in the first look at a patch in [`survey`] (stratified, see [`crate::rng::sobol2`]).
/// At 32, slivers of about 3.5% along a patch's edge went unseen: on a room with a block
/// resting on its floor at 4358 patches their rows stayed 0.955–0.968 (the exposed share
/// alone), the lowest rows of the scene; at 64 its lowest is 0.992.
pub(crate) const BURIED_FIRST: u32 = 64;

/// Points in all for a patch the first look finds partly buried. Independent uniform points
/// would give the share a standard error of up to `0.5 / √512 = 0.022`; the stratified ones
/// measured within ±0.003 of a 20 000-point estimate on strips along a patch's edge.
pub(crate) const BURIED_POINTS: u32 = 512;

/// A surveyed start that nothing buries ([`survey`]).
pub(crate) const EXPOSED: u32 = u32::MAX;

/// The burial survey: per patch, for each of its first [`BURIED_POINTS`] ray starts
/// ([`crate::form_factor::Starts`]), the object of the piece it lies on where another object
/// buries it ([`Occluders::covered`] or [`Occluders::buried`]: no light reaches it or leaves
/// it), [`EXPOSED`] where not; empty for a patch whose first [`BURIED_FIRST`] starts are all
/// exposed. The ray-cast rows start their rays only at surveyed starts of a partly buried
/// patch and [`expose`] takes its buried share from the same starts, so each start's burial
/// (up to 4 fans of 9 rays deep) is asked once (`docs/decisions/burial-survey.md`).
pub(crate) fn survey(patches: &Patches, occ: &Occluders) -> Vec<Vec<u32>> {
    (0..patches.len())
        .into_par_iter()
        .map(|i| survey_one(patches, occ, i).0)
        .collect()
}

/// [`survey`] of the patches `rows` only, in that order (a shard's, [`crate::plan`]), with
/// whether each one's burial questions asked about other points too
/// ([`Occluders::buried_traced`]).
pub(crate) fn survey_rows(
    patches: &Patches,
    occ: &Occluders,
    rows: &[u32],
) -> (Vec<Vec<u32>>, Vec<bool>) {
    rows.par_iter()
        .map(|&i| survey_one(patches, occ, i as usize))
        .unzip()
}

/// The starts [`survey`] looked at for a patch whose survey is `seen`: the first
/// [`BURIED_FIRST`], or all [`BURIED_POINTS`] where it found one buried.
pub(crate) fn surveyed_starts(seen: &[u32]) -> u32 {
    if seen.is_empty() {
        BURIED_FIRST
    } else {
        BURIED_POINTS
    }
}

/// [`survey`] of patch `i`, and whether a burial question asked about other points too.
pub(crate) fn survey_one(patches: &Patches, occ: &Occluders, i: usize) -> (Vec<u32>, bool) {
    let Some(starts) = Starts::new(patches, i) else {
        return (Vec::new(), false);
    };
    let recursed = std::cell::Cell::new(false);
    let look = |k: u32| {
        let (piece, _, x, n) = starts.point(k);
        let buried = occ.covered(piece.triangle, x) || {
            let (b, r) = occ.buried_traced(x, n);
            if r {
                recursed.set(true);
            }
            b
        };
        if buried { piece.object } else { EXPOSED }
    };
    let mut seen: Vec<u32> = (0..BURIED_FIRST).map(look).collect();
    if seen.iter().all(|&o| o == EXPOSED) {
        return (Vec::new(), recursed.get());
    }
    seen.extend((BURIED_FIRST..BURIED_POINTS).map(look));
    (seen, recursed.get())
}
