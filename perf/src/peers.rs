//! The peers the gather is measured against, each a [`Gather`] so that a bench holds every
//! method in one list and times them with one loop:
//!
//! - [`FaerDense`]: the dense f32 mat-vec of the same transfer matrix M with faer, one matrix
//!   per stored channel (what a user would write instead of compressing);
//! - [`DenseRgb`]: the same product written plainly with rayon + `wide` (a check on faer);
//! - [`JacobiBounces`]: classical radiosity, K Jacobi bounce iterations with F every frame;
//! - [`LuSolve`]: the exact solution per frame from an LU factorisation of `I − F^C`.
//!
//! All take exitance and give irradiance in the same numbering as their matrices, RGB, W/m².
//! [`Cost`] says what each touches per call, for the roofline.

use faer::linalg::solvers::{PartialPivLu, Solve};
use faer::{Accum, Mat, Par};
use radiosity_bake::transfer::Dense;
use radiosity_core::{Gather, GatherError, Rgb, TransferMatrix, check_gather_args};
use rayon::prelude::*;
use wide::f32x8;

/// What one call reads and computes, for a roofline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Bytes read or written from memory per call (matrix data plus the vectors).
    pub bytes: u64,
    /// Multiply-adds per call, counted in f32 lanes: an f64 multiply-add counts as two, since a
    /// SIMD register holds half as many.
    pub fmas_f32: u64,
}

/// Bytes of `n` RGB f32 vectors in and out.
fn vector_bytes(n: usize) -> u64 {
    2 * 12 * n as u64
}

/// The cost of a gather with a compressed matrix: its blocks, scales and sparse list once,
/// one multiply-add per entry and colour channel (a grey matrix still multiplies each entry
/// into three channels), plus one per channel for each sparse correction.
pub fn gather_cost(m: &TransferMatrix<'_>) -> Cost {
    let n = m.layout.n() as u64;
    let bytes = m.blocks.len() as u64
        + m.sparse.bytes() as u64
        + 8 * m.scales.len() as u64
        + vector_bytes(m.layout.n());
    let fmas_f32 = 3 * n * n + 3 * m.sparse.nnz() as u64;
    Cost { bytes, fmas_f32 }
}

/// Splits an interleaved row-major matrix (`(r·n + c)·channels + k`) into one faer matrix per
/// channel.
fn channel_mats(n: usize, channels: usize, dense: &[f32]) -> Vec<Mat<f32>> {
    assert_eq!(dense.len(), n * n * channels, "dense matrix of side {n}");
    (0..channels)
        .map(|k| Mat::from_fn(n, n, |r, c| dense[(r * n + c) * channels + k]))
        .collect()
}

/// Dense f32 mat-vec with faer: `y_k = M_k · x_k` per colour channel (a grey matrix: one
/// product with the three channels as three right-hand sides), parallel over rayon's pool.
pub struct FaerDense {
    n: usize,
    m: Vec<Mat<f32>>,
    x: Mat<f32>,
    y: Mat<f32>,
}

impl FaerDense {
    /// From an interleaved row-major matrix with 1 or 3 channels.
    pub fn new(n: usize, channels: usize, dense: &[f32]) -> Self {
        assert!(channels == 1 || channels == 3, "1 or 3 channels");
        Self {
            n,
            m: channel_mats(n, channels, dense),
            x: Mat::zeros(n, 3),
            y: Mat::zeros(n, 3),
        }
    }

    /// Bytes and multiply-adds per call.
    pub fn cost(&self) -> Cost {
        let nn = (self.n * self.n) as u64;
        Cost {
            bytes: 4 * nn * self.m.len() as u64 + vector_bytes(self.n),
            fmas_f32: 3 * nn,
        }
    }
}

impl Gather for FaerDense {
    fn name(&self) -> &str {
        "faer-dense-f32"
    }

    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        check_gather_args(self.n, exitance, irradiance)?;
        for (i, v) in exitance.iter().enumerate() {
            for k in 0..3 {
                self.x[(i, k)] = v.channel(k);
            }
        }
        if self.m.len() == 1 {
            faer::linalg::matmul::matmul(
                &mut self.y,
                Accum::Replace,
                &self.m[0],
                &self.x,
                1.0,
                Par::rayon(0),
            );
        } else {
            for k in 0..3 {
                faer::linalg::matmul::matmul(
                    self.y.col_mut(k).as_mat_mut(),
                    Accum::Replace,
                    &self.m[k],
                    self.x.col(k).as_mat(),
                    1.0,
                    Par::rayon(0),
                );
            }
        }
        for (i, out) in irradiance.iter_mut().enumerate() {
            *out = Rgb::new(self.y[(i, 0)], self.y[(i, 1)], self.y[(i, 2)]);
        }
        Ok(())
    }
}

