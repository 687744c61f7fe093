//! Hemisphere sampling from patches: points spread over a patch's pieces by area, either
//! uniformly or from the stratified unit square, cosine-weighted directions about their
//! normals, and the share of such rays that first meet a patch's front face or any back face.
//! The bake uses it to find buried surface, openings and dark patches
//! ([`crate::pipeline`]), and [`crate::check::row_check`] to check rows of F.

use crate::geometry::Occluders;
use crate::patch::{Patches, Piece};
use crate::rng::SplitMix64;
use glam::DVec3;

/// Which patch a point of a scene triangle belongs to: the piece of that triangle nearest to it.
pub(crate) struct Owners {
    /// `(triangle, piece)` sorted by triangle.
    by_triangle: Vec<(u32, u32)>,
    /// Each piece's bounding sphere (its vertices' mean, the farthest vertex's distance).
    sphere: Vec<(DVec3, f64)>,
    /// Patch of each piece.
    patch_of: Vec<u32>,
}

impl Owners {
    pub(crate) fn new(patches: &Patches) -> Self {
        let mut patch_of = vec![0u32; patches.pieces.len()];
        for (i, p) in patches.patches.iter().enumerate() {
            patch_of[p.pieces.clone()].fill(i as u32);
        }
        let mut by_triangle: Vec<(u32, u32)> = patches
            .pieces
            .iter()
            .enumerate()
            .map(|(k, p)| (p.triangle, k as u32))
            .collect();
        by_triangle.sort_unstable();
        let sphere = patches
            .pieces
            .iter()
            .map(|p| {
                let v = p.polygon.vertices();
                let c = v.iter().copied().sum::<DVec3>() / v.len().max(1) as f64;
                let r = v.iter().map(|q| q.distance(c)).fold(0.0, f64::max);
                (c, r)
            })
            .collect();
        Self {
            by_triangle,
            sphere,
            patch_of,
        }
    }

    /// The patch of the piece of `triangle` nearest to `x` (a point on that triangle). A
    /// large triangle is cut into many pieces: those whose bounding sphere lies farther than
    /// the nearest so far are passed over, and a piece holding `x` ends the search.
    pub(crate) fn patch_at(&self, pieces: &[Piece], triangle: u32, x: DVec3) -> Option<usize> {
        let start = self.by_triangle.partition_point(|e| e.0 < triangle);
        let mut best: Option<(f64, u32)> = None;
        for e in self.by_triangle[start..]
            .iter()
            .take_while(|e| e.0 == triangle)
        {
            let (c, r) = self.sphere[e.1 as usize];
            if best.is_some_and(|(d, _)| x.distance(c) - r >= d) {
                continue;
            }
            let p = &pieces[e.1 as usize];
            let d =
                crate::geometry::polygon::point_polygon_distance(x, p.polygon.vertices(), p.normal);
            if best.is_none_or(|(b, _)| d < b) {
                best = Some((d, e.1));
            }
            if d <= 0.0 {
                break;
            }
        }
        best.map(|(_, k)| self.patch_of[k as usize] as usize)
    }
}

/// A uniform point of a polygon (fan triangles chosen by area).
fn uniform_point(v: &[DVec3], rng: &mut SplitMix64) -> DVec3 {
    let fan = |k: usize| (v[k] - v[0]).cross(v[k + 1] - v[0]).length();
    let total: f64 = (1..v.len() - 1).map(fan).sum();
    let mut pick = rng.next_f64() * total;
    let mut k = 1;
    while k + 2 < v.len() && pick > fan(k) {
        pick -= fan(k);
        k += 1;
    }
    let (mut a, mut b) = (rng.next_f64(), rng.next_f64());
    if a + b > 1.0 {
        (a, b) = (1.0 - a, 1.0 - b);
    }
    v[0] + (v[k] - v[0]) * a + (v[k + 1] - v[0]) * b
}

/// A cosine-weighted direction about the unit normal `n` (two draws from `rng`).
pub(crate) fn cosine_direction(n: DVec3, rng: &mut SplitMix64) -> DVec3 {
    let u = rng.next_f64();
    cosine_at(n, u, rng.next_f64())
}

/// The cosine-weighted direction about the unit normal `n` at `(u, v)` of the unit square.
pub(crate) fn cosine_at(n: DVec3, u: f64, v: f64) -> DVec3 {
    let (t1, t2) = n.any_orthonormal_pair();
    let phi = std::f64::consts::TAU * v;
    (t1 * phi.cos() + t2 * phi.sin()) * u.sqrt() + n * (1.0 - u).sqrt()
}

