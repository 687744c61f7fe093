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

use crate::half::{f16_is_finite, f16_to_f32, f32_to_f16};
use crate::{RadError, Rgb, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};

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

fn invalid(index: usize, reason: &'static str) -> RadError {
    RadError::Invalid {
        section: SectionKind::Probes,
        index: index as u64,
        reason,
    }
}

/// The real SH basis up to order 2 at the unit direction `d`.
pub fn sh_basis(d: [f32; 3]) -> [f32; SH_COEFFICIENTS] {
    let [x, y, z] = d;
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
    ]
}

/// Irradiance on a surface with unit normal `n` from radiance SH `c` (Ramamoorthi & Hanrahan
/// 2001: the clamped cosine's SH `Â_0 = π`, `Â_1 = 2π/3`, `Â_2 = π/4`).
pub fn sh_irradiance(c: &[Rgb; SH_COEFFICIENTS], n: [f32; 3]) -> Rgb {
    use core::f32::consts::PI;
    let a = [
        PI,
        2.0 * PI / 3.0,
        2.0 * PI / 3.0,
        2.0 * PI / 3.0,
        PI / 4.0,
        PI / 4.0,
        PI / 4.0,
        PI / 4.0,
        PI / 4.0,
    ];
    let y = sh_basis(n);
    let mut e = Rgb::ZERO;
    for k in 0..SH_COEFFICIENTS {
        e += c[k] * (a[k] * y[k]);
    }
    e
}

/// Finite binary16 values to f32, exactly and without branches (so the loop vectorises): the
/// half's bits shifted into an f32's place read as a number 2¹¹² too small, normal or
/// subnormal alike; the product by 2¹¹² is exact. Infinities and NaN (refused on load) would
/// come out wrong.
#[inline]
fn finite_f16s_to_f32(h: &[u16; SH_COEFFICIENTS]) -> [f32; SH_COEFFICIENTS] {
    let rebase = f32::from_bits((127 + 112) << 23);
    h.map(|h| {
        let magnitude = f32::from_bits(u32::from(h & 0x7fff) << 13) * rebase;
        f32::from_bits(magnitude.to_bits() | (u32::from(h & 0x8000) << 16))
    })
}

