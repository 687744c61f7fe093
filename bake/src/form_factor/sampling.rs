//! Where shadow rays go: deterministic points on polygons, kernel-distributed ray ends, and
//! the systematic sampling that spreads a pair's rays over its contributions.

use crate::geometry::polygon::Polygon;
use crate::patch::Piece;
use crate::rng::SplitMix64;
use glam::DVec3;

/// Points on a polygon for shadow rays: the `k`-th point of a deterministic low-discrepancy
/// sequence (Roberts' R3), mapped to the fan triangles by area.
fn polygon_point(v: &[DVec3], k: u64) -> DVec3 {
    const G: f64 = 1.220_744_084_605_759_5; // plastic-like constant for 3-D
    let a = [1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G)];
    let u = [0, 1, 2].map(|d| (0.5 + a[d] * (k as f64 + 1.0)).fract());
    let m = v.len();
    let mut total = 0.0;
    for i in 1..m - 1 {
        total += (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
    }
    let mut pick = u[0] * total;
    let mut i = 1;
    while i < m - 2 {
        let w = (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
        if pick < w {
            break;
        }
        pick -= w;
        i += 1;
    }
    let (mut s, mut t) = (u[1], u[2]);
    if s + t > 1.0 {
        s = 1.0 - s;
        t = 1.0 - t;
    }
    v[0] + (v[i] - v[0]) * s + (v[i + 1] - v[0]) * t
}

/// Systematic sampling in proportion to weights that arrive one at a time (and sum to the
/// `total` given): `budget` evenly spaced positions along their running sum, from an offset set
/// by `seed`, and one visibility test for each. `total · visible / drawn` is unbiased for
/// `Σ g·V`, and a weight larger than `total / budget` is drawn at least `⌊g · budget / total⌋`
/// times. Exact pairs feed their stored contributions; clustered pairs recompute theirs and
/// skip, with [`Self::idle_until`] and [`Self::skip_to`], the stretches where no position falls.
pub(super) struct Systematic {
    step: f64,
    next: f64,
    run: f64,
    budget: u64,
    pub(super) drawn: u64,
    hits: u64,
}

impl Systematic {
    pub(super) fn new(total: f64, budget: usize, seed: u64) -> Self {
        let step = total / budget.max(1) as f64;
        Self {
            step,
            next: (0.5 + seed as f64 * 0.618_033_988_749_895).fract() * step,
            run: 0.0,
            budget: budget as u64,
            drawn: 0,
            hits: 0,
        }
    }

    /// The next weight: `visible(draw)` for each position that falls in it. With `last`, also
    /// the positions that rounding left past the final running sum (they belong to it), so a
    /// caller that numbers its rays by draw gets every number at any scale of the weights.
    pub(super) fn feed(&mut self, g: f64, last: bool, mut visible: impl FnMut(u64) -> bool) {
        self.run += g;
        while self.drawn < self.budget && (self.next < self.run || last) {
            self.hits += visible(self.drawn) as u64;
            self.drawn += 1;
            self.next += self.step;
        }
    }

    /// Whether no position falls before `end` of the running sum.
    pub(super) fn idle_until(&self, end: f64) -> bool {
        self.next >= end || self.drawn >= self.budget
    }

    /// Moves the running sum to `end`, over weights in which no position falls.
    pub(super) fn skip_to(&mut self, end: f64) {
        self.run = end;
    }

    /// `total · visible / drawn`.
    pub(super) fn estimate(&self, total: f64) -> f64 {
        total * self.hits as f64 / self.drawn.max(1) as f64
    }
}

/// Where a shadow ray from `x` (a point of source piece `s`) to target piece `t` ends: a point
/// of `t` drawn in proportion to the exchange kernel from `x`, `cos θ_x cos θ_t / (π r²) dA`,
/// which is the cosine-weighted direction from `x` restricted to the solid angle of `t`. So
/// one ray per source point and target piece is an unbiased sample of the visibility that the
/// kernel weighs. A point drawn uniformly over `t` instead ([`front_point`]) missed where
/// the kernel lives when `x` sits close to a large piece: in the conference room small parts a
/// few tenths of a unit in front of a 1000-unit panel saw it only through far points hidden
/// by other furniture, rows of F came out at 0.2 where hemisphere rays from the same patch
/// find 1.0, and rows over 1 where the near part is hidden and the far part not.
///
/// Drawn by rejection: directions uniform in a cone around `x` that holds `t` (around the
/// centroid, or the half-space towards `t`'s plane when that is narrower), kept when they
/// meet `t` and with probability `cos θ_x`. [`front_point`] after `KERNEL_TRIES` misses (a
/// grazing source, where the kernel is small anyway).
pub(super) fn ray_end(x: DVec3, s: &Piece, t: &Piece, k: u64) -> DVec3 {
    // Seeded by the draw and the pieces' triangles, never by coordinates: the same scene at
    // another scale draws the same rays (`results_do_not_depend_on_the_scale`).
    let seed = k ^ u64::from(s.triangle) << 40 ^ u64::from(t.triangle) << 20;
    kernel_point(x, s.normal, &t.polygon, t.normal, seed).unwrap_or_else(|| front_point(t, s, k))
}

/// Whether `x` lies strictly in front of piece `t`'s plane, where `t` can be seen from. A
/// visibility ray starts anywhere on its quadrature leaf (`Sample::leaf_point`), and the part
/// of a leaf behind the target's plane (a floor leaf reaching under a block whose side is the
/// target) sees the target from behind: its ray would meet the target first and count.
pub(super) fn in_front(x: DVec3, t: &Piece) -> bool {
    t.normal.dot(x - t.polygon.vertices()[0]) > 0.0
}

/// Proposals [`ray_end`] tries before it falls back to a uniform point.
const KERNEL_TRIES: u32 = 64;

/// The kernel-distributed point of [`ray_end`] for random stream `seed`, or `None` when `x`
/// is not in front of the polygon's plane or no proposal was kept.
fn kernel_point(x: DVec3, ns: DVec3, poly: &Polygon, nt: DVec3, seed: u64) -> Option<DVec3> {
    let v = poly.vertices();
    let height = nt.dot(x - v[0]);
    if !(height > 0.0) {
        return None;
    }
    // The narrower of two cones holding every direction from x to the polygon: around the
    // centroid's direction out to the farthest corner, or the half-space facing the plane.
    let centre = (poly.centroid() - x).normalize();
    let cos_corner = v
        .iter()
        .map(|c| centre.dot((*c - x).normalize()))
        .fold(1.0f64, f64::min);
    let (axis, cos_max) = if cos_corner > 0.0 {
        (centre, cos_corner)
    } else {
        (-nt, 0.0)
    };
    let (u, w) = axis.any_orthonormal_pair();
    let mut rng = SplitMix64(seed);
    for _ in 0..KERNEL_TRIES {
        let cos_t = 1.0 - rng.next_f64() * (1.0 - cos_max);
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * rng.next_f64();
        let d = axis * cos_t + (u * phi.cos() + w * phi.sin()) * sin_t;
        let cos_x = ns.dot(d);
        let toward = -nt.dot(d);
        if !(cos_x > 0.0 && toward > 0.0) || rng.next_f64() >= cos_x {
            continue;
        }
        let y = x + d * (height / toward);
        let inside = (0..v.len()).all(|i| {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            (b - a).cross(y - a).dot(nt) >= 0.0
        });
        if inside {
            return Some(y);
        }
    }
    None
}

/// A point of piece `p` (the `k`-th of [`polygon_point`]) in front of the plane of `other`:
/// drawn from the part of `p` in front of it when the first draw is not, the centre of `p` when
/// that part has no area.
pub(super) fn front_point(p: &Piece, other: &Piece, k: u64) -> DVec3 {
    let v = p.polygon.vertices();
    let y = polygon_point(v, k);
    let offset = other.normal.dot(other.polygon.vertices()[0]);
    if other.normal.dot(y) > offset {
        return y;
    }
    let front = p.polygon.clip(other.normal, offset, 0.0);
    if front.len() >= 3 {
        polygon_point(front.vertices(), k)
    } else {
        p.polygon.centroid()
    }
}
