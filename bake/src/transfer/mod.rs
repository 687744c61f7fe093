//! The multi-bounce transfer matrix `M = Σ_{b<K} (F^C)^b · F` (`docs/contract.md`), in f64
//! ([`transfer_matrix`]), with what was done ([`TransferReport`]) and why it could not be
//! ([`TransferError`]).
//!
//! - K = ∞ solves `(I − F^C) M = F` with an LU factorisation (faer, partial pivoting): about
//!   2.7 n³ flops for all bounces at once.
//! - finite K sums the series by doubling (`S_{2m} = S_m + G^m S_m`), about 3·log2(K) matrix
//!   products, then `M = S F`.
//! - `auto` bounds the energy still moving after K bounces by `r^K`, where `r` is the largest
//!   row sum of `F^C` (an upper bound of its spectral radius), and takes the fewest bounces that
//!   bring it under the tolerance. Since the LU gives every bounce for less than the price of two
//!   matrix products, auto uses the series only for K ≤ 2 and otherwise solves K = ∞, which is
//!   also the more accurate (see the tests).
//!
//! F reaches it closed or capped by the closure (`crate::closure`, with the row scalings of
//! [`crate::form_factor::matrix`]).

pub use crate::form_factor::matrix::Dense;
use faer::reborrow::{IntoConst, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use radiosity_core::Bounces;
use rayon::prelude::*;
use std::borrow::Cow;

/// How many bounces to carry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BounceSpec {
    /// Exactly `K ≥ 1` bounces.
    Fixed(u32),
    /// All of them.
    Infinite,
    /// As few as leave at most `tolerance` of the energy (relative) unaccounted.
    Auto {
        /// Relative energy allowed to remain after the last bounce.
        tolerance: f64,
    },
}

impl Default for BounceSpec {
    fn default() -> Self {
        BounceSpec::Auto { tolerance: 1e-3 }
    }
}

/// Why a transfer matrix cannot be computed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TransferError {
    /// Light in a closed scene with reflectance ≥ 1 never dies out.
    #[error(
        "the transfer cannot converge: some light path keeps a fraction {row_sum:.6} ≥ 1 of its energy per bounce (patch {patch}); reflectance must be below 1 in a closed scene"
    )]
    Divergent {
        /// The patch whose row of F^C sums to ≥ 1.
        patch: usize,
        /// That row sum.
        row_sum: f64,
    },
    /// Inputs of inconsistent sizes or non-finite values.
    #[error("transfer input: {0}")]
    Input(&'static str),
    /// Zero bounces requested.
    #[error("bounces must be at least 1")]
    ZeroBounces,
}

/// What the solve decided and measured.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferReport {
    /// Bounces carried by the result.
    pub bounces: Bounces,
    /// `"lu"` or `"series"`.
    pub method: &'static str,
    /// Largest row sum of F^C over channels: an upper bound of the energy kept per bounce.
    pub max_gain: f64,
    /// Bound on the relative energy left out by stopping after `bounces` (0 for K = ∞).
    pub energy_left: f64,
}

/// The largest row sum of `F^C = F · diag(ρ_c)` over channels, with its row.
fn max_gain(f: &Dense, reflectance: &[[f64; 3]], channels: usize) -> (f64, usize) {
    let mut best = (0.0, 0);
    for i in 0..f.n {
        for c in 0..channels {
            let s: f64 = f
                .row(i)
                .iter()
                .zip(reflectance)
                .map(|(fij, r)| fij * r[c])
                .sum();
            if s > best.0 {
                best = (s, i);
            }
        }
    }
    best
}

/// Calls `progress(done, total)` as the transfer's channels are solved.
pub type TransferProgress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Computes `M` per channel (`channels` = 1 uses channel 0 of `reflectance`). Returns the
/// row-major matrix with channels interleaved (`n·n·channels`, f32 as stored) and a report.
///
/// Keeps `f` and works on copies; the bake hands its F over instead ([`transfer`]).
pub fn transfer_matrix(
    f: &Dense,
    reflectance: &[[f64; 3]],
    channels: usize,
    bounces: BounceSpec,
) -> Result<(Vec<f32>, TransferReport), TransferError> {
    transfer(Cow::Borrowed(f), reflectance, channels, bounces, None)
}

