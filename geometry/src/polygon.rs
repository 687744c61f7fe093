//! Small convex planar polygons in f64: the pieces a triangle is cut into by the voxel grid,
//! and the clipped targets of the form-factor kernel.

use glam::DVec3;

/// Most vertices a [`Polygon`] holds: a triangle cut by the six faces of a box has at most
/// nine, and one more half-space clip adds one.
pub const MAX_VERTICES: usize = 12;

/// A convex planar polygon with at most [`MAX_VERTICES`] vertices, counter-clockwise about its
/// front normal. Plain value type: no allocation, so kernels can build them in inner loops.
#[derive(Clone, Copy, Debug)]
pub struct Polygon {
    len: usize,
    v: [DVec3; MAX_VERTICES],
}

impl Polygon {
    /// The empty polygon.
    pub const EMPTY: Polygon = Polygon {
        len: 0,
        v: [DVec3::ZERO; MAX_VERTICES],
    };

    /// A triangle.
    pub fn triangle(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let mut p = Self::EMPTY;
        p.push(a);
        p.push(b);
        p.push(c);
        p
    }

    /// A polygon from a slice of at most [`MAX_VERTICES`] points (more is a broken precondition).
    pub fn from_slice(points: &[DVec3]) -> Self {
        assert!(
            points.len() <= MAX_VERTICES,
            "polygon with {} vertices",
            points.len()
        );
        let mut p = Self::EMPTY;
        for &q in points {
            p.push(q);
        }
        p
    }

    /// Appends a vertex (silently ignored when full; clipping never fills it).
    #[inline]
    fn push(&mut self, q: DVec3) {
        if self.len < MAX_VERTICES {
            self.v[self.len] = q;
            self.len += 1;
        }
    }

    /// The vertices.
    #[inline]
    pub fn vertices(&self) -> &[DVec3] {
        &self.v[..self.len]
    }

    /// Number of vertices.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the polygon has fewer than three vertices (encloses no area).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len < 3
    }

    /// Twice the vector area (Newell's method): its direction is the front normal and its length
    /// twice the area. Exact for planar polygons, well defined for slightly warped ones.
    pub fn doubled_area_vector(&self) -> DVec3 {
        doubled_area_vector(self.vertices())
    }

    /// The area-weighted centroid (vertex mean for a degenerate polygon).
    pub fn centroid(&self) -> DVec3 {
        centroid(self.vertices())
    }

    /// The part on the side `n·x - offset >= 0` (Sutherland–Hodgman). Vertices within
    /// `eps` of the plane count as on it and are kept unchanged, so a polygon touching the plane
    /// loses nothing.
    pub fn clip(&self, n: DVec3, offset: f64, eps: f64) -> Polygon {
        let mut out = Polygon::EMPTY;
        let m = self.len;
        if m == 0 {
            return out;
        }
        let d = |p: DVec3| {
            let s = n.dot(p) - offset;
            if s.abs() <= eps { 0.0 } else { s }
        };
        for i in 0..m {
            let a = self.v[i];
            let b = self.v[(i + 1) % m];
            let (da, db) = (d(a), d(b));
            if da >= 0.0 {
                out.push(a);
            }
            if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
                let t = da / (da - db);
                out.push(a + (b - a) * t);
            }
        }
        out
    }

    /// Splits by the plane `p[axis] = value` into (below, above). A polygon lying on the plane,
    /// or touching it from one side, goes whole to one side: nothing is ever counted twice.
    pub fn split(&self, axis: usize, value: f64) -> (Polygon, Polygon) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in self.vertices() {
            lo = lo.min(p[axis] - value);
            hi = hi.max(p[axis] - value);
        }
        if hi <= 0.0 {
            return (*self, Polygon::EMPTY);
        }
        if lo >= 0.0 {
            return (Polygon::EMPTY, *self);
        }
        let mut n = DVec3::ZERO;
        n[axis] = 1.0;
        (self.clip(-n, -value, 0.0), self.clip(n, value, 0.0))
    }
}

/// Twice the vector area of a closed polygon given by its vertices (Newell's method).
pub fn doubled_area_vector(v: &[DVec3]) -> DVec3 {
    let m = v.len();
    if m < 3 {
        return DVec3::ZERO;
    }
    // Relative to the first vertex: the same result, far less cancellation for a small
    // polygon far from the origin.
    let o = v[0];
    let mut s = DVec3::ZERO;
    for i in 1..m - 1 {
        s += (v[i] - o).cross(v[i + 1] - o);
    }
    s
}

/// The area-weighted centroid of a planar polygon (vertex mean when it has no area).
pub fn centroid(v: &[DVec3]) -> DVec3 {
    let m = v.len();
    if m == 0 {
        return DVec3::ZERO;
    }
    let o = v[0];
    let mut acc = DVec3::ZERO;
    let mut w = 0.0;
    for i in 1..m.saturating_sub(1) {
        let a = (v[i] - o).cross(v[i + 1] - o).length();
        acc += (o + v[i] + v[i + 1]) / 3.0 * a;
        w += a;
    }
    if w > 0.0 {
        acc / w
    } else {
        v.iter().copied().sum::<DVec3>() / m as f64
    }
}

/// Distance from point `p` to the closed segment `a`–`b`.
pub fn point_segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let t = if l2 > 0.0 {
        ((p - a).dot(ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

/// Distance from `p` to a convex planar polygon with unit front normal `n`.
pub fn point_polygon_distance(p: DVec3, v: &[DVec3], n: DVec3) -> f64 {
    let m = v.len();
    if m == 0 {
        return f64::INFINITY;
    }
    let h = n.dot(p - v[0]);
    let q = p - n * h;
    // Inside when q is on the inner side of every edge.
    let inside = (0..m).all(|i| {
        let a = v[i];
        let b = v[(i + 1) % m];
        (b - a).cross(q - a).dot(n) >= 0.0
    });
    if inside {
        return h.abs();
    }
    (0..m)
        .map(|i| point_segment_distance(p, v[i], v[(i + 1) % m]))
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::dvec3;

    fn square() -> Polygon {
        Polygon::from_slice(&[
            dvec3(0.0, 0.0, 0.0),
            dvec3(1.0, 0.0, 0.0),
            dvec3(1.0, 1.0, 0.0),
            dvec3(0.0, 1.0, 0.0),
        ])
    }

    #[test]
    fn split_preserves_area_and_never_duplicates() {
        let sq = square();
        let (a, b) = sq.split(0, 0.3);
        let total = a.doubled_area_vector().length() + b.doubled_area_vector().length();
        assert!((total - 2.0).abs() < 1e-14, "split area {total} != 2");
        // A polygon on the splitting plane goes to one side only.
        let (a, b) = sq.split(2, 0.0);
        assert_eq!((a.len(), b.len()), (4, 0));
    }

    #[test]
    fn distance_inside_and_outside() {
        let sq = square();
        let n = DVec3::Z;
        let d = point_polygon_distance(dvec3(0.5, 0.5, 2.0), sq.vertices(), n);
        assert!((d - 2.0).abs() < 1e-15);
        let d = point_polygon_distance(dvec3(2.0, 0.5, 0.0), sq.vertices(), n);
        assert!((d - 1.0).abs() < 1e-15);
    }

    #[test]
    fn centroid_of_square() {
        let c = square().centroid();
        assert!((c - dvec3(0.5, 0.5, 0.0)).length() < 1e-15);
    }
}
