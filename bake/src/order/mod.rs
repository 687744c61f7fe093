//! Patch reordering before compression (paper §4.2; `docs/contract.md`, "Encoding").
//!
//! BC1/BC4 compress each 4×4 block on its own, so the error depends on which patches share a
//! block: renumbering patches (rows and columns of M together, `P M Pᵀ`) so that patches with
//! similar rows and columns fall in the same groups of four cuts the error, and the runtime
//! pays nothing, since the file is simply in the new numbering.
//!
//! Every order is a permutation `perm` with `perm[new] = old`. [`OrderKind`] names them;
//! [`permutation`] computes one; [`evaluate`] computes several and measures the compression
//! error of each ([`ErrorMeter`], exactly or from a sample of blocks) for the bake report;
//! [`choose_best`] picks among measured candidates. [`permute`] applies an order to the dense
//! matrix, [`permute_rows`] to per-patch arrays.
//!
//! ```
//! use radiosity_bake::encode::EncodeParams;
//! use radiosity_bake::order::{self, DenseMatrix, ErrorMeter, ErrorSampling, OrderKind, OrderParams};
//! use radiosity_core::{Format, Patch, Rgb};
//!
//! let n: usize = 8;
//! let patches: Vec<Patch> = (0..n)
//!     .map(|i| Patch {
//!         centre: [i as f32, 0.0, 0.0],
//!         area: 1.0,
//!         normal: [0.0, 1.0, 0.0],
//!         object: 0,
//!         reflectance: Rgb::splat(0.5),
//!         emission: Rgb::ZERO,
//!     })
//!     .collect();
//! let values: Vec<f32> = (0..n * n).map(|e| 1.0 / (1.0 + (e / n).abs_diff(e % n) as f32)).collect();
//! let m = DenseMatrix::new(n, 1, &values);
//! let params = OrderParams::for_encode(EncodeParams::for_format(Format::Bc4));
//! let perm = order::permutation(OrderKind::Spatial, &patches, m, &params).unwrap();
//! let reordered = order::permute(&values, n, 1, &perm);
//! let meter = ErrorMeter::new(m, &params.encode).unwrap();
//! let err = meter.measure(Some(&perm), ErrorSampling::Exact);
//! assert!(err.relative < 0.05);
//! # let _ = reordered;
//! ```

mod error;
mod similarity;
mod spatial;

pub use error::{ErrorEstimate, ErrorMeter, ErrorSampling, code_rms};
pub use spatial::orientation;

pub(crate) use similarity::{Signatures, greedy_chain};
pub(crate) use spatial::{Curve, spatial_order};

use crate::encode::{EncodeError, EncodeParams, SparseRule};
use crate::rng::SplitMix64;
use radiosity_core::{Patch, PatchOrder};
use rayon::prelude::*;
use std::time::Instant;

/// A patch order (`--order`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OrderKind {
    /// As patches come out of simplification: the identity.
    None,
    /// A seeded shuffle: the arbitrary order the paper starts from.
    Random,
    /// The paper's neighbour sort: a greedy chain over row/column signatures of M.
    Paper,
    /// Hilbert curve over patch centres within each of the six orientation groups.
    Spatial,
    /// Whichever of the others measures smallest compression error.
    Best,
}

impl OrderKind {
    /// Every kind, in command-line order.
    pub const ALL: [OrderKind; 5] = [
        OrderKind::None,
        OrderKind::Random,
        OrderKind::Paper,
        OrderKind::Spatial,
        OrderKind::Best,
    ];

    /// The concrete orders (everything but `best`): what a bake reports errors for.
    pub const CONCRETE: [OrderKind; 4] = [
        OrderKind::None,
        OrderKind::Random,
        OrderKind::Paper,
        OrderKind::Spatial,
    ];

    /// The orders `best` chooses among. `random` is left out: it is the baseline to beat,
    /// never a candidate worth its measuring time.
    pub const CANDIDATES: [OrderKind; 3] = [OrderKind::None, OrderKind::Paper, OrderKind::Spatial];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            OrderKind::None => "none",
            OrderKind::Random => "random",
            OrderKind::Paper => "paper",
            OrderKind::Spatial => "spatial",
            OrderKind::Best => "best",
        }
    }

    /// The kind with this command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// What the `.rad` file records; `None` for `best`, which must be resolved first.
    pub fn patch_order(self) -> Option<PatchOrder> {
        match self {
            OrderKind::None => Some(PatchOrder::Natural),
            OrderKind::Random => Some(PatchOrder::Random),
            OrderKind::Paper => Some(PatchOrder::Paper),
            OrderKind::Spatial => Some(PatchOrder::Spatial),
            OrderKind::Best => None,
        }
    }
}

