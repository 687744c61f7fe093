//! The log quantiser: a matrix value ↔ an 8-bit code, 0 meaning exactly zero.
//!
//! `q = round(255 · max(ln(v / v_max) + s, 0) / s)`, decoded as `v_max · exp(s · (q/255 − 1))`
//! for `q > 0` (the paper's transformation, §4.2). Each tile carries its own `(v_max, s)`, so a
//! tile of small values still uses all 255 codes.
//!
//! The decoded value is defined as a product of two factors, each rounded to f32: with
//! `d = 255 − q`, `decode(q) = high[d >> 4] · low[d & 15]`, `high[a] = v_max · e^(−16·a·s/255)`,
//! `low[b] = e^(−b·s/255)` ([`LogScale::factors`]). That is the formula above to f32 precision
//! (relative error at most (2s + 5)·ε, mostly from rounding the exponents' arguments, as a single
//! f32 `exp` has too; `decode(255) = v_max` exactly), and it lets a SIMD decoder evaluate any code with two
//! 16-entry in-register permutes and one multiply instead of a 256-entry table look-up per
//! value. Every decoder (reference, CPU, GPU) uses these values, so they agree bit for bit.

use crate::math;
use bytemuck::{Pod, Zeroable};

/// The scale of one tile and channel: the largest value it represents and the log range below it.
///
/// `#[repr(C)]`, 8 bytes, [`Pod`]: the `.rad` SCALES section is a plain `[LogScale]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct LogScale {
    /// The value code 255 stands for; finite and positive.
    pub v_max: f32,
    /// `s`, the natural-log range covered by codes 1..=255; finite and positive. Values below
    /// `v_max · e^(−s)` become 0. A larger `s` keeps smaller values at the cost of coarser steps
    /// (each code step is a factor `e^(s/255)`).
    pub shift: f32,
}

impl Default for LogScale {
    fn default() -> Self {
        Self {
            v_max: 1.0,
            shift: DEFAULT_SHIFT,
        }
    }
}

/// `ln(1000)`: three decades below the tile maximum. Measured on a 2124-patch closed box, it
/// beat ln(1e4) and ln(1e5) for BC1 lighting error.
pub const DEFAULT_SHIFT: f32 = 6.907_755_4;

impl LogScale {
    /// A scale for values up to `v_max` with log range `shift`.
    pub fn new(v_max: f32, shift: f32) -> Self {
        Self { v_max, shift }
    }

    /// Whether both fields are finite and positive (what a `.rad` file must hold).
    pub fn is_valid(&self) -> bool {
        self.v_max.is_finite() && self.v_max > 0.0 && self.shift.is_finite() && self.shift > 0.0
    }

    /// The code of `v`: 0 for zero, negative, NaN or anything below the range; 255 at or above
    /// `v_max`.
    pub fn encode(&self, v: f32) -> u8 {
        // `!(v > 0)` also catches NaN.
        if !(v > 0.0) {
            return 0;
        }
        let t = math::ln(v / self.v_max) + self.shift;
        if !(t > 0.0) {
            return 0;
        }
        let q = math::round(255.0 * t / self.shift);
        if q >= 255.0 { 255 } else { q as u8 }
    }

    /// The value of code `q` (0 decodes to exactly 0): `high[d >> 4] · low[d & 15]` with
    /// `d = 255 − q` (module docs).
    pub fn decode(&self, q: u8) -> f32 {
        if q == 0 {
            0.0
        } else {
            let d = usize::from(255 - q);
            self.high(d >> 4) * self.low(d & 15)
        }
    }

    /// `v_max · e^(−16·a·s/255)`, the factor of the high four bits of `255 − q`.
    fn high(&self, a: usize) -> f32 {
        self.v_max * math::exp(-self.shift * (16 * a) as f32 / 255.0)
    }

    /// `e^(−b·s/255)`, the factor of the low four bits of `255 − q`.
    fn low(&self, b: usize) -> f32 {
        math::exp(-self.shift * b as f32 / 255.0)
    }

    /// The two 16-entry factor tables `(high, low)` of [`LogScale::decode`]: code `q > 0` is
    /// `high[(255 − q) >> 4] · low[(255 − q) & 15]`, rounded once.
    pub fn factors(&self) -> ([f32; 16], [f32; 16]) {
        (
            core::array::from_fn(|a| self.high(a)),
            core::array::from_fn(|b| self.low(b)),
        )
    }

    /// The 256-entry decode table: what a gather indexes with each decoded code.
    pub fn table(&self) -> [f32; 256] {
        let (high, low) = self.factors();
        core::array::from_fn(|q| {
            if q == 0 {
                0.0
            } else {
                high[(255 - q) >> 4] * low[(255 - q) & 15]
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_error_is_half_a_step() {
        let s = LogScale::new(0.25, DEFAULT_SHIFT);
        // One code step is a factor e^(s/255); rounding costs at most half of it.
        let half_step = (s.shift / 255.0 / 2.0).exp() * (1.0 + 1e-5);
        let mut v = 0.25f32;
        while v > 0.25 * (-s.shift + s.shift / 255.0).exp() {
            let d = s.decode(s.encode(v));
            assert!(
                d / v <= half_step && v / d <= half_step,
                "v={v} decoded {d}"
            );
            v *= 0.97;
        }
    }

    #[test]
    fn zero_and_extremes() {
        let s = LogScale::new(2.0, 3.0);
        assert_eq!(s.encode(0.0), 0);
        assert_eq!(s.encode(-1.0), 0);
        assert_eq!(s.encode(f32::NAN), 0);
        assert_eq!(s.encode(1e-30), 0);
        assert_eq!(s.encode(2.0), 255);
        assert_eq!(s.encode(1e30), 255);
        assert_eq!(s.decode(0), 0.0);
        assert_eq!(s.decode(255), 2.0);
        let t = s.table();
        assert!(
            t.windows(2).all(|w| w[0] < w[1]),
            "table strictly increasing"
        );
    }

    /// The product form is `v_max · exp(s · (q/255 − 1))` (computed in f64) to f32 precision,
    /// is the table, and is what `decode` returns, for scales from the narrowest the bake
    /// writes (s = 1e-3) to wide ones.
    ///
    /// Bound: each factor's f32 argument `−s·k/255` carries two roundings (2ε relative, so
    /// 2ε·|arg| absolute, which `exp` turns into the same relative error), `exp` and the
    /// `v_max` product one ε each, the final product one more; the two arguments sum to at
    /// most s, so the relative error is at most (2s + 5)·ε (ε = f32::EPSILON; the f64
    /// reference is exact by comparison).
    #[test]
    fn product_form_is_the_exponential() {
        for (v_max, shift) in [
            (1.0f32, DEFAULT_SHIFT),
            (3.5e-4, 1e-3),
            (7e3, 20.0),
            (0.5, 2.0),
        ] {
            let s = LogScale::new(v_max, shift);
            let t = s.table();
            for q in 1..=255u8 {
                let want =
                    f64::from(v_max) * (f64::from(shift) * (f64::from(q) / 255.0 - 1.0)).exp();
                let got = s.decode(q);
                assert_eq!(got, t[usize::from(q)]);
                let rel = ((f64::from(got) - want) / want).abs();
                let bound = (2.0 * f64::from(shift) + 5.0) * f64::from(f32::EPSILON);
                assert!(
                    rel <= bound,
                    "v_max {v_max} s {shift} q {q}: {got} vs {want} ({rel:e})"
                );
            }
            assert_eq!(s.decode(255), v_max);
        }
    }
}