/// [`transfer_matrix`] on a borrowed or owned F: an owned one is consumed (the last channel is
/// solved in its buffer); `progress` hears how far the solve is, in quarters of a channel. The
/// same values bit for bit.
///
/// Memory (bytes per matrix entry) on the LU path with three channels: F (8), per channel
/// `I − G` factored in place (8) and the solution (8), and the finished channels as f32
/// planes (4 each), interleaved at the end (12). With F owned: 28 at the peak (the second
/// channel's solve), 24 while interleaving; borrowed, 32 (the last channel's copy of F). One
/// channel: 16 owned. The series path adds, during its doubling, the powers of G, their
/// product and G itself (8 each): 48 at most.
pub(crate) fn transfer(
    f: Cow<'_, Dense>,
    reflectance: &[[f64; 3]],
    channels: usize,
    bounces: BounceSpec,
    progress: Option<TransferProgress<'_>>,
) -> Result<(Vec<f32>, TransferReport), TransferError> {
    let n = f.n;
    if reflectance.len() != n {
        return Err(TransferError::Input("one reflectance per patch"));
    }
    if channels != 1 && channels != 3 {
        return Err(TransferError::Input("channels must be 1 or 3"));
    }
    if !f.values.iter().all(|v| v.is_finite() && *v >= 0.0) {
        return Err(TransferError::Input(
            "form factors must be finite and non-negative",
        ));
    }
    if !reflectance
        .iter()
        .flatten()
        .all(|r| r.is_finite() && (0.0..1.0).contains(r))
    {
        return Err(TransferError::Input(
            "reflectance must be finite and in [0, 1)",
        ));
    }
    let (gain, row) = max_gain(&f, reflectance, channels);
    let (k, method) = match bounces {
        BounceSpec::Fixed(0) => return Err(TransferError::ZeroBounces),
        BounceSpec::Fixed(k) => (Bounces::Finite(k), "series"),
        BounceSpec::Infinite => (Bounces::Infinite, "lu"),
        BounceSpec::Auto { tolerance } => {
            // Energy after K bounces ≤ gain^K; the series is cheaper only for K ≤ 2.
            if gain <= tolerance {
                (Bounces::Finite(1), "series")
            } else if gain * gain <= tolerance {
                (Bounces::Finite(2), "series")
            } else {
                (Bounces::Infinite, "lu")
            }
        }
    };
    if k == Bounces::Infinite && gain >= 1.0 {
        return Err(TransferError::Divergent {
            patch: row,
            row_sum: gain,
        });
    }
    let energy_left = match k {
        Bounces::Finite(k) => gain.powi(k as i32),
        Bounces::Infinite => 0.0,
    };
    // F until the last channel has taken it (owned) or copied it (borrowed).
    let mut f = Some(f);
    let mut planes: Vec<Vec<f32>> = Vec::with_capacity(channels);
    // Progress in quarters of a channel: the factorisation is about a quarter of its flops
    // (2n³/3 of 8n³/3), the solve for n right-hand sides the rest.
    let report = |quarters: usize| {
        if let Some(p) = progress {
            p(quarters, 4 * channels)
        }
    };
    for c in 0..channels {
        let last = c + 1 == channels;
        let fr: &Dense = f.as_deref().expect("F is kept until the last channel");
        // `G = F · diag(ρ_c)`: entry `(i, j)` from `F_ij`.
        let g = |j: usize, v: f64| v * reflectance[j][c];
        let plane = match k {
            Bounces::Infinite => {
                // `I − G`, entry by entry as `δ_ij − G_ij` (so 0 − G, never −G: no −0).
                let a = column_major(fr, |i, j, v| {
                    let delta = if i == j { 1.0 } else { 0.0 };
                    delta - g(j, v)
                });
                // The right-hand side F, column-major: F's own buffer for the last channel
                // when it is ours.
                let mut x = if last {
                    match f.take().expect("F is kept until the last channel") {
                        Cow::Owned(mut d) => {
                            transpose_in_place(&mut d.values, n);
                            d.values
                        }
                        Cow::Borrowed(d) => column_major(d, |_, _, v| v),
                    }
                } else {
                    column_major(fr, |_, _, v| v)
                };
                lu_solve_in_place(a, n, &mut x, || report(4 * c + 1));
                plane_of(MatRef::from_column_major_slice(&x, n, n))
            }
            Bounces::Finite(k) => {
                let s = series_sum(Mat::from_fn(n, n, |i, j| g(j, fr.get(i, j))), k);
                let mut m = Mat::<f64>::zeros(n, n);
                let ff = MatRef::from_row_major_slice(&fr.values, n, n);
                faer::linalg::matmul::matmul(&mut m, Accum::Replace, &s, ff, 1.0, Par::rayon(0));
                drop(s);
                plane_of(m.as_ref())
            }
        };
        planes.push(plane);
        report(4 * c + 4);
    }
    drop(f);
    let out = if channels == 1 {
        planes.pop().expect("one plane")
    } else {
        let mut out = vec![0f32; n * n * channels];
        out.par_chunks_mut((n * channels).max(1))
            .enumerate()
            .for_each(|(i, row)| {
                for (c, plane) in planes.iter().enumerate() {
                    for (o, v) in row[c..]
                        .iter_mut()
                        .step_by(channels)
                        .zip(&plane[i * n..][..n])
                    {
                        *o = *v;
                    }
                }
            });
        out
    };
    Ok((
        out,
        TransferReport {
            bounces: k,
            method,
            max_gain: gain,
            energy_left,
        },
    ))
}