/// Dense row-major RGB mat-vec written plainly: rayon over rows, `f32x8` over 8 columns (24
/// interleaved floats) at a time. Three channels only.
pub struct DenseRgb {
    n: usize,
    m: Vec<f32>,
    x: Vec<f32>,
}

impl DenseRgb {
    /// From an interleaved row-major three-channel matrix (`(r·n + c)·3 + k`).
    pub fn new(n: usize, dense: Vec<f32>) -> Self {
        assert_eq!(dense.len(), n * n * 3, "dense RGB matrix of side {n}");
        Self {
            n,
            m: dense,
            x: vec![0.0; 3 * n],
        }
    }

    /// Bytes and multiply-adds per call.
    pub fn cost(&self) -> Cost {
        let nn = (self.n * self.n) as u64;
        Cost {
            bytes: 12 * nn + vector_bytes(self.n),
            fmas_f32: 3 * nn,
        }
    }
}

/// `y = M·x` for an interleaved RGB matrix `m` and interleaved `x` (`3n` floats).
pub fn dense_rgb(n: usize, m: &[f32], x: &[f32], y: &mut [Rgb]) {
    y.par_iter_mut().enumerate().for_each(|(r, y)| {
        let row = &m[r * n * 3..(r + 1) * n * 3];
        let mut acc = [f32x8::ZERO; 3];
        let (rows24, rest) = row.split_at(n / 8 * 24);
        for (mc, xc) in rows24.chunks_exact(24).zip(x.chunks_exact(24)) {
            for v in 0..3 {
                let a: [f32; 8] = mc[8 * v..8 * v + 8].try_into().expect("8 floats");
                let b: [f32; 8] = xc[8 * v..8 * v + 8].try_into().expect("8 floats");
                acc[v] = f32x8::from(a).mul_add(f32x8::from(b), acc[v]);
            }
        }
        let mut s = [0f32; 3];
        for (v, a) in acc.iter().enumerate() {
            for (i, l) in a.to_array().iter().enumerate() {
                // Lane i of register v holds float 8v + i of each 24-float group: channel (8v + i) % 3.
                s[(8 * v + i) % 3] += l;
            }
        }
        let tail = &x[n / 8 * 24..];
        for (i, (a, b)) in rest.iter().zip(tail).enumerate() {
            s[i % 3] += a * b;
        }
        *y = Rgb::from_array(s);
    });
}

impl Gather for DenseRgb {
    fn name(&self) -> &str {
        "dense-f32-rayon-wide"
    }

    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        check_gather_args(self.n, exitance, irradiance)?;
        for (chunk, v) in self.x.chunks_exact_mut(3).zip(exitance) {
            chunk.copy_from_slice(&v.to_array());
        }
        dense_rgb(self.n, &self.m, &self.x, irradiance);
        Ok(())
    }
}

/// Classical radiosity: `iterations` Jacobi bounce iterations with the form factors every
/// frame. With first exitance `x`: `B₀ = x`, `H_k = F·B_{k−1}`, `B_k = x + ρ∘H_k`; the
/// irradiance returned is `H_K = Σ_{b<K} (F^C)^b F x`, the same as a transfer matrix with K
/// bounces. F is stored once in f32 (it is colour-free) and multiplies the three channels as
/// three right-hand sides, with faer.
pub struct JacobiBounces {
    n: usize,
    iterations: usize,
    f: Mat<f32>,
    reflectance: Vec<[f32; 3]>,
    x: Mat<f32>,
    b: Mat<f32>,
    h: Mat<f32>,
}

impl JacobiBounces {
    /// From form factors and reflectances of the same patches; `iterations ≥ 1`.
    pub fn new(f: &Dense, reflectance: &[[f64; 3]], iterations: usize) -> Self {
        assert!(iterations >= 1, "at least one iteration");
        assert_eq!(reflectance.len(), f.n, "one reflectance per patch");
        let n = f.n;
        Self {
            n,
            iterations,
            f: Mat::from_fn(n, n, |i, j| f.get(i, j) as f32),
            reflectance: reflectance.iter().map(|r| r.map(|v| v as f32)).collect(),
            x: Mat::zeros(n, 3),
            b: Mat::zeros(n, 3),
            h: Mat::zeros(n, 3),
        }
    }

    /// Bytes and multiply-adds per call: F is read once per iteration.
    pub fn cost(&self) -> Cost {
        let nn = (self.n * self.n) as u64;
        let k = self.iterations as u64;
        Cost {
            bytes: k * (4 * nn + vector_bytes(self.n)),
            fmas_f32: k * 3 * nn,
        }
    }
}

