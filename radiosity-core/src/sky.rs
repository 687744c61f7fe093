//! Light from the sky: a uniform sky or an equirectangular environment image, and the sky
//! visibility a `.rad` file stores per patch and per probe (its optional SKY section), so that
//! the sky may change every frame without a re-bake.
//!
//! A sky is radiance `L(ω)` arriving from direction `ω` (unit, pointing from the scene towards
//! the sky), from infinitely far away. Its radiance is projected on the real SH up to order 2
//! (nine coefficients, the order and basis of [`crate::probes`]): `L_k = ∫ L(ω) Y_k(ω) dω`.
//! A uniform sky of radiance `L` has `L_0 = 4π·Y_0·L` and nothing else, so it is carried
//! exactly.
//!
//! Per patch the file stores its **cosine-weighted sky visibility**
//! `T_k = (1/A) ∫_A ∫ Y_k(ω) V(x, ω) max(n·ω, 0) dω dx` (`V` = 1 where a ray from `x` leaves
//! the scene), so the sky's irradiance on the patch is `Σ_k L_k T_k`: exact for a uniform sky
//! (up to the rays' sampling of `V`), the order-2 truncation of the sky otherwise. Per probe it
//! stores the **visibility** `V_k = ∫ Y_k(ω) V(p, ω) dω`; the sky's radiance SH at the probe is
//! the order-2 product of the two ([`sh_product`]).
//!
//! Section layout (little-endian): `9·(n + m)` `f32`, the `n` patches' `T` (file numbering)
//! then the `m` probes' `V` (the PROBES section's order; `m = 0` without probes). An **empty**
//! section says that no ray from any patch or probe reached the sky (a closed scene): every
//! coefficient is zero. A file without the section was baked without sky visibility, and a
//! runtime refuses a sky for it rather than light it wrongly.

use crate::pod_bytes::cast;
use crate::probes::{SH_COEFFICIENTS, sh_basis};
use crate::{LightError, RadError, Rgb, SectionKind, math};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use core::f32::consts::PI;
use glam::Vec3;

/// The constant real SH basis function `Y_0 = 1/(2√π)`.
pub const Y0: f32 = 0.282_094_8;

/// A sky's radiance SH (orders 0 to 2), per channel.
pub type SkySh = [Rgb; SH_COEFFICIENTS];

/// The radiance SH of a uniform sky of radiance `radiance` (W·sr⁻¹·m⁻²).
pub fn uniform_sky_sh(radiance: Rgb) -> SkySh {
    let mut sh = [Rgb::ZERO; SH_COEFFICIENTS];
    sh[0] = radiance * (4.0 * PI * Y0);
    sh
}

/// The sky's irradiance on a patch of cosine-weighted sky visibility `t`: `Σ_k L_k t_k`, each
/// channel at least zero (an order-2 environment can ring below zero where it is dark).
pub fn sky_irradiance(t: &[f32; SH_COEFFICIENTS], sky: &SkySh) -> Rgb {
    let mut e = Rgb::ZERO;
    for (l, t) in sky.iter().zip(t) {
        e += *l * *t;
    }
    Rgb::new(e.r.max(0.0), e.g.max(0.0), e.b.max(0.0))
}

/// The SH triple-product tensor `Γ[i][j][k] = ∫ Y_i Y_j Y_k dω` of the order-2 basis, by
/// quadrature: midpoints in `z = cos θ` (area-uniform; 256 of them, relative error under
/// 1e-4 on these degree-6 polynomials) times 16 uniform azimuths (exact for their
/// trigonometric degree, at most 6). A caller computes it once.
pub fn sh_triple() -> [[[f32; SH_COEFFICIENTS]; SH_COEFFICIENTS]; SH_COEFFICIENTS] {
    const NZ: usize = 256;
    const NPHI: usize = 16;
    let mut g = [[[0f64; SH_COEFFICIENTS]; SH_COEFFICIENTS]; SH_COEFFICIENTS];
    let w = f64::from(4.0 * PI) / (NZ * NPHI) as f64;
    for iz in 0..NZ {
        let z = -1.0 + 2.0 * (iz as f32 + 0.5) / NZ as f32;
        let s = math::sqrt((1.0 - z * z).max(0.0));
        for ip in 0..NPHI {
            let phi = 2.0 * PI * ip as f32 / NPHI as f32;
            let y = sh_basis([s * math::cos(phi), s * math::sin(phi), z]);
            for i in 0..SH_COEFFICIENTS {
                for j in 0..SH_COEFFICIENTS {
                    let yij = f64::from(y[i] * y[j]);
                    for k in 0..SH_COEFFICIENTS {
                        g[i][j][k] += w * yij * f64::from(y[k]);
                    }
                }
            }
        }
    }
    g.map(|a| a.map(|b| b.map(|v| v as f32)))
}

