//! [`DecodedProbes`]: the probes' weights decoded to f32 once, gathered every frame on the
//! CPU, and the row and dot-product kernels [`super::Probes`] shares with it.

use super::{Probes, SH_COEFFICIENTS};
use crate::Rgb;
use crate::half::f16_to_f32;
use alloc::vec::Vec;

/// Finite binary16 values to f32, exactly and without branches (so the loop vectorises): the
/// half's bits shifted into an f32's place read as a number 2¹¹² too small, normal or
/// subnormal alike; the product by 2¹¹² is exact. Infinities and NaN (refused on load) would
/// come out wrong.
#[inline]
pub(super) fn finite_f16s_to_f32(h: &[u16; SH_COEFFICIENTS]) -> [f32; SH_COEFFICIENTS] {
    let rebase = f32::from_bits((127 + 112) << 23);
    h.map(|h| {
        let magnitude = f32::from_bits(u32::from(h & 0x7fff) << 13) * rebase;
        f32::from_bits(magnitude.to_bits() | (u32::from(h & 0x8000) << 16))
    })
}

/// `Σ sh·reflected[patch]` over a row, in its order from zero, per coefficient and channel.
#[inline]
pub(super) fn sum_row(
    row: impl Iterator<Item = (u32, [f32; SH_COEFFICIENTS])>,
    reflected: &[Rgb],
) -> [Rgb; SH_COEFFICIENTS] {
    // Channel-major sums: each channel's nine coefficients are one contiguous run, which the
    // compiler keeps in vector registers.
    let mut acc = [[0.0f32; SH_COEFFICIENTS]; 3];
    for (patch, sh) in row {
        let b = reflected[patch as usize].to_array();
        for (a, b) in acc.iter_mut().zip(b) {
            for k in 0..SH_COEFFICIENTS {
                a[k] += b * sh[k];
            }
        }
    }
    core::array::from_fn(|k| Rgb::new(acc[0][k], acc[1][k], acc[2][k]))
}

/// `Σ a_i·b_i` in eight lanes (so the loop vectorises), the lanes then added in order.
#[inline]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f32 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    acc.iter().sum::<f32>() + tail
}

/// The patches' reflected radiosity as three channel arrays.
fn channels(reflected: &[Rgb]) -> [Vec<f32>; 3] {
    [
        reflected.iter().map(|c| c.r).collect(),
        reflected.iter().map(|c| c.g).collect(),
        reflected.iter().map(|c| c.b).collect(),
    ]
}

/// A frame's modes `t = V·(B − E)` ([`DecodedProbes::modes`]): `k` values a channel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ProbeModes([Vec<f32>; 3]);

/// [`Probes`] with their weights decoded to f32 once, for a runtime that gathers them every
/// frame on the CPU: decoding binary16 costs as much as the sums, so this holds 40 bytes a
/// weight (4 a factor) to halve the frame. A row's results equal [`Probes::gather_probe`]'s
/// bit for bit.
#[derive(Clone, Debug, Default)]
pub struct DecodedProbes {
    count: usize,
    rows: Vec<u32>,
    patches: Vec<u32>,
    sh: Vec<[f32; SH_COEFFICIENTS]>,
    rank: usize,
    basis: Vec<f32>,
    coefficients: Vec<f32>,
}

impl DecodedProbes {
    /// Decodes `probes` (validated, as a parsed file's are).
    pub fn new(probes: &Probes<'_>) -> Self {
        let (rank, basis, coefficients) = match &probes.factors {
            Some(f) => (
                f.rank as usize,
                f.basis.iter().map(|&h| f16_to_f32(h)).collect(),
                f.coefficients.iter().map(|&h| f16_to_f32(h)).collect(),
            ),
            None => (0, Vec::new(), Vec::new()),
        };
        DecodedProbes {
            count: probes.len(),
            rows: probes.rows.to_vec(),
            patches: probes.weights.iter().map(|w| w.patch).collect(),
            sh: probes
                .weights
                .iter()
                .map(|w| finite_f16s_to_f32(&w.sh_bits))
                .collect(),
            rank,
            basis,
            coefficients,
        }
    }

    /// Probes held.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The rank of factored probes ([`ProbeFactors`](super::ProbeFactors)), 0 for rows of weights.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// The frame's modes `t = V·(B − E)` for factored probes (empty for rows), once a frame
    /// before [`DecodedProbes::gather_probe_with`]: `k·n` multiply-adds a channel.
    pub fn modes(&self, reflected: &[Rgb]) -> ProbeModes {
        if self.rank == 0 {
            return ProbeModes::default();
        }
        let n = self.basis.len() / self.rank;
        let ch = channels(&reflected[..n]);
        ProbeModes(core::array::from_fn(|c| {
            self.basis
                .chunks_exact(n)
                .map(|row| dot(row, &ch[c]))
                .collect()
        }))
    }

    /// Probe `p`'s radiance SH from the patches' reflected radiosity and the frame's
    /// [`DecodedProbes::modes`] (which rows of weights do not read).
    pub fn gather_probe_with(
        &self,
        p: usize,
        reflected: &[Rgb],
        modes: &ProbeModes,
    ) -> [Rgb; SH_COEFFICIENTS] {
        if self.rank == 0 {
            let range = self.rows[p] as usize..self.rows[p + 1] as usize;
            let row = self.patches[range.clone()].iter().copied();
            return sum_row(row.zip(self.sh[range].iter().copied()), reflected);
        }
        let k = self.rank;
        core::array::from_fn(|c| {
            let row = &self.coefficients[(p * SH_COEFFICIENTS + c) * k..][..k];
            Rgb::new(
                dot(row, &modes.0[0]),
                dot(row, &modes.0[1]),
                dot(row, &modes.0[2]),
            )
        })
    }

    /// Probe `p`'s radiance SH from the patches' reflected radiosity (as
    /// [`Probes::gather_probe`]). Factored probes take the frame's modes first, a
    /// probe's cost many times over: a frame of every probe calls
    /// [`DecodedProbes::gather`].
    pub fn gather_probe(&self, p: usize, reflected: &[Rgb]) -> [Rgb; SH_COEFFICIENTS] {
        self.gather_probe_with(p, reflected, &self.modes(reflected))
    }

    /// Every probe's radiance SH: `out[p] = P_p·reflected`, the modes taken once. Panics if
    /// `out` has the wrong length (a programming error).
    pub fn gather(&self, reflected: &[Rgb], out: &mut [[Rgb; SH_COEFFICIENTS]]) {
        assert_eq!(out.len(), self.len(), "one entry per probe");
        let modes = self.modes(reflected);
        for (p, o) in out.iter_mut().enumerate() {
            *o = self.gather_probe_with(p, reflected, &modes);
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        4 * (self.rows.len() + self.patches.len() + self.basis.len() + self.coefficients.len())
            + 4 * SH_COEFFICIENTS * self.sh.len()
    }
}