impl Gather for JacobiBounces {
    fn name(&self) -> &str {
        "jacobi"
    }

    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        check_gather_args(self.n, exitance, irradiance)?;
        for (i, v) in exitance.iter().enumerate() {
            for k in 0..3 {
                self.x[(i, k)] = v.channel(k);
                self.b[(i, k)] = v.channel(k);
            }
        }
        for it in 0..self.iterations {
            faer::linalg::matmul::matmul(
                &mut self.h,
                Accum::Replace,
                &self.f,
                &self.b,
                1.0,
                Par::rayon(0),
            );
            if it + 1 < self.iterations {
                for i in 0..self.n {
                    for k in 0..3 {
                        self.b[(i, k)] = self.x[(i, k)] + self.reflectance[i][k] * self.h[(i, k)];
                    }
                }
            }
        }
        for (i, out) in irradiance.iter_mut().enumerate() {
            *out = Rgb::new(self.h[(i, 0)], self.h[(i, 1)], self.h[(i, 2)]);
        }
        Ok(())
    }
}

/// The exact irradiance `H = (I − F^C)⁻¹ F x` by an LU factorisation (f64, partial
/// pivoting) of `I − F^C` per colour channel, made once in [`LuSolve::new`]: each call is
/// `F·x` and two triangular solves per channel. The factorisation depends only on geometry and
/// reflectance — what a bake fixes — so a renderer whose lights move would reuse it exactly as
/// here; re-factorising each frame (~2/3·n³ per channel) would be the same answer 1000× slower
/// at n = 4096 and is reported as the one-off setup cost instead.
pub struct LuSolve {
    n: usize,
    f: Mat<f64>,
    lu: Vec<PartialPivLu<f64>>,
    rhs: Mat<f64>,
}

impl LuSolve {
    /// Factorises `I − F^C` for each of the three channels.
    pub fn new(f: &Dense, reflectance: &[[f64; 3]]) -> Self {
        assert_eq!(reflectance.len(), f.n, "one reflectance per patch");
        let n = f.n;
        let lu = (0..3)
            .map(|c| {
                let a = Mat::from_fn(n, n, |i, j| {
                    let g = f.get(i, j) * reflectance[j][c];
                    if i == j { 1.0 - g } else { -g }
                });
                a.partial_piv_lu()
            })
            .collect();
        Self {
            n,
            f: Mat::from_fn(n, n, |i, j| f.get(i, j)),
            lu,
            rhs: Mat::zeros(n, 3),
        }
    }

    /// Bytes and multiply-adds per call: F and three LU factors (each `n²` f64, L and U
    /// together), one `n²` product and two `n²/2` triangular solves per channel, f64.
    pub fn cost(&self) -> Cost {
        let nn = (self.n * self.n) as u64;
        Cost {
            bytes: 8 * nn * 4 + vector_bytes(self.n),
            fmas_f32: 2 * (3 * nn + 3 * nn),
        }
    }

    /// The solution in f64 for an f64 first exitance: the accuracy oracle.
    pub fn solve(&mut self, exitance: &[[f64; 3]]) -> Vec<[f64; 3]> {
        assert_eq!(exitance.len(), self.n, "one exitance per patch");
        let x = Mat::from_fn(self.n, 3, |i, k| exitance[i][k]);
        faer::linalg::matmul::matmul(
            &mut self.rhs,
            Accum::Replace,
            &self.f,
            &x,
            1.0,
            Par::rayon(0),
        );
        for (k, lu) in self.lu.iter().enumerate() {
            lu.solve_in_place(self.rhs.col_mut(k).as_mat_mut());
        }
        (0..self.n)
            .map(|i| [self.rhs[(i, 0)], self.rhs[(i, 1)], self.rhs[(i, 2)]])
            .collect()
    }
}

