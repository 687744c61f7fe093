//! Burial: whether a point of a surface lies inside a solid or under a face laid against it
//! ([`Occluders::buried`]).

use super::{BURIED_DEPTH, LOCAL_EXTENT, Occluders, coverage::Sieve, ray_direction};
use glam::{DVec3, Vec3A};
use obvhs::ray::Ray;

impl Occluders {
    /// Whether the point `x` of a surface with unit normal `normal` is *buried*: no light can
    /// reach it or leave it because another object covers it. Rays along the normal and 45° and
    /// 80° off it either all first meet back faces (the inside of a block that rests on the
    /// surface or stands through it), or meet no front face while a triangle lies against `x`
    /// face to face (a block's bottom on the floor of a closed room). A front face met by any
    /// of the rays leaves `x` exposed, and the twin of a two-sided sheet (the same corners
    /// wound the other way) lies against it without burying it: a sheet in the open is lit on
    /// both sides.
    ///
    /// A back face with a front face behind it within [`SHEET_GAP`] (what
    /// [`Self::facing_sheet`] shows as the near sheet's front) is also where a solid touches
    /// another: a box standing inside a box with its back against a wall, whose faces lie in the
    /// wall's plane, or on the ground, whose bottom lies in the ground's plane. A ray from
    /// inside the box leaves it there, and its first hit is the box's back face tied with the
    /// wall's front. Such a tie leaves `x` exposed only when no ray meets a plain back face (a
    /// part facing a two-sided panel whose sheets are out of order sees the ties alone); when
    /// every ray meets a back face, tied or not, `x` is inside a solid and buried. (Steps
    /// modelled as boxes from the ground up, each standing inside the one below and all
    /// against a plinth, kept the tops inside the step above and the backs against the plinth
    /// as surface: three fifths of each step's exposed area saw nothing, and the patches that
    /// merged them with the lit strips gave shaded steps up to 10 times the path tracer's
    /// light, `docs/decisions/shaded-steps.md`.)
    pub fn buried(&self, x: DVec3, normal: DVec3) -> bool {
        self.buried_traced(x, normal).0
    }

    /// [`Self::buried`], and whether it asked about other points as well (the front faces it
    /// met, in turn). Where it did not, its answer depends on nothing but the first surfaces
    /// along [`Self::burial_directions`] from `x` and the triangles within a millionth of the
    /// scene of `x`: a rebake keeps it where none of those changed (`plan::reuse`).
    pub fn buried_traced(&self, x: DVec3, normal: DVec3) -> (bool, bool) {
        let recursed = std::cell::Cell::new(false);
        let buried = self.buried_within(x, normal, BURIED_DEPTH, &recursed);
        (buried, recursed.get())
    }

    /// The directions [`Self::buried`] looks along from a point whose surface has `normal`:
    /// the normal and eight directions 45° and 80° off it (not normalised).
    pub fn burial_directions(normal: DVec3) -> [DVec3; 9] {
        let (t1, t2) = normal.any_orthonormal_pair();
        let g = 80f64.to_radians().tan();
        [
            DVec3::ZERO,
            t1,
            -t1,
            t2,
            -t2,
            t1 * g,
            -t1 * g,
            t2 * g,
            -t2 * g,
        ]
        .map(|t| normal + t)
    }

    /// [`Self::buried`]; a front face met where another ray met a plain back face and no ray
    /// left is asked in turn whether it is buried (with `depth − 1`; at depth 0 it is taken as
    /// buried), and if so counts as a back face: the ray met it inside a solid, so `x` lies
    /// inside that solid too.
    fn buried_within(
        &self,
        x: DVec3,
        normal: DVec3,
        depth: u32,
        recursed: &std::cell::Cell<bool>,
    ) -> bool {
        if self.rt.is_empty() || !normal.is_finite() {
            return false;
        }
        // What the surface looks out on: the first hits along the normal and eight directions
        // 45° and 80° off it. A front face met by any of them: exposed.
        let (mut back, mut plain_back, mut tied) = (true, false, false);
        let mut fronts: Vec<(DVec3, DVec3)> = Vec::new();
        for d in Self::burial_directions(normal) {
            // A ray that leaves with a front face met: exposed, whatever the other rays meet.
            let Some(hit) = self.closest_hit_passing(
                x,
                d,
                0.0,
                10.0 * self.extent,
                &|t| self.holds(t, x),
                Sieve::All,
            ) else {
                if !fronts.is_empty() {
                    return false;
                }
                back = false;
                continue;
            };
            let (shown, front) = self.facing_sheet(x, d, hit, &|t| self.holds(t, x), Sieve::All);
            match (front && !self.touches(shown.triangle, x), shown == hit) {
                (true, true) if !back => return false,
                (true, true) => fronts.push((
                    x + d.normalize() * hit.distance,
                    self.front(hit.triangle).normalize_or_zero(),
                )),
                (true, false) => tied = true,
                (false, _) => plain_back = true,
            }
        }
        // A front face met where no ray met a plain back face, or where a ray left: exposed.
        // Where every ray met something and one a plain back face, the front faces may lie
        // inside the solid `x` is in (a box standing inside another: the inner box's faces
        // below the outer one's top), and `x` is buried if they are. Past `depth` faces that
        // is taken as so: faces inside solids see each other in a cycle (the ground under a
        // box sees the front of a box inside it, whose foot sees that ground).
        if !fronts.is_empty() {
            if !(back && plain_back) {
                return false;
            }
            if depth == 0 {
                return true;
            }
            recursed.set(true);
            return fronts
                .iter()
                .all(|&(p, n)| self.buried_within(p, n, depth - 1, recursed));
        }
        // Ties alone (a panel's sheets out of order) or with rays that leave: exposed.
        if tied && !(back && plain_back) {
            return false;
        }
        // Enclosed: every ray meets a back face (or a back face tied with a front, where the
        // solid it leaves touches another). One ray would call a table under a lampshade
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
        let against = |t: u32| {
            !(self.holds(t, x)
                && self.front(t).dot(normal) < 0.0
                && !self.twinned.get(t as usize).copied().unwrap_or(false))
        };
        self.first_hit(ray, &against, Sieve::All).is_some()
    }
}