/// The random stream of patch `i`'s rays.
pub(crate) fn patch_rng(seed: u64, i: usize) -> SplitMix64 {
    SplitMix64(seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
}

/// A uniform point of a patch (its pieces, of total area `total`, chosen by area) and the
/// normal of the piece it lies on.
fn patch_point(pieces: &[Piece], total: f64, rng: &mut SplitMix64) -> (DVec3, DVec3) {
    let mut pick = rng.next_f64() * total;
    let piece = pieces
        .iter()
        .find(|q| {
            pick -= q.area;
            pick <= 0.0
        })
        .unwrap_or(&pieces[pieces.len() - 1]);
    (uniform_point(piece.polygon.vertices(), rng), piece.normal)
}

/// The point of a patch (its pieces, of total area `total`) at `(u, v)` of the unit square,
/// by a map that keeps area: `u` picks the piece, then its fan triangle, by area (each time
/// rescaled to what is left of it), and places the point along the triangle with `v`. Returns
/// it with its piece's normal.
pub(crate) fn patch_point_at(pieces: &[Piece], total: f64, u: f64, v: f64) -> (DVec3, DVec3) {
    let (_, x, n) = patch_point_on(pieces, total, u, v);
    (x, n)
}

/// [`patch_point_at`], with the piece the point lies on.
pub(crate) fn patch_point_on(
    pieces: &[Piece],
    total: f64,
    u: f64,
    v: f64,
) -> (&Piece, DVec3, DVec3) {
    let mut pick = u * total;
    let last = pieces.len() - 1;
    let (piece, mut u) = pieces
        .iter()
        .enumerate()
        .find_map(|(k, q)| {
            if pick <= q.area || k == last {
                Some((q, (pick / q.area).clamp(0.0, 1.0)))
            } else {
                pick -= q.area;
                None
            }
        })
        .expect("a patch has pieces");
    let w = piece.polygon.vertices();
    if w.len() < 3 {
        return (piece, piece.polygon.centroid(), piece.normal);
    }
    let fan = |k: usize| (w[k] - w[0]).cross(w[k + 1] - w[0]).length();
    let fans = w.len() - 2;
    let mut pick = u * (1..=fans).map(fan).sum::<f64>();
    let mut k = 1;
    while k < fans && pick > fan(k) {
        pick -= fan(k);
        k += 1;
    }
    let area = fan(k);
    if area > 0.0 {
        u = (pick / area).clamp(0.0, 1.0);
    }
    let r = u.sqrt();
    (
        piece,
        w[0] * (1.0 - r) + (w[k] * (1.0 - v) + w[k + 1] * v) * r,
        piece.normal,
    )
}

/// Share of cosine-weighted rays from uniform points of patch `i` that first meet the front
/// face of a patch's triangle, and share that first meet a back face.
pub(crate) fn shares(
    patches: &Patches,
    owners: &Owners,
    occ: &Occluders,
    i: usize,
    rays: u32,
    seed: u64,
) -> (f64, f64) {
    let pieces = patches.pieces_of(i);
    let total: f64 = pieces.iter().map(|q| q.area).sum();
    if pieces.is_empty() || !(total > 0.0) || rays == 0 {
        return (0.0, 0.0);
    }
    let far = 10.0 * occ.extent();
    let mut rng = patch_rng(seed, i);
    let (mut seen, mut back) = (0u32, 0u32);
    for _ in 0..rays {
        let (x, n) = patch_point(pieces, total, &mut rng);
        let d = cosine_direction(n, &mut rng);
        let Some((h, front)) = occ.first_surface_from_surface(x, d, far) else {
            continue;
        };
        if !front {
            back += 1;
        } else if owners
            .patch_at(&patches.pieces, h.triangle, x + d * h.distance)
            .is_some()
        {
            seen += 1;
        }
    }
    let r = f64::from(rays);
    (f64::from(seen) / r, f64::from(back) / r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_points_fill_a_fan_by_area() {
        // A quad made of a 1 × 1 and a 3 × 1 half (fan triangles of areas 0.5 and 1.5): a
        // quarter of the points must land in the first. 40 000 points: the share's standard
        // error is 0.0022, the bound 0.01 is 4.5 of them.
        let v = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-2.0, 1.0, 0.0),
        ];
        let mut rng = SplitMix64(3);
        let first = (0..40_000)
            .map(|_| uniform_point(&v, &mut rng))
            .filter(|p| p.x >= p.y) // below the diagonal (0,0)–(1,1): the first fan triangle
            .count();
        let share = first as f64 / 40_000.0;
        assert!((share - 0.25).abs() < 0.01, "{share}");
    }
}
