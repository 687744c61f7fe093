//! Object-to-object view factors from the full-detail geometry (`radiosity view-factors`).
//!
//! `F_ab = (1/A_a) Σ_{S ⊂ a} Σ_{T ⊂ b} ∫_S F(x → T) V(x, T) dA(x)` over the scene's triangles:
//! - `F(x → T)`: the exact point-to-triangle kernel ([`crate::geometry::point_polygon`]);
//! - `∫_S`: adaptive quadrature over the smaller triangle of each pair (degree-5 rule, halving
//!   until a leaf is small against its distance to the other triangle), so pairs sharing an edge
//!   are resolved down to the edge; each unordered pair is integrated once, which makes
//!   reciprocity exact;
//! - `V(x, T)`: exactly 1, with no ray, for pairs that no triangle can come between
//!   ([`Occluders::may_block`]); otherwise `T` is subdivided around `x` until each part is seen
//!   wholly or not at all by its shadow rays (or a depth limit is reached), and the kernel
//!   of the visible parts is summed. The kernel stays analytic; rays only decide visibility.

use crate::form_factor::{Progress, facing};
use crate::geometry::bvh::Occluders;
use crate::geometry::point_polygon::point_to_polygon;
use crate::geometry::polygon::{Polygon, point_polygon_distance};
use crate::geometry::quadrature::{Adaptive, Rule, integrate};
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Parameters of [`view_factors`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewFactorParams {
    /// Source-side quadrature of the unoccluded exchange (no rays: fine and cheap).
    pub quadrature: Adaptive,
    /// Shadow rays where a blocker is possible; `false` treats every pair as unoccluded.
    pub visibility: bool,
    /// Source-side quadrature of the blocked part (rays at every point: coarser). The blocked
    /// part is subtracted from the exact unoccluded exchange, so its quadrature error only
    /// touches the shadowed share of the factor.
    pub visibility_quadrature: Adaptive,
    /// Target subdivisions always made for a pair with a possible blocker (4^n parts): a
    /// blocker whose shadow falls between the probes of a coarser part would be missed.
    pub min_visibility_depth: u32,
    /// Most subdivisions of a partly visible target part: the shadow boundary is resolved to
    /// about 2^-n of the triangle.
    pub max_visibility_depth: u32,
}

impl Default for ViewFactorParams {
    fn default() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Degree5,
                ratio: 0.5,
                max_depth: 9,
            },
            visibility: true,
            visibility_quadrature: Adaptive {
                rule: Rule::Degree5,
                ratio: 1.0,
                max_depth: 5,
            },
            min_visibility_depth: 2,
            max_visibility_depth: 6,
        }
    }
}

impl ViewFactorParams {
    /// Coarser: about 1% where occluded.
    pub fn fast() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Degree5,
                ratio: 1.0,
                max_depth: 6,
            },
            visibility_quadrature: Adaptive {
                rule: Rule::Degree2,
                ratio: 1.0,
                max_depth: 3,
            },
            min_visibility_depth: 1,
            max_visibility_depth: 4,
            ..Self::default()
        }
    }

    /// Finer: for reference values.
    pub fn high_quality() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Degree5,
                ratio: 0.25,
                max_depth: 12,
            },
            visibility_quadrature: Adaptive {
                rule: Rule::Degree5,
                ratio: 0.5,
                max_depth: 7,
            },
            min_visibility_depth: 3,
            max_visibility_depth: 8,
            ..Self::default()
        }
    }
}

/// The result of [`view_factors`].
#[derive(Clone, Debug, PartialEq)]
pub struct ViewFactors {
    /// Object names, in scene order.
    pub objects: Vec<String>,
    /// Object areas.
    pub areas: Vec<f64>,
    /// `matrix[a][b]` = F from object a to object b.
    pub matrix: Vec<Vec<f64>>,
    /// Shadow rays cast.
    pub rays_cast: u64,
}

impl ViewFactors {
    /// `Σ_b F_ab` for each object a (1 for an object inside a closed enclosure).
    pub fn row_sums(&self) -> Vec<f64> {
        self.matrix.iter().map(|r| r.iter().sum()).collect()
    }
}

struct Ctx<'a> {
    occ: &'a Occluders,
    params: &'a ViewFactorParams,
}