/// Side of the square tiles the transposing copies work in (cache-sized: 64² f64 = 32 KiB).
const TILE: usize = 64;

/// `out[j·n + i] = map(i, j, F_ij)`: F's entries mapped, column-major, tile by tile.
fn column_major(f: &Dense, map: impl Fn(usize, usize, f64) -> f64 + Sync) -> Vec<f64> {
    let n = f.n;
    let mut out = vec![0f64; n * n];
    out.par_chunks_mut((n * TILE).max(1))
        .enumerate()
        .for_each(|(band, cols)| {
            let j0 = band * TILE;
            for i0 in (0..n).step_by(TILE) {
                for (jl, col) in cols.chunks_exact_mut(n).enumerate() {
                    let (j, end) = (j0 + jl, (i0 + TILE).min(n));
                    for (i, c) in (i0..end).zip(&mut col[i0..end]) {
                        *c = map(i, j, f.values[i * n + j]);
                    }
                }
            }
        });
    out
}

/// Transposes a square row-major `n × n` matrix in its own buffer, tile by tile.
fn transpose_in_place(v: &mut [f64], n: usize) {
    for i0 in (0..n).step_by(TILE) {
        for j0 in (i0..n).step_by(TILE) {
            for i in i0..(i0 + TILE).min(n) {
                let from = if i0 == j0 { i + 1 } else { j0 };
                for j in from..(j0 + TILE).min(n) {
                    v.swap(i * n + j, j * n + i);
                }
            }
        }
    }
}

/// Factors the column-major `a` in its own buffer (partial pivoting, faer's `lu_in_place`,
/// as `Mat::partial_piv_lu` does on its copy), calls `factored`, and solves `a · X = x` in
/// `x` (column-major, `n` right-hand sides) as faer's `solve_in_place` does, but permuting
/// the rows of `x` one column at a time: faer's permutes through a whole n × n copy.
fn lu_solve_in_place(mut a: Vec<f64>, n: usize, x: &mut [f64], factored: impl FnOnce()) {
    use dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::lu::partial_pivoting::factor;
    use faer::linalg::triangular_solve;
    let par = faer::get_global_parallelism();
    let mut lu = MatMut::from_column_major_slice_mut(&mut a, n, n);
    let (mut fwd, mut bwd) = (vec![0usize; n], vec![0usize; n]);
    factor::lu_in_place(
        lu.rb_mut(),
        &mut fwd,
        &mut bwd,
        par,
        MemStack::new(&mut MemBuffer::new(
            factor::lu_in_place_scratch::<usize, f64>(n, n, par, Default::default()),
        )),
        Default::default(),
    );
    factored();
    // `P x`: row i takes row fwd[i] (faer's `permute_rows`).
    x.par_chunks_mut(n.max(1)).for_each_init(
        || vec![0f64; n],
        |held, col| {
            held.copy_from_slice(col);
            for (v, &from) in col.iter_mut().zip(&fwd) {
                *v = held[from];
            }
        },
    );
    // The unit lower factor and the upper one share the buffer: each solve reads only its own
    // triangle.
    let lu = lu.into_const();
    let mut rhs = MatMut::from_column_major_slice_mut(x, n, n);
    triangular_solve::solve_unit_lower_triangular_in_place(lu, rhs.rb_mut(), par);
    triangular_solve::solve_upper_triangular_in_place(lu, rhs.rb_mut(), par);
}

