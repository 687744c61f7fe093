//! Which triangles could block the segments between two polygons: conservative tests that
//! let the form factors skip shadow rays where nothing can come between.

use super::{LOCAL_EXTENT, Occluders};
use glam::{DVec3, Vec3A};
use obvhs::aabb::Aabb;

/// Relative (to the scene extent) tolerance of the plane tests in [`Occluders::may_block`]:
/// above f64 rounding of any coordinate, far below any feature a form factor resolves.
const PLANE_TOL: f64 = 1e-9;

impl Occluders {
    /// Whether any triangle could block some segment from a point of polygon `s` (unit normal
    /// `ns`, light leaving its front) to a point of polygon `t` (normal `nt`, receiving on its
    /// front). Conservative: `false` is a proof that nothing blocks (so no ray is needed);
    /// `true` only means a candidate exists.
    ///
    /// A triangle is ruled out when its box misses the box of `s ∪ t`, or it lies on or behind
    /// the plane of `s` or of `t` (segments run in front of both), or `s` and `t` lie on one
    /// side of its plane (segments between them cannot cross it), or an axis separates it from
    /// the convex hull of `s ∪ t` (see [`Occluders::may_block_hull`]).
    pub fn may_block(&self, s: &[DVec3], ns: DVec3, t: &[DVec3], nt: DVec3) -> bool {
        self.candidate(s, t, Some((ns, nt)))
    }

    /// Whether any triangle could block some segment between the convex hull of the points
    /// `s` and that of the points `t` (two whole patches, curved or not, with no one normal
    /// each). Conservative like [`Occluders::may_block`], with the tests that need no normal
    /// of `s` or `t`: every such segment lies in the convex hull of `s ∪ t`, so a triangle is
    /// ruled out when its box misses that hull's box, when the hull lies on one side of the
    /// triangle's plane, or when the hull and the triangle are apart along the axis from the
    /// segment between the two centroids to the triangle's centroid (two disjoint convex sets
    /// separated along one axis: a one-axis separating-axis test, the axis chosen per
    /// triangle). A patch's own triangles are ruled out by their planes where the patch is flat
    /// or curves towards the other (the inside of an enclosure); on a patch curving away they
    /// stay candidates, and the answer is `true`.
    pub fn may_block_hull(&self, s: &[DVec3], t: &[DVec3]) -> bool {
        self.candidate(s, t, None)
    }

    fn candidate(&self, s: &[DVec3], t: &[DVec3], planes: Option<(DVec3, DVec3)>) -> bool {
        if self.rt.is_empty() || s.is_empty() || t.is_empty() {
            return false;
        }
        let tol = PLANE_TOL * self.extent;
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in s.iter().chain(t) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let (lo, hi) = (lo - tol, hi + tol);
        let bx = Aabb::new(
            self.local(lo) - Vec3A::splat((1e-6 * LOCAL_EXTENT) as f32),
            self.local(hi) + Vec3A::splat((1e-6 * LOCAL_EXTENT) as f32),
        );
        let planes = planes.map(|(ns, nt)| (ns, ns.dot(s[0]), nt, nt.dot(t[0])));
        let mean = |v: &[DVec3]| v.iter().copied().sum::<DVec3>() / v.len() as f64;
        let (cs, ct) = (mean(s), mean(t));
        let radius =
            |v: &[DVec3], c: DVec3| v.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
        let (rs, rt) = (radius(s, cs), radius(t, ct));
        let d = ct - cs;
        let dd = d.length_squared();
        let mut found = false;
        self.bvh.aabb_traverse(bx, |bvh, node_index| {
            let node = &bvh.nodes[node_index as usize];
            for k in node.first_index..node.first_index + node.prim_count {
                let c = &self.corners[k as usize];
                // Box test in f64 (the node boxes are f32 and padded).
                let (clo, chi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
                if clo.cmpgt(hi).any() || chi.cmplt(lo).any() {
                    continue;
                }
                if let Some((ns, ds, nt, dt)) = planes
                    && (c.iter().all(|p| ns.dot(*p) - ds <= tol)
                        || c.iter().all(|p| nt.dot(*p) - dt <= tol))
                {
                    continue;
                }
                // Both tests below first on the bounding spheres of `s` and `t` (O(1) per
                // triangle; a whole patch has dozens of corners), then on the points where the
                // spheres leave it open.
                let nc = (c[1] - c[0]).cross(c[2] - c[0]);
                let ncl = nc.length();
                if ncl > 0.0 {
                    let nc = nc / ncl;
                    let dc = nc.dot(c[0]);
                    let side = |p: &DVec3| nc.dot(*p) - dc;
                    let (ss, st) = (side(&cs), side(&ct));
                    if (ss - rs >= -tol && st - rt >= -tol) || (ss + rs <= tol && st + rt <= tol) {
                        continue;
                    }
                    let all_pos = s.iter().chain(t).all(|p| side(p) >= -tol);
                    let all_neg = s.iter().chain(t).all(|p| side(p) <= tol);
                    if all_pos || all_neg {
                        continue;
                    }
                }
                // One separating axis: from the nearest point of the centroids' segment
                // towards the triangle's centroid.
                let cc = (c[0] + c[1] + c[2]) / 3.0;
                let u = if dd > 0.0 {
                    ((cc - cs).dot(d) / dd).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let axis = cc - (cs + d * u);
                let len = axis.length();
                if planes.is_none() && len > 0.0 {
                    let near = c.iter().map(|p| axis.dot(*p)).fold(f64::INFINITY, f64::min);
                    let spheres = (axis.dot(cs) + rs * len).max(axis.dot(ct) + rt * len);
                    if near > spheres + tol * len {
                        continue;
                    }
                    let hull = s
                        .iter()
                        .chain(t)
                        .map(|p| axis.dot(*p))
                        .fold(f64::NEG_INFINITY, f64::max);
                    if near > hull + tol * len {
                        continue;
                    }
                }
                found = true;
                return false;
            }
            true
        });
        found
    }
}
