//! Occlusion over the full-detail triangles: an obvhs CWBVH (8-wide, compressed) for segment
//! (shadow-ray) and closest-hit queries, and a BVH2 for the box queries that find which
//! triangles could possibly block light between two surfaces.
//!
//! Every triangle blocks from both sides (DESIGN.md): the intersection test does not cull back
//! faces. Coordinates are stored in f32 relative to the scene centre and scaled to one extent
//! ([`LOCAL_EXTENT`]), so a scene far from the origin loses no precision and one of any size
//! looks the same to obvhs, whose CWBVH has an absolute epsilon.

use crate::scene::Scene;
use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::Ray;
use obvhs::triangle::Triangle as BvhTriangle;
use std::time::Duration;

/// The triangles that block light, with a BVH over them.
pub struct Occluders {
    /// For box queries ([`Self::may_block`]).
    bvh: Bvh2,
    /// For rays: twice as fast as the BVH2 on segments that mostly get through (conference
    /// room, 400 k segments: 0.53 against 1.14 µs each), 1.8× on closest hits.
    cw: CwBvh,
    /// Ray-test triangles in CWBVH primitive order (`cw.primitive_indices` maps them to the
    /// triangle list the BVH was built from).
    rt: Vec<RayTriangle>,
    /// Where each triangle, by its index in the list given, sits in [`Self::corners`] (for
    /// [`Self::reaches`]).
    slot: Vec<u32>,
    /// f64 corners in BVH2 primitive order (for the exact plane tests of [`Self::may_block`]).
    corners: Vec<[DVec3; 3]>,
    /// Local origin of the f32 coordinates.
    origin: DVec3,
    /// Local units per scene unit, `LOCAL_EXTENT / extent`: the BVH sees every scene at one
    /// size (see [`LOCAL_EXTENT`]).
    scale: f64,
    /// Diagonal of the scene bounds: the length scale of every tolerance here.
    extent: f64,
}

/// The extent of every scene in the BVH's f32 coordinates. obvhs's CWBVH skips every node
/// that lies within an absolute 1e-4 of a ray's origin (`cwbvh::node::EPSILON`), so the local
/// unit must make 1e-4 far smaller than the segment margin (1e-6 of the extent, 0.066 here):
/// in scene units a small scene (the Cornell box's extent is ~3.5) can lose blockers near ray
/// origins, a scene scaled by 1e-4 lost them all (`results_do_not_depend_on_the_scale`), and
/// at extent 1 the conference room's loose parts merged through chair details (4269 patches
/// instead of 4410). A power of two, so the scaling is exact in the exponent; f32 keeps the
/// same relative precision at any scale.
const LOCAL_EXTENT: f64 = 65_536.0;

/// Whether `p`, a point in the plane of triangle `t` (or next to it), lies inside it by at
/// least `margin` from every edge.
fn inside_by(t: &[DVec3; 3], p: DVec3, margin: f64) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    (0..3).all(|k| {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        // Signed distance from the edge's line, positive inside.
        let inward = n.cross(b - a);
        let l = inward.length();
        l > 0.0 && (p - a).dot(inward) / l > margin
    })
}

/// `p` in the BVH's f32 coordinates: relative to `origin`, `scale` local units per scene unit.
fn to_local(p: DVec3, origin: DVec3, scale: f64) -> Vec3A {
    Vec3A::from(((p - origin) * scale).as_vec3())
}

/// A ray direction in f32 with every zero component `+0.0`: obvhs's CWBVH traversal misses
/// every triangle when a component is `-0.0` (a ray straight up with normal `(-0, 1, 0)`,
/// from a cross product or a negation, met nothing; the same ray with `+0` met the ceiling).
fn ray_direction(d: DVec3) -> Vec3A {
    Vec3A::from(d.as_vec3()) + Vec3A::ZERO
}

/// Relative (to the scene extent) tolerance of the plane tests in [`Occluders::may_block`]:
/// above f64 rounding of any coordinate, far below any feature a form factor resolves.
const PLANE_TOL: f64 = 1e-9;

/// A triangle prepared for the Möller–Trumbore test.
#[derive(Clone, Copy, Debug)]
struct RayTriangle {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

/// Barycentric slack of the ray test: a ray through a shared edge (or a vertex) must hit one of
/// the triangles, whatever the rounding. obvhs's own test rejects `-0.0` barycentrics, which
/// lets rays through the diagonal of a quad; 1e-6 closes those cracks and widens a triangle
/// by a millionth of its size, which no form factor can see.
const EDGE_SLACK: f32 = 1e-6;

impl RayTriangle {
    /// Barycentrics `(u, v)` of the ray's crossing of this triangle's plane, clamped into the
    /// triangle (the ray test lets a hit through by [`EDGE_SLACK`]).
    fn barycentrics(&self, ray: &Ray) -> (f32, f32) {
        let p = ray.direction.cross(self.e2);
        let inv = 1.0 / self.e1.dot(p);
        let s = ray.origin - self.v0;
        let u = (s.dot(p) * inv).clamp(0.0, 1.0);
        let v = (ray.direction.dot(s.cross(self.e1)) * inv).clamp(0.0, 1.0 - u);
        (u, v)
    }

