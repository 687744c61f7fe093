//! Occlusion over the full-detail triangles: an obvhs CWBVH (8-wide, compressed) for segment
//! (shadow-ray) and closest-hit queries, and a BVH2 for the box queries that find which
//! triangles could possibly block light between two surfaces.
//!
//! Every triangle blocks from both sides (`docs/contract.md`): the intersection test does not cull back
//! faces. Coordinates are stored in f32 relative to the scene centre and scaled to one extent
//! ([`LOCAL_EXTENT`]), so a scene far from the origin loses no precision and one of any size
//! looks the same to obvhs, whose CWBVH has an absolute epsilon.

use glam::{DVec3, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::{build_cwbvh, build_cwbvh_from_tris};
use obvhs::ray::Ray;
use obvhs::triangle::Triangle as BvhTriangle;
use std::time::Duration;

mod blockers;
mod burial;
mod coverage;

use coverage::Sieve;

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
    /// Each of [`Self::rt`]'s triangles' own (unpadded) box, for [`NEAR`] (robust only).
    tight: Vec<Aabb>,
    /// Whether rays are answered independently of the tree's shape ([`Self::robust`]).
    robust: bool,
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
    /// Whether each triangle (by its index in the list given) emits, for [`Self::reaches`]'s
    /// ties: empty when built from bare corners (nothing emits).
    emits: Vec<bool>,
    /// The emitting triangles drawn in the plane of each non-emitting one they overlap, facing
    /// the same way (a light on the ceiling): they cover it ([`Self::covered`]).
    covers: std::collections::HashMap<u32, Vec<u32>>,
    /// Whether each triangle (by its index in the list given) has a twin: a triangle of the
    /// same three corners wound the other way, the back of a two-sided sheet (glTF
    /// `doubleSided`, or two sheets modelled back to back). A twin never buries its sheet
    /// ([`Self::buried`]).
    twinned: Vec<bool>,
    /// Each triangle's coverage c in (0, 1] (by its index in the list given): the fraction of
    /// its area that is there (glTF `alphaMode` MASK and BLEND). A ray meets a triangle of
    /// coverage below 1 with probability c, decided by a hash of the ray and the triangle
    /// ([`Self::passes`]); empty when every triangle is opaque.
    coverage: Vec<f32>,
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

/// obvhs enters no box that the ray leaves within this of its origin (`cwbvh::node::EPSILON`,
/// local units): a triangle whose own box the ray leaves that near stays unmet, as it was with
/// tight leaves, whatever [`PAD`] adds to its leaf.
const NEAR: f32 = 1e-4;

/// Padding of each triangle's box in the ray tree, in local units: about 12 f32 ulps at the
/// edge of the local frame (0.004 there), a millionth of the scene's diagonal.
const PAD: f32 = 0.05;

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

/// Whether each triangle has a twin among `tris`: the same three corners (exactly) wound the
/// other way.
fn twins(tris: &[[DVec3; 3]]) -> Vec<bool> {
    let key = |p: DVec3| p.to_array().map(f64::to_bits);
    // Corners sorted, with the winding's parity: a twin has the same corners, the other parity.
    let mut seen: std::collections::HashMap<[[u64; 3]; 3], [Vec<u32>; 2]> = Default::default();
    for (i, t) in tris.iter().enumerate() {
        let mut k = t.map(key);
        // Rotating a triangle's corners keeps its winding; its smallest corner first, then the
        // order of the other two is the winding.
        let first = (0..3).min_by_key(|&c| k[c]).expect("three corners");
        k.rotate_left(first);
        let parity = usize::from(k[1] > k[2]);
        if parity == 1 {
            k.swap(1, 2);
        }
        seen.entry(k).or_default()[parity].push(i as u32);
    }
    let mut out = vec![false; tris.len()];
    for [a, b] in seen.values() {
        if !a.is_empty() && !b.is_empty() {
            for &i in a.iter().chain(b) {
                out[i as usize] = true;
            }
        }
    }
    out
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

/// How many faces deep [`Occluders::buried`] follows front faces met inside a solid: a point
/// on the ground under the lowest of three nested step boxes sees the second's front face,
/// inside the lowest, and from there the third's (`docs/decisions/shaded-steps.md`).
const BURIED_DEPTH: u32 = 3;

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
    /// Builds the BVH over triangles given by their corners, `emits[t]` saying whether
    /// triangle `t` emits (for [`Self::reaches`]'s ties and [`Self::covered`]). The bake builds
    /// it from its scene (`Scene::occluders`); [`Self::from_triangles`] is the same with
    /// nothing emitting.
    ///
    /// # Panics
    /// If `emits` is not one flag per triangle.
    pub fn with_emitters(tris: &[[DVec3; 3]], emits: Vec<bool>) -> Self {
        assert_eq!(emits.len(), tris.len(), "one emission flag per triangle");
        let mut occ = Self::from_triangles(tris);
        occ.emits = emits;
        occ.covers = occ.find_covers();
        occ
    }

    /// The same occluders with the ray tree's answer independent of its shape, so that the
    /// trees of two scenes that differ elsewhere answer a ray that meets nothing of the
    /// difference alike (a planned bake's rebake relies on it, `bake::plan::reuse`): each
    /// leaf's box padded by [`PAD`] (a ray that meets a triangle at its edge, where a tight box
    /// could lose it to f32 rounding, visits it), a triangle whose own box the ray leaves
    /// within [`NEAR`] of its origin not met (what the tight leaves did), and a tie at one
    /// distance going to the face turned to the ray, then to the lower triangle index
    /// ([`Self::before`]). A bake without a plan keeps the plain tree.
    pub fn robust(mut self) -> Self {
        if self.rt.is_empty() || self.robust {
            self.robust = true;
            return self;
        }
        let (origin, scale) = (self.origin, self.scale);
        let bt: Vec<BvhTriangle> = (0..self.slot.len() as u32)
            .map(|t| {
                let c = self.given(t);
                BvhTriangle {
                    v0: to_local(c[0], origin, scale),
                    v1: to_local(c[1], origin, scale),
                    v2: to_local(c[2], origin, scale),
                }
            })
            .collect();
        let boxes: Vec<Aabb> = bt
            .iter()
            .map(|t| {
                let b = t.aabb();
                Aabb::new(b.min - Vec3A::splat(PAD), b.max + Vec3A::splat(PAD))
            })
            .collect();
        let params = BvhBuildParams::medium_build();
        self.cw = build_cwbvh(&boxes, params, &mut Duration::default());
        let prims = &self.cw.primitive_indices;
        self.rt = prims
            .iter()
            .map(|&i| RayTriangle::new(&bt[i as usize]))
            .collect();
        self.tight = prims.iter().map(|&i| bt[i as usize].aabb()).collect();
        self.robust = true;
        self
    }

    /// For [`Self::covers`]: each emitting triangle against the triangles near its box, kept
    /// where the other does not emit, faces the same way and its plane holds the emitter's
    /// corners (within 1e-9 of the extent).
    fn find_covers(&self) -> std::collections::HashMap<u32, Vec<u32>> {
        let mut covers: std::collections::HashMap<u32, Vec<u32>> = Default::default();
        let tol = 1e-9 * self.extent;
        for e in (0..self.emits.len()).filter(|&e| self.emits[e]) {
            let c = *self.given(e as u32);
            let (lo, hi) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
            let pad = Vec3A::splat((1e-6 * LOCAL_EXTENT) as f32);
            let bx = Aabb::new(self.local(lo) - pad, self.local(hi) + pad);
            let front = self.front(e as u32);
            self.bvh.aabb_traverse(bx, |bvh, node_index| {
                let node = &bvh.nodes[node_index as usize];
                for k in node.first_index..node.first_index + node.prim_count {
                    let t = bvh.primitive_indices[k as usize];
                    if self.emits(t) || self.front(t).dot(front) <= 0.0 {
                        continue;
                    }
                    if c.iter().all(|p| self.plane_distance(t, *p) <= tol) {
                        covers.entry(t).or_default().push(e as u32);
                    }
                }
                true
            });
        }
        covers
    }

    /// Whether the point `x` of triangle `own` (its index in the list given) lies under an
    /// emitter drawn in its plane ([`Self::covers`]): that part of the surface is hidden
    /// behind the light, as a surface under a block is buried.
    pub fn covered(&self, own: u32, x: DVec3) -> bool {
        // Every ray of F that reaches its target asks: most scenes have no such pair.
        !self.covers.is_empty()
            && self.covers.get(&own).is_some_and(|list| {
                list.iter()
                    .any(|&e| inside_by(self.given(e), x, 1e-9 * self.extent))
            })
    }

    /// Whether triangle `t` (its index in the list given) emits.
    fn emits(&self, t: u32) -> bool {
        self.emits.get(t as usize).copied().unwrap_or(false)
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
            tight: Vec::new(),
            robust: false,
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
            emits: Vec::new(),
            covers: Default::default(),
            twinned: twins(tris),
            coverage: Vec::new(),
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

    /// The f32 frame of the BVH: its origin and local units per scene unit. Two BVHs of
    /// the same frame give a ray the same f32 coordinates.
    pub fn frame(&self) -> (DVec3, f64) {
        (self.origin, self.scale)
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
            let t = self.cw.primitive_indices[id];
            if skip(t) {
                return f32::INFINITY;
            }
            let d = self.rt[id].intersect(r);
            if d < f32::INFINITY && self.passes(t, r) {
                f32::INFINITY
            } else {
                d
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
        self.closest_hit_passing(origin, direction, t_min, t_max, &|_| false, Sieve::Hash)
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
        self.closest_hit_passing(
            origin,
            direction,
            0.0,
            t_max,
            &|t| self.holds(t, origin),
            Sieve::Hash,
        )
    }

    /// [`Self::closest_hit_from_surface`] from a point on a surface that was stored in f32 (a
    /// file's mesh samples): it passes through every triangle whose plane lies within the
    /// point's own rounding, `ε_f32·|origin|` (twice the half step of each coordinate) beyond
    /// the 1e-9 of the extent. On an axis-aligned face the rounding leaves the point on its
    /// plane; on a tilted one it moves the point off it by up to `0.5·ε_f32·|origin|`, and
    /// within 1e-9 of the extent alone about half of a tilted face's points started under their
    /// own surface and met it at once (a roof at 30° kept half its sky).
    pub fn closest_hit_from_stored_point(
        &self,
        origin: DVec3,
        direction: DVec3,
        t_max: f64,
    ) -> Option<Hit> {
        let tol = 1e-9 * self.extent + f64::from(f32::EPSILON) * origin.length();
        self.closest_hit_passing(
            origin,
            direction,
            0.0,
            t_max,
            &|t| self.plane_distance(t, origin) <= tol,
            Sieve::Hash,
        )
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
        let (hit, front) = self.facing_sheet(
            origin,
            direction,
            hit,
            &|t| self.holds(t, origin),
            Sieve::Hash,
        );
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
        Some(self.facing_sheet(origin, direction, hit, &|_| false, Sieve::Hash))
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
        sieve: Sieve,
    ) -> (Hit, bool) {
        if self.front(hit.triangle).dot(direction) < 0.0 {
            return (hit, true);
        }
        let near = hit.distance * (1.0 - SHEET_GAP);
        let far = hit.distance * (1.0 + SHEET_GAP);
        let sheet = self.closest_hit_passing(
            origin,
            direction,
            near,
            far,
            &|t| pass(t) || self.front(t).dot(direction) >= 0.0,
            sieve,
        );
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
        sieve: Sieve,
    ) -> Option<Hit> {
        let len = direction.length();
        if self.rt.is_empty() || !(len > 0.0) || !len.is_finite() {
            return None;
        }
        let dir = ray_direction(direction / len);
        let o = self.local(origin);
        let t_max = (t_max * self.scale).min(f64::from(f32::MAX));
        let ray = Ray::new(o, dir, (t_min * self.scale) as f32, t_max as f32);
        let (id, t) = self.first_hit(ray, pass, sieve)?;
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
    /// local distance. `pass` is asked only about triangles the ray meets; `sieve` says which
    /// triangles of partial coverage it goes through.
    fn first_hit(
        &self,
        ray: Ray,
        pass: &dyn Fn(u32) -> bool,
        sieve: Sieve,
    ) -> Option<(usize, f32)> {
        let mut hit = obvhs::ray::RayHit::none();
        let prims = &self.cw.primitive_indices;
        if !self.robust {
            return self
                .cw
                .ray_traverse(ray, &mut hit, |r, id| {
                    let t = self.rt[id].intersect(r);
                    if t < f32::INFINITY && (pass(prims[id]) || self.sifts(sieve, prims[id], r)) {
                        f32::INFINITY
                    } else {
                        t
                    }
                })
                .then_some((hit.primitive_id as usize, hit.t));
        }
        // Robust ([`Self::robust`]): the nearest hit, a tie at one distance (a ray through an edge two triangles share,
        // the two sheets of a panel modelled face to face) going to the face turned to the
        // ray, then to the lower triangle index ([`Self::before`]), so that the answer does
        // not depend on the order the tree visits them in: trees built over scenes that differ
        // elsewhere agree (`plan::reuse` relies on it). The padded leaves ([`PAD`]) make sure
        // every triangle the ray meets is visited.
        let dir = DVec3::from(Vec3::from(ray.direction));
        let best = std::cell::Cell::new((ray.tmax, u32::MAX, usize::MAX));
        self.cw.ray_traverse(ray, &mut hit, |r, id| {
            let t = self.rt[id].intersect(r);
            // A triangle whose own box the ray leaves within obvhs's node epsilon of its
            // origin: its tight leaf was never entered before the padding, so it stays hidden.
            if t < f32::INFINITY && self.leaves_near(id, r) {
                return f32::INFINITY;
            }
            if t < f32::INFINITY {
                if pass(prims[id]) || self.sifts(sieve, prims[id], r) {
                    return f32::INFINITY;
                }
                let (bt, bp, _) = best.get();
                if t < bt || (t == bt && bp != u32::MAX && self.before(prims[id], bp, dir)) {
                    best.set((t, prims[id], id));
                }
            }
            t
        });
        let (t, p, id) = best.get();
        (p != u32::MAX).then_some((id, t))
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
    /// `target`, reaches it: the first triangle it meets is `target` (and `to` is not
    /// [`Self::covered`]), or there is none before `to`, or the one met at `to` (within 1e-4
    /// of the distance) is not a copy of the target in front of it (see the body; an emitting
    /// target wins that tie over a face that does not emit). Triangles whose planes hold `from` are passed through
    /// (as in [`Self::closest_hit_from_surface`]), so the ray starts on the surface itself.
    /// The closest-hit question of a hemisphere ray, asked of one point: unlike
    /// [`Self::segment_visible`] it needs no margin at either end, so a surface just in front
    /// of the target (a second layer of a modelled panel) hides it, and one a hair in front of
    /// the start (two parts in contact, modelled 5e-4 apart in a room 3300 across) is met, not
    /// stepped over (`docs/decisions/rays-from-the-surface.md`).
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
        let Some((id, t)) =
            self.first_hit(ray, &|t| self.holds(t, from), Sieve::HashExcept(target))
        else {
            return true;
        };
        let met = self.cw.primitive_indices[id];
        if met == target {
            // Met whatever its coverage: the form factors scale by the target's coverage
            // themselves, on both sides of a pair (`form_factor::coverage`); triangles of
            // partial coverage on the way pass their share of the rays.
            return !self.covered(target, to);
        }
        if f64::from(t) < len * (1.0 - SHEET_GAP) {
            return false;
        }
        // Met at the target's own distance: a neighbour of the target (a point within rounding
        // of its edge), the back of a two-sided panel, or a coincident copy of the target
        // (a surface modelled twice). Only the copy stands in front of it, so that the two
        // together count once: a triangle that faces the ray, with `to` well inside the target.
        // An emitter drawn in the plane of a surface it overlaps (a light on the ceiling, as
        // the Cornell page gives it) stands in front of that surface: the tie is the
        // emitter's whichever of the two the BVH returns first.
        if self.emits(target) && !self.emits(met) {
            return true;
        }
        let c = self.given(met);
        if (c[1] - c[0]).cross(c[2] - c[0]).dot(to - from) >= 0.0 {
            return true;
        }
        let margin = 1e-6 * self.extent;
        !inside_by(self.given(target), to, margin)
    }

    /// Whether `ray` leaves the own box of [`Self::rt`]'s triangle `id` within [`NEAR`] of
    /// its origin.
    fn leaves_near(&self, id: usize, ray: &Ray) -> bool {
        let b = &self.tight[id];
        let t1 = (b.min - ray.origin) * ray.inv_direction;
        let t2 = (b.max - ray.origin) * ray.inv_direction;
        t1.max(t2).min_element() < NEAR
    }

    /// Whether triangle `a` goes before `b` met at the same distance along `dir`: a face
    /// turned to the ray before one turned away, then the lower index.
    fn before(&self, a: u32, b: u32, dir: DVec3) -> bool {
        let away = |t: u32| self.front(t).dot(dir) >= 0.0;
        (away(a), a) < (away(b), b)
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
}

#[cfg(test)]
mod tests;