impl From<PatchOrder> for OrderKind {
    fn from(o: PatchOrder) -> Self {
        match o {
            PatchOrder::Natural => OrderKind::None,
            PatchOrder::Random => OrderKind::Random,
            PatchOrder::Paper => OrderKind::Paper,
            PatchOrder::Spatial => OrderKind::Spatial,
        }
    }
}

/// A dense transfer matrix as the encoder takes it: row-major `n × n`, `channels` values per
/// entry, interleaved.
#[derive(Clone, Copy, Debug)]
pub struct DenseMatrix<'a> {
    /// Patches.
    pub n: usize,
    /// Values per entry (1 or 3).
    pub channels: usize,
    /// `n · n · channels` values.
    pub values: &'a [f32],
}

impl<'a> DenseMatrix<'a> {
    /// Wraps `values`; panics if the length is not `n² · channels` (a programming error).
    pub fn new(n: usize, channels: usize, values: &'a [f32]) -> Self {
        assert_eq!(
            values.len(),
            n * n * channels,
            "dense matrix of {n} patches and {channels} channels"
        );
        Self {
            n,
            channels,
            values,
        }
    }
}

/// How orders are computed and judged. Each field trades bake time against the order's
/// quality or the precision of its measured error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrderParams {
    /// Seed of the `random` order and of the error sample. Same seed, same result.
    pub seed: u64,
    /// Sampled rows and columns per `paper` signature. More: closer to comparing whole rows,
    /// at `n²·2·samples` flops. 32 keeps n = 4096 near half a second.
    pub signature_samples: usize,
    /// The encoding the error is measured for (format, shift, sparse fraction, tiles). `best`
    /// may pick a different order for BC1 than for BC4.
    pub encode: EncodeParams,
    /// Block positions encoded per order when measuring; exact when the matrix has no more.
    /// Time is linear in it (BC1: 16 384 blocks ≈ 0.3–1 s on 2 busy cores); the relative
    /// standard error of the squared error falls as its square root: measured on the Cornell
    /// box at n = 4175, 0.3–0.7% with 65 536 blocks, so ≈ 1% with the default 16 384.
    pub error_blocks: usize,
}

impl Default for OrderParams {
    fn default() -> Self {
        Self {
            seed: 0x5eed,
            signature_samples: 32,
            encode: EncodeParams::default(),
            error_blocks: 1 << 14,
        }
    }
}

impl OrderParams {
    /// Defaults, measuring errors for `encode`.
    pub fn for_encode(encode: EncodeParams) -> Self {
        Self {
            encode,
            ..Self::default()
        }
    }

    /// Exact errors (every block encoded) and 64 signature samples: for reports and tests
    /// where time does not matter.
    pub fn exact(encode: EncodeParams) -> Self {
        Self {
            encode,
            signature_samples: 64,
            error_blocks: usize::MAX,
            ..Self::default()
        }
    }

    /// The error sampling for `n` patches.
    pub fn sampling(&self, n: usize) -> ErrorSampling {
        ErrorSampling::budget(n, self.error_blocks, self.seed)
    }
}

/// The identity: patches as simplification numbered them.
pub fn identity(n: usize) -> Vec<u32> {
    (0..n as u32).collect()
}

/// A seeded Fisher–Yates shuffle of `0..n`.
pub fn random_order(n: usize, seed: u64) -> Vec<u32> {
    let mut perm = identity(n);
    SplitMix64(seed).shuffle(&mut perm);
    perm
}

/// The paper's neighbour sort over signatures of `m` ([`Signatures`], [`greedy_chain`]).
pub(crate) fn paper_order(m: DenseMatrix<'_>, params: &OrderParams) -> Vec<u32> {
    let rule = SparseRule::new(m.values, m.n, m.channels, sparse_fraction(&params.encode));
    let sig = Signatures::new(m, params.signature_samples, params.encode.shift, &rule);
    greedy_chain(&sig)
}

/// The share of entries the encoder keeps sparse (none for the float formats).
fn sparse_fraction(p: &EncodeParams) -> f32 {
    if p.format.is_log() {
        p.sparse_fraction
    } else {
        0.0
    }
}

