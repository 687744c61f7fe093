//! F held as the discretisation corrects it (burial, closure, dark patches), held
//! dense for one matrix or as sparse rows for a level cut into systems
//! ([`crate::pipeline::SystemsChoice`]): a level of 65 536 patches needs 34 GB dense in f64,
//! its ray-cast rows about 600 entries each. Both forms do the same f64 arithmetic entry by
//! entry, so the sparse rows carry the values the dense matrix would (the zeros apart).

use crate::form_factor::{
    FormFactorParams, FormFactors, Progress, SparseFormFactors, form_factors_sparse_surveyed,
    form_factors_surveyed,
};
use crate::geometry::Occluders;
use crate::patch::Patches;
pub(crate) mod dense;

pub use dense::Dense;
use dense::{cap_row_sums, enforce_closure};

/// The form factors of `patches` as the discretisation holds them, with their summary: sparse
/// rows where `level` (the bake cuts the patches into systems) and the rows are ray-cast (a
/// dense n² matrix of 65 536 patches would need 17 GB in f32), else the dense matrix in f64.
pub(crate) fn form_factors(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    burial: &[Vec<u32>],
    progress: Progress<'_>,
    level: bool,
) -> (Exchange, FormFactors) {
    let sparse = level
        .then(|| {
            form_factors_sparse_surveyed(patches, occluders, params, Some(burial), Some(progress))
        })
        .flatten();
    if let Some(s) = sparse {
        return sparse_exchange(s, patches);
    }
    let mut ff = form_factors_surveyed(patches, occluders, params, Some(burial), Some(progress));
    // F in f64 from here on; the f32 matrix goes as soon as it is converted.
    let values = std::mem::take(&mut ff.matrix)
        .into_iter()
        .map(f64::from)
        .collect();
    (Exchange::Dense(Dense::new(patches.len(), values)), ff)
}

/// Ray-cast sparse rows of `patches` as the discretisation holds them, with their summary.
pub(crate) fn sparse_exchange(s: SparseFormFactors, patches: &Patches) -> (Exchange, FormFactors) {
    let summary = FormFactors {
        n: s.n,
        matrix: Vec::new(),
        rays_cast: s.rays_cast,
        row_sums: Vec::new(),
        reciprocity_error: 0.0,
        pieces: patches.pieces.len(),
        sites: 0,
        clustered_pairs: 0,
        rays_per_patch: s.rays_per_patch,
        piece_pairs: crate::form_factor::piece_pairs(patches),
    };
    (Exchange::Sparse(SparseRows::from_f32(s)), summary)
}

/// F in f64 by rows of its stored entries (compressed sparse rows, columns increasing). The
/// pattern is symmetric (an entry `(i, j)` has its `(j, i)`), as the ray-cast rows pool both
/// sides of each pair ([`SparseFormFactors`]); burial zeroes values in place.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SparseRows {
    pub(crate) n: usize,
    pub(crate) row_ptr: Vec<usize>,
    pub(crate) cols: Vec<u32>,
    pub(crate) values: Vec<f64>,
}

impl SparseRows {
    /// The ray-cast rows in f64 (each entry widened exactly, as the dense path widens them).
    pub(crate) fn from_f32(ff: SparseFormFactors) -> Self {
        let values = ff.values.iter().map(|&v| f64::from(v)).collect();
        Self {
            n: ff.n,
            row_ptr: ff.row_ptr,
            cols: ff.cols,
            values,
        }
    }

    fn span(&self, i: usize) -> std::ops::Range<usize> {
        self.row_ptr[i]..self.row_ptr[i + 1]
    }

    /// Index of entry `(i, j)` in `cols`/`values`, where stored.
    fn at(&self, i: usize, j: usize) -> Option<usize> {
        let r = self.span(i);
        self.cols[r.clone()]
            .binary_search(&(j as u32))
            .ok()
            .map(|k| r.start + k)
    }

    /// `W = (diag(A) F + (diag(A) F)ᵀ) / 2` in place, as [`crate::transfer`] makes it dense:
    /// each pair gets one value `(A_i F_ij + A_j F_ji) / 2`. An entry whose transpose is not
    /// stored (never, for ray-cast rows) keeps `A_i F_ij / 2`.
    fn reciprocal_exchange(&mut self, areas: &[f64]) {
        for i in 0..self.n {
            for k in self.span(i) {
                let j = self.cols[k] as usize;
                if j < i {
                    continue;
                }
                match self.at(j, i) {
                    Some(t) => {
                        let w = 0.5 * (areas[i] * self.values[k] + areas[j] * self.values[t]);
                        self.values[k] = w;
                        self.values[t] = w;
                    }
                    None => self.values[k] = 0.5 * (areas[i] * self.values[k]),
                }
            }
        }
        // The lower entries without a stored transpose (never, for ray-cast rows).
        for i in 0..self.n {
            for k in self.span(i) {
                let j = self.cols[k] as usize;
                if j < i && self.at(j, i).is_none() {
                    self.values[k] = 0.5 * (areas[i] * self.values[k]);
                }
            }
        }
    }