/// The order-2 SH of the product `L(ω)·V(ω)` of a sky `sky` and a visibility `vis`, with the
/// tensor of [`sh_triple`]: the sky's radiance SH as a probe of visibility `vis` receives it.
pub fn sh_product(
    gamma: &[[[f32; SH_COEFFICIENTS]; SH_COEFFICIENTS]; SH_COEFFICIENTS],
    sky: &SkySh,
    vis: &[f32; SH_COEFFICIENTS],
) -> SkySh {
    let mut out = [Rgb::ZERO; SH_COEFFICIENTS];
    for (i, o) in out.iter_mut().enumerate() {
        for (j, l) in sky.iter().enumerate() {
            let mut w = 0.0;
            for (k, v) in vis.iter().enumerate() {
                w += gamma[i][j][k] * v;
            }
            *o += *l * w;
        }
    }
    out
}

/// An equirectangular environment image: radiance per texel (linear RGB, W·sr⁻¹·m⁻², after
/// its `intensity`), turned `rotation_deg` about +Y.
///
/// Direction convention (`docs/contract.md`, the lights file; Mitsuba 3's `envmap` with an
/// identity transform): +Y is up; for a direction `m` in the image's frame, the column is
/// `u = atan2(m.x, −m.z)/(2π)` (wrapped to [0, 1)) and the row `v = acos(m.y)/π`, row 0 at the
/// zenith. So the image's left edge (u = 0) looks along −Z, u = 0.25 along +X, its centre
/// along +Z, u = 0.75 along −X. A rotation of `θ` turns the environment counter-clockwise seen
/// from above (right-handed about +Y): what the image shows towards +Z appears towards +X
/// at θ = 90°. Texels are bilinearly interpolated, wrapping across the left and right edges.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    width: usize,
    height: usize,
    texels: Vec<Rgb>,
    cos_r: f32,
    sin_r: f32,
    sh: SkySh,
}

