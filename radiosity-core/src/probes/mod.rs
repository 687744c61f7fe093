//! Light probes a `.rad` file may carry (its optional PROBES section): points in the scene's
//! empty space that hold, per matrix patch, what that patch's reflected radiosity adds to the
//! radiance arriving there, as spherical harmonics up to order 2 (nine coefficients). Each
//! frame `c = P·(B − E)` gives every probe's SH; [`sh_irradiance`] turns them into the
//! irradiance for any normal. Emitted light is left out on purpose: a small bright emitter is
//! a near-delta in direction, whose SH ring (`docs/decisions/probe-sh-order.md`); a runtime
//! takes emitters' direct light at the query point, as it takes the analytic lights'.
//!
//! The weight of patch `j` in coefficient `lm` of a probe is `(1/π)·∫_{Ω_j} Y_lm(ω) dω` over
//! the directions in which the probe sees the patch (radiance `L = B/π`). Real SH, in the
//! order `Y00, Y1−1, Y10, Y11, Y2−2, Y2−1, Y20, Y21, Y22` with `Y1−1 ∝ y`, `Y10 ∝ z`,
//! `Y11 ∝ x`.
//!
//! Section layout (little-endian, 4-byte aligned):
//!
//! | bytes | content |
//! |---|---|
//! | 12 | probes `m`, weights `w` (`u32` each), lattice step `h` (`f32`, positive) |
//! | 12·m | positions `[f32; 3]` |
//! | 4·(m+1) | weight row starts, one row per probe |
//! | 24·w | [`ProbeWeight`]s: patch index, nine binary16 coefficients, two zero bytes |
//!
//! Factored probes ([`ProbeFactors`]) store `w = 0`, rows of zeros, and after them:
//!
//! | bytes | content |
//! |---|---|
//! | 8 | rank `k`, patches `n` (`u32` each) |
//! | 2·k·n, padded to 4 | the basis `V`: `k` rows over the patches, binary16 |
//! | 2·9·m·k, padded to 4 | the coefficients `C`: per probe and SH coefficient, `k` binary16 |
//!
//! The weights are stored as binary16, as the matrix's `f16` format stores its entries: the
//! weights are signed (the matrix's log codes are not) and a probe's row holds only the
//! patches it sees, so block codes do not apply; half precision (a relative step of 2⁻¹¹)
//! moves a probe's irradiance by under 0.05% and takes 24 bytes a weight instead of 40.

mod decoded;
mod factors;
mod section;
mod sh;
#[cfg(test)]
mod tests;

pub use decoded::{DecodedProbes, ProbeModes};
pub use factors::ProbeFactors;
pub use sh::{sh_basis, sh_irradiance};

use crate::Rgb;
use crate::half::{f16_to_f32, f32_to_f16};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};
use decoded::{finite_f16s_to_f32, sum_row};

/// SH coefficients a probe holds per channel (orders 0 to 2).
pub const SH_COEFFICIENTS: usize = 9;

/// The part of a probe's interpolation weight that does not depend on which side of the
/// point's surface it lies ([`Probes::interpolation_weights`]; 0.5 of the range 0–2 measured
/// best, `docs/decisions/probe-interpolation.md`).
pub const FACING_FLOOR: f32 = 0.5;

/// One patch's weights in one probe.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ProbeWeight {
    /// Patch index in the matrix numbering.
    pub patch: u32,
    /// `(1/π)·∫ Y_lm dω` over the directions the probe sees the patch in, per coefficient,
    /// as binary16 bits ([`ProbeWeight::sh`] gives them as f32).
    pub sh_bits: [u16; SH_COEFFICIENTS],
    /// Zero.
    pub reserved: u16,
}

impl ProbeWeight {
    /// The weight of `patch` with coefficients `sh`, rounded to binary16 (to nearest, even).
    pub fn new(patch: u32, sh: [f32; SH_COEFFICIENTS]) -> Self {
        ProbeWeight {
            patch,
            sh_bits: sh.map(f32_to_f16),
            reserved: 0,
        }
    }

    /// The coefficients as f32 (exact).
    #[inline]
    pub fn sh(&self) -> [f32; SH_COEFFICIENTS] {
        self.sh_bits.map(f16_to_f32)
    }
}

/// The probes, borrowing from the file where aligned.
#[derive(Clone, Debug, PartialEq)]
pub struct Probes<'a> {
    /// The lattice step a point interpolates over ([`Probes::interpolation_weights`]): the
    /// step of a lattice, the median distance to the nearest probe for scattered probes.
    pub spacing: f32,
    /// Probe positions, scene units.
    pub positions: Cow<'a, [[f32; 3]]>,
    /// Weight row starts (`probes + 1`).
    pub rows: Cow<'a, [u32]>,
    /// Weights, each probe's patches in increasing order (empty, the rows all 0, when
    /// `factors` holds them).
    pub weights: Cow<'a, [ProbeWeight]>,
    /// The weights as factors, in place of `weights`.
    pub factors: Option<ProbeFactors<'a>>,
}

