//! The PROBES section's bytes (the layout is the parent module's doc) and their validation.

use super::{ProbeFactors, Probes, SH_COEFFICIENTS};
use crate::half::f16_is_finite;
use crate::pod_bytes::{cast, u32_at};
use crate::{RadError, SectionKind};
use alloc::vec::Vec;

fn invalid(index: usize, reason: &'static str) -> RadError {
    RadError::Invalid {
        section: SectionKind::Probes,
        index: index as u64,
        reason,
    }
}

impl<'a> Probes<'a> {
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
        let word = |at: usize| u32_at(bytes, at);
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
        let positions = cast(next(sizes[0]));
        let rows = cast(next(sizes[1]));
        let weights = cast(next(sizes[2]));
        let factors = factor_sizes.map(|(rank, basis, coefficients)| {
            next(8);
            let b = next(2 * basis);
            next(2 * (basis % 2));
            let c = next(2 * coefficients);
            ProbeFactors {
                rank,
                basis: cast(b),
                coefficients: cast(c),
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
}