/// The permutation of one order (`perm[new] = old`). `patches` give positions and normals,
/// `m` the matrix in the same numbering. `best` measures [`OrderKind::CANDIDATES`] with
/// `params` and returns the winner ([`choose_best`]); only `best` can fail (bad encode input).
pub fn permutation(
    kind: OrderKind,
    patches: &[Patch],
    m: DenseMatrix<'_>,
    params: &OrderParams,
) -> Result<Vec<u32>, EncodeError> {
    assert_eq!(patches.len(), m.n, "one patch per matrix row");
    Ok(match kind {
        OrderKind::None => identity(m.n),
        OrderKind::Random => random_order(m.n, params.seed),
        OrderKind::Paper => paper_order(m, params),
        OrderKind::Spatial => spatial_order(patches, Curve::Hilbert),
        OrderKind::Best => {
            let mut candidates = evaluate(&OrderKind::CANDIDATES, patches, m, params)?;
            let best = choose_best(&candidates);
            candidates.swap_remove(best).perm
        }
    })
}

/// One order with its measured compression error.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// Which order (never [`OrderKind::Best`]).
    pub kind: OrderKind,
    /// `perm[new] = old`.
    pub perm: Vec<u32>,
    /// Its compression error under [`OrderParams::encode`].
    pub error: ErrorEstimate,
    /// Time to compute the order, in ms.
    pub order_ms: f64,
    /// Time to measure its error, in ms.
    pub measure_ms: f64,
}

/// Computes every order in `kinds` (`best` is skipped: it is a choice among these) and
/// measures each one's compression error with one [`ErrorMeter`], sampled as
/// [`OrderParams::sampling`] says. Errors only for input [`crate::encode::encode_dense`] would
/// refuse.
pub fn evaluate(
    kinds: &[OrderKind],
    patches: &[Patch],
    m: DenseMatrix<'_>,
    params: &OrderParams,
) -> Result<Vec<Candidate>, EncodeError> {
    let meter = ErrorMeter::new(m, &params.encode)?;
    let sampling = params.sampling(m.n);
    let mut out = Vec::new();
    for &kind in kinds.iter().filter(|k| **k != OrderKind::Best) {
        let t = Instant::now();
        let perm = permutation(kind, patches, m, params)?;
        let order_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        let error = meter.measure(Some(&perm), sampling);
        out.push(Candidate {
            kind,
            perm,
            error,
            order_ms,
            measure_ms: t.elapsed().as_secs_f64() * 1e3,
        });
    }
    Ok(out)
}

/// Standard errors by which a candidate must beat `none` to be chosen over it when errors are
/// sampled. The estimates of different orders are independent, so "better by 3σ of the
/// difference" is wrong about once in 700 comparisons; exact measurements need no margin.
pub(crate) const BEST_MARGIN_SIGMAS: f64 = 3.0;

/// Index of the candidate with the smallest measured error. When `none` is among them, another
/// order replaces it only if its squared error is smaller by more than [`BEST_MARGIN_SIGMAS`]
/// standard errors of the difference: with exact errors `best` is never worse than `none`,
/// and with sampled ones it is not worse except with probability ≈ 0.1%. Panics on an empty
/// list.
pub fn choose_best(candidates: &[Candidate]) -> usize {
    assert!(!candidates.is_empty(), "no candidates to choose from");
    let by_error =
        |a: &&Candidate, b: &&Candidate| a.error.squared_error.total_cmp(&b.error.squared_error);
    let winner = candidates.iter().min_by(by_error).expect("not empty");
    let pos = |c: &Candidate| {
        candidates
            .iter()
            .position(|x| std::ptr::eq(x, c))
            .expect("from the list")
    };
    let Some(none) = candidates.iter().find(|c| c.kind == OrderKind::None) else {
        return pos(winner);
    };
    let sd = |e: &ErrorEstimate| e.relative_std * e.squared_error;
    let margin = BEST_MARGIN_SIGMAS * sd(&winner.error).hypot(sd(&none.error));
    if winner.error.squared_error + margin < none.error.squared_error {
        pos(winner)
    } else {
        pos(none)
    }
}

/// `P M Pᵀ`: the dense matrix (row-major `n × n`, `channels` interleaved) renumbered by `perm`
/// (`perm[new] = old`), rows and columns together: `out[i][j] = dense[perm[i]][perm[j]]`.
pub fn permute(dense: &[f32], n: usize, channels: usize, perm: &[u32]) -> Vec<f32> {
    assert_eq!(dense.len(), n * n * channels, "dense matrix of side {n}");
    check_permutation(perm, n);
    let mut out = vec![0f32; dense.len()];
    out.par_chunks_mut((n * channels).max(1))
        .enumerate()
        .for_each(|(i, row)| {
            let src = &dense[perm[i] as usize * n * channels..][..n * channels];
            for (j, &pj) in perm.iter().enumerate() {
                let (d, s) = (j * channels, pj as usize * channels);
                row[d..d + channels].copy_from_slice(&src[s..s + channels]);
            }
        });
    out
}

