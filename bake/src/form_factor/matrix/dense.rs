//! F held dense: a row-major `n × n` matrix of f64, and the closure's row scalings on it.
//!
//! Closed scenes need rows of F that sum to exactly 1, or multi-bounce light is lost: at
//! ρ = 0.999 a row-sum error of 1e-4 costs 9% of the radiosity (docs/reference/multibounce.md §1).
//! [`enforce_closure`] balances F symmetrically so that every row sums to 1 while reciprocity
//! `A_i F_ij = A_j F_ji` is kept exactly; [`cap_row_sums`] scales an open scene's rows above 1
//! down the same way.

/// Side of the square tiles the symmetrising pass works in (cache-sized: 64² f64 = 32 KiB).
const TILE: usize = 64;

/// A row-major dense `n × n` matrix of f64.
#[derive(Clone, Debug, PartialEq)]
pub struct Dense {
    /// Side.
    pub n: usize,
    /// `n·n` values, row-major.
    pub values: Vec<f64>,
}

impl Dense {
    /// Wraps values; panics if the length is not `n²` (a programming error).
    pub fn new(n: usize, values: Vec<f64>) -> Self {
        assert_eq!(values.len(), n * n, "dense matrix of side {n}");
        Self { n, values }
    }

    /// Entry (`i`, `j`).
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.values[i * self.n + j]
    }

    /// Row `i`.
    #[inline]
    pub fn row(&self, i: usize) -> &[f64] {
        &self.values[i * self.n..(i + 1) * self.n]
    }
}

/// Whether the form factors describe a closed enclosure, and how far from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Closure {
    /// Smallest row sum of F over patches that see anything.
    pub min_row_sum: f64,
    /// Largest row sum of F.
    pub max_row_sum: f64,
    /// Whether every row sums to within the tolerance of 1.
    pub closed: bool,
}

/// Measures the row sums of `f`; `closed` when every row that sees anything sums to
/// `1 ± tolerance`. Rows that see nothing (sum 0) do not count: they are dropped, not open.
#[cfg(test)]
pub(crate) fn analyse_closure(f: &Dense, tolerance: f64) -> Closure {
    closure_of_sums((0..f.n).map(|i| f.row(i).iter().sum()), tolerance)
}

/// [`analyse_closure`] from the row sums themselves (those of the rows that should count).
pub(crate) fn closure_of_sums(sums: impl Iterator<Item = f64>, tolerance: f64) -> Closure {
    let (mut min_row_sum, mut max_row_sum) = (f64::INFINITY, 0f64);
    for s in sums.filter(|s| *s > 0.0) {
        min_row_sum = min_row_sum.min(s);
        max_row_sum = max_row_sum.max(s);
    }
    let closed = min_row_sum.is_finite()
        && (1.0 - min_row_sum) <= tolerance
        && (max_row_sum - 1.0) <= tolerance;
    Closure {
        min_row_sum,
        max_row_sum,
        closed,
    }
}

/// Replaces F by `W = (diag(A) F + (diag(A) F)ᵀ) / 2` in its own buffer: the exchange
/// between patches with reciprocity made exact, which both row-sum corrections balance. Each
/// pair `(i, j)`, `(j, i)` gets the one value `(A_i F_ij + A_j F_ji) / 2` (the sum is the same
/// in either order), tile by tile.
fn reciprocal_exchange(f: &mut Dense, areas: &[f64]) {
    let n = f.n;
    assert_eq!(areas.len(), n, "one area per patch");
    let v = &mut f.values;
    for i0 in (0..n).step_by(TILE) {
        for j0 in (i0..n).step_by(TILE) {
            for i in i0..(i0 + TILE).min(n) {
                let from = if i0 == j0 { i } else { j0 };
                for j in from..(j0 + TILE).min(n) {
                    let w = 0.5 * (areas[i] * v[i * n + j] + areas[j] * v[j * n + i]);
                    v[i * n + j] = w;
                    v[j * n + i] = w;
                }
            }
        }
    }
}

