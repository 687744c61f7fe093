//! The scene's own emitters' columns kept exact where the blocks would light the scene visibly
//! off ([`EmitterColumns`]).
//!
//! A small light's columns hold the entries that carry almost all of the scene's own light,
//! and each row sees the light's patches almost alike, so their block errors add up along the
//! row instead of averaging out. The coupled pass (`refine::Coupling`) cancels much of that,
//! but on a coarse matrix a 4×4 block of four levels still spans near-field entries a hundred
//! times the light's: the Cornell box at 1008 patches in BC1 is lit 1.38% off by its own lamp
//! (0.21% at 4098). A reflectance edit is measured against a re-bake, and each carries its
//! file's error, so an error of that size in both is visible per object (1.3% on the lamp's own
//! face). Where the blocks leave the emitters' light more than [`EMITTER_ERROR_LIMIT`] off, the
//! emitters' columns move whole into the sparse list, which stores each entry exactly: the
//! scene's own light is then exact at any emitter intensity and under any edit of the other
//! patches. `docs/decisions/exact-emitter-columns.md` has the figures.

use super::{EncodeParams, ErrorWeights, build_sparse, correct};
use radiosity_core::{DecodeMode, Gather, ReferenceGather, Rgb, SparseRows, TransferMatrix};

/// The largest relative L2 error of the scene's own light `y = M·E` that the blocks may leave
/// before the emitters' columns are kept exact: a quarter of a percent, half the 0.5% per
/// object that a reflectance edit may be off a re-bake (each carries its own file's error).
pub const EMITTER_ERROR_LIMIT: f32 = 0.0025;

/// The most the exact columns may add, as a share of the block bytes: beyond it (emitters
/// covering more than about a sixtieth of a BC1 matrix's patches: a glowing room, not a lamp)
/// the blocks' error stands and the report says so.
pub const EXACT_EMITTERS_CAP: f64 = 0.5;

/// What the encoder did with the scene's own emitters' columns.
#[derive(Clone, Debug, PartialEq)]
pub struct EmitterColumns {
    /// Emitting columns.
    pub columns: usize,
    /// Relative L2 error of `y = M·E` through the blocks, sparse list and corrections as
    /// first encoded.
    pub error_in_blocks: f64,
    /// Whether the columns were moved into the sparse list.
    pub kept: bool,
    /// Bytes the columns take (or would take) in the sparse list beyond what it held.
    pub bytes: usize,
    /// Those bytes as a share of the block bytes.
    pub share_of_blocks: f64,
}

/// Relative L2 error of `y = M·E` between the exact dense `m` (`n × n × channels`) and
/// `encoded`; `None` when nothing emits. Scale-free: measured with the brightest emitter at 1,
/// so emission near f32's limit cannot overflow the f32 gather.
pub fn lighting_error(
    m: &[f32],
    n: usize,
    channels: usize,
    encoded: &TransferMatrix<'_>,
    emission: &[Rgb],
) -> Option<f64> {
    let peak = emission
        .iter()
        .map(|e| e.max_channel())
        .fold(0.0f32, f32::max);
    if !(peak > 0.0) {
        return None;
    }
    let scaled: Vec<Rgb> = emission.iter().map(|e| *e * (1.0 / peak)).collect();
    let emitting: Vec<usize> = (0..n).filter(|&j| scaled[j] != Rgb::ZERO).collect();
    let mut exact = vec![[0f64; 3]; n];
    for (i, row) in exact.iter_mut().enumerate() {
        for &j in &emitting {
            let e = scaled[j].to_array();
            for (k, y) in row.iter_mut().enumerate() {
                let v = m[(i * n + j) * channels + if channels == 1 { 0 } else { k }];
                *y += f64::from(v) * f64::from(e[k]);
            }
        }
    }
    let mut gather = ReferenceGather::new(encoded.clone(), DecodeMode::D3d10);
    let mut y = vec![Rgb::ZERO; n];
    gather.gather(&scaled, &mut y).ok()?;
    let num: f64 = exact
        .iter()
        .zip(&y)
        .map(|(a, b)| {
            (0..3)
                .map(|k| (a[k] - f64::from(b.channel(k))).powi(2))
                .sum::<f64>()
        })
        .sum();
    let den: f64 = exact.iter().flatten().map(|v| v * v).sum();
    (den > 0.0).then(|| (num / den).sqrt())
}

/// Measures the scene's own light through `matrix` (the encode of `dense` under `weights`)
/// and, where it is more than `params.emitter_error_limit` off and the columns fit
/// [`EXACT_EMITTERS_CAP`], moves the emitting columns into the sparse list and chooses the
/// block corrections again. `None` without emitters or for the float formats (exact already).
pub(super) fn review(
    matrix: &mut TransferMatrix<'static>,
    dense: &[f32],
    weights: &ErrorWeights,
    params: &EncodeParams,
) -> Option<EmitterColumns> {
    if !weights.has_emitters() || !params.format.is_log() {
        return None;
    }
    let (n, channels) = (matrix.layout.n(), matrix.layout.channels());
    // E/σ: proportional to E, and the error is relative.
    let emission: Vec<Rgb> = (0..n)
        .map(|c| {
            let [r, g, b] = weights.emission(c);
            Rgb::new(r, g, b)
        })
        .collect();
    let error_in_blocks = lighting_error(dense, n, channels, matrix, &emission)?;
    let emitting: Vec<bool> = emission.iter().map(|e| *e != Rgb::ZERO).collect();
    let old = matrix.sparse.clone();
    let held = |r: usize, c: usize| {
        let cols = &old.cols[old.row_ptr[r] as usize..old.row_ptr[r + 1] as usize];
        cols.binary_search(&(c as u32)).is_ok()
    };
    let columns_at: Vec<usize> = (0..n).filter(|&c| emitting[c]).collect();
    let added = (0..n)
        .map(|r| columns_at.iter().filter(|&&c| !held(r, c)).count())
        .sum::<usize>();
    let bytes = added * (4 + 4 * channels);
    let share_of_blocks = bytes as f64 / matrix.blocks.len().max(1) as f64;
    let kept = f64::from(params.emitter_error_limit) < error_in_blocks
        && share_of_blocks <= EXACT_EMITTERS_CAP;
    if kept {
        let sparse: SparseRows<'static> =
            build_sparse(matrix, dense, &|e| emitting[e % n] || held(e / n, e % n));
        matrix.sparse = sparse;
        let side = matrix.layout.padded() / 4;
        matrix.corrections = correct::choose(matrix, dense, weights, correct::count(params, side));
    }
    Some(EmitterColumns {
        columns: columns_at.len(),
        error_in_blocks,
        kept,
        bytes,
        share_of_blocks,
    })
}