    fn new(t: &BvhTriangle) -> Self {
        Self {
            v0: t.v0,
            e1: t.v1 - t.v0,
            e2: t.v2 - t.v0,
        }
    }

    /// Distance along the ray of the hit, or infinity. Both sides hit.
    #[inline]
    fn intersect(&self, ray: &Ray) -> f32 {
        let p = ray.direction.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return f32::INFINITY;
        }
        let inv = 1.0 / det;
        let s = ray.origin - self.v0;
        let u = s.dot(p) * inv;
        if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
            return f32::INFINITY;
        }
        let q = s.cross(self.e1);
        let v = ray.direction.dot(q) * inv;
        if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
            return f32::INFINITY;
        }
        let t = self.e2.dot(q) * inv;
        if t >= ray.tmin && t <= ray.tmax {
            t
        } else {
            f32::INFINITY
        }
    }
}

/// Surfaces closer than this (relative to the scene's extent) are in contact: one f32 step of
/// the BVH's coordinates at the far end of the scene (`LOCAL_EXTENT`), below which its rays
/// do not reliably resolve a gap. (Plates 1.4e-7 of the extent apart, 2.4 steps, are still
/// seen across: `hemisphere_rays_check_rows_across_micro_gaps_and_thin_sheets`; the
/// conference room's chair parts, 4e-10 to 5e-9 apart, were seen across by some rays and
/// passed through by others.)
pub const CONTACT_GAP: f64 = 0.5 * f32::EPSILON as f64;

/// Two sheets this close along a ray (relative to its distance) count as one panel: a ray meeting
/// the back of one and then the front of the other sees that front ([`Occluders::reaches`],
/// [`Occluders::first_surface`]).
pub const SHEET_GAP: f64 = 1e-4;

/// Where a ray first meets a triangle ([`Occluders::closest_hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (normalised) ray.
    pub distance: f64,
    /// Index of the triangle in the list the BVH was built from.
    pub triangle: u32,
    /// Barycentric weight of the triangle's corner 1.
    pub u: f32,
    /// Barycentric weight of the triangle's corner 2.
    pub v: f32,
}

