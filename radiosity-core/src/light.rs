//! Analytic lights and the per-frame arithmetic around the gather.
//!
//! Visibility (shadow rays) belongs to whoever owns the geometry; this module gives the
//! unoccluded irradiance and the segment a shadow ray must test.

use crate::sky::{EnvMap, SkySh, uniform_sky_sh};
use crate::{Patch, Rgb, SH_COEFFICIENTS, math};
use alloc::sync::Arc;
use core::fmt;
use glam::Vec3;

/// A light of the lights file (`docs/contract.md`): intensities in W/sr, irradiance in W/m²,
/// radiance in W·sr⁻¹·m⁻².
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr) per channel.
        intensity: Rgb,
    },
    /// Point light limited to a cone with a hard edge.
    Spot {
        /// Position.
        position: Vec3,
        /// Axis of the cone (need not be normalised; must be non-zero).
        direction: Vec3,
        /// Half-angle of the cone in degrees, in (0, 180].
        cone_deg: f32,
        /// Radiant intensity (W/sr) inside the cone.
        intensity: Rgb,
    },
    /// Parallel light from infinitely far away, e.g. the sun.
    Directional {
        /// Direction the light travels (need not be normalised; must be non-zero).
        direction: Vec3,
        /// Irradiance (W/m²) on a surface facing the light.
        irradiance: Rgb,
    },
    /// A uniform sky: the same radiance from every direction, from infinitely far away.
    Sky {
        /// Radiance (W·sr⁻¹·m⁻²) per channel.
        radiance: Rgb,
    },
    /// An environment image around the scene ([`EnvMap`]: its direction convention).
    Environment(Arc<EnvMap>),
}

/// Why a light is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightError {
    /// A coordinate, direction or intensity is NaN or infinite.
    NonFinite,
    /// An intensity or irradiance channel is negative.
    Negative,
    /// A direction is the zero vector.
    ZeroDirection,
    /// A spot cone angle outside (0, 180] degrees.
    ConeAngle,
    /// An environment image with no texels, or not `width × height` of them.
    EnvironmentSize,
}

impl fmt::Display for LightError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LightError::NonFinite => "light has a NaN or infinite value",
            LightError::Negative => "light intensity is negative",
            LightError::ZeroDirection => "light direction is zero",
            LightError::ConeAngle => "spot cone_deg must be in (0, 180]",
            LightError::EnvironmentSize => {
                "environment image is empty or not width × height texels"
            }
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LightError {}

/// The segment a shadow ray must find clear for a light to reach a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowRay {
    /// Unit direction from the point towards the light.
    pub direction: Vec3,
    /// Distance to the light (`f32::INFINITY` for a directional light).
    pub distance: f32,
}

impl Light {
    /// Checks the light's values.
    pub fn validate(&self) -> Result<(), LightError> {
        let (vectors, colour): ([Vec3; 2], Rgb) = match *self {
            // [a point, a direction]; Vec3::X stands in where a light has no direction.
            Light::Point {
                position,
                intensity,
            } => ([position, Vec3::X], intensity),
            Light::Spot {
                position,
                direction,
                cone_deg,
                intensity,
            } => {
                if !cone_deg.is_finite() {
                    return Err(LightError::NonFinite);
                }
                if !(cone_deg > 0.0 && cone_deg <= 180.0) {
                    return Err(LightError::ConeAngle);
                }
                ([position, direction], intensity)
            }
            Light::Directional {
                direction,
                irradiance,
            } => ([Vec3::ZERO, direction], irradiance),
            Light::Sky { radiance } => ([Vec3::ZERO, Vec3::X], radiance),
            // Checked when it was made (`EnvMap::new`).
            Light::Environment(_) => return Ok(()),
        };
        if !vectors.iter().all(|v| v.is_finite()) || !colour.is_finite() {
            return Err(LightError::NonFinite);
        }
        if colour.min_channel() < 0.0 {
            return Err(LightError::Negative);
        }
        if vectors[1] == Vec3::ZERO {
            return Err(LightError::ZeroDirection);
        }
        Ok(())
    }