/// [`permute`] in `dense`'s own buffer: the same values, with one row of scratch per thread
/// instead of a second matrix. Each row's columns are renumbered first, then the rows are
/// moved along the cycles of `perm`.
pub(crate) fn permute_in_place(dense: &mut [f32], n: usize, channels: usize, perm: &[u32]) {
    assert_eq!(dense.len(), n * n * channels, "dense matrix of side {n}");
    check_permutation(perm, n);
    let w = (n * channels).max(1);
    dense.par_chunks_mut(w).for_each_init(
        || vec![0f32; w],
        |scratch, row| {
            scratch.copy_from_slice(row);
            for (j, &pj) in perm.iter().enumerate() {
                let (d, s) = (j * channels, pj as usize * channels);
                row[d..d + channels].copy_from_slice(&scratch[s..s + channels]);
            }
        },
    );
    // Row `i` takes old row `perm[i]`: along each cycle, hold its first row and shift.
    let mut done = vec![false; n];
    let mut held = vec![0f32; w];
    for start in 0..n {
        if done[start] {
            continue;
        }
        held.copy_from_slice(&dense[start * w..][..w]);
        let mut i = start;
        loop {
            done[i] = true;
            let from = perm[i] as usize;
            if from == start {
                dense[i * w..][..w].copy_from_slice(&held);
                break;
            }
            dense.copy_within(from * w..(from + 1) * w, i * w);
            i = from;
        }
    }
}

/// A per-patch array renumbered by `perm`: `out[new] = items[perm[new]]`.
pub fn permute_rows<T: Clone>(items: &[T], perm: &[u32]) -> Vec<T> {
    check_permutation(perm, items.len());
    perm.iter().map(|&p| items[p as usize].clone()).collect()
}

/// The inverse: `inv[old] = new`.
#[cfg(test)]
pub(crate) fn inverse(perm: &[u32]) -> Vec<u32> {
    check_permutation(perm, perm.len());
    let mut inv = vec![0u32; perm.len()];
    for (new, &old) in perm.iter().enumerate() {
        inv[old as usize] = new as u32;
    }
    inv
}

/// Whether `perm` holds each of `0..n` exactly once.
pub fn is_permutation(perm: &[u32], n: usize) -> bool {
    if perm.len() != n {
        return false;
    }
    let mut seen = vec![false; n];
    perm.iter()
        .all(|&p| (p as usize) < n && !std::mem::replace(&mut seen[p as usize], true))
}

fn check_permutation(perm: &[u32], n: usize) {
    assert!(
        is_permutation(perm, n),
        "not a permutation of 0..{n} (length {})",
        perm.len()
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for k in OrderKind::ALL {
            assert_eq!(OrderKind::from_name(k.name()), Some(k));
            if let Some(p) = k.patch_order() {
                assert_eq!(p.name(), k.name());
                assert_eq!(OrderKind::from(p), k);
            }
        }
        assert_eq!(OrderKind::from_name("hilbert"), None);
    }

    #[test]
    fn permute_moves_rows_and_columns_together() {
        let (n, ch) = (3, 2);
        let dense: Vec<f32> = (0..n * n * ch).map(|v| v as f32).collect();
        let perm = [2u32, 0, 1];
        let out = permute(&dense, n, ch, &perm);
        for i in 0..n {
            for j in 0..n {
                for k in 0..ch {
                    let (pi, pj) = (perm[i] as usize, perm[j] as usize);
                    assert_eq!(out[(i * n + j) * ch + k], dense[(pi * n + pj) * ch + k]);
                }
            }
        }
        // Undoing with the inverse gives the original back.
        assert_eq!(permute(&out, n, ch, &inverse(&perm)), dense);
    }

    #[test]
    fn permuting_in_place_matches_the_copy() {
        // Several cycles (a 3-cycle, a swap, fixed points) and a random order.
        let (n, ch) = (9, 3);
        let dense: Vec<f32> = (0..n * n * ch).map(|v| v as f32).collect();
        for perm in [vec![2u32, 0, 1, 4, 3, 5, 6, 8, 7], random_order(n, 7)] {
            let mut inplace = dense.clone();
            permute_in_place(&mut inplace, n, ch, &perm);
            assert_eq!(inplace, permute(&dense, n, ch, &perm), "{perm:?}");
        }
    }

    #[test]
    fn random_is_a_seeded_permutation() {
        let a = random_order(100, 1);
        assert!(is_permutation(&a, 100));
        assert_eq!(a, random_order(100, 1));
        assert_ne!(a, random_order(100, 2));
        assert!(!is_permutation(&[0, 0, 1], 3));
        assert!(!is_permutation(&[0, 3, 1], 3));
    }
}