impl Occluders {
    /// Builds the BVH over every triangle of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let corners: Vec<[DVec3; 3]> = (0..scene.triangles.len())
            .map(|t| scene.corners(t))
            .collect();
        Self::from_triangles(&corners)
    }

    /// Builds the BVH over triangles given by their corners.
    pub fn from_triangles(tris: &[[DVec3; 3]]) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in tris {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let (origin, extent) = if tris.is_empty() {
            (DVec3::ZERO, 1.0)
        } else {
            ((lo + hi) * 0.5, (hi - lo).length().max(f64::MIN_POSITIVE))
        };
        let scale = LOCAL_EXTENT / extent;
        let local = |p: DVec3| to_local(p, origin, scale);
        let bt: Vec<BvhTriangle> = tris
            .iter()
            .map(|t| BvhTriangle {
                v0: local(t[0]),
                v1: local(t[1]),
                v2: local(t[2]),
            })
            .collect();
        let (bvh, cw) = if bt.is_empty() {
            (Bvh2::default(), CwBvh::default())
        } else {
            let params = BvhBuildParams::medium_build();
            (
                build_bvh2_from_tris(&bt, params, &mut Duration::default()),
                build_cwbvh_from_tris(&bt, params, &mut Duration::default()),
            )
        };
        let order: Vec<usize> = bvh.primitive_indices.iter().map(|&i| i as usize).collect();
        Self {
            rt: cw
                .primitive_indices
                .iter()
                .map(|&i| RayTriangle::new(&bt[i as usize]))
                .collect(),
            slot: {
                let mut slot = vec![0u32; tris.len()];
                for (k, &i) in order.iter().enumerate() {
                    slot[i] = k as u32;
                }
                slot
            },
            corners: order.iter().map(|&i| tris[i]).collect(),
            bvh,
            cw,
            origin,
            scale,
            extent,
        }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.rt.len()
    }

    /// Whether there is no triangle at all.
    pub fn is_empty(&self) -> bool {
        self.rt.is_empty()
    }

    /// `p` in the f32 coordinates of the BVH.
    fn local(&self, p: DVec3) -> Vec3A {
        to_local(p, self.origin, self.scale)
    }

    /// The length scale of the scene (diagonal of its bounds).
    pub fn extent(&self) -> f64 {
        self.extent
    }

    /// Whether the open segment `a`–`b` misses every triangle. The ends are excluded by
    /// `max(1e-4·|b−a|, 1e-6·extent)` each, so the surfaces the segment starts and ends on (and
    /// f32 rounding near them) never count as blockers; a segment too short for that margin is
    /// visible.
    pub fn segment_visible(&self, a: DVec3, b: DVec3) -> bool {
        self.segment_visible_skipping(a, b, &|_| false)
    }

    /// [`Self::segment_visible`], except that triangles for which `skip` (given the index in
    /// the list the BVH was built from) says `true` never block: the surfaces a segment
    /// starts and ends on when its ends lie off them (a flat site standing in for a curved
    /// patch, see `form_factor::flat_site`).
    pub fn segment_visible_skipping(&self, a: DVec3, b: DVec3, skip: &dyn Fn(u32) -> bool) -> bool {
        if self.rt.is_empty() {
            return true;
        }
        // In local units (the scene extent is LOCAL_EXTENT).
        let d = (b - a) * self.scale;
        let len = d.length();
        let margin = (1e-4 * len).max(1e-6 * LOCAL_EXTENT);
        if len <= 2.0 * margin {
            return true;
        }
        let dir = ray_direction(d / len);
        let o = self.local(a);
        let ray = Ray::new(o, dir, margin as f32, (len - margin) as f32);
        self.cw.ray_traverse_miss(ray, |r, id| {
            if skip(self.cw.primitive_indices[id]) {
                f32::INFINITY
            } else {
                self.rt[id].intersect(r)
            }
        })
    }

    /// The first triangle a ray meets, both sides counting, at a distance in `[t_min, t_max]`
    /// (in scene units). `direction` must be non-zero; it need not be normalised. Returns the
    /// hit's distance, the triangle's index in the list the BVH was built from (the scene's
    /// triangle order for [`Self::new`]) and the barycentrics `(u, v)` of corners 1 and 2.
    pub fn closest_hit(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<Hit> {
        self.closest_hit_passing(origin, direction, t_min, t_max, &|_| false)
    }

    /// [`Self::closest_hit`] from a point on a surface: it passes through every triangle whose
    /// plane holds `origin` (within 1e-9 of the extent, in f64): its own, its coplanar
    /// neighbours, the other side of a zero-thickness panel. A ray leaving a plane meets
    /// those only through f32 rounding, so the ray needs no lift, and a surface a real gap in
    /// front of `origin` is met however small the gap.
    pub fn closest_hit_from_surface(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_max: f64,
    ) -> Option<Hit> {
        self.closest_hit_passing(origin, direction, 0.0, t_max, &|t| self.holds(t, origin))
    }

    /// What a ray from a point on a surface sees ([`Self::closest_hit_from_surface`]): the hit
    /// and whether it is a front face the point can see, as [`Self::reaches`] decides: the two
    /// sheets of a panel resolved ([`Self::facing_sheet`]), and a front face in contact with
    /// `origin` (its plane within [`CONTACT_GAP`]) covering it, not seen.
    pub fn first_surface_from_surface(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_max: f64,
    ) -> Option<(Hit, bool)> {
        let hit = self.closest_hit_from_surface(origin, direction, t_max)?;
        let (hit, front) = self.facing_sheet(origin, direction, hit, &|t| self.holds(t, origin));
        Some((hit, front && !self.touches(hit.triangle, origin)))
    }

    /// What a ray sees ([`Self::closest_hit`], from a point off the surfaces: a camera, a
    /// lifted path vertex): the hit and whether it is a front face, with the two sheets of a
    /// panel resolved ([`Self::facing_sheet`]).
    pub fn first_surface(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_min: f64,
        t_max: f64,
    ) -> Option<(Hit, bool)> {
        let hit = self.closest_hit(origin, direction, t_min, t_max)?;
        Some(self.facing_sheet(origin, direction, hit, &|_| false))
    }

    /// `hit` (the first triangle met along `direction`, passing those `pass` names) as the
    /// surface it shows: a front face is itself; a back face with a front face behind it within
    /// [`SHEET_GAP`] of its distance is the far sheet of a two-sided panel whose sheets the
    /// model put out of order, and the ray sees the near one's front. (In the conference room
    /// a panel's two sheets lie 1e-4 apart that way round: hemisphere rays from a chair part
    /// facing it met the back of the outer sheet and sent 0.00004 of its light to the panel
    /// where the form factors' rays sent 0.108, and the burial test called 87% of the part
    /// buried, so its row over the exposed part came out at 2.0.) Returns the hit and whether
    /// it is a front face.
    fn facing_sheet(
        &self,
        origin: DVec3,
        direction: DVec3,
        hit: Hit,
        pass: &dyn Fn(u32) -> bool,
    ) -> (Hit, bool) {
        if self.front(hit.triangle).dot(direction) < 0.0 {
            return (hit, true);
        }
        let near = hit.distance * (1.0 - SHEET_GAP);
        let far = hit.distance * (1.0 + SHEET_GAP);
        let sheet = self.closest_hit_passing(origin, direction, near, far, &|t| {
            pass(t) || self.front(t).dot(direction) >= 0.0
        });
        match sheet {
            Some(front) => (front, true),
            None => (hit, false),
        }
    }

    fn closest_hit_passing(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_min: f64,
        t_max: f64,
        pass: &dyn Fn(u32) -> bool,
    ) -> Option<Hit> {
        let len = direction.length();
        if self.rt.is_empty() || !(len > 0.0) || !len.is_finite() {
            return None;
        }
        let dir = ray_direction(direction / len);
        let o = self.local(origin);
        let t_max = (t_max * self.scale).min(f64::from(f32::MAX));
        let ray = Ray::new(o, dir, (t_min * self.scale) as f32, t_max as f32);
        let (id, t) = self.first_hit(ray, pass)?;
        let (u, v) = self.rt[id].barycentrics(&ray);
        Some(Hit {
            distance: f64::from(t) / self.scale,
            triangle: self.cw.primitive_indices[id],
            u,
            v,
        })
    }

    /// The first triangle `ray` (local coordinates) meets, except those `pass` (given a
    /// triangle's index in the list given) lets it through: its CWBVH primitive index and the
    /// local distance. `pass` is asked only about triangles the ray meets.
    fn first_hit(&self, ray: Ray, pass: &dyn Fn(u32) -> bool) -> Option<(usize, f32)> {
        let mut hit = obvhs::ray::RayHit::none();
        let prims = &self.cw.primitive_indices;
        self.cw
            .ray_traverse(ray, &mut hit, |r, id| {
                let t = self.rt[id].intersect(r);
                if t < f32::INFINITY && pass(prims[id]) {
                    f32::INFINITY
                } else {
                    t
                }
            })
            .then_some((hit.primitive_id as usize, hit.t))
    }

    /// Whether the plane of triangle `t` (its index in the list given) holds `x`, within 1e-9
    /// of the extent (f64; a point computed on a triangle is within 1e-15 of it, a real gap
    /// in a scene is far above).
    fn holds(&self, t: u32, x: DVec3) -> bool {
        self.plane_distance(t, x) <= 1e-9 * self.extent
    }

    /// The distance from `x` to the plane of triangle `t` (0 for a degenerate triangle).
    fn plane_distance(&self, t: u32, x: DVec3) -> f64 {
        let c = self.given(t);
        let n = (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero();
        n.dot(x - c[0]).abs()
    }

    /// Whether the plane of triangle `t` lies within [`CONTACT_GAP`] of `x`.
    fn touches(&self, t: u32, x: DVec3) -> bool {
        self.plane_distance(t, x) <= CONTACT_GAP * self.extent
    }

    /// Whether a ray from `from`, a point on a surface, toward `to`, a point of triangle
    /// `target`, reaches it: the first triangle it meets is `target`, or there is none before
    /// `to`, or the one met at `to` (within 1e-4 of the distance) is not a copy of the target
    /// in front of it (see the body). Triangles whose planes hold `from` are passed through
    /// (as in [`Self::closest_hit_from_surface`]), so the ray starts on the surface itself.
    /// The closest-hit question of a hemisphere ray, asked of one point: unlike
    /// [`Self::segment_visible`] it needs no margin at either end, so a surface just in front
    /// of the target (a second layer of a modelled panel) hides it, and one a hair in front of
    /// the start (two parts in contact, modelled 5e-4 apart in a room 3300 across) is met, not
    /// stepped over (ARCHITECTURE.md, "First hit, not a lifted segment").
    pub fn reaches(&self, from: DVec3, to: DVec3, target: u32) -> bool {
        let d = (to - from) * self.scale;
        let len = d.length();
        if self.rt.is_empty() || !(len > 0.0) || !len.is_finite() {
            return true;
        }
        // A target whose plane lies within [`CONTACT_GAP`] of `from` faces it in contact (a
        // part pressed against another) or lies beside it in one plane: neither passes light.
        // The BVH's f32 rays cannot see into so thin a gap: hemisphere rays and the burial
        // test pass through such a target and call the point buried when the inside of an
        // object lies beyond, and the bake takes that area out of the patch (`expose`), so
        // a visibility ray must not find the target there. (Without this, chair parts in
        // the conference room pressed 2e-6 to 2e-5 against each other exchanged F ≈ 1 over
        // their contact, and their rows over the exposed part came out at up to 2.3.)
        if self.touches(target, from) {
            return false;
        }
        let dir = ray_direction(d / len);
        let ray = Ray::new(self.local(from), dir, 0.0, (len * (1.0 + SHEET_GAP)) as f32);
        let Some((id, t)) = self.first_hit(ray, &|t| self.holds(t, from)) else {
            return true;
        };
        let met = self.cw.primitive_indices[id];
        if met == target {
            return true;
        }
        if f64::from(t) < len * (1.0 - SHEET_GAP) {
            return false;
        }
        // Met at the target's own distance: a neighbour of the target (a point within rounding
        // of its edge), the back of a two-sided panel, or a coincident copy of the target
        // (a surface modelled twice). Only the copy stands in front of it, so that the two
        // together count once: a triangle that faces the ray, with `to` well inside the target.
        let c = self.given(met);
        if (c[1] - c[0]).cross(c[2] - c[0]).dot(to - from) >= 0.0 {
            return true;
        }
        let margin = 1e-6 * self.extent;
        !inside_by(self.given(target), to, margin)
    }

    /// Whether the point `x` of a surface with unit normal `normal` is *buried*: no light can
    /// reach it or leave it because another object covers it. Rays along the normal and 45° and
    /// 80° off it either all first meet back faces (the inside of a block that rests on the
    /// surface or stands through it), or meet no front face while a triangle lies against `x`
    /// face to face (a block's bottom on the floor of a closed room). A front face met by any
    /// of the rays leaves `x` exposed (the sheets of a two-sided panel lie face to face).
    pub fn buried(&self, x: DVec3, normal: DVec3) -> bool {
        if self.rt.is_empty() || !normal.is_finite() {
            return false;
        }
        // What the surface looks out on: the first hits along the normal and eight directions
        // 45° and 80° off it. A front face met by any of them: exposed.
        let (t1, t2) = normal.any_orthonormal_pair();
        let tilts = [DVec3::ZERO, t1, -t1, t2, -t2];
        let grazing = [t1, -t1, t2, -t2].map(|t| t * 80f64.to_radians().tan());
        let mut back = true;
        for &t in tilts.iter().chain(&grazing) {
            let d = normal + t;
            match self.first_surface_from_surface(x, d, 10.0 * self.extent) {
                Some((_, true)) => return false,
                Some(_) => {}
                None => back = false,
            }
        }
        // Enclosed: every ray meets a back face. One ray would call a table under a lampshade
        // (its inside is its back faces) buried, and rays up to 45° the floor under a bucket
        // hung just above it; the grazing rays leave through the gap. Rays from under a block
        // that rests on the floor meet its inside whichever way they go.
        if back {
            return true;
        }
        // Some rays leave the scene, none meets a front face: buried if a triangle lies against
        // `x` face to face (its plane holds `x`, it covers `x`, it faces the other way), as a
        // block's bottom on the floor of a closed room looks through the floor into the void.
        // The sheet behind a two-sided panel lies face to face too, but the panel looks out on
        // the room's front faces and was called exposed above.
        let lift = 1e-6 * LOCAL_EXTENT;
        let o = self.local(x) + Vec3A::from(normal.as_vec3()) * lift as f32;
        let ray = Ray::new(o, ray_direction(-normal), 0.0, 2.0 * lift as f32);
        let against = |t: u32| !(self.holds(t, x) && self.front(t).dot(normal) < 0.0);
        self.first_hit(ray, &against).is_some()
    }

    /// The corners of triangle `t` (its index in the list given).
    fn given(&self, t: u32) -> &[DVec3; 3] {
        &self.corners[self.slot[t as usize] as usize]
    }

    /// The (unnormalised) front normal of triangle `t`: counter-clockwise winding.
    fn front(&self, t: u32) -> DVec3 {
        let c = self.given(t);
        (c[1] - c[0]).cross(c[2] - c[0])
    }

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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    fn quad(z: f64, up: bool) -> Vec<[DVec3; 3]> {
        let (a, b, c, d) = (
            dvec3(0.0, 0.0, z),
            dvec3(1.0, 0.0, z),
            dvec3(1.0, 1.0, z),
            dvec3(0.0, 1.0, z),
        );
        if up {
            vec![[a, b, c], [a, c, d]]
        } else {
            vec![[a, c, b], [a, d, c]]
        }
    }

    #[test]
    fn blocks_from_both_sides() {
        let occ = Occluders::from_triangles(&quad(0.5, true));
        assert!(!occ.segment_visible(dvec3(0.5, 0.5, 0.0), dvec3(0.5, 0.5, 1.0)));
        assert!(!occ.segment_visible(dvec3(0.5, 0.5, 1.0), dvec3(0.5, 0.5, 0.0)));
        assert!(occ.segment_visible(dvec3(1.5, 0.5, 0.0), dvec3(1.5, 0.5, 1.0)));
    }

    #[test]
    fn may_block_rules_out_the_two_surfaces_themselves() {
        let mut tris = quad(0.0, true);
        tris.extend(quad(1.0, false));
        let occ = Occluders::from_triangles(&tris);
        let s = [
            dvec3(0.0, 0.0, 0.0),
            dvec3(1.0, 0.0, 0.0),
            dvec3(1.0, 1.0, 0.0),
        ];
        let t = [
            dvec3(0.0, 0.0, 1.0),
            dvec3(1.0, 1.0, 1.0),
            dvec3(1.0, 0.0, 1.0),
        ];
        assert!(!occ.may_block(&s, DVec3::Z, &t, -DVec3::Z));
        // A plate between them is a candidate.
        tris.extend(quad(0.5, true));
        let occ = Occluders::from_triangles(&tris);
        assert!(occ.may_block(&s, DVec3::Z, &t, -DVec3::Z));
    }

    /// Two patches at right angles, facing each other, and a small triangle in the plane
    /// x = y between them: the boxes overlap and the patches lie on both sides of its plane,
    /// so only the axis from the centres' segment towards the triangle proves it clear, while
    /// it sits near the origin; moved onto the segment, it is a candidate either way.
    #[test]
    fn may_block_hull_separates_what_boxes_and_planes_cannot() {
        let quad = |c: DVec3, u: DVec3, v: DVec3| [c - u - v, c + u - v, c + u + v, c - u + v];
        let s = quad(
            dvec3(1.0, 0.0, 0.0),
            dvec3(0.0, 0.05, 0.0),
            dvec3(0.0, 0.0, 0.05),
        );
        let t = quad(
            dvec3(0.0, 1.0, 0.0),
            dvec3(0.0, 0.0, 0.05),
            dvec3(0.05, 0.0, 0.0),
        );
        let (ns, nt) = (-DVec3::X, -DVec3::Y);
        let near_origin = [
            dvec3(0.1, 0.1, -0.1),
            dvec3(0.2, 0.2, -0.1),
            dvec3(0.15, 0.15, 0.1),
        ];
        let occ = Occluders::from_triangles(&[near_origin]);
        assert!(
            occ.may_block(&s, ns, &t, nt),
            "boxes and planes leave it open"
        );
        assert!(!occ.may_block_hull(&s, &t), "the axis proves it clear");
        let on_segment = near_origin.map(|p| p + dvec3(0.35, 0.35, 0.0));
        let occ = Occluders::from_triangles(&[on_segment]);
        assert!(occ.may_block(&s, ns, &t, nt));
        assert!(occ.may_block_hull(&s, &t));
        // The patches' own corners give no candidate: nothing else is there.
        let occ = Occluders::from_triangles(&[[s[0], s[1], s[2]], [t[0], t[2], t[1]]]);
        assert!(!occ.may_block_hull(&s, &t));
    }

    #[test]
    fn closest_hit_finds_the_nearest_triangle_and_where() {
        // Two plates at z = 0.5 and z = 1; a ray down from z = 2 meets z = 1 first.
        let mut tris = quad(0.5, true);
        tris.extend(quad(1.0, false));
        let occ = Occluders::from_triangles(&tris);
        let o = dvec3(0.3, 0.6, 2.0);
        let hit = occ
            .closest_hit(o, dvec3(0.0, 0.0, -3.0), 0.0, f64::INFINITY)
            .expect("the ray crosses both plates");
        // f32 traversal: distances good to a few ulps of the scene size.
        assert!((hit.distance - 1.0).abs() < 1e-5, "{hit:?}");
        assert!(hit.triangle >= 2, "{hit:?}");
        let [a, b, c] = tris[hit.triangle as usize];
        let p = a + (b - a) * f64::from(hit.u) + (c - a) * f64::from(hit.v);
        assert!((p - dvec3(0.3, 0.6, 1.0)).length() < 1e-5, "{p}");
        // Nothing within 0.9, and nothing at all beside the plates.
        assert!(occ.closest_hit(o, -DVec3::Z, 0.0, 0.9).is_none());
        assert!(
            occ.closest_hit(dvec3(3.0, 0.0, 2.0), -DVec3::Z, 0.0, 10.0)
                .is_none()
        );
    }

    /// The 12 triangles of the box `lo`–`hi`, facing out (or in, for a room).
    fn boxed(lo: DVec3, hi: DVec3, out: bool) -> Vec<[DVec3; 3]> {
        let mid = (lo + hi) * 0.5;
        let mut tris = Vec::new();
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |a: f64, b: f64| {
                    let mut p = DVec3::ZERO;
                    p[axis] = side;
                    p[u] = a;
                    p[v] = b;
                    p
                };
                let q = [
                    corner(lo[u], lo[v]),
                    corner(hi[u], lo[v]),
                    corner(hi[u], hi[v]),
                    corner(lo[u], hi[v]),
                ];
                let n = (q[1] - q[0]).cross(q[2] - q[0]);
                let outward = n.dot(q[0] - mid) > 0.0;
                let [a, b, c, d] = if outward == out {
                    q
                } else {
                    [q[3], q[2], q[1], q[0]]
                };
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
        tris
    }

    #[test]
    fn burial_and_negative_zero_directions() {
        // A room with a box standing on its floor. obvhs's traversal missed every triangle
        // for a direction with a `-0.0` component: straight up from the floor under the box
        // with (-0, 1, -0) met nothing, with (0, 1, 0) the box's top at 2.2.
        let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
        tris.extend(boxed(dvec3(2.8, 0.0, 0.5), dvec3(3.6, 2.2, 1.2), true));
        let occ = Occluders::from_triangles(&tris);
        let x = dvec3(3.2, 0.0, 1.0);
        for d in [dvec3(0.0, 1.0, 0.0), dvec3(-0.0, 1.0, -0.0)] {
            let hit = occ.closest_hit_from_surface(x, d, 100.0);
            let hit = hit.unwrap_or_else(|| panic!("{d:?} met nothing"));
            assert!((hit.distance - 2.2).abs() < 1e-5, "{d:?}: {hit:?}");
        }
        // Buried: the floor under the box (its inside above), whichever sign its normal's
        // zeros carry; the box's bottom (face to face with the floor). Exposed: the floor
        // beside the box, and the box's top.
        assert!(occ.buried(x, dvec3(0.0, 1.0, 0.0)));
        assert!(occ.buried(x, dvec3(-0.0, 1.0, -0.0)));
        assert!(occ.buried(x, dvec3(0.0, -1.0, 0.0)));
        assert!(!occ.buried(dvec3(2.0, 0.0, 2.5), dvec3(-0.0, 1.0, 0.0)));
        assert!(!occ.buried(dvec3(3.2, 2.2, 1.0), DVec3::Y));
        // Under an open-bottomed shade 2 wide hung 0.5 above the floor (its inside is its
        // back faces): exposed, the grazing rays leave through the gap (they would need more
        // than 87° under a gap of 0.05).
        let mut shade = boxed(dvec3(0.5, 0.5, 2.0), dvec3(2.5, 1.5, 4.0), true);
        shade.retain(|t| t.iter().any(|p| p.y > 0.5));
        let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
        tris.extend(shade);
        let occ = Occluders::from_triangles(&tris);
        assert!(!occ.buried(dvec3(1.5, 0.0, 3.0), DVec3::Y));
        // A two-sided panel (two sheets face to face) in the middle of the room: both sides
        // look out on the room's front faces, neither is buried.
        let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
        let [a, b, c, d] =
            [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)].map(|(x, z)| dvec3(x, 1.5, z));
        tris.extend([[a, b, c], [a, c, d], [a, c, b], [a, d, c]]);
        let occ = Occluders::from_triangles(&tris);
        assert!(!occ.buried(dvec3(2.0, 1.5, 2.0), DVec3::Y));
        assert!(!occ.buried(dvec3(2.0, 1.5, 2.0), -DVec3::Y));
    }

    #[test]
    fn a_panels_sheets_out_of_order_show_the_near_front() {
        // A two-sided panel over the floor of a room, modelled as in the conference room: the
        // sheet facing up (+y) lies 1e-5 *below* the sheet facing down, so a ray up from the
        // floor meets the back of the upper-facing sheet first. What it sees is the panel's
        // underside; `reaches` already said so for a ray toward it, the closest hit does not.
        let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
        let sheet =
            |y: f64| [(1.0, 1.0), (3.0, 1.0), (3.0, 3.0), (1.0, 3.0)].map(|(x, z)| dvec3(x, y, z));
        let [a, b, c, d] = sheet(1.5 - 1e-5);
        tris.extend([[a, c, b], [a, d, c]]); // facing +y
        let [a, b, c, d] = sheet(1.5 + 1e-5);
        let under = tris.len() as u32;
        tris.extend([[a, b, c], [a, c, d]]); // facing -y
        let occ = Occluders::from_triangles(&tris);
        let x = dvec3(2.0, 0.0, 2.0);
        let back = occ.closest_hit_from_surface(x, DVec3::Y, 10.0).unwrap();
        assert!(back.triangle < under, "{back:?}");
        let (hit, front) = occ.first_surface_from_surface(x, DVec3::Y, 10.0).unwrap();
        assert!(front && hit.triangle >= under, "{hit:?} {front}");
        assert!((hit.distance - 1.5).abs() < 1e-4, "{hit:?}");
        assert!(occ.reaches(x, dvec3(2.0, 1.5 + 1e-5, 2.0), under));
        // From the camera's side too, and from above: the top sheet's front.
        let (_, front) = occ
            .first_surface(x + DVec3::Y * 0.1, DVec3::Y, 0.0, 10.0)
            .unwrap();
        assert!(front);
        let (hit, front) = occ
            .first_surface_from_surface(dvec3(2.0, 3.0, 2.0), -DVec3::Y, 10.0)
            .unwrap();
        assert!(front && hit.triangle < under, "{hit:?}");
        // A lone back face stays a back face: the room seen from outside.
        let (_, front) = occ
            .first_surface(dvec3(2.0, -1.0, 2.0), DVec3::Y, 0.0, 10.0)
            .unwrap();
        assert!(!front);
    }

    #[test]
    fn parts_in_contact_exchange_nothing() {
        // A block resting on the floor of a room 7 across with a gap of 2e-7 (2.8e-8 of the
        // extent: above the 1e-9 within which a plane holds a point, below the f32 steps of
        // the BVH, as parts modelled against each other come out of f32 files). The floor
        // under it and the block's bottom face each other in contact: buried, and a
        // visibility ray between them finds nothing, as the burial test decides. Before,
        // `reaches` let the pair exchange F ≈ 1 over the contact while burial took that area
        // out of the patches: rows over the exposed part up to 2.3 in the conference room.
        let gap = 2e-7;
        let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
        let bottom = tris.len() as u32;
        tris.extend(boxed(dvec3(1.0, gap, 1.0), dvec3(2.0, 1.0, 2.0), true));
        let occ = Occluders::from_triangles(&tris);
        let (x, y) = (dvec3(1.3, 0.0, 1.6), dvec3(1.3, gap, 1.6));
        let (on_floor, on_bottom) = (dvec3(1.35, 0.0, 1.62), dvec3(1.35, gap, 1.62));
        let holding = |range: core::ops::Range<u32>, p: DVec3| {
            range
                .clone()
                .find(|&t| {
                    let c = tris[t as usize];
                    c.iter().all(|q| q.y == p.y) && inside_by(&c, p, 0.0)
                })
                .unwrap()
        };
        let floor = holding(0..bottom, on_floor);
        let bottom = holding(bottom..tris.len() as u32, on_bottom);
        assert!(!occ.reaches(x, on_bottom, bottom));
        assert!(!occ.reaches(y, on_floor, floor));
        assert!(occ.buried(x, DVec3::Y));
        assert!(occ.buried(y, -DVec3::Y));
        let (_, front) = occ.first_surface_from_surface(x, DVec3::Y, 10.0).unwrap();
        assert!(!front);
        // Beside the block the floor is exposed and sees the block's side.
        assert!(!occ.buried(dvec3(2.5, 0.0, 1.5), DVec3::Y));
        // Raised by 1e-3 (1.4e-4 of the extent, far above f32 rounding) it is a real gap:
        // the floor under the block sees its bottom.
        let mut tris = boxed(DVec3::ZERO, dvec3(4.0, 3.0, 5.0), false);
        tris.extend(boxed(dvec3(1.0, 1e-3, 1.0), dvec3(2.0, 1.0, 2.0), true));
        let occ = Occluders::from_triangles(&tris);
        let (hit, front) = occ.first_surface_from_surface(x, DVec3::Y, 10.0).unwrap();
        assert!(front && (hit.distance - 1e-3).abs() < 1e-5, "{hit:?}");
        assert!(!occ.buried(x, DVec3::Y));
    }
}
