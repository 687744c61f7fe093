//! IEEE 754 binary16 conversions for the `f16` matrix format.
//!
//! Written here rather than taken from the `half` crate because the core depends only on glam
//! and bytemuck; the two functions are exhaustively tested against `f32` arithmetic below.

/// Converts to binary16 with round-to-nearest-even; overflow gives infinity, NaN stays NaN.
pub fn f32_to_f16(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exp = ((bits >> 23) & 0xff) as i32;
    let man = bits & 0x007f_ffff;
    if exp == 0xff {
        // Infinity or NaN (keep a quiet-NaN bit so NaN never becomes infinity).
        return sign | 0x7c00 | if man != 0 { 0x0200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    if e <= 0 {
        // Subnormal half (or zero): shift the full significand into place, rounding to even.
        if e < -10 {
            return sign;
        }
        let m = man | 0x0080_0000;
        let shift = (14 - e) as u32;
        let half_m = m >> shift;
        let rem = m & ((1 << shift) - 1);
        let halfway = 1 << (shift - 1);
        let round_up = rem > halfway || (rem == halfway && (half_m & 1) == 1);
        return sign | (half_m + u32::from(round_up)) as u16;
    }
    let half_m = man >> 13;
    let rem = man & 0x1fff;
    let round_up = rem > 0x1000 || (rem == 0x1000 && (half_m & 1) == 1);
    // A carry out of the mantissa correctly bumps the exponent (and may reach infinity).
    (u32::from(sign) | ((e as u32) << 10) | half_m) as u16 + u16::from(round_up)
}

/// Converts binary16 to `f32` exactly.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = u32::from(h & 0x8000) << 16;
    let exp = u32::from((h >> 10) & 0x1f);
    let man = u32::from(h & 0x3ff);
    let bits = match (exp, man) {
        (0, 0) => sign,
        (0, _) => {
            // Subnormal: value = man · 2^-24, exact in f32.
            let v = (man as f32) * (1.0 / 16_777_216.0);
            return if sign != 0 { -v } else { v };
        }
        (0x1f, 0) => sign | 0x7f80_0000,
        (0x1f, _) => sign | 0x7fc0_0000 | (man << 13),
        _ => sign | ((exp + 127 - 15) << 23) | (man << 13),
    };
    f32::from_bits(bits)
}

/// Whether a binary16 value is finite (neither infinity nor NaN).
#[inline]
pub fn f16_is_finite(h: u16) -> bool {
    (h & 0x7c00) != 0x7c00
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_half_round_trips() {
        for h in 0..=u16::MAX {
            let f = f16_to_f32(h);
            if f.is_nan() {
                assert!(f32_to_f16(f) & 0x7c00 == 0x7c00 && f32_to_f16(f) & 0x3ff != 0);
            } else {
                assert_eq!(f32_to_f16(f), h, "half {h:#06x} → {f}");
            }
        }
    }

    #[test]
    fn rounding_is_to_nearest_even() {
        // Between consecutive halves, values round to the nearer; ties to the even mantissa.
        for h in 0x0000u16..0x7bff {
            let (a, b) = (f16_to_f32(h), f16_to_f32(h + 1));
            let mid = (f64::from(a) + f64::from(b)) / 2.0;
            let even = if h & 1 == 0 { h } else { h + 1 };
            assert_eq!(
                f32_to_f16(mid as f32),
                even,
                "tie between {h:#06x} and next"
            );
            let below = (mid - (mid - f64::from(a)) * 0.01) as f32;
            assert_eq!(f32_to_f16(below), h);
        }
        assert_eq!(f32_to_f16(1e6), 0x7c00);
        assert_eq!(f32_to_f16(1e-9), 0);
        assert!(!f16_is_finite(0x7c00) && f16_is_finite(0x7bff));
    }
}
