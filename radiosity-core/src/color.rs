//! Linear RGB triples of `f32`: exitance, irradiance, reflectance.

use bytemuck::{Pod, Zeroable};
use core::ops::{Add, AddAssign, Mul, Sub};

/// A linear RGB triple (W/m² for exitance and irradiance, unitless for reflectance).
///
/// `#[repr(C)]` and [`Pod`], so a `&[Rgb]` casts to `&[f32]` (three per element) for upload.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Rgb {
    /// Red channel.
    pub r: f32,
    /// Green channel.
    pub g: f32,
    /// Blue channel.
    pub b: f32,
}

impl Rgb {
    /// All channels zero.
    pub const ZERO: Rgb = Rgb::splat(0.0);
    /// All channels one.
    pub const ONE: Rgb = Rgb::splat(1.0);

    /// A triple from its three channels.
    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Self { r, g, b }
    }

    /// The same value in every channel (a grey).
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Self { r: v, g: v, b: v }
    }

    /// The channels as an array.
    #[inline]
    pub const fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }

    /// A triple from an array.
    #[inline]
    pub const fn from_array(a: [f32; 3]) -> Self {
        Self::new(a[0], a[1], a[2])
    }

    /// Channel `i` (0 = r, 1 = g, 2 = b). Panics for `i > 2`.
    #[inline]
    pub fn channel(self, i: usize) -> f32 {
        self.to_array()[i]
    }

    /// Whether every channel is finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }

    /// The largest channel.
    #[inline]
    pub fn max_channel(self) -> f32 {
        self.r.max(self.g).max(self.b)
    }

    /// The smallest channel.
    #[inline]
    pub fn min_channel(self) -> f32 {
        self.r.min(self.g).min(self.b)
    }

    /// Whether all three channels are equal (a grey).
    #[inline]
    pub fn is_grey(self) -> bool {
        self.r == self.g && self.g == self.b
    }

    /// The mean of the three channels.
    #[inline]
    pub fn mean(self) -> f32 {
        (self.r + self.g + self.b) / 3.0
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}

impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        Rgb::new(self.r - o.r, self.g - o.g, self.b - o.b)
    }
}

impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}

/// Channel-wise product (ρ∘H).
impl Mul for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }
}

impl Mul<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, s: f32) -> Rgb {
        Rgb::new(self.r * s, self.g * s, self.b * s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_is_three_packed_f32() {
        assert_eq!(core::mem::size_of::<Rgb>(), 12);
        assert_eq!(core::mem::align_of::<Rgb>(), 4);
        let v = [Rgb::new(1.0, 2.0, 3.0), Rgb::new(4.0, 5.0, 6.0)];
        let flat: &[f32] = bytemuck::cast_slice(&v);
        assert_eq!(flat, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn arithmetic_is_channel_wise() {
        let a = Rgb::new(1.0, 2.0, 3.0);
        let b = Rgb::new(0.5, 0.25, 2.0);
        assert_eq!(a * b, Rgb::new(0.5, 0.5, 6.0));
        assert_eq!(a + b, Rgb::new(1.5, 2.25, 5.0));
        assert_eq!(a * 2.0, Rgb::new(2.0, 4.0, 6.0));
        assert_eq!(a.max_channel(), 3.0);
        assert!(Rgb::splat(0.3).is_grey() && !a.is_grey());
        assert!(!Rgb::new(f32::NAN, 0.0, 0.0).is_finite());
    }
}
