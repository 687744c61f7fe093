//! [`ProbeFactors`]: the probes' weights as a product `C·V`, and the rows that product
//! stands for.

use super::{ProbeWeight, Probes, SH_COEFFICIENTS};
use crate::half::f16_to_f32;
use alloc::borrow::Cow;
use alloc::vec::Vec;

/// The probes' weights as a product of two thin matrices, `P ≈ C·V` (`P` the 9·m × n matrix
/// of [`ProbeWeight`]s, probe-major, one row per probe and SH coefficient): a frame takes
/// `t = V·(B − E)` once (`k` values a channel), then each probe `C_p·t`, `k·(n + 9m)`
/// multiply-adds in place of `9·w` (`docs/decisions/probe-factors.md` measures the rank).
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeFactors<'a> {
    /// The rank `k` (at least 1).
    pub rank: u32,
    /// `V`, `k` rows of one weight a patch, row-major, binary16 bits.
    pub basis: Cow<'a, [u16]>,
    /// `C`, per probe and SH coefficient (probe-major) `k` weights, binary16 bits.
    pub coefficients: Cow<'a, [u16]>,
}

impl ProbeFactors<'_> {
    /// The patches the basis spans.
    pub fn patches(&self) -> usize {
        self.basis.len() / (self.rank.max(1) as usize)
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> ProbeFactors<'static> {
        ProbeFactors {
            rank: self.rank,
            basis: Cow::Owned(self.basis.into_owned()),
            coefficients: Cow::Owned(self.coefficients.into_owned()),
        }
    }
}

impl Probes<'_> {
    /// The probes as rows of weights, every patch in every row for factored ones (their
    /// product `C·V`, rounded to binary16), for a consumer that reads rows only.
    pub fn to_rows(&self) -> Probes<'static> {
        let Some(f) = &self.factors else {
            return self.clone().into_owned();
        };
        let (k, n, m) = (f.rank as usize, f.patches(), self.len());
        let basis: Vec<f32> = f.basis.iter().map(|&h| f16_to_f32(h)).collect();
        let mut weights = Vec::with_capacity(m * n);
        let mut rows = alloc::vec![0u32];
        for p in 0..m {
            let coefficients: Vec<[f32; SH_COEFFICIENTS]> = (0..k)
                .map(|q| {
                    core::array::from_fn(|c| {
                        f16_to_f32(f.coefficients[(p * SH_COEFFICIENTS + c) * k + q])
                    })
                })
                .collect();
            for j in 0..n {
                let mut sh = [0.0f32; SH_COEFFICIENTS];
                for (q, cq) in coefficients.iter().enumerate() {
                    let v = basis[q * n + j];
                    for c in 0..SH_COEFFICIENTS {
                        sh[c] += cq[c] * v;
                    }
                }
                weights.push(ProbeWeight::new(j as u32, sh));
            }
            rows.push(weights.len() as u32);
        }
        Probes {
            spacing: self.spacing,
            positions: Cow::Owned(self.positions.to_vec()),
            rows: Cow::Owned(rows),
            weights: Cow::Owned(weights),
            factors: None,
        }
    }
}
