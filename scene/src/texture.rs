//! Albedo textures (`map_Kd`, glTF `baseColorTexture`): decoded once to linear RGB, then averaged over regions.

use crate::SceneError;
use std::path::Path;

/// A decoded albedo texture in linear RGB, each channel in `[0, 1]`.
#[derive(Clone, Debug)]
pub struct Texture {
    width: usize,
    height: usize,
    texels: Vec<[f32; 3]>,
    /// Linear alpha per texel, row-major like `texels`; empty when the image has none
    /// (alpha 1 everywhere).
    alpha: Vec<f32>,
}

/// sRGB transfer function inverse: 8-bit albedo maps are sRGB-encoded by convention.
fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Texture {
    /// Decodes an image file (PNG, JPEG or GIF).
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
            path: path.into(),
            source,
        })?;
        Self::decode(&bytes, path, "")
    }

    /// Decodes an encoded image (PNG, JPEG or GIF) held in memory; `path` and `what` (e.g.
    /// `image 2: `, may be empty) name it in messages.
    pub fn decode(bytes: &[u8], path: &Path, what: &str) -> Result<Self, SceneError> {
        let img = image::load_from_memory(bytes).map_err(|e| SceneError::Texture {
            path: path.into(),
            message: format!("{what}{e}"),
        })?;
        let alpha: Vec<f32> = if img.color().has_alpha() {
            img.to_rgba32f()
                .pixels()
                .map(|p| p[3].clamp(0.0, 1.0))
                .collect()
        } else {
            Vec::new()
        };
        let rgb = img.to_rgb32f();
        let (width, height) = (rgb.width() as usize, rgb.height() as usize);
        if width == 0 || height == 0 {
            return Err(SceneError::Texture {
                path: path.into(),
                message: format!("{what}empty image"),
            });
        }
        let texels = rgb
            .pixels()
            .map(|p| {
                [
                    srgb_to_linear(p[0]),
                    srgb_to_linear(p[1]),
                    srgb_to_linear(p[2]),
                ]
                .map(|c| c.clamp(0.0, 1.0))
            })
            .collect();
        Ok(Self {
            width,
            height,
            texels,
            alpha,
        })
    }

    /// A texture from linear texels, row-major, `v` = 0 at the bottom row as in OBJ.
    pub fn from_texels(width: usize, height: usize, texels: Vec<[f32; 3]>) -> Self {
        assert_eq!(texels.len(), width * height, "texel count");
        assert!(width > 0 && height > 0, "empty texture");
        Self {
            width,
            height,
            texels,
            alpha: Vec::new(),
        }
    }

    /// The texture with linear alpha `alpha` per texel (row-major, as `texels`).
    pub fn with_alpha(mut self, alpha: Vec<f32>) -> Self {
        assert_eq!(alpha.len(), self.width * self.height, "alpha count");
        self.alpha = alpha.into_iter().map(|a| a.clamp(0.0, 1.0)).collect();
        self
    }

    /// Whether the image carries an alpha channel.
    pub fn has_alpha(&self) -> bool {
        !self.alpha.is_empty()
    }

    /// The texel row and column of texture coordinate `(u, v)` (wrap-around) and the
    /// bilinear weights: `[(x, y, weight); 4]`.
    fn taps(&self, u: f64, v: f64) -> [(usize, usize, f64); 4] {
        // OBJ's v runs up, image rows run down.
        let x = u.rem_euclid(1.0) * self.width as f64 - 0.5;
        let y = (1.0 - v.rem_euclid(1.0)) * self.height as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: f64, n: usize| (i as i64).rem_euclid(n as i64) as usize;
        let (xa, xb) = (wrap(x0, self.width), wrap(x0 + 1.0, self.width));
        let (ya, yb) = (wrap(y0, self.height), wrap(y0 + 1.0, self.height));
        [
            (xa, ya, (1.0 - fx) * (1.0 - fy)),
            (xb, ya, fx * (1.0 - fy)),
            (xa, yb, (1.0 - fx) * fy),
            (xb, yb, fx * fy),
        ]
    }

    /// Bilinear alpha at texture coordinate `(u, v)` (1 without an alpha channel).
    pub fn sample_alpha(&self, u: f64, v: f64) -> f64 {
        if self.alpha.is_empty() {
            return 1.0;
        }
        self.taps(u, v)
            .iter()
            .map(|&(x, y, w)| f64::from(self.alpha[y * self.width + x]) * w)
            .sum()
    }

    /// Bilinear sample with wrap-around (`repeat`) addressing at texture coordinate `(u, v)`.
    pub fn sample(&self, u: f64, v: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (x, y, w) in self.taps(u, v) {
            let t = self.texels[y * self.width + x];
            for (o, &c) in out.iter_mut().zip(&t) {
                *o += f64::from(c) * w;
            }
        }
        out
    }

    /// Mean over the UV triangle `uv`, by a fixed barycentric lattice of `k(k+1)/2` points with
    /// `k` chosen from the triangle's texel footprint (at most 64 per side).
    pub(crate) fn mean_over_triangle(&self, uv: [[f64; 2]; 3]) -> [f64; 3] {
        let mut acc = [0.0; 3];
        let mut n = 0.0;
        self.lattice(uv, |u, v, _| {
            let s = self.sample(u, v);
            for ch in 0..3 {
                acc[ch] += s[ch];
            }
            n += 1.0;
        });
        acc.map(|x| x / n)
    }

    /// The alpha coverage of the UV triangle `uv` (same lattice as
    /// [`Self::mean_over_triangle`]), alpha being the texel's times `factor`, given at the
    /// triangle's corners and interpolated (`baseColorFactor` alpha × `COLOR_0` alpha): with
    /// `cutoff` (glTF MASK) the fraction of points at or above it, without (BLEND) the mean.
    pub(crate) fn coverage_over_triangle(
        &self,
        uv: [[f64; 2]; 3],
        factor: [f64; 3],
        cutoff: Option<f64>,
    ) -> f64 {
        let (mut acc, mut n) = (0.0, 0.0);
        self.lattice(uv, |u, v, w| {
            let f = w[0] * factor[0] + w[1] * factor[1] + w[2] * factor[2];
            let a = self.sample_alpha(u, v) * f;
            acc += match cutoff {
                Some(c) => f64::from(u8::from(a >= c)),
                None => a,
            };
            n += 1.0;
        });
        acc / n
    }

    /// Calls `f(u, v, w)` at the centroids of the k² sub-triangles of a regular subdivision
    /// of the UV triangle `uv` (equal weights), `w` their barycentric weights of the three
    /// corners, `k` from its texel footprint (1 to 64).
    fn lattice(&self, uv: [[f64; 2]; 3], mut f: impl FnMut(f64, f64, [f64; 3])) {
        let span = |i: usize| {
            let (a, b) = (uv[i], uv[(i + 1) % 3]);
            ((a[0] - b[0]) * self.width as f64).hypot((a[1] - b[1]) * self.height as f64)
        };
        let k = (span(0).max(span(1)).max(span(2)).ceil() as usize).clamp(1, 64);
        barycentric_lattice(k, |w| {
            f(
                w[0] * uv[0][0] + w[1] * uv[1][0] + w[2] * uv[2][0],
                w[0] * uv[0][1] + w[1] * uv[1][1] + w[2] * uv[2][1],
                w,
            )
        });
    }
}