    /// The radiance SH of a sky or environment light, `None` for the other lights.
    pub fn sky_sh(&self) -> Option<SkySh> {
        match self {
            Light::Sky { radiance } => Some(uniform_sky_sh(*radiance)),
            Light::Environment(map) => Some(*map.sh()),
            _ => None,
        }
    }

    /// The radiance a sky or environment light sends from direction `d` (towards the sky),
    /// `None` for the other lights.
    pub fn sky_radiance(&self, d: Vec3) -> Option<Rgb> {
        match self {
            Light::Sky { radiance } => Some(*radiance),
            Light::Environment(map) => Some(map.radiance(d)),
            _ => None,
        }
    }

    /// Whether the light is a sky or an environment (light from every direction, with no
    /// shadow ray of its own: the file's sky visibility carries its occlusion).
    pub fn is_sky(&self) -> bool {
        matches!(self, Light::Sky { .. } | Light::Environment(_))
    }

    /// Irradiance at `point` on a surface with unit `normal`, ignoring occluders, and the shadow
    /// ray to test. `None` when the light cannot reach the front of the surface at all, and for
    /// a sky (its light comes from every direction: [`Light::sky_sh`]).
    pub fn irradiance_at(&self, point: Vec3, normal: Vec3) -> Option<(Rgb, ShadowRay)> {
        match *self {
            Light::Point {
                position,
                intensity,
            } => point_light(point, normal, position, intensity, None),
            Light::Spot {
                position,
                direction,
                cone_deg,
                intensity,
            } => point_light(
                point,
                normal,
                position,
                intensity,
                Some((direction.normalize(), cone_deg)),
            ),
            Light::Directional {
                direction,
                irradiance,
            } => {
                let to_light = -direction.normalize();
                let cos = normal.dot(to_light);
                (cos > 0.0).then(|| {
                    (
                        irradiance * cos,
                        ShadowRay {
                            direction: to_light,
                            distance: f32::INFINITY,
                        },
                    )
                })
            }
            Light::Sky { .. } | Light::Environment(_) => None,
        }
    }
}

/// The summed radiance SH of every sky and environment among `lights`, `None` when there is
/// none.
pub fn sky_sh_of(lights: &[Light]) -> Option<SkySh> {
    let mut any = false;
    let mut sum = [Rgb::ZERO; SH_COEFFICIENTS];
    for sh in lights.iter().filter_map(Light::sky_sh) {
        any = true;
        for (s, c) in sum.iter_mut().zip(sh) {
            *s += c;
        }
    }
    any.then_some(sum)
}

/// The summed radiance every sky and environment among `lights` sends from direction `d`.
pub fn sky_radiance_of(lights: &[Light], d: Vec3) -> Rgb {
    let mut sum = Rgb::ZERO;
    for l in lights.iter().filter_map(|l| l.sky_radiance(d)) {
        sum += l;
    }
    sum
}

fn point_light(
    point: Vec3,
    normal: Vec3,
    position: Vec3,
    intensity: Rgb,
    cone: Option<(Vec3, f32)>,
) -> Option<(Rgb, ShadowRay)> {
    let d = position - point;
    let r2 = d.length_squared();
    if !(r2 > 0.0) {
        return None;
    }
    let r = math::sqrt(r2);
    let to_light = d / r;
    let cos = normal.dot(to_light);
    if cos <= 0.0 {
        return None;
    }
    if let Some((axis, cone_deg)) = cone {
        // Inside the cone when the angle between the axis and light→point is ≤ the half-angle.
        if axis.dot(-to_light) < math::cos(cone_deg.to_radians()) {
            return None;
        }
    }
    Some((
        intensity * (cos / r2),
        ShadowRay {
            direction: to_light,
            distance: r,
        },
    ))
}