impl EnvMap {
    /// An environment from `width × height` texels (row-major from the top-left), scaled by
    /// `intensity` and turned `rotation_deg` degrees about +Y. Refuses an empty or mis-sized
    /// image and a NaN, infinite or negative texel, intensity or angle.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<Rgb>,
        intensity: f32,
        rotation_deg: f32,
    ) -> Result<Self, LightError> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(texels.len()) {
            return Err(LightError::EnvironmentSize);
        }
        if !(intensity.is_finite() && rotation_deg.is_finite()) {
            return Err(LightError::NonFinite);
        }
        if intensity < 0.0 {
            return Err(LightError::Negative);
        }
        let mut texels = texels;
        for t in &mut texels {
            if !t.is_finite() {
                return Err(LightError::NonFinite);
            }
            if t.min_channel() < 0.0 {
                return Err(LightError::Negative);
            }
            *t = *t * intensity;
            if !t.is_finite() {
                return Err(LightError::NonFinite);
            }
        }
        let r = rotation_deg.to_radians();
        let mut map = EnvMap {
            width,
            height,
            texels,
            cos_r: math::cos(r),
            sin_r: math::sin(r),
            sh: [Rgb::ZERO; SH_COEFFICIENTS],
        };
        map.sh = map.project();
        if !map.sh.iter().all(|c| c.is_finite()) {
            return Err(LightError::NonFinite);
        }
        Ok(map)
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The radiance SH of the whole environment (rotation and intensity included).
    pub fn sh(&self) -> &SkySh {
        &self.sh
    }

    /// Radiance arriving from direction `d` (need not be unit length; zero gives zero).
    pub fn radiance(&self, d: Vec3) -> Rgb {
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return Rgb::ZERO;
        }
        let d = d / len;
        // Into the image's frame: turn back by the rotation.
        let m = Vec3::new(
            self.cos_r * d.x - self.sin_r * d.z,
            d.y,
            self.sin_r * d.x + self.cos_r * d.z,
        );
        let mut u = math::atan2(m.x, -m.z) / (2.0 * PI);
        if u < 0.0 {
            u += 1.0;
        }
        let v = math::acos(m.y.clamp(-1.0, 1.0)) / PI;
        self.lookup(u, v)
    }

    /// Bilinear lookup at image coordinates `(u, v)` in [0, 1]², wrapping in `u`.
    fn lookup(&self, u: f32, v: f32) -> Rgb {
        let (w, h) = (self.width as f32, self.height as f32);
        let fx = u * w - 0.5;
        let fy = (v * h - 0.5).clamp(0.0, h - 1.0);
        let x0 = math::floor(fx);
        let y0 = math::floor(fy);
        let (tx, ty) = (fx - x0, fy - y0);
        let wrap = |x: f32| (x as i64).rem_euclid(self.width as i64) as usize;
        let (xa, xb) = (wrap(x0), wrap(x0 + 1.0));
        let ya = (y0 as usize).min(self.height - 1);
        let yb = (ya + 1).min(self.height - 1);
        let at = |x: usize, y: usize| self.texels[y * self.width + x];
        let top = at(xa, ya) * (1.0 - tx) + at(xb, ya) * tx;
        let bottom = at(xa, yb) * (1.0 - tx) + at(xb, yb) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// `∫ L(ω) Y_k(ω) dω` by the midpoint rule over a latitude–longitude grid of at least
    /// 256 × 128 cells (the texel centres themselves for a larger image, at most 4096 × 2048),
    /// each cell weighted by its solid angle.
    fn project(&self) -> SkySh {
        let nu = self.width.clamp(256, 4096);
        let nv = self.height.clamp(128, 2048);
        let mut acc = [[0f64; 3]; SH_COEFFICIENTS];
        let cell = f64::from(2.0 * PI * PI) / (nu * nv) as f64;
        for j in 0..nv {
            let v = (j as f32 + 0.5) / nv as f32;
            let theta = PI * v;
            let (st, ct) = (math::sin(theta), math::cos(theta));
            let w = cell * f64::from(st);
            for i in 0..nu {
                let u = (i as f32 + 0.5) / nu as f32;
                let phi = 2.0 * PI * u;
                // The image-frame direction of (u, v), then turned into the world.
                let (mx, mz) = (st * math::sin(phi), -st * math::cos(phi));
                let d = [
                    self.cos_r * mx + self.sin_r * mz,
                    ct,
                    -self.sin_r * mx + self.cos_r * mz,
                ];
                let l = self.lookup(u, v);
                for (a, y) in acc.iter_mut().zip(sh_basis(d)) {
                    let wy = w * f64::from(y);
                    a[0] += wy * f64::from(l.r);
                    a[1] += wy * f64::from(l.g);
                    a[2] += wy * f64::from(l.b);
                }
            }
        }
        acc.map(|a| Rgb::new(a[0] as f32, a[1] as f32, a[2] as f32))
    }
}

/// The SKY section: per patch the cosine-weighted sky visibility, per probe the visibility
/// (module docs). Empty when nothing sees the sky.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyVisibility<'a> {
    /// `9·(n + m)` coefficients, or none.
    pub values: Cow<'a, [f32]>,
}

/// Largest `|T_k|` a patch may store: `π·max|Y_k|` (the cosine lobe integrates to π, and
/// `max|Y_k| ≤ 1.0926`), with room for the rays' rounding.
const PATCH_BOUND: f32 = PI * 1.1;
/// Largest `|V_k|` a probe may store: the sphere's `4π` times `max|Y_k|`, with room.
const PROBE_BOUND: f32 = 4.0 * PI * 1.1;

