//! Linear-light images and their way to the screen: exposure, tone mapping and sRGB encoding.
//! What [`crate::render`] and the path tracer draw; writing a file is the caller's.

use glam::Vec3;

/// A linear-light RGB image (radiance, W·sr⁻¹·m⁻², or any linear quantity), row-major from the
/// top-left corner.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height` pixels, row-major from the top-left corner.
    pub pixels: Vec<Vec3>,
}

impl LinearImage {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }

    /// The exposure that maps the 99th percentile of luminance to 0.8 before tone mapping, so
    /// that a visible light source saturates but the lit walls do not. 1 for a black image.
    pub fn auto_exposure(&self) -> f32 {
        let mut lum: Vec<f32> = self
            .pixels
            .iter()
            .map(|p| luminance(*p))
            .filter(|l| l.is_finite() && *l > 0.0)
            .collect();
        if lum.is_empty() {
            return 1.0;
        }
        let k = ((lum.len() - 1) as f64 * 0.99) as usize;
        let (_, p99, _) = lum.select_nth_unstable_by(k, f32::total_cmp);
        0.8 / *p99
    }

    /// Tone maps (exposure, then extended Reinhard `x(1 + x/w²)/(1 + x)` per channel with white
    /// point w = 4) and encodes to 8-bit sRGB.
    /// Row-major from the top-left corner, three bytes (R, G, B) a pixel.
    pub fn to_srgb8(&self, exposure: f32) -> Vec<u8> {
        let mut img = vec![0u8; 3 * self.pixels.len()];
        for (px, v) in img.chunks_exact_mut(3).zip(&self.pixels) {
            let v = *v * exposure;
            let c = [v.x, v.y, v.z].map(|x| {
                let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
                // Extended Reinhard, white point 4: 0.8 → 0.47, 1 → 0.53, 4 → 1.
                let t = x * (1.0 + x / 16.0) / (1.0 + x);
                (srgb_encode(t.min(1.0)) * 255.0 + 0.5) as u8
            });
            px.copy_from_slice(&c);
        }
        img
    }
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value in [0, 1].
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_curve_matches_the_standard_at_known_points() {
        // IEC 61966-2-1: 0.0031308 is the linear/power switch; 0.18 grey encodes to 0.4614.
        assert!((srgb_encode(0.0) - 0.0).abs() < 1e-7);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
    }

    #[test]
    fn tone_mapping_is_monotone_and_survives_nan() {
        let mut img = LinearImage::new(4, 1);
        img.pixels = vec![
            Vec3::splat(0.1),
            Vec3::splat(1.0),
            Vec3::splat(100.0),
            Vec3::splat(f32::NAN),
        ];
        let out = img.to_srgb8(1.0);
        let g: Vec<u8> = out.chunks_exact(3).map(|p| p[1]).collect();
        assert!(g[0] < g[1] && g[1] < g[2], "{g:?}");
        assert_eq!(g[2], 255);
        assert_eq!(g[3], 0);
        assert!(img.auto_exposure().is_finite());
    }
}