/// Calls `f(w)` with the barycentric weights of the centroids of the k² sub-triangles of a
/// regular subdivision of a triangle into k parts along each edge (equal areas).
pub(crate) fn barycentric_lattice(k: usize, mut f: impl FnMut([f64; 3])) {
    for i in 0..k {
        for j in 0..k - i {
            for up in [true, false] {
                if !up && i + j + 1 >= k {
                    continue;
                }
                let off = if up { 1.0 / 3.0 } else { 2.0 / 3.0 };
                let a = (i as f64 + off) / k as f64;
                let b = (j as f64 + off) / k as f64;
                f([a, b, 1.0 - a - b]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_of_two_colour_texture() {
        // Left half black, right half white: the mean over the whole UV square is 0.5.
        let t = Texture::from_texels(2, 1, vec![[0.0; 3], [1.0; 3]]);
        let a = t.mean_over_triangle([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
        let b = t.mean_over_triangle([[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        let m = 0.5 * (a[0] + b[0]);
        // Bilinear filtering with wrap blurs the edge symmetrically: the mean is exact to the
        // lattice resolution.
        assert!((m - 0.5).abs() < 0.02, "mean {m}");
    }

    #[test]
    fn mask_coverage_of_half_cut_texture() {
        // Alpha 0 on the left half, 1 on the right: under MASK (cutoff 0.5) half the square
        // is kept; under BLEND the mean alpha is a half too; factor 0.4 under MASK keeps none.
        let t = Texture::from_texels(2, 1, vec![[1.0; 3]; 2]).with_alpha(vec![0.0, 1.0]);
        let tris = [
            [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]],
            [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
        ];
        let both = |factor, cutoff| {
            0.5 * tris
                .iter()
                .map(|&uv| t.coverage_over_triangle(uv, [factor; 3], cutoff))
                .sum::<f64>()
        };
        // The lattice has 64 points per side: the edge is resolved to about 1/64.
        assert!((both(1.0, Some(0.5)) - 0.5).abs() < 0.03);
        assert!((both(1.0, None) - 0.5).abs() < 0.03);
        assert_eq!(both(0.4, Some(0.5)), 0.0);
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    }
}