impl<'a> SkyVisibility<'a> {
    /// The section for `patches` and `probes`, empty when every coefficient is zero.
    pub fn new(
        patches: &[[f32; SH_COEFFICIENTS]],
        probes: &[[f32; SH_COEFFICIENTS]],
    ) -> SkyVisibility<'static> {
        let all: Vec<f32> = patches.iter().chain(probes).flatten().copied().collect();
        if all.iter().all(|v| *v == 0.0) {
            return SkyVisibility {
                values: Cow::Owned(Vec::new()),
            };
        }
        SkyVisibility {
            values: Cow::Owned(all),
        }
    }

    /// Whether no patch or probe sees the sky (the section is empty).
    pub fn is_closed(&self) -> bool {
        self.values.is_empty()
    }

    /// Entry `i` of the section (patch `i`, or probe `i − n`); zeros in a closed scene.
    /// Panics past the end of a non-empty section (the file was validated against its size).
    pub fn entry(&self, i: usize) -> [f32; SH_COEFFICIENTS] {
        if self.values.is_empty() {
            return [0.0; SH_COEFFICIENTS];
        }
        let s = &self.values[i * SH_COEFFICIENTS..(i + 1) * SH_COEFFICIENTS];
        core::array::from_fn(|k| s[k])
    }

    /// The section's bytes.
    pub fn to_bytes(&self) -> &[u8] {
        bytemuck::cast_slice(&self.values)
    }

    /// The section from its bytes (whole `f32`s; [`SkyVisibility::validate`] checks the rest).
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, RadError> {
        if !bytes.len().is_multiple_of(4 * SH_COEFFICIENTS) {
            return Err(RadError::Invalid {
                section: SectionKind::Sky,
                index: 0,
                reason: "length is not a whole number of nine-coefficient entries",
            });
        }
        Ok(SkyVisibility {
            values: cast(bytes),
        })
    }

    /// Checks the section against a file of `patches` patches and `probes` probes: empty or
    /// one entry each, every value finite and within its bound, `T_0` and `V_0` not negative.
    pub fn validate(&self, patches: usize, probes: usize) -> Result<(), RadError> {
        if self.values.is_empty() {
            return Ok(());
        }
        let expected = (patches as u64 + probes as u64) * SH_COEFFICIENTS as u64;
        if self.values.len() as u64 != expected {
            return Err(RadError::Count {
                section: SectionKind::Sky,
                expected,
                found: self.values.len() as u64,
            });
        }
        for (e, entry) in self.values.chunks_exact(SH_COEFFICIENTS).enumerate() {
            let bound = if e < patches {
                PATCH_BOUND
            } else {
                PROBE_BOUND
            };
            let bad = |reason| RadError::Invalid {
                section: SectionKind::Sky,
                index: e as u64,
                reason,
            };
            if !entry.iter().all(|v| v.is_finite()) {
                return Err(bad("sky visibility is NaN or infinite"));
            }
            if entry[0] < 0.0 {
                return Err(bad("sky visibility's constant term is negative"));
            }
            // The constant term is at most the whole lobe's: π·Y0 (patch), 4π·Y0 (probe).
            let most = if e < patches { PI * Y0 } else { 4.0 * PI * Y0 };
            if entry[0] > most * 1.001 {
                return Err(bad("sky visibility sees more than the whole sky"));
            }
            if entry.iter().any(|v| v.abs() > bound) {
                return Err(bad(
                    "sky visibility exceeds what a sphere of directions holds",
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_environment_projects_like_a_uniform_sky() {
        let map = EnvMap::new(8, 4, alloc::vec![Rgb::splat(2.0); 32], 1.5, 30.0).unwrap();
        let sky = uniform_sky_sh(Rgb::splat(3.0));
        // Midpoint quadrature of a constant over 128 rows: sin θ's rule errs by ~1e-4.
        assert!(
            (map.sh()[0].r - sky[0].r).abs() < 1e-3 * sky[0].r,
            "{:?}",
            map.sh()[0]
        );
        for k in 1..SH_COEFFICIENTS {
            assert!(
                map.sh()[k].r.abs() < 1e-3,
                "coefficient {k}: {:?}",
                map.sh()[k]
            );
        }
        // An upward face under it, unoccluded: T = π·Y_0 in the constant term only, E = π·L.
        let mut t = [0.0; SH_COEFFICIENTS];
        t[0] = PI * Y0;
        let e = sky_irradiance(&t, &sky);
        assert!((e.r - PI * 3.0).abs() < 1e-4 * e.r);
    }

    #[test]
    fn directions_land_where_the_convention_says() {
        // Four columns: −Z, +X, +Z, −X at their centres (u = 0.125, 0.375, 0.625, 0.875 are the
        // texel centres; the directions below sit at column boundaries' middles).
        let texels: Vec<Rgb> = (0..8).map(|i| Rgb::splat((i % 4) as f32)).collect();
        let map = EnvMap::new(4, 2, texels, 1.0, 0.0).unwrap();
        // u(−Z) = 0, between column 3 and column 0 (wrapping): the mean of 3 and 0.
        let at = |d: Vec3| map.radiance(d).r;
        assert!((at(-Vec3::Z) - 1.5).abs() < 1e-5, "{}", at(-Vec3::Z));
        assert!((at(Vec3::X) - 0.5).abs() < 1e-5, "{}", at(Vec3::X));
        assert!((at(Vec3::Z) - 1.5).abs() < 1e-5, "{}", at(Vec3::Z));
        assert!((at(-Vec3::X) - 2.5).abs() < 1e-5, "{}", at(-Vec3::X));
        // Turned 90°: what was towards +Z (1.5) is towards +X.
        let turned = EnvMap::new(4, 2, map.texels.clone(), 1.0, 90.0).unwrap();
        assert!((turned.radiance(Vec3::X).r - 1.5).abs() < 1e-4);
        assert!((turned.radiance(-Vec3::Z).r - 0.5).abs() < 1e-4);
    }

    #[test]
    fn an_upper_hemisphere_sky_has_the_zonal_terms() {
        // Bright above the horizon, black below: L_0 = 2π·Y0, L_(1,0) (∝ y) = π·0.4886.
        let (w, h) = (64, 32);
        let texels = (0..w * h)
            .map(|i| if i / w < h / 2 { Rgb::ONE } else { Rgb::ZERO })
            .collect();
        let map = EnvMap::new(w, h, texels, 1.0, 0.0).unwrap();
        let sh = map.sh();
        // The bilinear ramp across the horizon rows smears the edge: 1% of the terms.
        assert!(
            (sh[0].r - 2.0 * PI * Y0).abs() < 0.01 * 2.0 * PI * Y0,
            "{:?}",
            sh[0]
        );
        assert!(
            (sh[1].r - PI * 0.488_602_5).abs() < 0.01 * PI * 0.4886,
            "{:?}",
            sh[1]
        );
        assert!(sh[3].r.abs() < 1e-3 && sh[2].r.abs() < 1e-3);
    }

    #[test]
    fn the_product_with_full_visibility_is_the_sky() {
        let g = sh_triple();
        let map = EnvMap::new(
            16,
            8,
            (0..128).map(|i| Rgb::splat((i % 7) as f32)).collect(),
            1.0,
            0.0,
        )
        .unwrap();
        // V ≡ 1 has V_0 = 4π·Y0 and nothing else; L·1 = L.
        let mut full = [0.0; SH_COEFFICIENTS];
        full[0] = 4.0 * PI * Y0;
        let p = sh_product(&g, map.sh(), &full);
        for k in 0..SH_COEFFICIENTS {
            let (a, b) = (p[k].r, map.sh()[k].r);
            // The tensor's quadrature error (module docs), on coefficients of order 10.
            assert!((a - b).abs() < 1e-3 * (1.0 + b.abs()), "{k}: {a} vs {b}");
        }
    }

    #[test]
    fn bad_maps_and_sections_are_refused() {
        assert_eq!(
            EnvMap::new(2, 2, alloc::vec![Rgb::ONE; 3], 1.0, 0.0),
            Err(LightError::EnvironmentSize)
        );
        assert_eq!(
            EnvMap::new(1, 1, alloc::vec![Rgb::splat(-1.0)], 1.0, 0.0),
            Err(LightError::Negative)
        );
        assert_eq!(
            EnvMap::new(1, 1, alloc::vec![Rgb::ONE], f32::NAN, 0.0),
            Err(LightError::NonFinite)
        );
        let ok = SkyVisibility::new(&[[0.5; 9]], &[[1.0; 9]]);
        assert!(ok.validate(1, 1).is_ok());
        assert!(ok.validate(2, 1).is_err(), "one entry short");
        let mut bad = ok.clone();
        bad.values.to_mut()[0] = -0.1;
        assert!(bad.validate(1, 1).is_err());
        bad.values.to_mut()[0] = f32::NAN;
        assert!(bad.validate(1, 1).is_err());
        bad.values.to_mut()[0] = 4.0; // a patch's T_0 is at most π·Y0
        assert!(bad.validate(1, 1).is_err());
        assert!(SkyVisibility::from_bytes(&[0u8; 12]).is_err());
        assert!(SkyVisibility::new(&[[0.0; 9]], &[]).is_closed());
    }
}
