//! Orders from the matrix itself: each patch gets a short signature of its row and column of M,
//! and patches with close signatures are put together.
//!
//! The signature of patch i is the quantiser's view of `M[i, s_k]` and `M[s_k, i]` at `m`
//! sampled patches `s_k` (evenly spaced in the given numbering), each as `max(ln(v/v_max) + s,
//! 0)/s` (the log code divided by 255, before rounding) of the channel mean, with the sparse
//! entries at 0 as the blocks see them. Distances between signatures are then distances between
//! the codes BC has to fit. With `m = 32` the paper's neighbour sort costs `n²·2m/2` flops
//! (≈ 0.5 s at n = 4096) instead of the `n³` of comparing whole rows.

use super::DenseMatrix;
use rayon::prelude::*;

/// Per-patch signatures, `dim` values each, patch after patch.
pub(crate) struct Signatures {
    /// Values per patch (`2·samples`).
    pub dim: usize,
    /// `n · dim` values.
    pub values: Vec<f32>,
}

impl Signatures {
    /// Signatures of every patch of `m` from `samples` sampled rows and columns (clamped to
    /// `1..=n`). Entries the sparse `rule` keeps count as 0 (the sparse
    /// list holds them); `shift` is the quantiser's log range.
    pub(crate) fn new(
        m: DenseMatrix<'_>,
        samples: usize,
        shift: f32,
        rule: &crate::encode::SparseRule,
    ) -> Self {
        let (n, ch) = (m.n, m.channels);
        let samples = samples.clamp(1, n.max(1));
        let picks: Vec<usize> = (0..samples)
            .map(|k| (2 * k + 1) * n / (2 * samples))
            .collect();
        let seen = |r: usize, c: usize| -> f32 {
            let e = &m.values[(r * n + c) * ch..(r * n + c + 1) * ch];
            if rule.keeps(r, e) {
                0.0
            } else {
                e.iter().sum::<f32>() / ch as f32
            }
        };
        let v_max = (0..n)
            .into_par_iter()
            .map(|r| {
                picks
                    .iter()
                    .map(|&c| seen(r, c).max(seen(c, r)))
                    .fold(0f32, f32::max)
            })
            .reduce(|| 0f32, f32::max);
        let code = |v: f32| -> f32 {
            if v > 0.0 && v_max > 0.0 {
                ((v / v_max).ln() + shift).max(0.0) / shift
            } else {
                0.0
            }
        };
        let dim = 2 * samples;
        let mut values = vec![0f32; n * dim];
        values.par_chunks_mut(dim).enumerate().for_each(|(i, out)| {
            for (k, &s) in picks.iter().enumerate() {
                out[k] = code(seen(i, s));
                out[samples + k] = code(seen(s, i));
            }
        });
        Self { dim, values }
    }

    /// Number of patches.
    pub(crate) fn len(&self) -> usize {
        self.values.len().checked_div(self.dim).unwrap_or(0)
    }

    /// Signature of patch `i`.
    pub(crate) fn of(&self, i: usize) -> &[f32] {
        &self.values[i * self.dim..(i + 1) * self.dim]
    }
}

/// Squared Euclidean distance.
#[inline]
fn distance2(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Remaining patches below which one thread scans (a rayon split costs more than it saves).
const PARALLEL_SCAN: usize = 2048;

/// The paper's neighbour sort (§4.2): a greedy chain that starts at the patch whose signature
/// is farthest from the mean (an end of the data, not its middle) and always appends the
/// unvisited patch nearest the last one. Ties go to the lower index. O(n²·dim).
pub(crate) fn greedy_chain(sig: &Signatures) -> Vec<u32> {
    let (n, dim) = (sig.len(), sig.dim);
    if n == 0 {
        return Vec::new();
    }
    let mut mean = vec![0f32; dim];
    for i in 0..n {
        for (m, v) in mean.iter_mut().zip(sig.of(i)) {
            *m += v / n as f32;
        }
    }
    let start = (0..n)
        .map(|i| (distance2(sig.of(i), &mean), i))
        .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)))
        .map_or(0, |(_, i)| i);
    // The unvisited signatures, kept compact (swap-remove) so every scan is contiguous.
    let mut pool = sig.values.clone();
    let mut ids: Vec<u32> = (0..n as u32).collect();
    let mut order = Vec::with_capacity(n);
    let mut take = |pool: &mut Vec<f32>, ids: &mut Vec<u32>, k: usize| -> Vec<f32> {
        let last = ids.len() - 1;
        let row = pool[k * dim..(k + 1) * dim].to_vec();
        pool.copy_within(last * dim..(last + 1) * dim, k * dim);
        pool.truncate(last * dim);
        order.push(ids.swap_remove(k));
        row
    };
    let mut current = take(&mut pool, &mut ids, start);
    while !ids.is_empty() {
        let better = |a: (f32, u32, usize), b: (f32, u32, usize)| {
            if a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).is_le() {
                a
            } else {
                b
            }
        };
        let scan = |(k, s): (usize, &[f32])| (distance2(s, &current), ids[k], k);
        let worst = (f32::INFINITY, u32::MAX, usize::MAX);
        let best = if ids.len() >= PARALLEL_SCAN {
            pool.par_chunks(dim)
                .enumerate()
                .map(scan)
                .reduce(|| worst, better)
        } else {
            pool.chunks(dim).enumerate().map(scan).fold(worst, better)
        };
        current = take(&mut pool, &mut ids, best.2);
    }
    order
}
