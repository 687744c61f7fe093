//! Flat sites: the flat stand-in of a patch of many pieces, which its far pairs integrate
//! instead of the pieces in scenes above [`super::FormFactorParams::exact_pieces`] pieces.

use crate::geometry::polygon::{MAX_VERTICES, Polygon};
use crate::patch::Piece;
use glam::DVec3;

/// Rays per quadrature leaf and `per_sample` between a site and its far partner: a partly
/// hidden pair gets a visible fraction in steps of 1/16 instead of all or nothing (on a box of
/// tessellated walls around a floating cube, one ray per pair left rows of F off by 2%).
pub(super) const SITE_RAYS: u32 = 16;

/// Offset into the point sequence of a site's own ray ends, so that they do not pair up with
/// the same points of the target.
pub(super) const SITE_SOURCE_OFFSET: u64 = 1 << 20;

/// [`Piece::triangle`] of a flat site, which stands for many triangles.
pub(super) const SITE: u32 = u32::MAX;

/// The flat stand-in of a patch of many pieces, with the triangles it stands for.
pub(super) struct Sites {
    /// The whole patch as one site: for far pairs.
    pub(super) whole: Piece,
    /// The full-detail triangles of the patch, sorted: its own rays ignore them.
    pub(super) triangles: Vec<u32>,
}

/// Largest angle between a piece's normal and its patch's mean normal, and largest spread of
/// the piece corners across the mean plane relative to the patch's size, for a patch to stand
/// in as a flat site. Only flat patches do: a tessellated wall, floor or table top, whose site
/// is its outline. A curved patch keeps its pieces: measured on nested spheres at 58 patches,
/// flat stand-ins for the caps left rows of F off by up to 21% (caps of one convex sphere,
/// flattened, see each other), and a closed scene then no longer reads as closed.
const FLAT_COS: f64 = 0.999_4; // 2°

const FLAT_SPREAD: f64 = 1e-3;

impl Sites {
    pub(super) fn new(pieces: &[Piece]) -> Option<Self> {
        let whole = flat_site(pieces)?;
        let n = whole.normal;
        if pieces.iter().any(|p| p.normal.dot(n) < FLAT_COS) {
            return None;
        }
        let heights = pieces
            .iter()
            .flat_map(|p| p.polygon.vertices())
            .map(|x| n.dot(*x));
        let (lo, hi) = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| {
            (l.min(y), h.max(y))
        });
        let size = whole.area.sqrt();
        if hi - lo > FLAT_SPREAD * size {
            return None;
        }
        let mut triangles: Vec<u32> = pieces.iter().map(|p| p.triangle).collect();
        triangles.sort_unstable();
        triangles.dedup();
        Some(Self { whole, triangles })
    }
}

/// A flat stand-in for `pieces`: the convex hull of their corners projected on the plane
/// through their area-weighted centre with their mean normal, cut down to [`MAX_VERTICES`]
/// corners (dropping the corner whose triangle with its neighbours is smallest), scaled about
/// its centroid to the pieces' area, its centroid moved to their centre, then pushed along the
/// normal until no corner of the pieces lies in front of it (so that its rays leave from in
/// front of the surface it stands for). Area, centre and orientation are the pieces': a
/// distant patch sees it as it sees them. `None` for a degenerate set (no area, no mean
/// normal, a hull of no area).
fn flat_site(pieces: &[Piece]) -> Option<Piece> {
    let area: f64 = pieces.iter().map(|p| p.area).sum();
    let sum_n: DVec3 = pieces.iter().map(|p| p.normal * p.area).sum();
    if !(area > 0.0) || !(sum_n.length() > 1e-9 * area) {
        return None;
    }
    let n = sum_n.normalize();
    let centre = pieces
        .iter()
        .map(|p| p.polygon.centroid() * p.area)
        .sum::<DVec3>()
        / area;
    let (u, v) = n.any_orthonormal_pair();
    // Counter-clockwise in (u, v) must be counter-clockwise about n.
    let (u, v) = if u.cross(v).dot(n) > 0.0 {
        (u, v)
    } else {
        (v, u)
    };
    let corners = pieces.iter().flat_map(|p| p.polygon.vertices());
    let lift = corners
        .clone()
        .map(|x| n.dot(*x - centre))
        .fold(0f64, f64::max);
    let mut pts: Vec<[f64; 2]> = corners
        .map(|x| {
            let d = *x - centre;
            [d.dot(u), d.dot(v)]
        })
        .collect();
    let mut hull = convex_hull(&mut pts);
    let tri = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) * 0.5
    };
    while hull.len() > MAX_VERTICES {
        let m = hull.len();
        let cut = |i: usize| tri(hull[(i + m - 1) % m], hull[i], hull[(i + 1) % m]);
        let k = (0..m)
            .min_by(|&i, &j| cut(i).total_cmp(&cut(j)))
            .expect("non-empty");
        hull.remove(k);
    }
    let m = hull.len();
    let (mut hull_area, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 0..m {
        let (a, b) = (hull[i], hull[(i + 1) % m]);
        let cross = a[0] * b[1] - b[0] * a[1];
        hull_area += cross * 0.5;
        cx += (a[0] + b[0]) * cross;
        cy += (a[1] + b[1]) * cross;
    }
    if !(hull_area > 1e-12 * area) {
        return None;
    }
    let (cx, cy) = (cx / (6.0 * hull_area), cy / (6.0 * hull_area));
    let k = (area / hull_area).sqrt();
    let origin = centre + n * lift;
    let corners: Vec<DVec3> = hull
        .iter()
        .map(|p| origin + u * (k * (p[0] - cx)) + v * (k * (p[1] - cy)))
        .collect();
    Some(Piece {
        polygon: Polygon::from_slice(&corners),
        normal: n,
        area,
        triangle: SITE,
        object: pieces[0].object,
    })
}