/// Rebalances a closed scene's form factors so every row sums to 1 and reciprocity holds
/// exactly; returns the largest relative change of a row sum made (the size of the correction).
///
/// Symmetric Sinkhorn balancing: with `W = (diag(A) F + (diag(A) F)ᵀ) / 2` (reciprocity made
/// exact), find `d > 0` such that `D W D` has row sums `A`, by `d_i ← sqrt(d_i · A_i / (W d)_i)`
/// until row sums agree to 1e-13; then `F' = diag(A)⁻¹ D W D`. Rows that see nothing stay zero.
pub(crate) fn enforce_closure(f: &mut Dense, areas: &[f64]) -> f64 {
    let n = f.n;
    let before: Vec<f64> = (0..n).map(|i| f.row(i).iter().sum()).collect();
    reciprocal_exchange(f, areas);
    let w = &f.values;
    let live: Vec<bool> = (0..n)
        .map(|i| w[i * n..(i + 1) * n].iter().any(|v| *v > 0.0))
        .collect();
    let mut d = vec![1.0; n];
    for _ in 0..10_000 {
        let wd: Vec<f64> = (0..n)
            .map(|i| {
                w[i * n..(i + 1) * n]
                    .iter()
                    .zip(&d)
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect();
        let mut worst = 0f64;
        for i in 0..n {
            if live[i] {
                let sum = d[i] * wd[i];
                worst = worst.max((sum / areas[i] - 1.0).abs());
                d[i] = (d[i] * areas[i] / wd[i]).sqrt();
            }
        }
        if worst < 1e-13 {
            break;
        }
    }
    let mut correction = 0f64;
    for i in 0..n {
        let mut sum = 0.0;
        for j in 0..n {
            let v = d[i] * f.values[i * n + j] * d[j] / areas[i];
            f.values[i * n + j] = v;
            sum += v;
        }
        if before[i] > 0.0 {
            correction = correction.max((sum - before[i]).abs() / before[i]);
        }
    }
    correction
}

/// Scales down the rows of an open scene's form factors that sum above 1, keeping reciprocity;
/// returns the largest relative reduction of a row sum (0 when no row exceeds 1).
///
/// A row above 1 sends out more light than the patch emits and reflects: energy would be
/// created at every bounce. It happens beyond quadrature error when faces coincide (coplanar
/// overlapping faces are both seen through the same solid angle, and neither blocks the
/// other). With `W = (diag(A) F + (diag(A) F)ᵀ) / 2`, find `d ≤ 1` such that the rows of
/// `diag(A)⁻¹ D W D` are at most 1, by `d_i ← d_i / sqrt(r_i)` for every row sum `r_i > 1`;
/// `d` only decreases, so rows at or below 1 stay there. Rows that see nothing stay zero.
pub(crate) fn cap_row_sums(f: &mut Dense, areas: &[f64]) -> f64 {
    let n = f.n;
    let before: Vec<f64> = (0..n).map(|i| f.row(i).iter().sum()).collect();
    reciprocal_exchange(f, areas);
    let w = &f.values;
    let mut d = vec![1.0f64; n];
    let row = |d: &[f64], i: usize| -> f64 {
        d[i] * w[i * n..(i + 1) * n]
            .iter()
            .zip(d)
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / areas[i]
    };
    for _ in 0..10_000 {
        let sums: Vec<f64> = (0..n).map(|i| row(&d, i)).collect();
        let worst = sums.iter().copied().fold(0.0, f64::max);
        if worst <= 1.0 + 1e-13 {
            break;
        }
        for i in 0..n {
            if sums[i] > 1.0 {
                // A hair below the exact root so the iteration ends at or under 1.
                d[i] /= sums[i].sqrt() * (1.0 + 1e-15);
            }
        }
    }
    let mut correction = 0f64;
    for i in 0..n {
        let mut sum = 0.0;
        for j in 0..n {
            let v = d[i] * f.values[i * n + j] * d[j] / areas[i];
            f.values[i * n + j] = v;
            sum += v;
        }
        if before[i] > 0.0 {
            correction = correction.max((before[i] - sum).abs() / before[i]);
        }
    }
    correction
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_above_one_are_capped_keeping_reciprocity() {
        // Patch 0 sees patches 1 and 2 through the same solid angle (coincident faces): its
        // row sums to 1.4. After capping every row is at most 1 (to rounding), reciprocity is
        // exact, and rows that were below 1 did not grow.
        let areas = [1.0, 2.0, 2.0];
        let mut f = Dense::new(3, vec![0.0, 0.7, 0.7, 0.35, 0.0, 0.0, 0.35, 0.0, 0.0]);
        let before: Vec<f64> = (0..3).map(|i| f.row(i).iter().sum()).collect();
        let correction = cap_row_sums(&mut f, &areas);
        assert!(correction > 0.25 && correction < 0.3, "{correction}");
        for i in 0..3 {
            let s: f64 = f.row(i).iter().sum();
            assert!(s <= 1.0 + 1e-12, "row {i} sums to {s}");
            assert!(s <= before[i] + 1e-15, "row {i} grew: {s} > {}", before[i]);
            for j in 0..3 {
                let (a, b) = (areas[i] * f.get(i, j), areas[j] * f.get(j, i));
                assert!((a - b).abs() < 1e-15, "reciprocity {i},{j}: {a} vs {b}");
            }
        }
        assert!(
            (f.row(0).iter().sum::<f64>() - 1.0).abs() < 1e-12,
            "the capped row is 1"
        );
        // Nothing above 1: untouched.
        let mut g = Dense::new(2, vec![0.0, 0.5, 0.5, 0.0]);
        assert_eq!(cap_row_sums(&mut g, &[1.0, 1.0]), 0.0);
        assert_eq!(g.values, vec![0.0, 0.5, 0.5, 0.0]);
    }

    #[test]
    fn closure_enforcement_keeps_reciprocity_and_sums_rows_to_one() {
        // Three patches of different areas, slightly off a closed enclosure.
        let areas = [1.0, 2.0, 4.0];
        let mut f = Dense::new(3, vec![0.0, 0.40, 0.585, 0.2, 0.1, 0.685, 0.15, 0.35, 0.49]);
        let before = analyse_closure(&f, 0.02);
        assert!(before.closed && before.min_row_sum < 0.99);
        let correction = enforce_closure(&mut f, &areas);
        assert!(correction > 0.0 && correction < 0.02, "{correction}");
        for i in 0..3 {
            let s: f64 = f.row(i).iter().sum();
            assert!((s - 1.0).abs() < 1e-12, "row {i} sums to {s}");
            for j in 0..3 {
                let (a, b) = (areas[i] * f.get(i, j), areas[j] * f.get(j, i));
                assert!((a - b).abs() < 1e-12, "reciprocity {i},{j}: {a} vs {b}");
            }
        }
    }
}
