//! The real SH basis up to order 2, and the irradiance a radiance SH gives a surface.

use super::SH_COEFFICIENTS;
use crate::Rgb;

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
