//! The analytic differential-area-to-polygon form factor (Lambert's contour integral).
//!
//! For a point `x` with unit normal `n` and a planar polygon `P` wholly in front of `x`,
//! `F(x → P) = −1/(2π) Σᵢ γᵢ n·(Rᵢ × Rᵢ₊₁)/|Rᵢ × Rᵢ₊₁|`, where `Rᵢ = vᵢ − x`, γᵢ is the angle
//! between `Rᵢ` and `Rᵢ₊₁`, and the vertices run counter-clockwise about the polygon's front
//! normal. It is exact for any distance, so unlike the centre-to-centre `cos·cos/(πr²)` kernel it
//! stays bounded (≤ 1) for polygons that touch `x` or share an edge with the emitter.
//!
//! Where it fails, and what is done instead:
//! - `x` in the polygon's own plane (or behind it): every `Rᵢ × Rᵢ₊₁` is parallel to the
//!   polygon normal and the edge through `x`, if any, has a zero cross product, so the sum is
//!   meaningless. The polygon is then seen edge-on or from behind and receives nothing from
//!   the front of `x` through its front side: the factor is 0, returned before the sum.
//! - polygon partly behind `x`'s tangent plane: the formula counts the hidden part with the
//!   wrong sign; the polygon is first clipped to the closed front half-space of `x`.
//! - γ near 0 or π: `atan2(|R×R'|, R·R')` instead of `acos`, accurate at both ends.

use crate::polygon::Polygon;
use glam::DVec3;
use std::f64::consts::PI;

/// Relative tolerance for "in the plane": distances below this times the local size count as
/// zero. 1e-12 is far above f64 rounding of the coordinates (1e-16 relative) and far below any
/// distance that matters for a form factor (the factor is continuous in it).
const PLANE_EPS: f64 = 1e-12;

/// Unoccluded form factor from a differential area at `x` (unit normal `n`) to the convex
/// planar polygon `poly` (counter-clockwise about `poly_normal`, a unit vector). Only the
/// polygon's front side receives. Always finite, in `[0, 1]`.
pub fn point_to_polygon(x: DVec3, n: DVec3, poly: &Polygon, poly_normal: DVec3) -> f64 {
    let v = poly.vertices();
    if v.len() < 3 {
        return 0.0;
    }
    // Front of the polygon only; in its plane the factor is zero (see module docs).
    let r0 = v[0] - x;
    let h = -poly_normal.dot(r0);
    if h <= PLANE_EPS * r0.length() {
        return 0.0;
    }
    // Clip to the closed front half-space of x. Tolerance relative to the polygon's distance.
    let scale = r0.length();
    let mut any_front = false;
    let mut any_back = false;
    for &p in v {
        let d = n.dot(p - x);
        any_front |= d > PLANE_EPS * scale;
        any_back |= d < -PLANE_EPS * scale;
    }
    if !any_front {
        return 0.0;
    }
    let clipped;
    let v = if any_back {
        clipped = poly.clip(n, n.dot(x), PLANE_EPS * scale);
        clipped.vertices()
    } else {
        v
    };
    let m = v.len();
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    let mut ri = v[m - 1] - x;
    for &p in v {
        let rj = p - x;
        let c = ri.cross(rj);
        let cl = c.length();
        if cl > 0.0 {
            let gamma = cl.atan2(ri.dot(rj));
            sum += gamma * n.dot(c) / cl;
        }
        ri = rj;
    }
    (-sum / (2.0 * PI)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    /// Howell B-3: element whose normal passes through a corner of a parallel a×b rectangle at
    /// distance c (value from tests/tests/data/viewfactors.csv row 24, a = b = c = 1).
    #[test]
    fn corner_of_parallel_rectangle() {
        // Rectangle at z = 1 facing down (-z): counter-clockwise about -z.
        let p = Polygon::from_slice(&[
            dvec3(0.0, 0.0, 1.0),
            dvec3(0.0, 1.0, 1.0),
            dvec3(1.0, 1.0, 1.0),
            dvec3(1.0, 0.0, 1.0),
        ]);
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &p, -DVec3::Z);
        let exact = 0.138_531_605_994_893; // B-3 closed form, a = b = c = 1
        assert!((f - exact).abs() < 1e-13, "F = {f}, exact {exact}");
        // Seen from behind (wrong winding): nothing.
        let back = point_to_polygon(DVec3::ZERO, DVec3::Z, &p, DVec3::Z);
        assert_eq!(back, 0.0);
    }

    #[test]
    fn point_on_shared_edge_is_finite_and_in_plane_is_zero() {
        // Wall x = 0, y in [0,1], z in [0,1], facing +x; floor element at (eps, 0.5, 0) facing +z.
        let wall = Polygon::from_slice(&[
            dvec3(0.0, 0.0, 0.0),
            dvec3(0.0, 1.0, 0.0),
            dvec3(0.0, 1.0, 1.0),
            dvec3(0.0, 0.0, 1.0),
        ]);
        let nw = DVec3::X;
        // Down to 1e-9 of the distance the value approaches its edge limit; closer than
        // PLANE_EPS it counts as in the wall's plane (a strip of relative width 1e-12: no
        // measurable effect on any integral).
        for eps in [1e-3, 1e-6, 1e-9] {
            let f = point_to_polygon(dvec3(eps, 0.5, 0.0), DVec3::Z, &wall, nw);
            // Limit at the edge: half the hemisphere minus the two open ends, below 0.5.
            assert!(f > 0.3 && f < 0.5, "eps {eps}: F = {f}");
        }
        assert_eq!(
            point_to_polygon(dvec3(0.0, 0.5, 0.0), DVec3::Z, &wall, nw),
            0.0
        );
    }

    #[test]
    fn clipping_behind_the_tangent_plane() {
        // A large polygon facing the element, half of it below the element's plane: the factor
        // of the visible half is that of a half-space-limited square (symmetric), i.e. half of
        // the full "infinite wall" value 0.5 for a wall through the element's position.
        let big = 1e6;
        let wall = Polygon::from_slice(&[
            dvec3(1.0, -big, -big),
            dvec3(1.0, -big, big),
            dvec3(1.0, big, big),
            dvec3(1.0, big, -big),
        ]);
        let f = point_to_polygon(DVec3::ZERO, DVec3::Z, &wall, -DVec3::X);
        // Exact value for an infinite plane perpendicular to the element at distance 1: 1/2.
        assert!((f - 0.5).abs() < 1e-5, "F = {f}");
    }
}