/// A channel of M as stored: row-major f32 from the f64 solution. LU round-off can leave
/// tiny negatives where M is zero; M ≥ 0 in exact arithmetic.
fn plane_of(x: MatRef<'_, f64>) -> Vec<f32> {
    let n = x.nrows();
    let mut out = vec![0f32; n * n];
    out.par_chunks_mut((n * TILE).max(1))
        .enumerate()
        .for_each(|(band, rows)| {
            let i0 = band * TILE;
            for j0 in (0..n).step_by(TILE) {
                let end = (j0 + TILE).min(n);
                for (il, row) in rows.chunks_exact_mut(n).enumerate() {
                    for (j, r) in (j0..end).zip(&mut row[j0..end]) {
                        *r = x[(i0 + il, j)].max(0.0) as f32;
                    }
                }
            }
        });
    out
}

/// `Σ_{b<k} G^b` by binary doubling: about 3·log2(k) matrix products. Takes `G` so that it is
/// freed as soon as it is no longer needed; holds the sum, the power, their product and (for
/// a `k` with set bits below the top one, bit 0 aside) G: 32 bytes per entry at most, 16 for
/// `k ≤ 2`.
fn series_sum(g: Mat<f64>, k: u32) -> Mat<f64> {
    let n = g.nrows();
    let mut s = Mat::from_fn(n, n, |i, j| if i == j { 1.0 } else { 0.0 });
    if k == 1 {
        return s;
    }
    let top = 31 - k.leading_zeros();
    // G is multiplied in for the set bits below the top one, bit 0 excepted (nothing follows).
    let needs_g = k & ((1 << top) - 1) & !1 != 0;
    let (mut p, g) = if needs_g {
        (g.clone(), Some(g))
    } else {
        (g, None)
    };
    let mut tmp = Mat::<f64>::new();
    let product = |tmp: &mut Mat<f64>, a: &Mat<f64>, b: &Mat<f64>| {
        if tmp.nrows() != n {
            *tmp = Mat::zeros(n, n);
        }
        faer::linalg::matmul::matmul(tmp, Accum::Replace, a, b, 1.0, Par::rayon(0));
    };
    // Invariant: s = Σ_{b<m} G^b and p = G^m for the prefix m of k's bits read so far.
    for bit in (0..top).rev() {
        // m → 2m: s ← s + p·s, p ← p·p. At the first step s = I, and p·I is p exactly (every
        // entry one product by 1 and sums of +0), so the product is skipped.
        if bit + 1 == top {
            s += &p;
        } else {
            product(&mut tmp, &p, &s);
            s += &tmp;
        }
        if bit == 0 && k & 1 == 0 {
            // p is not needed again.
            break;
        }
        product(&mut tmp, &p, &p);
        std::mem::swap(&mut p, &mut tmp);
        if k & (1 << bit) != 0 {
            // m → m + 1: s ← s + p, p ← p·G.
            s += &p;
            if bit == 0 {
                break;
            }
            let g = g.as_ref().expect("kept while a bit is set");
            product(&mut tmp, &p, g);
            std::mem::swap(&mut p, &mut tmp);
        }
    }
    s
}

#[cfg(test)]
mod tests;