/// Andrew's monotone chain: the convex hull of `pts`, counter-clockwise, without collinear
/// corners (sorts `pts`).
fn convex_hull(pts: &mut [[f64; 2]]) -> Vec<[f64; 2]> {
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(pts.len() + 1);
    for pass in 0..2 {
        let start = hull.len();
        let chain = |p: [f64; 2], hull: &mut Vec<[f64; 2]>| {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        };
        if pass == 0 {
            pts.iter().for_each(|&p| chain(p, &mut hull));
        } else {
            pts.iter().rev().for_each(|&p| chain(p, &mut hull));
        }
        hull.pop(); // the last point of each chain starts the other
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    fn piece(a: DVec3, b: DVec3, c: DVec3) -> Piece {
        let cross = (b - a).cross(c - a);
        Piece {
            polygon: Polygon::triangle(a, b, c),
            normal: cross.normalize(),
            area: cross.length() / 2.0,
            triangle: 0,
            object: 0,
        }
    }

    #[test]
    fn the_site_of_a_tiled_square_is_the_square() {
        // A 2 × 2 square in the plane z = 1, facing +z, as 8 triangles of a 2 × 2 grid: the
        // hull is the square itself (collinear corners dropped), area 4 and centroid (1, 1, 1)
        // kept, counter-clockwise about +z, nothing to lift (the pieces are flat). Tolerances:
        // f64 rounding of a few operations on numbers of order 1.
        let p = |x: f64, y: f64| DVec3::new(x, y, 1.0);
        let mut pieces = Vec::new();
        for i in 0..2 {
            for j in 0..2 {
                let (x, y) = (i as f64, j as f64);
                pieces.push(piece(p(x, y), p(x + 1.0, y), p(x + 1.0, y + 1.0)));
                pieces.push(piece(p(x, y), p(x + 1.0, y + 1.0), p(x, y + 1.0)));
            }
        }
        let s = flat_site(&pieces).unwrap();
        assert_eq!(s.triangle, SITE);
        assert_eq!(s.polygon.len(), 4);
        assert!((s.area - 4.0).abs() < 1e-12);
        assert!((s.polygon.centroid() - p(1.0, 1.0)).length() < 1e-12);
        let vector_area = s.polygon.doubled_area_vector() / 2.0;
        assert!((vector_area - DVec3::new(0.0, 0.0, 4.0)).length() < 1e-12);
        for v in s.polygon.vertices() {
            assert!([0.0, 2.0].iter().any(|c| (v.x - c).abs() < 1e-12), "{v}");
            assert!((v.z - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn the_site_of_a_bent_fan_keeps_area_and_lies_in_front() {
        // A fan of 40 triangles around the apex (0, 0, 0.3) over a unit circle at z = 0: a
        // shallow cone facing +z, whose hull has 40 corners. The site must cut them to
        // MAX_VERTICES, keep the true (slanted) area, face +z, and lie on or in front of every
        // corner of the pieces (so that its rays leave from in front of the surface).
        let apex = DVec3::new(0.0, 0.0, 0.3);
        let rim = |k: usize| {
            let a = std::f64::consts::TAU * k as f64 / 40.0;
            DVec3::new(a.cos(), a.sin(), 0.0)
        };
        let pieces: Vec<Piece> = (0..40).map(|k| piece(apex, rim(k), rim(k + 1))).collect();
        let area: f64 = pieces.iter().map(|p| p.area).sum();
        let s = flat_site(&pieces).unwrap();
        assert_eq!(s.polygon.len(), MAX_VERTICES);
        assert!((s.area - area).abs() < 1e-12 * area);
        let polygon_area = s.polygon.doubled_area_vector().length() / 2.0;
        assert!(
            (polygon_area - area).abs() < 1e-9 * area,
            "{polygon_area} vs {area}"
        );
        assert!((s.normal - DVec3::Z).length() < 1e-12);
        let plane = s.normal.dot(s.polygon.vertices()[0]);
        for p in &pieces {
            for v in p.polygon.vertices() {
                assert!(
                    s.normal.dot(*v) <= plane + 1e-12,
                    "{v} in front of the site"
                );
            }
        }
    }

    #[test]
    fn degenerate_pieces_have_no_site() {
        // Zero area, or normals that cancel: no site (the pieces are used instead).
        let z = DVec3::ZERO;
        assert!(flat_site(&[piece(z, DVec3::X, DVec3::Y)]).is_some());
        let up = piece(z, DVec3::X, DVec3::Y);
        let down = piece(z, DVec3::Y, DVec3::X);
        assert!(flat_site(&[up, down]).is_none());
        assert!(flat_site(&[]).is_none());
    }
}