    /// `Σ_j W_ij d_j` of row `i`.
    fn row_dot(&self, i: usize, d: &[f64]) -> f64 {
        self.span(i)
            .map(|k| self.values[k] * d[self.cols[k] as usize])
            .sum()
    }

    /// `F' = diag(A)⁻¹ D W D` from `W` in place; the largest relative change of a row sum
    /// against `before`.
    fn rescale(&mut self, d: &[f64], areas: &[f64], before: &[f64]) -> f64 {
        let mut correction = 0f64;
        for i in 0..self.n {
            let mut sum = 0.0;
            for k in self.span(i) {
                let v = d[i] * self.values[k] * d[self.cols[k] as usize] / areas[i];
                self.values[k] = v;
                sum += v;
            }
            if before[i] > 0.0 {
                correction = correction.max((sum - before[i]).abs() / before[i]);
            }
        }
        correction
    }

    /// [`enforce_closure`] on sparse rows: symmetric Sinkhorn balancing to row sums of 1.
    fn enforce_closure(&mut self, areas: &[f64]) -> f64 {
        let before: Vec<f64> = (0..self.n).map(|i| self.row_sum(i)).collect();
        self.reciprocal_exchange(areas);
        let live: Vec<bool> = (0..self.n).map(|i| !self.sees_nothing(i)).collect();
        let mut d = vec![1.0; self.n];
        for _ in 0..10_000 {
            let wd: Vec<f64> = (0..self.n).map(|i| self.row_dot(i, &d)).collect();
            let mut worst = 0f64;
            for i in 0..self.n {
                if live[i] {
                    worst = worst.max((d[i] * wd[i] / areas[i] - 1.0).abs());
                    d[i] = (d[i] * areas[i] / wd[i]).sqrt();
                }
            }
            if worst < 1e-13 {
                break;
            }
        }
        self.rescale(&d, areas, &before)
    }

    /// [`cap_row_sums`] on sparse rows: rows above 1 scaled down keeping reciprocity.
    fn cap_row_sums(&mut self, areas: &[f64]) -> f64 {
        let before: Vec<f64> = (0..self.n).map(|i| self.row_sum(i)).collect();
        self.reciprocal_exchange(areas);
        let mut d = vec![1.0f64; self.n];
        for _ in 0..10_000 {
            let sums: Vec<f64> = (0..self.n)
                .map(|i| d[i] * self.row_dot(i, &d) / areas[i])
                .collect();
            if sums.iter().copied().fold(0.0, f64::max) <= 1.0 + 1e-13 {
                break;
            }
            for i in 0..self.n {
                if sums[i] > 1.0 {
                    d[i] /= sums[i].sqrt() * (1.0 + 1e-15);
                }
            }
        }
        self.rescale(&d, areas, &before)
    }

    fn row_sum(&self, i: usize) -> f64 {
        self.values[self.span(i)].iter().sum()
    }

    fn sees_nothing(&self, i: usize) -> bool {
        !self.values[self.span(i)].iter().any(|v| *v > 0.0)
    }
}

/// F during the discretisation: dense (one matrix) or sparse rows (systems).
#[derive(Clone, Debug)]
pub(crate) enum Exchange {
    Dense(Dense),
    Sparse(SparseRows),
}

impl Exchange {
    /// Patches.
    pub(crate) fn n(&self) -> usize {
        match self {
            Exchange::Dense(f) => f.n,
            Exchange::Sparse(s) => s.n,
        }
    }

    /// `Σ_j F_ij`.
    pub(crate) fn row_sum(&self, i: usize) -> f64 {
        match self {
            Exchange::Dense(f) => f.row(i).iter().sum(),
            Exchange::Sparse(s) => s.row_sum(i),
        }
    }

    /// Whether row `i` has no positive entry.
    pub(crate) fn sees_nothing(&self, i: usize) -> bool {
        match self {
            Exchange::Dense(f) => !f.row(i).iter().any(|v| *v > 0.0),
            Exchange::Sparse(s) => s.sees_nothing(i),
        }
    }

    /// Divides row `i` by `e`.
    pub(crate) fn divide_row(&mut self, i: usize, e: f64) {
        let row = match self {
            Exchange::Dense(f) => &mut f.values[i * f.n..(i + 1) * f.n],
            Exchange::Sparse(s) => {
                let r = s.span(i);
                &mut s.values[r]
            }
        };
        for v in row {
            *v /= e;
        }
    }

