//! Exact pairs or ray-cast rows: what integrating every piece pair would cost against casting
//! the rays (`docs/decisions/form-factor-cost.md`).

use crate::patch::Patches;

/// The piece pairs exact pairs integrate: `Σ_{i<j} p_i·p_j` over the patches' piece counts
/// `p_i` (each patch pair integrates every pair of their pieces).
pub(crate) fn piece_pairs(patches: &Patches) -> f64 {
    let (sum, squares) = (0..patches.len())
        .map(|i| patches.pieces_of(i).len() as f64)
        .fold((0.0, 0.0), |(s, q), p| (s + p, q + p * p));
    (sum * sum - squares) / 2.0
}

/// Piece pairs the exact pairs always integrate, whatever the rays would cost: about 20 s on
/// two cores at [`RAYS_PER_PIECE_PAIR`]'s rate, and the rows exact to the quadrature instead of
/// a sample's noise (a ray-cast row's sum is within about `0.5/√rays` of the truth).
pub(crate) const EXACT_PAIRS_ALWAYS: f64 = 1e7;

/// What a piece pair of the exact pairs costs, in cast rays. Measured on a roof-and-railings
/// part of 12 564 pieces at 1053 patches (`tests/cli/memory.rs`'s kind, 120 balusters a
/// railing; 2-core VM): 7.9e7 piece pairs in 165 s, 2.1 µs each; 4.3e6 rays in 4 s, 0.9 µs
/// each. Per object against the path tracer under sun and sky: 0.76% exact, 0.79% ray-cast.
pub(crate) const RAYS_PER_PIECE_PAIR: f64 = 2.3;

/// How much more time the exact pairs may take than the rays before the rays are cast: the
/// exact rows carry no sampling noise, so they are worth a few times the rays' time.
pub(crate) const EXACT_PREFERENCE: f64 = 8.0;

/// Whether integrating `pairs` piece pairs costs more than [`EXACT_PREFERENCE`] times casting
/// `per_patch` rays from each of `n` patches (and more than [`EXACT_PAIRS_ALWAYS`]): the scene
/// then takes ray-cast rows, so a scene of fewer triangles is never many times slower than a
/// larger one whose pieces exceed [`FormFactorParams::exact_pieces`](super::FormFactorParams::exact_pieces).
pub(crate) fn exact_costs_too_much(pairs: f64, n: usize, per_patch: u32) -> bool {
    pairs > EXACT_PAIRS_ALWAYS
        && pairs * RAYS_PER_PIECE_PAIR > EXACT_PREFERENCE * n as f64 * f64::from(per_patch)
}
