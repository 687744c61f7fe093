//! A clear day's sun and sky for a given sun position: the lights an outdoor frame needs as
//! the sun moves (`radiosity sunset` sweeps it down to the horizon over one bake).
//!
//! This is a small model for pictures and tests of a changing sky, not a measured sky (a
//! Preetham or Hošek–Wilkie model would be one):
//!
//! - **The sun**: a directional light of `E₀·exp(−τ_c·m)` per channel at normal incidence,
//!   `E₀` = 1300 W/m² a channel above the atmosphere, `m` the Kasten–Young relative air mass
//!   (Kasten & Young 1989, `m = 1/(sin h + 0.50572·(h + 6.07995°)^−1.6364)`, `h` the elevation
//!   in degrees), `τ_c` the optical depth per channel: Rayleigh (Hansen & Travis 1974,
//!   `0.008569·λ⁻⁴·(1 + 0.0113·λ⁻² + 0.00013·λ⁻⁴)`, λ in µm) plus aerosol by Ångström's law
//!   (`0.1·(λ/0.55)^−1.3`), at 680, 550 and 450 nm. The sun reddens and dims towards the
//!   horizon.
//! - **The sky**: an [`EnvMap`] whose luminance follows the CIE standard clear sky (CIE S
//!   011/E:2003, type 12: `a = −1, b = −0.32, c = 10, d = −3, e = 0.45`), brightest around
//!   the sun and towards the horizon, coloured by what scatters (`τ_c`) out of the sunlight
//!   that reaches it (`exp(−τ_c·m/2)`, half the sun's path): blue by day, orange at sunset.
//!   Its scale puts `20 + 100·sin(h)^0.7` W/m² of luminance (Rec. 709 weights) on an open
//!   upward face. Below the horizon the image is the distant ground beyond the scene: a
//!   diffuse plane of reflectance 0.2 lit by that sun and sky.
//!
//! Azimuth follows the environment's image: 0° looks along −Z, 90° along +X, 180° along +Z,
//! 270° along −X (`docs/contract.md`, the lights file).

use glam::Vec3;
use radiosity_core::{EnvMap, Light, Rgb};
use std::f32::consts::PI;
use std::sync::Arc;

/// Sun irradiance per channel above the atmosphere, W/m² at normal incidence.
const E0: f32 = 1300.0;
/// Optical depth per channel (680, 550, 450 nm): Rayleigh plus aerosol (module docs).
const TAU: [f32; 3] = [0.0411 + 0.0759, 0.0973 + 0.1, 0.2214 + 0.1298];
/// The sky image's size: 128 × 64 texels (2.8° each), enough for order-2 SH and for the sky
/// seen behind the scene in a 256-pixel frame.
const SKY_W: usize = 128;
/// Reflectance of the distant ground (the lower half of the sky image).
const GROUND: f32 = 0.2;
const SKY_H: usize = 64;

