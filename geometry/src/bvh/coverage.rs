//! Partial coverage (glTF `alphaMode`): triangles that are only partly there let rays through
//! by their share ([`Occluders::with_coverage`]), and shadow segments take the light through
//! them ([`Occluders::segment_transmittance`]).

use super::{LOCAL_EXTENT, Occluders, ray_direction};
use glam::DVec3;
use obvhs::ray::Ray;

/// Which triangles of partial coverage a traversal lets a ray through.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Sieve {
    /// Each by its hash ([`Occluders::passes`]).
    Hash,
    /// Each by its hash except this one (the target of [`Occluders::reaches`]: met always).
    HashExcept(u32),
    /// Every one: a surface with holes buries nothing ([`Occluders::buried`]).
    All,
}

/// Uniform in `[0, 1)` from a ray (its local origin and direction, bit for bit) and a
/// triangle: SplitMix64's finaliser over the words folded together, so the same ray asks the
/// same question of a triangle every time it is traced ([`Occluders::facing_sheet`]
/// re-traces a ray) and different rays ask independently.
fn ray_hash(ray: &Ray, triangle: u32) -> f32 {
    let words = [
        ray.origin.x,
        ray.origin.y,
        ray.origin.z,
        ray.direction.x,
        ray.direction.y,
        ray.direction.z,
    ];
    let mut h = u64::from(triangle).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    for w in words {
        h = (h ^ u64::from(w.to_bits())).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h ^= h >> 29;
    }
    h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    h ^= h >> 31;
    (h >> 40) as f32 / (1u64 << 24) as f32
}

impl Occluders {
    /// Gives each triangle (by its index in the list given) its coverage c: the fraction of
    /// its area that is there, in (0, 1]. Rays meet a triangle of c < 1 with probability c
    /// ([`Self::passes`]); [`Self::segment_transmittance`] takes `1 − c` of the light
    /// through. An empty list, or one of only 1s, keeps every triangle opaque.
    ///
    /// # Panics
    /// If `coverage` is neither empty nor one value per triangle.
    #[must_use]
    pub fn with_coverage(mut self, coverage: Vec<f32>) -> Self {
        assert!(
            coverage.is_empty() || coverage.len() == self.slot.len(),
            "one coverage per triangle"
        );
        self.coverage = if coverage.iter().all(|&c| c >= 1.0) {
            Vec::new()
        } else {
            coverage
        };
        self
    }

    /// The coverage of triangle `t` (its index in the list given): 1 unless
    /// [`Self::with_coverage`] said less.
    pub fn coverage(&self, t: u32) -> f32 {
        self.coverage.get(t as usize).copied().unwrap_or(1.0)
    }

    /// Whether `ray` (local coordinates) goes through triangle `t`, which it meets, rather than
    /// stopping there: with probability `1 − c` by [`ray_hash`]; never for an opaque one.
    pub(super) fn passes(&self, t: u32, ray: &Ray) -> bool {
        !self.coverage.is_empty() && {
            let c = self.coverage(t);
            c < 1.0 && ray_hash(ray, t) >= c
        }
    }

    /// Whether `sieve` lets `ray` through triangle `t`, which it meets.
    pub(super) fn sifts(&self, sieve: Sieve, t: u32, ray: &Ray) -> bool {
        match sieve {
            Sieve::Hash => self.passes(t, ray),
            Sieve::HashExcept(target) => t != target && self.passes(t, ray),
            Sieve::All => self.coverage(t) < 1.0,
        }
    }

    /// The fraction of light that crosses the open segment `a`–`b` (ends excluded as in
    /// [`Self::segment_visible`]): 0 if an opaque triangle lies across it, else the product of
    /// `1 − c` over the triangles of partial coverage c it crosses (1 when it meets none). The
    /// runtime's shadow rays: a sun behind a half-covered sheet gives half its light, with no
    /// noise from the hash [`Self::segment_visible`] uses.
    pub fn segment_transmittance(&self, a: DVec3, b: DVec3) -> f64 {
        if self.rt.is_empty() {
            return 1.0;
        }
        let d = (b - a) * self.scale;
        let len = d.length();
        let margin = (1e-4 * len).max(1e-6 * LOCAL_EXTENT);
        if len <= 2.0 * margin {
            return 1.0;
        }
        let ray = Ray::new(
            self.local(a),
            ray_direction(d / len),
            margin as f32,
            (len - margin) as f32,
        );
        let mut through = 1.0f64;
        let missed = self.cw.ray_traverse_miss(ray, |r, id| {
            let d = self.rt[id].intersect(r);
            let c = self.coverage(self.cw.primitive_indices[id]);
            if d < f32::INFINITY && c < 1.0 {
                through *= 1.0 - f64::from(c);
                f32::INFINITY
            } else {
                d
            }
        });
        if missed { through } else { 0.0 }
    }
}