    /// Zeroes the row and the column of every patch marked in `gone`.
    pub(crate) fn bury(&mut self, gone: &[bool]) {
        match self {
            Exchange::Dense(f) => {
                let n = f.n;
                for i in (0..n).filter(|&i| gone[i]) {
                    for j in 0..n {
                        f.values[i * n + j] = 0.0;
                        f.values[j * n + i] = 0.0;
                    }
                }
            }
            Exchange::Sparse(s) => {
                for i in 0..s.n {
                    for k in s.span(i) {
                        if gone[i] || gone[s.cols[k] as usize] {
                            s.values[k] = 0.0;
                        }
                    }
                }
            }
        }
    }

    /// Rebalances a closed scene's rows to 1 keeping reciprocity ([`enforce_closure`]).
    pub(crate) fn enforce_closure(&mut self, areas: &[f64]) -> f64 {
        match self {
            Exchange::Dense(f) => enforce_closure(f, areas),
            Exchange::Sparse(s) => s.enforce_closure(areas),
        }
    }

    /// Scales rows above 1 down keeping reciprocity ([`cap_row_sums`]).
    pub(crate) fn cap_row_sums(&mut self, areas: &[f64]) -> f64 {
        match self {
            Exchange::Dense(f) => cap_row_sums(f, areas),
            Exchange::Sparse(s) => s.cap_row_sums(areas),
        }
    }

    /// The largest row sum of `F^C` (`Σ_j F_ij ρ_j`) over channels.
    pub(crate) fn largest_gain(&self, patches: &Patches) -> f64 {
        let rho: Vec<[f64; 3]> = patches
            .patches
            .iter()
            .map(|p| p.reflectance.to_array().map(f64::from))
            .collect();
        let gain = |entries: &mut dyn Iterator<Item = (usize, f64)>| {
            let mut g = [0f64; 3];
            for (j, v) in entries {
                for (c, gc) in g.iter_mut().enumerate() {
                    *gc += v * rho[j][c];
                }
            }
            g.into_iter().fold(0.0, f64::max)
        };
        (0..self.n())
            .map(|i| match self {
                Exchange::Dense(f) => gain(&mut f.row(i).iter().copied().enumerate()),
                Exchange::Sparse(s) => {
                    gain(&mut s.span(i).map(|k| (s.cols[k] as usize, s.values[k])))
                }
            })
            .fold(0.0, f64::max)
    }

    /// The largest relative reciprocity error `|A_i F_ij − A_j F_ji| / max` over pairs.
    pub(crate) fn reciprocity_error(&self, areas: &[f64]) -> f64 {
        let mut worst = 0f64;
        let mut pair = |a: f64, b: f64| {
            let m = a.max(b);
            if m > 0.0 {
                worst = worst.max((a - b).abs() / m);
            }
        };
        match self {
            Exchange::Dense(f) => {
                for i in 0..f.n {
                    for j in i + 1..f.n {
                        pair(areas[i] * f.get(i, j), areas[j] * f.get(j, i));
                    }
                }
            }
            Exchange::Sparse(s) => {
                for i in 0..s.n {
                    for k in s.span(i) {
                        let j = s.cols[k] as usize;
                        if j > i {
                            let back = s.at(j, i).map_or(0.0, |t| s.values[t]);
                            pair(areas[i] * s.values[k], areas[j] * back);
                        }
                    }
                }
            }
        }
        worst
    }

    /// F among the `live` patches (increasing indices) as f32 sparse rows, zeros dropped:
    /// entry `(a, b)` is `F[live[a]][live[b]]`.
    pub(crate) fn live_sparse(&self, live: &[usize]) -> SparseFormFactors {
        match self {
            Exchange::Dense(f) => dense_live_sparse(f, live),
            Exchange::Sparse(s) => live_rows(s.n, live, |i, keep| {
                s.span(i)
                    .for_each(|k| keep(s.cols[k] as usize, s.values[k]))
            }),
        }
    }
}

/// [`Exchange::live_sparse`] of a dense F.
pub(crate) fn dense_live_sparse(f: &Dense, live: &[usize]) -> SparseFormFactors {
    live_rows(f.n, live, |i, keep| {
        f.row(i).iter().enumerate().for_each(|(j, &v)| keep(j, v))
    })
}

/// The positive entries among the `live` of `n` patches, `row(i, keep)` calling `keep(j,
/// F_ij)` for row `i`'s entries in increasing `j`.
fn live_rows(
    n: usize,
    live: &[usize],
    row: impl Fn(usize, &mut dyn FnMut(usize, f64)),
) -> SparseFormFactors {
    let mut at = vec![u32::MAX; n];
    for (k, &i) in live.iter().enumerate() {
        at[i] = k as u32;
    }
    let (mut row_ptr, mut cols, mut values) = (vec![0usize], Vec::new(), Vec::new());
    for &i in live {
        row(i, &mut |j, v| {
            if v > 0.0 && at[j] != u32::MAX {
                cols.push(at[j]);
                values.push(v as f32);
            }
        });
        row_ptr.push(cols.len());
    }
    SparseFormFactors {
        n: live.len(),
        row_ptr,
        cols,
        values,
        rays_cast: 0,
        rays_per_patch: 0,
    }
}