impl Probes<'_> {
    /// Probes held.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The weights of probe `p`.
    pub fn weights_of(&self, p: usize) -> &[ProbeWeight] {
        &self.weights[self.rows[p] as usize..self.rows[p + 1] as usize]
    }

    /// Every probe's radiance SH from the patches' reflected radiosity `reflected` (`B − E`,
    /// one entry per matrix patch): `out[p] = Σ_j w_pj·reflected_j`. Panics if `reflected`
    /// or `out` has the wrong length (a programming error).
    pub fn gather(&self, reflected: &[Rgb], out: &mut [[Rgb; SH_COEFFICIENTS]]) {
        if self.factors.is_some() {
            return DecodedProbes::new(self).gather(reflected, out);
        }
        assert_eq!(out.len(), self.len(), "one entry per probe");
        for (p, o) in out.iter_mut().enumerate() {
            *o = self.gather_probe(p, reflected);
        }
    }

    /// Probe `p`'s radiance SH (one entry of [`Probes::gather`]), for a caller that spreads
    /// the probes over threads. The row is summed in stored order from zero, per coefficient
    /// and channel; factored probes are decoded first ([`DecodedProbes`], which a runtime
    /// keeps instead). Panics if a weight names a patch past `reflected` (a programming error:
    /// validated probes do not).
    pub fn gather_probe(&self, p: usize, reflected: &[Rgb]) -> [Rgb; SH_COEFFICIENTS] {
        if self.factors.is_some() {
            return DecodedProbes::new(self).gather_probe(p, reflected);
        }
        let row = self.weights_of(p);
        sum_row(
            row.iter()
                .map(|w| (w.patch, finite_f16s_to_f32(&w.sh_bits))),
            reflected,
        )
    }

    /// The probes a point at `p` takes its reflected light from, with weights summing to 1,
    /// into `out` (cleared first); `false` (and `out` empty) when none is in sight.
    ///
    /// The probes of the point's lattice cell (each axis within one [`Probes::spacing`]) that
    /// `visible(probe)` says the point sees (a segment from the point to the probe clear of
    /// the scene: the caller's ray caster), each with its trilinear weight
    /// `Π (1 − |d_axis|/h)`; for a surface of unit normal `n`, times
    /// `FACING_FLOOR + ((1 + n·ω)/2)²` towards probes in front of it (ω the unit direction to
    /// the probe). Where no probe of the cell is in sight, a cell twice as wide. A probe behind
    /// a wall is out of sight, so light does not come through the wall from the next room.
    /// `docs/decisions/probe-interpolation.md` measures the choice. The probes are scanned
    /// linearly (about 500 of them by default).
    pub fn interpolation_weights(
        &self,
        p: [f32; 3],
        n: Option<[f32; 3]>,
        mut visible: impl FnMut(usize) -> bool,
        out: &mut Vec<(usize, f32)>,
    ) -> bool {
        let p = glam::Vec3::from(p);
        for width in [self.spacing, 2.0 * self.spacing] {
            out.clear();
            let mut total = 0.0f32;
            for (i, q) in self.positions.iter().enumerate() {
                let d = glam::Vec3::from(*q) - p;
                let a = d.abs() / width;
                if a.max_element() >= 1.0 {
                    continue;
                }
                let tent = (1.0 - a.x) * (1.0 - a.y) * (1.0 - a.z);
                let dist = d.length();
                if dist > 1e-6 * self.spacing && !visible(i) {
                    continue;
                }
                let facing = match n {
                    Some(n) if dist > 0.0 => {
                        let c = (1.0 + glam::Vec3::from(n).dot(d / dist)) / 2.0;
                        FACING_FLOOR + c * c
                    }
                    _ => 1.0,
                };
                out.push((i, tent * facing));
                total += tent * facing;
            }
            if total > 0.0 {
                for w in out.iter_mut() {
                    w.1 /= total;
                }
                return true;
            }
        }
        out.clear();
        false
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> Probes<'static> {
        Probes {
            spacing: self.spacing,
            positions: Cow::Owned(self.positions.into_owned()),
            rows: Cow::Owned(self.rows.into_owned()),
            weights: Cow::Owned(self.weights.into_owned()),
            factors: self.factors.map(ProbeFactors::into_owned),
        }
    }
}