/// First exitance `x = E + ρ∘H_d` for every patch, from direct irradiance `H_d`.
///
/// Panics if the slices differ in length (a programming error).
pub fn first_exitance(patches: &[Patch], direct: &[Rgb], out: &mut [Rgb]) {
    assert!(
        patches.len() == direct.len() && direct.len() == out.len(),
        "one entry per patch"
    );
    for ((x, p), h) in out.iter_mut().zip(patches).zip(direct) {
        *x = p.emission + p.reflectance * *h;
    }
}

/// Completes a frame from direct irradiance `H_d` and gathered irradiance `y`: total
/// irradiance `H = H_d + y` and radiosity `B = E + ρ∘H`.
///
/// Panics if the slices differ in length (a programming error).
pub fn finish_frame(
    patches: &[Patch],
    direct: &[Rgb],
    gathered: &[Rgb],
    irradiance: &mut [Rgb],
    radiosity: &mut [Rgb],
) {
    let n = patches.len();
    assert!(
        direct.len() == n && gathered.len() == n && irradiance.len() == n && radiosity.len() == n,
        "one entry per patch"
    );
    for i in 0..n {
        irradiance[i] = direct[i] + gathered[i];
        radiosity[i] = patches[i].emission + patches[i].reflectance * irradiance[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_light_follows_inverse_square_cosine() {
        let l = Light::Point {
            position: Vec3::new(0.0, 2.0, 0.0),
            intensity: Rgb::splat(8.0),
        };
        let (h, ray) = l.irradiance_at(Vec3::ZERO, Vec3::Y).unwrap();
        assert_eq!(h, Rgb::splat(2.0)); // 8 W/sr / 4 m²
        assert_eq!(ray.distance, 2.0);
        // 45° off the normal at distance √2·... : cos 45° / r².
        let (h, _) = l.irradiance_at(Vec3::new(2.0, 0.0, 0.0), Vec3::Y).unwrap();
        let expect = 8.0 * (0.5f32).sqrt() / 8.0;
        assert!((h.r - expect).abs() < 1e-6, "{} vs {expect}", h.r);
        assert!(
            l.irradiance_at(Vec3::ZERO, -Vec3::Y).is_none(),
            "back faces get nothing"
        );
    }

    #[test]
    fn spot_cone_and_directional() {
        let s = Light::Spot {
            position: Vec3::Y,
            direction: -Vec3::Y,
            cone_deg: 30.0,
            intensity: Rgb::ONE,
        };
        assert!(s.irradiance_at(Vec3::ZERO, Vec3::Y).is_some());
        assert!(
            s.irradiance_at(Vec3::new(1.0, 0.0, 0.0), Vec3::Y).is_none(),
            "45° is outside 30°"
        );
        let d = Light::Directional {
            direction: -Vec3::Y,
            irradiance: Rgb::splat(3.0),
        };
        let (h, ray) = d.irradiance_at(Vec3::ZERO, Vec3::Y).unwrap();
        assert_eq!((h, ray.distance), (Rgb::splat(3.0), f32::INFINITY));
    }

    #[test]
    fn bad_lights_are_refused() {
        let p = |x: f32| Light::Point {
            position: Vec3::splat(x),
            intensity: Rgb::ONE,
        };
        assert_eq!(p(f32::NAN).validate(), Err(LightError::NonFinite));
        assert_eq!(
            Light::Point {
                position: Vec3::ZERO,
                intensity: Rgb::splat(-1.0)
            }
            .validate(),
            Err(LightError::Negative)
        );
        assert_eq!(
            Light::Directional {
                direction: Vec3::ZERO,
                irradiance: Rgb::ONE
            }
            .validate(),
            Err(LightError::ZeroDirection)
        );
        assert_eq!(
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::Y,
                cone_deg: 0.0,
                intensity: Rgb::ONE
            }
            .validate(),
            Err(LightError::ConeAngle)
        );
        assert!(p(1.0).validate().is_ok());
    }
}