/// F among the `live` patches (increasing indices), in F's own buffer: entry `(a, b)` of the
/// result is `F[live[a]][live[b]]`. Moving entries forward in row-major order never overwrites
/// one still to be read (the destination `a·m + b` is at most the source `live[a]·n +
/// live[b]`, both increasing).
pub(crate) fn live_rows_dense(f: Dense, live: &[usize]) -> Dense {
    let (n, m) = (f.n, live.len());
    let mut values = f.values;
    let mut to = 0;
    for &i in live {
        for &j in live {
            values[to] = values[i * n + j];
            to += 1;
        }
    }
    values.truncate(m * m);
    values.shrink_to_fit();
    Dense::new(m, values)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dense F and its sparse rows (the non-zero entries, pattern symmetric).
    fn both(n: usize, entries: &[(usize, usize, f64)]) -> (Exchange, Exchange) {
        let mut d = vec![0.0; n * n];
        for &(i, j, v) in entries {
            d[i * n + j] = v;
        }
        let dense = Dense::new(n, d.clone());
        let (mut row_ptr, mut cols, mut values) = (vec![0], Vec::new(), Vec::new());
        for i in 0..n {
            for j in 0..n {
                if d[i * n + j] != 0.0 || d[j * n + i] != 0.0 {
                    cols.push(j as u32);
                    values.push(d[i * n + j]);
                }
            }
            row_ptr.push(cols.len());
        }
        let sparse = SparseRows {
            n,
            row_ptr,
            cols,
            values,
        };
        (Exchange::Dense(dense), Exchange::Sparse(sparse))
    }

    fn dense_of(e: &Exchange) -> Vec<f64> {
        let n = e.n();
        let s = e.live_sparse(&(0..n).collect::<Vec<_>>());
        let mut d = vec![0.0; n * n];
        for i in 0..n {
            for (j, v) in s.row(i) {
                d[i * n + j] = f64::from(v);
            }
        }
        d
    }

    #[test]
    fn sparse_rows_correct_as_the_dense_matrix_does() {
        // Four patches, one pair unseen (0, 3), unequal areas, rows near but off 1.
        let entries = [
            (0, 1, 0.5),
            (1, 0, 0.26),
            (0, 2, 0.49),
            (2, 0, 0.24),
            (1, 2, 0.3),
            (2, 1, 0.31),
            (1, 3, 0.45),
            (3, 1, 0.9),
            (2, 3, 0.44),
            (3, 2, 0.12),
        ];
        let areas = [1.0, 2.0, 2.0, 1.0];
        for closure in [true, false] {
            let (mut dense, mut sparse) = both(4, &entries);
            let (a, b) = if closure {
                (
                    dense.enforce_closure(&areas),
                    sparse.enforce_closure(&areas),
                )
            } else {
                (dense.cap_row_sums(&areas), sparse.cap_row_sums(&areas))
            };
            // The same f64 operations in the same order, entry by entry: equal bits.
            assert_eq!(a, b);
            assert_eq!(dense_of(&dense), dense_of(&sparse));
            for i in 0..4 {
                assert_eq!(dense.row_sum(i), sparse.row_sum(i));
            }
            assert!(a > 0.0, "the rows were corrected");
        }
        let (mut dense, mut sparse) = both(4, &entries);
        for e in [&mut dense, &mut sparse] {
            e.divide_row(1, 0.5);
            e.bury(&[false, false, true, false]);
        }
        assert_eq!(dense_of(&dense), dense_of(&sparse));
        assert!(sparse.sees_nothing(2) && !sparse.sees_nothing(1));
        assert_eq!(sparse.row_sum(1), (0.26 + 0.45) / 0.5);
        assert_eq!(
            dense.reciprocity_error(&areas),
            sparse.reciprocity_error(&areas)
        );
    }

    #[test]
    fn live_rows_keep_the_live_block_in_place() {
        let n = 5;
        let f = Dense::new(n, (0..n * n).map(|e| e as f64).collect());
        for live in [vec![0, 2, 3], vec![1, 4], vec![0, 1, 2, 3, 4], vec![4]] {
            let want: Vec<f64> = live
                .iter()
                .flat_map(|&i| live.iter().map(move |&j| (i * n + j) as f64))
                .collect();
            let got = live_rows_dense(f.clone(), &live);
            assert_eq!((got.n, &got.values), (live.len(), &want), "{live:?}");
        }
    }
}