impl Ctx<'_> {
    /// The blocked part of `F(x → T)`: the kernel of the parts of `T` that shadow rays from
    /// `x` do not reach, by adaptive subdivision of `T`.
    fn blocked_factor(
        &self,
        x: DVec3,
        n: DVec3,
        t: [DVec3; 3],
        nt: DVec3,
        depth: u32,
        rays: &mut u64,
    ) -> f64 {
        let poly = Polygon::triangle(t[0], t[1], t[2]);
        let k = point_to_polygon(x, n, &poly, nt);
        if k <= 0.0 {
            return 0.0;
        }
        let m01 = (t[0] + t[1]) * 0.5;
        let m12 = (t[1] + t[2]) * 0.5;
        let m20 = (t[2] + t[0]) * 0.5;
        let children = [
            [t[0], m01, m20],
            [m01, t[1], m12],
            [m20, m12, t[2]],
            [m01, m12, m20],
        ];
        if depth < self.params.min_visibility_depth {
            return children
                .iter()
                .map(|&c| self.blocked_factor(x, n, c, nt, depth + 1, rays))
                .sum();
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        // Probes: the centroid, the corners and the edge midpoints, all pulled 2% towards the
        // centroid (never exactly on an edge shared with a neighbour). A shadow that reaches
        // into the part almost always covers one of the six boundary probes.
        let pull = |p: DVec3| p + (c - p) * 0.02;
        let probes = [
            c,
            pull(t[0]),
            pull(t[1]),
            pull(t[2]),
            pull(m01),
            pull(m12),
            pull(m20),
        ];
        let seen = probes
            .iter()
            .filter(|&&y| self.occ.segment_visible(x, y))
            .count();
        *rays += probes.len() as u64;
        if seen == probes.len() {
            return 0.0;
        }
        if seen == 0 {
            return k;
        }
        if depth >= self.params.max_visibility_depth {
            return k * (probes.len() - seen) as f64 / probes.len() as f64;
        }
        children
            .iter()
            .map(|&c| self.blocked_factor(x, n, c, nt, depth + 1, rays))
            .sum()
    }

    /// `∫_S F(x → T) V dA` for one triangle pair: the exact unoccluded exchange minus the
    /// blocked part where a blocker is possible.
    fn exchange(&self, s: [DVec3; 3], t: [DVec3; 3], rays: &mut u64) -> f64 {
        let ns = (s[1] - s[0]).cross(s[2] - s[0]).normalize();
        let nt = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let tol = 1e-9 * self.occ.extent();
        if !facing(&s, ns, &t, nt, tol) {
            return 0.0;
        }
        let tpoly = Polygon::triangle(t[0], t[1], t[2]);
        let dist = |x: DVec3| point_polygon_distance(x, tpoly.vertices(), nt);
        let mut total = 0.0;
        integrate(s, &self.params.quadrature, &dist, &mut |q| {
            total += q.w * point_to_polygon(q.x, ns, &tpoly, nt);
        });
        if self.params.visibility && self.occ.may_block(&s, ns, &t, nt) {
            let mut blocked = 0.0;
            integrate(s, &self.params.visibility_quadrature, &dist, &mut |q| {
                blocked += q.w * self.blocked_factor(q.x, ns, t, nt, 0, rays);
            });
            total = (total - blocked).max(0.0);
        }
        total
    }
}

/// View factors between the objects of `scene`, from its full-detail triangles. `progress` is
/// told about finished source triangles.
pub fn view_factors(
    scene: &Scene,
    params: &ViewFactorParams,
    progress: Option<Progress<'_>>,
) -> ViewFactors {
    let m = scene.objects.len();
    let nt = scene.triangles.len();
    let occ = scene.occluders();
    let ctx = Ctx { occ: &occ, params };
    let corners: Vec<[DVec3; 3]> = (0..nt).map(|t| scene.corners(t)).collect();
    let area: Vec<f64> = (0..nt).map(|t| scene.triangle_area(t)).collect();
    let done = AtomicUsize::new(0);
    let (exchange, rays_cast) = (0..nt)
        .into_par_iter()
        .fold(
            || (vec![0.0f64; m * m], 0u64),
            |(mut g, mut rays), i| {
                let oi = scene.triangles[i].object as usize;
                for j in i + 1..nt {
                    let oj = scene.triangles[j].object as usize;
                    // Integrate over the smaller triangle; the kernel is exact on the other.
                    let e = if area[i] <= area[j] {
                        ctx.exchange(corners[i], corners[j], &mut rays)
                    } else {
                        ctx.exchange(corners[j], corners[i], &mut rays)
                    };
                    // One exchange serves both directions: A_i F_ij = A_j F_ji. Within one
                    // object both land on the diagonal.
                    g[oi * m + oj] += e;
                    g[oj * m + oi] += e;
                }
                let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                if let Some(p) = progress {
                    p(d, nt);
                }
                (g, rays)
            },
        )
        .reduce(
            || (vec![0.0f64; m * m], 0u64),
            |(mut a, ra), (b, rb)| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x += y;
                }
                (a, ra + rb)
            },
        );
    let areas = scene.object_areas();
    let matrix = (0..m)
        .map(|a| {
            (0..m)
                .map(|b| {
                    if areas[a] > 0.0 {
                        exchange[a * m + b] / areas[a]
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    ViewFactors {
        objects: scene.objects.clone(),
        areas,
        matrix,
        rays_cast,
    }
}