/// The unit vector towards the sun at `elevation_deg` above the horizon and `azimuth_deg`
/// (module docs).
pub fn sun_direction(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (h, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(h.cos() * a.sin(), h.sin(), -h.cos() * a.cos())
}

/// Kasten–Young relative air mass at elevation `h_deg` (1 at the zenith, about 38 at the
/// horizon).
pub fn air_mass(h_deg: f32) -> f32 {
    let h = h_deg.max(0.0);
    1.0 / (h.to_radians().sin() + 0.50572 * (h + 6.07995).powf(-1.6364))
}

/// The sun's irradiance at normal incidence per channel through `m` air masses.
fn transmitted(m: f32, scale: f32) -> [f32; 3] {
    TAU.map(|t| (-t * m * scale).exp())
}

/// CIE clear-sky luminance relative to the zenith's, for a sky direction at zenith angle `z`
/// and angle `gamma` from the sun, the sun at zenith angle `zs` (radians).
fn cie_clear(z: f32, gamma: f32, zs: f32) -> f32 {
    let (a, b, c, d, e) = (-1.0f32, -0.32f32, 10.0f32, -3.0f32, 0.45f32);
    let phi = |z: f32| {
        if z < PI / 2.0 - 1e-4 {
            1.0 + a * (b / z.cos()).exp()
        } else {
            1.0
        }
    };
    let f = |g: f32| 1.0 + c * ((d * g).exp() - (d * PI / 2.0).exp()) + e * g.cos().powi(2);
    f(gamma) * phi(z) / (f(zs) * phi(0.0))
}

/// The sun and the sky (module docs) with the sun at `elevation_deg` (0 to 90) and
/// `azimuth_deg`. An error for an elevation outside [0, 90] or a non-finite angle.
pub fn daylight(elevation_deg: f32, azimuth_deg: f32) -> crate::Result<[Light; 2]> {
    if !(elevation_deg.is_finite() && azimuth_deg.is_finite()) {
        invalid!("the sun's elevation and azimuth must be finite");
    }
    if !(0.0..=90.0).contains(&elevation_deg) {
        invalid!("the sun's elevation {elevation_deg}° is outside [0, 90]");
    }
    let s = sun_direction(elevation_deg, azimuth_deg);
    let m = air_mass(elevation_deg);
    let sun = transmitted(m, 1.0).map(|t| E0 * t);
    let zs = PI / 2.0 - elevation_deg.to_radians();
    let mut texels = vec![Rgb::ZERO; SKY_W * SKY_H];
    let mut up = Rgb::ZERO;
    for (i, t) in texels.iter_mut().enumerate() {
        let (x, y) = (i % SKY_W, i / SKY_W);
        let theta = PI * (y as f32 + 0.5) / SKY_H as f32;
        if theta >= PI / 2.0 {
            continue;
        }
        let u = (x as f32 + 0.5) / SKY_W as f32;
        let d = sun_direction(90.0 - theta.to_degrees(), 360.0 * u);
        let gamma = d.dot(s).clamp(-1.0, 1.0).acos();
        // The sunlight that scatters towards a low view has crossed more air than the light
        // scattered overhead: half the sun's path at the horizon, a tenth at the zenith.
        let lit = transmitted(m, 0.5 * (1.0 - 0.8 * theta.cos()));
        let colour = Rgb::new(TAU[0] * lit[0], TAU[1] * lit[1], TAU[2] * lit[2]);
        *t = colour * cie_clear(theta, gamma, zs);
        let solid_angle = (2.0 * PI / SKY_W as f32) * (PI / SKY_H as f32) * theta.sin();
        up += *t * (theta.cos() * solid_angle);
    }
    let luminance = 0.2126 * up.r + 0.7152 * up.g + 0.0722 * up.b;
    let target = 20.0 + 100.0 * elevation_deg.to_radians().sin().powf(0.7);
    let scale = target / luminance;
    // Below the horizon, the distant ground beyond the scene: a diffuse plane of reflectance
    // GROUND under the sun and the sky, `ρ·E/π`.
    let ground = (up * scale + Rgb::new(sun[0], sun[1], sun[2]) * s.y) * (GROUND / PI);
    for (i, t) in texels.iter_mut().enumerate() {
        if PI * ((i / SKY_W) as f32 + 0.5) / SKY_H as f32 >= PI / 2.0 {
            *t = ground * (1.0 / scale);
        }
    }
    let sky = EnvMap::new(SKY_W, SKY_H, texels, scale, 0.0)
        .map_err(|e| crate::Error::Invalid(format!("the sky: {e}")))?;
    Ok([
        Light::Directional {
            direction: -s,
            irradiance: Rgb::new(sun[0], sun[1], sun[2]),
        },
        Light::Environment(Arc::new(sky)),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sun(l: &Light) -> Rgb {
        match l {
            Light::Directional { irradiance, .. } => *irradiance,
            _ => panic!("not the sun"),
        }
    }

    #[test]
    fn air_mass_is_one_overhead_and_about_38_at_the_horizon() {
        // Kasten & Young's table: 1.0 at 90°, 37.9 at 0°, 2.0 near 30°.
        assert!((air_mass(90.0) - 1.0).abs() < 1e-3);
        assert!((air_mass(0.0) - 37.92).abs() < 0.1, "{}", air_mass(0.0));
        assert!((air_mass(30.0) - 1.995).abs() < 0.01, "{}", air_mass(30.0));
    }

    #[test]
    fn the_sun_dims_and_reddens_towards_the_horizon() {
        let high = sun(&daylight(60.0, 270.0).unwrap()[0]);
        let low = sun(&daylight(3.0, 270.0).unwrap()[0]);
        assert!(low.g < 0.2 * high.g, "{low:?} {high:?}");
        assert!(low.r / low.b > 5.0 * high.r / high.b, "{low:?} {high:?}");
        // Travels away from the sun: down and towards +X for a sun in the west (270°).
        match &daylight(30.0, 270.0).unwrap()[0] {
            Light::Directional { direction, .. } => {
                assert!(direction.y < 0.0 && direction.x > 0.0 && direction.z.abs() < 1e-5);
            }
            _ => unreachable!(),
        }
    }

    #[test]
    fn the_sky_is_blue_by_day_warm_at_sunset_and_brightest_near_the_sun() {
        let [_, day] = daylight(45.0, 270.0).unwrap();
        let [_, dusk] = daylight(2.0, 270.0).unwrap();
        let look = |l: &Light, d| radiosity_core::sky_radiance_of(std::slice::from_ref(l), d);
        let (z_day, z_dusk) = (look(&day, Vec3::Y), look(&dusk, Vec3::Y));
        assert!(z_day.b > z_day.r, "{z_day:?}");
        // At sunset the horizon under the sun turns orange and the zenith stays the bluer.
        let west = sun_direction(3.0, 270.0);
        let (h_day, h_dusk) = (look(&day, west), look(&dusk, west));
        assert!(
            h_dusk.r / h_dusk.b > 4.0 * h_day.r / h_day.b,
            "{h_dusk:?} {h_day:?}"
        );
        assert!(h_dusk.r > h_dusk.b, "{h_dusk:?}");
        assert!(
            z_dusk.b / z_dusk.r > h_dusk.b / h_dusk.r,
            "{z_dusk:?} {h_dusk:?}"
        );
        // Towards the low sun (west, −X) against away from it (east, +X), at 10° up.
        let at = |az| {
            radiosity_core::sky_radiance_of(std::slice::from_ref(&dusk), sun_direction(10.0, az)).g
        };
        assert!(at(270.0) > 3.0 * at(90.0), "{} {}", at(270.0), at(90.0));
        // Below the horizon, the distant ground: 0.2·E/π of the sun and sky on it, far less
        // than the sky overhead by day.
        let below = radiosity_core::sky_radiance_of(std::slice::from_ref(&day), -Vec3::Y);
        let sun_on_ground = sun(&daylight(45.0, 270.0).unwrap()[0]).g * 45f32.to_radians().sin();
        // The sky adds 20 + 100·sin(45°)^0.7 ≈ 98 W/m² of luminance (module docs).
        let (lo, hi) = (0.2 * sun_on_ground / PI, 0.2 * (sun_on_ground + 110.0) / PI);
        assert!(
            below.g > lo && below.g < hi,
            "{below:?} not in [{lo}, {hi}]"
        );
    }

    #[test]
    fn the_sky_puts_its_stated_luminance_on_an_open_face() {
        for h in [1.0f32, 20.0, 70.0] {
            let [_, sky] = daylight(h, 200.0).unwrap();
            let Light::Environment(map) = &sky else {
                unreachable!()
            };
            // The SH's upward irradiance against the texel sum the scale was set from: order
            // 2 keeps a hemisphere's cosine-weighted sum within a few per cent.
            let e = radiosity_core::probes::sh_irradiance(map.sh(), [0.0, 1.0, 0.0]);
            let y = 0.2126 * e.r + 0.7152 * e.g + 0.0722 * e.b;
            let want = 20.0 + 100.0 * h.to_radians().sin().powf(0.7);
            assert!((y - want).abs() < 0.05 * want, "{h}: {y} against {want}");
        }
    }

    #[test]
    fn refuses_a_sun_below_the_horizon_or_not_finite() {
        assert!(daylight(-1.0, 0.0).is_err());
        assert!(daylight(f32::NAN, 0.0).is_err());
        assert!(daylight(10.0, f32::INFINITY).is_err());
    }
}