/// `Σ sh·reflected[patch]` over a row, in its order from zero, per coefficient and channel.
#[inline]
fn sum_row(
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

    /// The rank of factored probes ([`ProbeFactors`]), 0 for rows of weights.
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

impl<'a> Probes<'a> {
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

    /// Checks every index and value against a file of `patches` patches.
    pub fn validate(&self, patches: usize) -> Result<(), RadError> {
        let m = self.positions.len();
        if m > (u32::MAX as usize - 1) || self.weights.len() > u32::MAX as usize {
            return Err(invalid(0, "probes too large"));
        }
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            return Err(invalid(0, "probe spacing is not positive and finite"));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(invalid(i, "probe position is NaN or infinite"));
        }
        if self.rows.len() != m + 1 {
            return Err(RadError::Count {
                section: SectionKind::Probes,
                expected: m as u64 + 1,
                found: self.rows.len() as u64,
            });
        }
        if self.rows[0] != 0 {
            return Err(invalid(0, "probe rows do not start at 0"));
        }
        if let Some(i) = self.rows.windows(2).position(|w| w[1] < w[0]) {
            return Err(invalid(i + 1, "probe rows decrease"));
        }
        if self.rows[m] as usize != self.weights.len() {
            return Err(invalid(m, "probe rows do not end at the weight count"));
        }
        if let Some(f) = &self.factors {
            if !self.weights.is_empty() {
                return Err(invalid(0, "factored probes hold rows of weights too"));
            }
            let k = f.rank as usize;
            if k == 0 {
                return Err(invalid(0, "probe factors of rank 0"));
            }
            if f.basis.len() != k * patches {
                return Err(RadError::Count {
                    section: SectionKind::Probes,
                    expected: (k * patches) as u64,
                    found: f.basis.len() as u64,
                });
            }
            if f.coefficients.len() != SH_COEFFICIENTS * m * k {
                return Err(RadError::Count {
                    section: SectionKind::Probes,
                    expected: (SH_COEFFICIENTS * m * k) as u64,
                    found: f.coefficients.len() as u64,
                });
            }
            if let Some(i) = f.basis.iter().position(|&h| !f16_is_finite(h)) {
                return Err(invalid(i, "probe basis weight is NaN or infinite"));
            }
            if let Some(i) = f.coefficients.iter().position(|&h| !f16_is_finite(h)) {
                return Err(invalid(i, "probe coefficient is NaN or infinite"));
            }
        }
        for p in 0..m {
            let row = self.weights_of(p);
            for (i, w) in row.iter().enumerate() {
                let at = self.rows[p] as usize + i;
                if w.patch as usize >= patches {
                    return Err(invalid(at, "probe weight patch index out of range"));
                }
                if i > 0 && row[i - 1].patch >= w.patch {
                    return Err(invalid(at, "probe weight patches not increasing"));
                }
                if !w.sh_bits.iter().all(|&h| f16_is_finite(h)) {
                    return Err(invalid(at, "probe weight is NaN or infinite"));
                }
                if w.reserved != 0 {
                    return Err(invalid(at, "probe weight reserved bytes are not zero"));
                }
            }
        }
        Ok(())
    }

    /// The section's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(&(self.positions.len() as u32).to_le_bytes());
        out.extend_from_slice(&(self.weights.len() as u32).to_le_bytes());
        out.extend_from_slice(&self.spacing.to_le_bytes());
        out.extend_from_slice(bytemuck::cast_slice(&self.positions));
        out.extend_from_slice(bytemuck::cast_slice(&self.rows));
        out.extend_from_slice(bytemuck::cast_slice(&self.weights));
        if let Some(f) = &self.factors {
            out.extend_from_slice(&f.rank.to_le_bytes());
            out.extend_from_slice(&(f.patches() as u32).to_le_bytes());
            for part in [&f.basis, &f.coefficients] {
                out.extend_from_slice(bytemuck::cast_slice(part));
                if part.len() % 2 == 1 {
                    out.extend_from_slice(&[0, 0]);
                }
            }
        }
        out
    }

    /// Splits the section bytes, checking the length against the counts. Values are checked
    /// by [`Self::validate`].
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, RadError> {
        let short = |expected: u64| RadError::SectionLength {
            kind: SectionKind::Probes,
            expected,
            found: bytes.len() as u64,
        };
        if bytes.len() < 12 {
            return Err(short(12));
        }
        let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
        let (m, w) = (u64::from(word(0)), u64::from(word(4)));
        let spacing = f32::from_bits(word(8));
        let sizes = [12 * m, 4 * (m + 1), 24 * w];
        let rows_end = 12 + sizes.iter().sum::<u64>();
        let mut factor_sizes = None;
        let expected = if rows_end + 8 <= bytes.len() as u64 {
            let at = rows_end as usize;
            let (k, n) = (u64::from(word(at)), u64::from(word(at + 4)));
            let basis = k.saturating_mul(n);
            let coefficients = (SH_COEFFICIENTS as u64).saturating_mul(m).saturating_mul(k);
            factor_sizes = Some((k as u32, basis, coefficients));
            let padded = |halves: u64| halves.saturating_add(halves % 2).saturating_mul(2);
            (rows_end + 8)
                .saturating_add(padded(basis))
                .saturating_add(padded(coefficients))
        } else {
            rows_end
        };
        if bytes.len() as u64 != expected {
            return Err(short(expected));
        }
        let mut at = 12usize;
        let mut next = |len: u64| {
            let s = &bytes[at..at + len as usize];
            at += len as usize;
            s
        };
        let positions = crate::container::cast(next(sizes[0]));
        let rows = crate::container::cast(next(sizes[1]));
        let weights = crate::container::cast(next(sizes[2]));
        let factors = factor_sizes.map(|(rank, basis, coefficients)| {
            next(8);
            let b = next(2 * basis);
            next(2 * (basis % 2));
            let c = next(2 * coefficients);
            ProbeFactors {
                rank,
                basis: crate::container::cast(b),
                coefficients: crate::container::cast(c),
            }
        });
        Ok(Probes {
            spacing,
            positions,
            rows,
            weights,
            factors,
        })
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

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec;

    fn two() -> Probes<'static> {
        Probes {
            spacing: 1.0,
            positions: Cow::Owned(vec![[0.0; 3], [1.0, 0.0, 0.0]]),
            rows: Cow::Owned(vec![0, 2, 3]),
            weights: Cow::Owned(vec![
                ProbeWeight::new(0, [0.5; SH_COEFFICIENTS]),
                ProbeWeight::new(2, [0.25; SH_COEFFICIENTS]),
                ProbeWeight::new(1, [1.0; SH_COEFFICIENTS]),
            ]),
            factors: None,
        }
    }

    #[test]
    fn bytes_round_trip_and_bad_values_are_named() {
        let p = two();
        p.validate(3).unwrap();
        let bytes = p.to_bytes();
        assert_eq!(Probes::from_bytes(&bytes).unwrap(), p);
        assert!(matches!(
            Probes::from_bytes(&bytes[..bytes.len() - 4]),
            Err(RadError::SectionLength {
                kind: SectionKind::Probes,
                ..
            })
        ));
        let reason = |q: Probes<'_>| match q.validate(3) {
            Err(RadError::Invalid { reason, .. }) => reason,
            other => panic!("{other:?}"),
        };
        let mut q = two();
        q.weights.to_mut()[1].patch = 3;
        assert_eq!(reason(q), "probe weight patch index out of range");
        let mut q = two();
        q.weights.to_mut()[1].patch = 0;
        assert_eq!(reason(q), "probe weight patches not increasing");
        let mut q = two();
        q.weights.to_mut()[2].sh_bits[4] = f32_to_f16(f32::NAN);
        assert_eq!(reason(q), "probe weight is NaN or infinite");
        let mut q = two();
        q.weights.to_mut()[0].reserved = 1;
        assert_eq!(reason(q), "probe weight reserved bytes are not zero");
        let mut q = two();
        q.positions.to_mut()[1][2] = f32::INFINITY;
        assert_eq!(reason(q), "probe position is NaN or infinite");
        let mut q = two();
        q.rows.to_mut()[1] = 4;
        assert_eq!(reason(q), "probe rows decrease");
        let mut q = two();
        q.spacing = 0.0;
        assert_eq!(reason(q), "probe spacing is not positive and finite");
    }

    /// Two probes over three patches as factors of rank 2.
    fn factored() -> Probes<'static> {
        let h = |v: &[f32]| v.iter().map(|&x| f32_to_f16(x)).collect::<Vec<_>>();
        let coefficients: Vec<f32> = (0..2 * SH_COEFFICIENTS * 2)
            .map(|i| 0.25 * (i % 7) as f32 - 0.5)
            .collect();
        Probes {
            spacing: 1.0,
            positions: Cow::Owned(vec![[0.0; 3], [1.0, 0.0, 0.0]]),
            rows: Cow::Owned(vec![0; 3]),
            weights: Cow::Owned(vec![]),
            factors: Some(ProbeFactors {
                rank: 2,
                basis: Cow::Owned(h(&[0.5, -0.25, 1.0, 0.125, 0.75, -1.0])),
                coefficients: Cow::Owned(h(&coefficients)),
            }),
        }
    }

    #[test]
    fn factored_bytes_round_trip_and_bad_factors_are_named() {
        let p = factored();
        p.validate(3).unwrap();
        let bytes = p.to_bytes();
        assert_eq!(Probes::from_bytes(&bytes).unwrap(), p);
        assert!(matches!(
            Probes::from_bytes(&bytes[..bytes.len() - 4]),
            Err(RadError::SectionLength { .. })
        ));
        // A basis over three patches does not fit a file of four.
        assert!(matches!(p.validate(4), Err(RadError::Count { .. })));
        let reason = |q: Probes<'_>| match q.validate(3) {
            Err(RadError::Invalid { reason, .. }) => reason,
            other => panic!("{other:?}"),
        };
        let mut q = factored();
        q.factors.as_mut().unwrap().coefficients.to_mut()[5] = f32_to_f16(f32::INFINITY);
        assert_eq!(reason(q), "probe coefficient is NaN or infinite");
        let mut q = factored();
        q.factors.as_mut().unwrap().basis.to_mut()[1] = f32_to_f16(f32::NAN);
        assert_eq!(reason(q), "probe basis weight is NaN or infinite");
        let mut q = factored();
        q.weights = Cow::Owned(vec![ProbeWeight::new(0, [1.0; SH_COEFFICIENTS])]);
        q.rows = Cow::Owned(vec![0, 1, 1]);
        assert_eq!(reason(q), "factored probes hold rows of weights too");
    }

    #[test]
    fn factored_probes_gather_their_product() {
        let p = factored();
        let b = [
            Rgb::new(2.0, 0.5, 1.0),
            Rgb::splat(4.0),
            Rgb::new(8.0, 3.0, 0.25),
        ];
        let d = DecodedProbes::new(&p);
        assert_eq!(d.rank(), 2);
        let rows = p.to_rows();
        rows.validate(3).unwrap();
        let mut all = [[Rgb::ZERO; SH_COEFFICIENTS]; 2];
        d.gather(&b, &mut all);
        for i in 0..2 {
            let want = rows.gather_probe(i, &b);
            for (got, slow, want) in zip3(all[i], p.gather_probe(i, &b), want) {
                for (g, w) in [(got, want), (slow, want)] {
                    // The rows round each product to binary16: half its relative step
                    // (2⁻¹¹) of each of three terms, each at most 1.25·1·8 = 10.
                    let tol = 3.0 * 10.0 * 2f32.powi(-11) + 1e-6;
                    for (x, y) in [(g.r, w.r), (g.g, w.g), (g.b, w.b)] {
                        assert!((x - y).abs() <= tol, "{g:?} {w:?}");
                    }
                }
            }
        }
    }

    fn zip3(
        a: [Rgb; SH_COEFFICIENTS],
        b: [Rgb; SH_COEFFICIENTS],
        c: [Rgb; SH_COEFFICIENTS],
    ) -> impl Iterator<Item = (Rgb, Rgb, Rgb)> {
        (0..SH_COEFFICIENTS).map(move |k| (a[k], b[k], c[k]))
    }

    #[test]
    fn weights_round_to_half_precision() {
        let w = ProbeWeight::new(3, [0.1, -0.2, 1e-6, 0.0, 1.0, -1.0, 3.0e-3, 7.0, -0.5]);
        for (got, want) in w
            .sh()
            .iter()
            .zip([0.1f32, -0.2, 1e-6, 0.0, 1.0, -1.0, 3.0e-3, 7.0, -0.5])
        {
            // Half of binary16's relative step (2⁻¹¹), or its subnormal step 2⁻²⁴ near zero.
            assert!(
                (got - want).abs() <= want.abs() * 2f32.powi(-11) + 2f32.powi(-25),
                "{got} {want}"
            );
        }
        assert_eq!(core::mem::size_of::<ProbeWeight>(), 24);
    }

    #[test]
    fn the_fast_conversion_is_exact_for_every_finite_half() {
        for h in 0..=u16::MAX {
            if f16_is_finite(h) {
                let got = finite_f16s_to_f32(&[h; SH_COEFFICIENTS])[0];
                assert_eq!(got.to_bits(), f16_to_f32(h).to_bits(), "{h:#06x}");
            }
        }
    }

    #[test]
    fn decoded_probes_gather_the_same_bits() {
        let p = two();
        let d = DecodedProbes::new(&p);
        assert_eq!(d.len(), 2);
        let b = [
            Rgb::new(2.0, 0.5, 1.0),
            Rgb::splat(4.0),
            Rgb::new(8.0, 3.0, 0.25),
        ];
        for i in 0..2 {
            assert_eq!(d.gather_probe(i, &b), p.gather_probe(i, &b));
        }
    }

    #[test]
    fn interpolation_is_trilinear_and_skips_hidden_probes() {
        // A unit lattice cell: eight probes at its corners.
        let positions: Vec<[f32; 3]> = (0..8)
            .map(|i| [(i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32])
            .collect();
        let p = Probes {
            spacing: 1.0,
            positions: Cow::Owned(positions),
            rows: Cow::Owned(vec![0; 9]),
            weights: Cow::Owned(vec![]),
            factors: None,
        };
        let mut w = Vec::new();
        assert!(p.interpolation_weights([0.25, 0.5, 0.5], None, |_| true, &mut w));
        // Without a normal the weights are the trilinear ones: 0.75·0.5·0.5 at x = 0.
        assert_eq!(w.len(), 8);
        assert!(
            (w[0].1 - 0.1875).abs() < 1e-6 && (w[1].1 - 0.0625).abs() < 1e-6,
            "{w:?}"
        );
        // Probes at x = 1 hidden: the rest share everything.
        assert!(p.interpolation_weights([0.25, 0.5, 0.5], None, |i| i & 1 == 0, &mut w));
        assert_eq!(w.len(), 4);
        assert!(
            w.iter()
                .all(|&(i, v)| i & 1 == 0 && (v - 0.25).abs() < 1e-6),
            "{w:?}"
        );
        // A normal towards +x favours the probes at x = 1 over a plain trilinear blend.
        assert!(p.interpolation_weights([0.5, 0.5, 0.5], Some([1.0, 0.0, 0.0]), |_| true, &mut w));
        let ahead: f32 = w.iter().filter(|(i, _)| i & 1 == 1).map(|x| x.1).sum();
        assert!(ahead > 0.6, "{w:?}");
        // None in sight, even in a cell twice as wide.
        assert!(!p.interpolation_weights([0.5, 0.5, 0.5], None, |_| false, &mut w));
        assert!(w.is_empty());
    }

    #[test]
    fn a_gather_sums_each_probes_row() {
        let p = two();
        let b = [Rgb::splat(2.0), Rgb::splat(4.0), Rgb::splat(8.0)];
        let mut out = [[Rgb::ZERO; SH_COEFFICIENTS]; 2];
        p.gather(&b, &mut out);
        assert_eq!(out[0][0], Rgb::splat(0.5 * 2.0 + 0.25 * 8.0));
        assert_eq!(out[1][8], Rgb::splat(4.0));
    }

    #[test]
    fn a_uniform_sky_gives_pi_times_its_radiance_for_every_normal() {
        // Radiance L = 1 everywhere: only Y00 is non-zero, c00 = 4π·0.2821 = √(4π).
        let mut c = [Rgb::ZERO; SH_COEFFICIENTS];
        c[0] = Rgb::splat((4.0 * core::f32::consts::PI).sqrt());
        for n in [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]] {
            let e = sh_irradiance(&c, n);
            assert!((e.r - core::f32::consts::PI).abs() < 1e-5, "{e:?}");
        }
    }
}