impl Gather for LuSolve {
    fn name(&self) -> &str {
        "lu-per-frame"
    }

    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        check_gather_args(self.n, exitance, irradiance)?;
        let x: Vec<[f64; 3]> = exitance
            .iter()
            .map(|v| v.to_array().map(f64::from))
            .collect();
        for (out, h) in irradiance.iter_mut().zip(self.solve(&x)) {
            *out = Rgb::from_array(h.map(|v| v as f32));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two facing unit-ish patches plus a third: a small closed-ish system with a known exact
    /// answer by direct 3×3 algebra.
    fn system() -> (Dense, Vec<[f64; 3]>) {
        let f = Dense::new(3, vec![0.0, 0.5, 0.3, 0.4, 0.0, 0.4, 0.3, 0.5, 0.0]);
        let rho = vec![[0.5, 0.2, 0.8], [0.7, 0.1, 0.3], [0.4, 0.6, 0.9]];
        (f, rho)
    }

    fn rel(a: &[Rgb], b: &[[f64; 3]]) -> f64 {
        let mut num = 0.0;
        let mut den = 0.0;
        for (x, y) in a.iter().zip(b) {
            for k in 0..3 {
                num += (f64::from(x.channel(k)) - y[k]).powi(2);
                den += y[k] * y[k];
            }
        }
        (num / den).sqrt()
    }

    /// Jacobi with many iterations converges to the LU answer (the gain per bounce is at most
    /// 0.8·0.9 = 0.72, so 200 iterations leave 0.72^200 ≈ 1e-29: only f32 rounding remains,
    /// bounded by 1e-6 relative).
    #[test]
    fn jacobi_converges_to_the_lu_solution() {
        let (f, rho) = system();
        let x = vec![
            Rgb::new(1.0, 2.0, 3.0),
            Rgb::new(0.0, 0.5, 0.0),
            Rgb::new(4.0, 0.0, 1.0),
        ];
        let x64: Vec<[f64; 3]> = x.iter().map(|v| v.to_array().map(f64::from)).collect();
        let exact = LuSolve::new(&f, &rho).solve(&x64);
        // Check the LU against the definition H = F (x + ρ∘H) directly, in f64.
        for i in 0..3 {
            for k in 0..3 {
                let rhs: f64 = (0..3)
                    .map(|j| f.get(i, j) * (x64[j][k] + rho[j][k] * exact[j][k]))
                    .sum();
                assert!(
                    (rhs - exact[i][k]).abs() < 1e-12,
                    "H[{i}][{k}] = {} but F(x + ρH) = {rhs}",
                    exact[i][k]
                );
            }
        }
        let mut y = vec![Rgb::ZERO; 3];
        JacobiBounces::new(&f, &rho, 200)
            .gather(&x, &mut y)
            .unwrap();
        let e = rel(&y, &exact);
        assert!(e < 1e-6, "jacobi-200 vs LU: relative error {e:e} > 1e-6");
        // One iteration is F·x exactly (up to f32 rounding).
        JacobiBounces::new(&f, &rho, 1).gather(&x, &mut y).unwrap();
        let fx: Vec<[f64; 3]> = (0..3)
            .map(|i| std::array::from_fn(|k| (0..3).map(|j| f.get(i, j) * x64[j][k]).sum()))
            .collect();
        let e = rel(&y, &fx);
        assert!(e < 1e-6, "jacobi-1 vs F·x: relative error {e:e} > 1e-6");
    }

    /// faer and the plain rayon + wide product agree with an f64 mat-vec, on a size that is not
    /// a multiple of 8 (exercises the tail). f32 sums of 37 positive terms: relative 1e-5 is
    /// ~100 ulps of room.
    #[test]
    fn dense_peers_match_an_f64_product() {
        let n = 37;
        let m: Vec<f32> = (0..n * n * 3)
            .map(|i| ((i * 7919) % 1000) as f32 / 1000.0)
            .collect();
        let x: Vec<Rgb> = (0..n)
            .map(|i| Rgb::new(i as f32 / 10.0, 1.0, (n - i) as f32))
            .collect();
        let exact: Vec<[f64; 3]> = (0..n)
            .map(|r| {
                std::array::from_fn(|k| {
                    (0..n)
                        .map(|c| f64::from(m[(r * n + c) * 3 + k]) * f64::from(x[c].channel(k)))
                        .sum()
                })
            })
            .collect();
        let mut y = vec![Rgb::ZERO; n];
        FaerDense::new(n, 3, &m).gather(&x, &mut y).unwrap();
        let e = rel(&y, &exact);
        assert!(e < 1e-5, "faer: relative error {e:e} > 1e-5");
        DenseRgb::new(n, m.clone()).gather(&x, &mut y).unwrap();
        let e = rel(&y, &exact);
        assert!(e < 1e-5, "rayon+wide: relative error {e:e} > 1e-5");
        // A grey matrix (one channel) multiplies each channel of x.
        let grey: Vec<f32> = m.iter().step_by(3).copied().collect();
        FaerDense::new(n, 1, &grey).gather(&x, &mut y).unwrap();
        let exact_grey: Vec<[f64; 3]> = (0..n)
            .map(|r| {
                std::array::from_fn(|k| {
                    (0..n)
                        .map(|c| f64::from(grey[r * n + c]) * f64::from(x[c].channel(k)))
                        .sum()
                })
            })
            .collect();
        let e = rel(&y, &exact_grey);
        assert!(e < 1e-5, "faer grey: relative error {e:e} > 1e-5");
    }
}
