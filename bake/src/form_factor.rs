//! The patch-to-patch form-factor matrix F (n × n, f64 accumulation, f32 storage).
//!
//! `F_ij = (1/A_i) ∫_{A_i} Σ_{t ∈ pieces(j)} F(x → t) · V(x, t) dA(x)`:
//! - the inner factor `F(x → t)` is the exact point-to-polygon kernel ([`crate::kernel`]), so
//!   neighbours that share an edge or nearly touch are as accurate as distant ones;
//! - the outer integral is an adaptive quadrature ([`crate::quadrature`]) that subdivides the
//!   source where it is large compared with its distance to the target, each target piece on
//!   its own (until session 14 a source piece was refined against the nearest of its targets
//!   and read every other one on those leaves: twice the time on an icosphere);
//! - piece pairs far apart compared with their sizes ([`FormFactorParams::far_pieces`]) take
//!   the rule's points on both sides with the point kernel `cos cos / (π r²)`, three points
//!   each for degree 2, instead of Lambert's formula, whose `atan2` per edge was two thirds of
//!   the time on a tessellated sphere; rows move by 1e-5 at most;
//! - the depth limit, which only bounds the strip beside a shared edge, drops where the kernel
//!   is small everywhere (nearly coplanar neighbours on a curved surface, [`pair_depth`]);
//! - `V` is the visible fraction of `t` seen from `x`, weighted by the kernel, from shadow rays
//!   against the full-detail triangles ([`Visibility`]); each ray ends at a point of `t` drawn
//!   in proportion to the kernel from its source point (`ray_end`), and each piece pair gets
//!   at least `MIN_PIECE_RAYS`, drawn systematically in proportion to the quadrature's
//!   contributions; a patch pair of more than 256 piece pairs instead gets one budget for the
//!   whole pair ([`EXACT_PAIR_RAYS`]).
//!
//! Each unordered pair is integrated once, over the patch of smaller area (the better
//! conditioned direction), giving the exchange `G = A_i F_ij = A_j F_ji`; reciprocity therefore
//! holds to rounding and the row sums are the honest accuracy check.
//!
//! The cost of a pair is the product of the two patches' piece counts, so exact pairs cost the
//! square of the scene's piece count whatever the patch count (nested spheres of 2 × 1280
//! triangles: 8 s; a 330 000-triangle room: days). Above [`FormFactorParams::exact_pieces`]
//! pieces in all, a patch of more than [`MAX_EXACT_PIECES`] pieces is integrated through flat
//! sites (`flat_site`): the paper's own simplification (§4.3, form factors "for sites of the
//! simplified scene") for far pairs (centres more than `FAR_RATIO` times the sum of the
//! radii apart), while neighbours keep their pieces. Shadow rays still test the full-detail triangles, except
//! those of a site's own patch, which its flat stand-in may lie off.
//!
//! **Clustered pairs.** In the same large scenes every pair (after flat sites) is integrated by
//! [`Pairs::clustered`], made for patches of many pieces — curved furniture, which no flat
//! stand-in can represent — and for pieces far larger than their distance:
//! - two pieces whose centres are more than [`POINT_RATIO`] times the sum of their radii apart
//!   meet centre to centre, `A_s A_t cos⁺ cos⁺ / (π r²)`, each with its own normal, so a convex
//!   surface still sees none of itself;
//! - every other piece pair is integrated as in exact pairs, but with a quadrature of the
//!   source refined against that target piece alone, or of the target against the source when
//!   the target is less than half as wide (`integrate_over_target`);
//! - visibility is sampled once per pair, not once per sample and piece: [`FAR_RAYS`] or
//!   [`NEAR_RAYS`] rays drawn systematically in proportion to the unoccluded contributions
//!   (unbiased for `Σ g·V`), each ending at a kernel-distributed point of its target piece. A
//!   large piece carrying much of a pair gets many rays to different points of it (a
//!   1000-unit floor triangle seen through furniture had been all or nothing).
//!
//! On Greg Ward's conference room (330 000 triangles, 4410 patches) this took the form factors
//! from an estimated 4 h to minutes on 2 cores (ARCHITECTURE.md has the measurements).

use crate::bvh::{CONTACT_GAP, Occluders};
use crate::kernel::point_to_polygon;
use crate::polygon::point_polygon_distance;
use crate::polygon::{MAX_VERTICES, Polygon};
use crate::quadrature::{Adaptive, Rule, Sample, integrate_bounded};
use crate::rng::SplitMix64;
use crate::voxel::{Patches, Piece};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// How visibility between a source point and a target piece is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visibility {
    /// No rays: every pair sees every other unoccluded (exact for convex enclosures, and what
    /// a caller that already knows nothing occludes asks for).
    Off,
    /// Shadow rays against the full-detail triangles.
    Rays {
        /// Rays per quadrature leaf and target piece (and at least `MIN_PIECE_RAYS` times
        /// this per piece pair), each to its own kernel-distributed point of the piece. More:
        /// smoother penumbrae, proportionally slower.
        per_sample: u32,
        /// Skip the rays for piece pairs that no triangle can come between (a conservative
        /// plane-and-box test per pair of full-detail triangles, cached when the scene has at
        /// most 2048 triangles). Exact, and much faster in mostly open scenes.
        skip_unblockable: bool,
    },
}

/// Parameters of [`form_factors`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FormFactorParams {
    /// Source-side quadrature.
    pub quadrature: Adaptive,
    /// Shadow rays.
    pub visibility: Visibility,
    /// Pieces in all up to which every pair is integrated exactly, piece by piece. Above it,
    /// patches of more than [`MAX_EXACT_PIECES`] pieces are integrated through flat sites
    /// (module doc): a scene of 300 000 triangles becomes feasible at all.
    pub exact_pieces: usize,
    /// The rule of clustered pairs' per-target quadratures (`Pairs::clustered`, scenes above
    /// `exact_pieces`). Their error is the sampled visibility's and the centre-to-centre far
    /// pieces', so the default keeps the centroid there: degree 2 cost the conference room's
    /// rows 69% more time for an RMS against hemisphere rays of 0.0124 instead of 0.0137.
    pub clustered_rule: Rule,
    /// Exact pairs: two pieces whose centres are more than this many times the sum of their
    /// radii apart are integrated by the source rule on both sides with the point kernel
    /// `cos cos / (π r²)`, instead of the adaptive quadrature and the exact polygon kernel
    /// (`f64::INFINITY`: never).
    pub far_pieces: f64,
}

impl Default for FormFactorParams {
    fn default() -> Self {
        Self {
            // Degree 2, not the centroid. Each target refines the source on its own, so far
            // targets are read on coarse leaves, where the kernel is concave and one point
            // over-reads it: a closed box's rows of F came out 4.4e-4 high on average
            // (ARCHITECTURE.md, "The quadrature rule"); three points a leaf take them within
            // 1e-5 of 1. Rays are counted per leaf, not per point (`exchange`).
            quadrature: Adaptive {
                rule: Rule::Degree2,
                ratio: 0.5,
                max_depth: 5,
            },
            visibility: Visibility::Rays {
                per_sample: 1,
                skip_unblockable: true,
            },
            exact_pieces: EXACT_PIECES,
            clustered_rule: Rule::Centroid,
            far_pieces: FAR_PIECES,
        }
    }
}

impl FormFactorParams {
    /// Coarser quadrature (`--form-factors draft`): the centroid rule on leaves up to their
    /// distance, depth 3. On the Cornell box at 4096 patches it saves a tenth of the form
    /// factors' time (most rays are each piece pair's minimum), and its rows read about 8e-4
    /// high, which a nearly closed room at ρ = 0.999 turns into +29% (README, "What
    /// form-factor accuracy costs"). Fewer patches are the better preview.
    pub fn fast() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Centroid,
                ratio: 1.0,
                max_depth: 3,
            },
            ..Self::default()
        }
    }

    /// Finer quadrature and four rays per leaf (`--form-factors fine`): leaves to depth 6,
    /// degree 2 in clustered pairs too, the exact kernel for piece pairs up to 8× their radii
    /// apart. About 4× the rays and 3× the form factors' time of the
    /// default for rows that the default already has within a hemisphere check's noise.
    pub fn high_quality() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Degree2,
                ratio: 0.5,
                max_depth: 6,
            },
            visibility: Visibility::Rays {
                per_sample: 4,
                skip_unblockable: true,
            },
            exact_pieces: EXACT_PIECES,
            clustered_rule: Rule::Degree2,
            far_pieces: 8.0,
        }
    }

    /// What these parameters ask for, as the bake report states it.
    pub fn summary(&self) -> FormFactorSummary {
        FormFactorSummary {
            rule: self.quadrature.rule.name(),
            leaf_ratio: self.quadrature.ratio,
            max_depth: self.quadrature.max_depth,
            rays_per_leaf: match self.visibility {
                Visibility::Off => 0,
                Visibility::Rays { per_sample, .. } => per_sample.max(1),
            },
            clustered_rule: self.clustered_rule.name(),
            far_pieces: self.far_pieces.is_finite().then_some(self.far_pieces),
        }
    }

    /// The default with visibility rays switched off.
    pub fn unoccluded() -> Self {
        Self {
            visibility: Visibility::Off,
            ..Self::default()
        }
    }
}

/// The form-factor settings a bake used ([`FormFactorParams::summary`]), in its report.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FormFactorSummary {
    /// The quadrature rule on each leaf of the source: `centroid`, `degree 2` or `degree 5`.
    pub rule: &'static str,
    /// A leaf is at most this many times as wide as its distance to the target.
    pub leaf_ratio: f64,
    /// Most halvings of a source triangle.
    pub max_depth: u32,
    /// Shadow rays per leaf and target piece asked for (0: none; the occlusion effect also
    /// switches them off where nothing can occlude).
    pub rays_per_leaf: u32,
    /// The rule of clustered pairs' quadratures (scenes above `exact_pieces` pieces).
    pub clustered_rule: &'static str,
    /// Piece pairs more than this many times the sum of their radii apart take the rule on
    /// both sides with the point kernel (`None`: every piece pair through the exact kernel).
    pub far_pieces: Option<f64>,
}

/// The computed matrix and its diagnostics.
#[derive(Clone, Debug)]
pub struct FormFactors {
    /// Number of patches.
    pub n: usize,
    /// Row-major `F_ij`, `n × n`.
    pub matrix: Vec<f32>,
    /// Shadow rays cast.
    pub rays_cast: u64,
    /// Row sums `Σ_j F_ij` (f64 sums of the stored values); 1 for a closed scene.
    pub row_sums: Vec<f64>,
    /// Largest `|A_i F_ij − A_j F_ji| / max(A_i F_ij, A_j F_ji)` over the stored matrix (f32
    /// rounding only: the exchange is computed once per pair).
    pub reciprocity_error: f64,
    /// Pieces of all patches.
    pub pieces: usize,
    /// Patches integrated through flat sites (0 when every pair was exact).
    pub sites: usize,
    /// Pairs integrated as clusters of pieces with sampled visibility (module doc, "clustered
    /// pairs"; 0 when every pair was exact).
    pub clustered_pairs: u64,
}

impl FormFactors {
    /// `F_ij`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f32 {
        self.matrix[i * self.n + j]
    }
}

/// Progress callback: `(rows done, rows in all)`, called from worker threads.
pub type Progress<'a> = &'a (dyn Fn(usize, usize) + Sync);

/// Points on a polygon for shadow rays: the `k`-th point of a deterministic low-discrepancy
/// sequence (Roberts' R3), mapped to the fan triangles by area.
pub(crate) fn polygon_point(v: &[DVec3], k: u64) -> DVec3 {
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

/// Whether piece `t` can receive anything from piece `s` at all: some of `t` strictly in front
/// of `s`'s plane and some of `s` strictly in front of `t`'s.
pub(crate) fn facing(s: &[DVec3], ns: DVec3, t: &[DVec3], nt: DVec3, tol: f64) -> bool {
    let ds = ns.dot(s[0]);
    let dt = nt.dot(t[0]);
    t.iter().any(|p| ns.dot(*p) - ds > tol) && s.iter().any(|p| nt.dot(*p) - dt > tol)
}

/// Flat patches of more pieces than this are integrated through flat sites (`Sites`). A plane
/// wall cut by the grid gives one to four pieces per patch, a box corner up to a dozen; a
/// curved or finely tessellated surface gives many more, and the exact pair costs their product.
pub const MAX_EXACT_PIECES: usize = 16;

/// Default of [`FormFactorParams::exact_pieces`]: the exact cost grows as the square of the
/// piece count (nested spheres of 2 × 1280 triangles take 8 s on 2 cores at any patch count),
/// and flat sites cost accuracy on coarse curved patches (row sums of F off by up to 6% at 58
/// patches on those spheres, where the exact pairs are within 0.3%).
pub const EXACT_PIECES: usize = 20_000;

/// The lowest depth limit [`pair_depth`] gives a nearly coplanar pair. Measured on an
/// icosphere of 1280 triangles at 398 patches (3668 pieces): rows of F differ from the full
/// depth by 8e-6 (L1, worst row) at 3, 2.7e-5 at 2, 1.0e-4 at 1; the form factors took 2.4 s
/// at 3 against 4.8 s at the full depth.
const MIN_PAIR_DEPTH: u32 = 3;

/// Default of [`FormFactorParams::far_pieces`]. Against every piece pair exact, on an
/// icosphere of 1280 facets at 398 patches (3668 pieces; a throwaway probe): rows of F 1.7e-6
/// / 4.5e-6 / 8.2e-6 / 1.6e-5 apart (L1, worst row) at 8 / 5 / 4 / 3, the form factors 7.6 s
/// exact and 4.8 s at 5; on a closed box of 1494 pieces, 2.8e-6 at 5.
pub const FAR_PIECES: f64 = 5.0;

/// In a clustered pair, two pieces whose centres are more than this many times the sum of
/// their radii apart meet centre to centre (`A_s A_t cos cos / (π r² + A_s + A_t)`, exact
/// for a point on the axis of a disc, 0.3% off for two equal coaxial discs at this distance).
const POINT_RATIO: f64 = 4.0;

/// Shadow rays per far clustered pair (times `per_sample`), drawn in proportion to the
/// unoccluded contributions of its piece pairs. 16 left the wall rows of the sphere-in-a-box
/// test in [0.9841, 1.0071], 32 in [0.9877, 1.0046] (exact pairs: [0.9874, 1.0109]).
pub const FAR_RAYS: usize = 32;

/// Shadow rays per near clustered pair (times `per_sample`): neighbours, where contact shadows
/// vary faster.
pub const NEAR_RAYS: usize = 64;

/// A clustered pair whose unoccluded form factor from its smaller patch is `F` gets at least
/// this many times `F` shadow rays (times `per_sample`; at most [`MAX_PAIR_RAYS`]). Sampled
/// visibility `v` costs the pair an error of about `F·√(v(1−v)/rays)`, so a fixed budget let
/// the few pairs that carry a row decide it: in the conference room a small part facing a
/// large curved patch of its own object (unoccluded F 1.82, about half of it hidden by the
/// patch itself) got 0.74 from 64 rays, 0.94 from 256, 0.84 from 1024, against 0.86 by
/// hemisphere rays. Minimising the summed variance for a given total puts rays in proportion
/// to `F`; 512 gives such a pair about 900 rays (error near 0.03) and leaves every pair with
/// `F` below 1/8 at the fixed budget.
pub const PAIR_RAYS_PER_FORM_FACTOR: f64 = 512.0;

/// The most shadow rays one clustered pair gets from [`PAIR_RAYS_PER_FORM_FACTOR`].
pub const MAX_PAIR_RAYS: usize = 4096;

/// A pair is far when its centres are more than this many times the sum of the patches' radii
/// apart (their bounding spheres do not meet): each side then sees the other as one flat site.
/// Near pairs (neighbours) keep their pieces: touching patches are where the kernel is most
/// sensitive to the shape, and a flattened stand-in there cost a closed box's rows up to 2%.
const FAR_RATIO: f64 = 1.0;

/// Rays per quadrature leaf and `per_sample` between a site and its far partner: a partly
/// hidden pair gets a visible fraction in steps of 1/16 instead of all or nothing (on a box of
/// tessellated walls around a floating cube, one ray per pair left rows of F off by 2%).
const SITE_RAYS: u32 = 16;

/// Offset into the point sequence of a site's own ray ends, so that they do not pair up with
/// the same points of the target.
const SITE_SOURCE_OFFSET: u64 = 1 << 20;

/// [`Piece::triangle`] of a flat site, which stands for many triangles.
const SITE: u32 = u32::MAX;

/// The flat stand-in of a patch of many pieces, with the triangles it stands for.
struct Sites {
    /// The whole patch as one site: for far pairs.
    whole: Piece,
    /// The full-detail triangles of the patch, sorted: its own rays ignore them.
    triangles: Vec<u32>,
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
    fn new(pieces: &[Piece]) -> Option<Self> {
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

/// Cache of [`Occluders::may_block`] per pair of full-detail triangles.
struct BlockCache {
    n: usize,
    bits: Vec<bool>,
}

impl BlockCache {
    const MAX_TRIANGLES: usize = 2048;

    fn new(patches: &Patches, occ: &Occluders, tris: &[[DVec3; 3]]) -> Option<Self> {
        let n = tris.len();
        if n > Self::MAX_TRIANGLES || patches.is_empty() {
            return None;
        }
        let normal = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
        let bits = (0..n * n)
            .into_par_iter()
            .map(|k| {
                let (a, b) = (&tris[k / n], &tris[k % n]);
                occ.may_block(a, normal(a), b, normal(b))
            })
            .collect();
        Some(Self { n, bits })
    }

    fn may_block(&self, a: u32, b: u32) -> bool {
        self.bits[a as usize * self.n + b as usize]
    }
}

/// The exchange `A_src·F(src → dst)` by integrating over `src`.
#[allow(clippy::too_many_arguments)] // internal kernel: splitting the context into a struct buys nothing
fn exchange(
    src: &[Piece],
    dst: &[Piece],
    occ: Option<&Occluders>,
    cache: Option<&BlockCache>,
    params: &FormFactorParams,
    tol: f64,
    rays: &mut u64,
    scratch: &mut Scratch,
    skip: &dyn Fn(u32) -> bool,
    pair: u64,
) -> f64 {
    let Scratch {
        live,
        far,
        samples,
        targets,
        points,
        spans,
        ..
    } = scratch;
    let rule = params.quadrature.rule;
    // Far piece pairs (`FormFactorParams::far_pieces`): the rule on both sides, so each
    // target's points are laid out once.
    targets.clear();
    points.clear();
    spans.clear();
    for t in dst {
        targets.push(centre_radius(t));
        let start = points.len() as u32;
        for tri in fan(t.polygon.vertices()) {
            points.extend(rule_points(tri, rule));
        }
        spans.push((start, points.len() as u32));
    }
    // Where on its leaf each ray starts is drawn from a stream of its own per patch pair: the
    // rays' numbers below repeat in every pair of one-piece patches, and rays from the same
    // points to every target would make a row's visibility a handful of draws.
    let leaf_stream = pair.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    // Sampled as a whole (`EXACT_PAIR_RAYS`): the minimum per piece pair would cost more.
    let whole = src.len() * dst.len() * MIN_PIECE_RAYS > EXACT_PAIR_RAYS;
    let mut total = 0.0;
    samples.clear();
    for (si, s) in src.iter().enumerate() {
        let sv = s.polygon.vertices();
        let (cs, rs) = centre_radius(s);
        live.clear();
        far.clear();
        for (k, t) in dst.iter().enumerate() {
            if !facing(sv, s.normal, t.polygon.vertices(), t.normal, tol) {
                continue;
            }
            let need_rays = match (params.visibility, occ) {
                (Visibility::Off, _) | (_, None) => false,
                (
                    Visibility::Rays {
                        skip_unblockable, ..
                    },
                    Some(o),
                ) => {
                    !skip_unblockable
                        || match cache {
                            Some(c) if s.triangle != SITE && t.triangle != SITE => {
                                c.may_block(s.triangle, t.triangle)
                            }
                            // A pair sampled as a whole draws its rays over all its
                            // contributions: one walk of the occluders per piece pair to
                            // prove some of them unblocked would cost more than the rays.
                            _ if whole => true,
                            _ => o.may_block(sv, s.normal, t.polygon.vertices(), t.normal),
                        }
                }
            };
            let (ct, rt) = targets[k];
            if (ct - cs).length_squared() > (params.far_pieces * (rs + rt)).powi(2) {
                far.push((k, need_rays));
            } else {
                live.push((k, need_rays));
            }
        }
        if live.is_empty() && far.is_empty() {
            continue;
        }
        // Contributions that need rays are kept, per piece pair, and their visibility is
        // sampled afterwards: at least MIN_PIECE_RAYS rays per piece pair, drawn in proportion
        // to the contributions (or EXACT_PAIR_RAYS for the whole patch pair). One ray per quadrature point left a pair that the adaptive
        // quadrature settles in two points all or nothing (the Cornell box at 256 patches: a
        // face of the tall box saw two back-wall patches through the short box, row 1.04).
        let si = si as u32;
        // Far targets: the rule's points of each source leaf (the whole fan triangle: at
        // `far_pieces` ≥ 5 the distance rule would not split it) against the target's.
        if !far.is_empty() {
            for tri in fan(sv) {
                for (x, wx) in rule_points(tri, rule) {
                    for &(k, need_rays) in far.iter() {
                        let (lo, hi) = spans[k];
                        let nt = dst[k].normal;
                        let g: f64 = points[lo as usize..hi as usize]
                            .iter()
                            .map(|&(y, wy)| wy * point_kernel(x, s.normal, y, nt))
                            .sum();
                        if g <= 0.0 {
                            continue;
                        }
                        if need_rays {
                            samples.push((si, k as u32, tri, wx * g));
                        } else {
                            total += wx * g;
                        }
                    }
                }
            }
        }
        // Each near target refines the source against itself alone.
        for &(k, need_rays) in live.iter() {
            let t = &dst[k];
            let dist = |x: DVec3| point_polygon_distance(x, t.polygon.vertices(), t.normal);
            let bound = sphere_distance(targets[k]);
            let quadrature = Adaptive {
                max_depth: pair_depth(params.quadrature.max_depth, s.normal, t.normal),
                ..params.quadrature
            };
            for tri in fan(sv) {
                integrate_bounded(tri, &quadrature, &bound, &dist, &mut |q| {
                    let f = point_to_polygon(q.x, s.normal, &t.polygon, t.normal);
                    if f > 0.0 && need_rays {
                        samples.push((si, k as u32, q.leaf, q.w * f));
                    } else if f > 0.0 {
                        total += q.w * f;
                    }
                });
            }
        }
    }
    if samples.is_empty() {
        return total;
    }
    let o = occ.expect("rays need occluders");
    let per_sample = match params.visibility {
        Visibility::Rays { per_sample, .. } => per_sample.max(1),
        Visibility::Off => 0,
    };
    // Stable: within a piece pair the contributions keep their order.
    samples.sort_by_key(|e| (e.0, e.1));
    // One shadow ray from source point `x` (drawn with `ray` on leaf `leaf`) of `s` to `t`.
    let visible = |s: &Piece, t: &Piece, leaf: &[DVec3; 3], ray: u64, k: u64, scramble| {
        // A site stands for a whole patch, usually at one quadrature point: its rays are
        // spread over both polygons, not sent from the point.
        if s.triangle == SITE || t.triangle == SITE {
            let x = if s.triangle == SITE {
                front_point(s, t, k + SITE_SOURCE_OFFSET)
            } else {
                Sample::leaf_point(leaf, ray, scramble)
            };
            o.segment_visible_skipping(x, front_point(t, s, k), skip)
        } else {
            let x = Sample::leaf_point(leaf, ray, scramble);
            in_front(x, t) && o.reaches(x, ray_end(x, s, t, k), t.triangle)
        }
    };
    let same_pieces = |a: &Contribution, b: &Contribution| (a.0, a.1) == (b.0, b.1);
    if whole {
        let sum: f64 = samples.iter().map(|e| e.3).sum();
        let area: f64 = src.iter().map(|p| p.area).sum();
        let pair_budget = exact_pair_rays(sum, area) * per_sample as usize;
        let base = leaf_stream >> 24;
        let scramble = Sample::leaf_scramble(base);
        let mut sampler = Systematic::new(sum, pair_budget, base);
        for (i, e) in samples.iter().enumerate() {
            let (s, t) = (&src[e.0 as usize], &dst[e.1 as usize]);
            sampler.feed(e.3, i + 1 == samples.len(), |ray| {
                visible(s, t, &e.2, ray, base + ray, scramble)
            });
        }
        *rays += sampler.drawn;
        return total + sampler.estimate(sum);
    }
    for group in samples.chunk_by(same_pieces) {
        let (s, t) = (&src[group[0].0 as usize], &dst[group[0].1 as usize]);
        let site = s.triangle == SITE || t.triangle == SITE;
        let per_point = per_sample * if site { SITE_RAYS } else { 1 };
        // Rays start anywhere on their leaf, so a leaf's points share its rays: the budget
        // counts leaves, and a finer rule costs kernel evaluations, not rays.
        let leaves = group.len().div_ceil(params.quadrature.rule.points().len());
        let budget = (leaves * per_point as usize).max(MIN_PIECE_RAYS * per_sample as usize);
        // Each piece pair numbers its own rays: a quadrature that differs in one pair (by
        // rounding) must not renumber the rays of the others.
        let base = u64::from(group[0].0) << 40 | u64::from(group[0].1) << 20;
        let sum: f64 = group.iter().map(|e| e.3).sum();
        let mut sampler = Systematic::new(sum, budget, base);
        let scramble = Sample::leaf_scramble(base ^ leaf_stream);
        for (i, e) in group.iter().enumerate() {
            sampler.feed(e.3, i + 1 == group.len(), |ray| {
                visible(s, t, &e.2, ray, base + ray, scramble)
            });
        }
        *rays += sampler.drawn;
        total += sampler.estimate(sum);
    }
    total
}

/// Everything a pair's exchange needs: the patches, their stand-ins and radii, the occluders.
struct Pairs<'a> {
    patches: &'a Patches,
    occ: Option<&'a Occluders>,
    cache: Option<&'a BlockCache>,
    params: &'a FormFactorParams,
    tol: f64,
    /// Flat sites for patches of many pieces (an exact patch has none).
    sites: Vec<Option<Sites>>,
    /// Every patch's radius about its centre, for the near/far test.
    radius: Vec<f64>,
    /// Pairs of many pieces go through [`Pairs::clustered`] (the scene has more pieces than
    /// [`FormFactorParams::exact_pieces`]).
    clustered: bool,
}

impl<'a> Pairs<'a> {
    fn new(
        patches: &'a Patches,
        occ: Option<&'a Occluders>,
        cache: Option<&'a BlockCache>,
        params: &'a FormFactorParams,
        tol: f64,
    ) -> Self {
        let n = patches.len();
        let use_sites = patches.pieces.len() > params.exact_pieces;
        let sites: Vec<Option<Sites>> = (0..n)
            .into_par_iter()
            .map(|i| {
                let pieces = patches.pieces_of(i);
                (use_sites && pieces.len() > MAX_EXACT_PIECES)
                    .then(|| Sites::new(pieces))
                    .flatten()
            })
            .collect();
        let radius: Vec<f64> = (0..n)
            .map(|i| {
                let c = patches.patches[i].centre;
                patches
                    .pieces_of(i)
                    .iter()
                    .flat_map(|p| p.polygon.vertices())
                    .map(|x| (*x - c).length())
                    .fold(0f64, f64::max)
            })
            .collect();
        Self {
            patches,
            occ,
            cache,
            params,
            tol,
            sites,
            radius,
            clustered: use_sites,
        }
    }

    fn geometry(&self, i: usize, far: bool) -> &[Piece] {
        match &self.sites[i] {
            Some(s) if far => std::slice::from_ref(&s.whole),
            _ => self.patches.pieces_of(i),
        }
    }

    fn own(&self, i: usize) -> &[u32] {
        self.sites[i].as_ref().map_or(&[], |s| &s.triangles[..])
    }

    /// The exchange `G = A_i F_ij = A_j F_ji`.
    fn exchange(&self, i: usize, j: usize, rays: &mut u64, scratch: &mut Scratch) -> f64 {
        let (pi, pj) = (&self.patches.patches[i], &self.patches.patches[j]);
        // Integrate over the smaller patch. Equal areas (regular grids) take the lower index:
        // deciding ties by the rounding of the areas would integrate a pair from one side at
        // one scale and from the other side at another, and the two quadratures differ by
        // their error (measured 1e-4 to 5e-3 of the irradiance between a scene and the same
        // scene ×3).
        let tie = (pi.area - pj.area).abs() <= 1e-9 * pi.area.max(pj.area);
        let (a, b) = if tie || pi.area < pj.area {
            (i, j)
        } else {
            (j, i)
        };
        let (own_a, own_b) = (self.own(a), self.own(b));
        let skip = |t: u32| own_a.binary_search(&t).is_ok() || own_b.binary_search(&t).is_ok();
        let gap = (self.patches.patches[a].centre - self.patches.patches[b].centre).length();
        let far = gap > FAR_RATIO * (self.radius[a] + self.radius[b]);
        let (src, dst) = (self.geometry(a, far), self.geometry(b, far));
        if self.clustered {
            let seed = (a as u64) << 32 | b as u64;
            scratch.clustered += 1;
            return self.clustered(src, dst, far, seed, rays, scratch, &skip);
        }
        // Many triangles and no per-triangle-pair cache: one proof for the whole patch pair
        // first, so that an unblocked pair walks the occluders once instead of once per piece
        // pair (nested spheres: the inner sphere lies in the box of most pairs on the outer
        // one). Without a candidate no piece pair needs rays, and the sum is the same.
        let occ = match (self.occ, self.cache, self.params.visibility) {
            (
                Some(o),
                None,
                Visibility::Rays {
                    skip_unblockable: true,
                    ..
                },
            ) => {
                let (hs, ht) = &mut scratch.hull;
                hs.clear();
                ht.clear();
                hs.extend(
                    src.iter()
                        .flat_map(|p| p.polygon.vertices().iter().copied()),
                );
                ht.extend(
                    dst.iter()
                        .flat_map(|p| p.polygon.vertices().iter().copied()),
                );
                o.may_block_hull(hs, ht).then_some(o)
            }
            (o, ..) => o,
        };
        exchange(
            src,
            dst,
            occ,
            self.cache,
            self.params,
            self.tol,
            rays,
            scratch,
            &skip,
            (a as u64) << 32 | b as u64,
        )
    }

    /// The exchange of a pair of many pieces (module doc, "clustered pairs"): piece pairs far
    /// apart compared with their sizes meet centre to centre, the rest through the source
    /// quadrature and the exact kernel, and visibility is sampled in proportion to the
    /// unoccluded contributions instead of one ray for each of them.
    #[allow(clippy::too_many_arguments)] // internal kernel, like `exchange`
    fn clustered(
        &self,
        src: &[Piece],
        dst: &[Piece],
        far: bool,
        seed: u64,
        rays: &mut u64,
        scratch: &mut Scratch,
        skip: &dyn Fn(u32) -> bool,
    ) -> f64 {
        let Scratch {
            live,
            targets,
            sources,
            starts,
            blocks,
            ..
        } = scratch;
        targets.clear();
        sources.clear();
        starts.clear();
        blocks.clear();
        // Every piece's centre and radius, once per pair: the walk below asks them for every
        // near piece pair.
        targets.extend(dst.iter().map(centre_radius));
        sources.extend(src.iter().map(centre_radius));
        let (targets, sources) = (&*targets, &*sources);
        // The near contributions of source piece `s` and target piece `t`: each near target
        // gets its own adaptive quadrature of the source, so that a source piece that touches
        // one target is refined next to that one only.
        // The exchange is symmetric, so each piece pair is integrated over the smaller of its
        // two pieces (`integrate_over_target`): a piece the size of a wall against a chair's
        // facet a hand away from it was refined to the depth limit once per facet.
        let near_contributions = |si: usize, ti: usize, out: &mut dyn FnMut([DVec3; 3], f64)| {
            let (s, t) = (&src[si], &dst[ti]);
            let (s, t, t_sphere) = if integrate_over_target(sources[si].1, targets[ti].1) {
                (t, s, sources[si])
            } else {
                (s, t, targets[ti])
            };
            let dist = |x: DVec3| point_polygon_distance(x, t.polygon.vertices(), t.normal);
            let bound = sphere_distance(t_sphere);
            let quadrature = Adaptive {
                rule: self.params.clustered_rule,
                max_depth: pair_depth(self.params.quadrature.max_depth, s.normal, t.normal),
                ..self.params.quadrature
            };
            for tri in fan(s.polygon.vertices()) {
                integrate_bounded(tri, &quadrature, &bound, &dist, &mut |q| {
                    let f = point_to_polygon(q.x, s.normal, &t.polygon, t.normal);
                    if f > 0.0 {
                        out(q.leaf, q.w * f);
                    }
                });
            }
        };
        // The contributions come in a fixed order (per source piece: its centre-to-centre
        // pairs in target order, then the quadrature of each near target), and visibility is
        // drawn along their running sum. None is kept: they are about `|src|·|dst|` many, and
        // a touching pair of pieces has hundreds of quadrature points (48 bytes each: with
        // patches of up to 25 000 pieces, the conference room's bake was killed at 21–24 GB
        // keeping them). This pass sums them and records the running sum where each source
        // piece and each near piece pair starts; the drawing pass recomputes them, in the same
        // order and to the same bits, only where a ray falls.
        let mut total = 0.0;
        for (si, s) in src.iter().enumerate() {
            let sv = s.polygon.vertices();
            let (cs, rs) = sources[si];
            starts.push((total, blocks.len()));
            live.clear();
            for (ti, t) in dst.iter().enumerate() {
                if near(cs, rs, targets[ti]) {
                    if facing(sv, s.normal, t.polygon.vertices(), t.normal, self.tol) {
                        live.push((ti, true));
                    }
                } else if let Some(g) = centre_to_centre(s, cs, t, targets[ti].0) {
                    total += g;
                }
            }
            for &(k, _) in live.iter() {
                blocks.push((total, k as u32));
                near_contributions(si, k, &mut |_, g| total += g);
            }
        }
        let (per_sample, occ) = match (self.params.visibility, self.occ) {
            (Visibility::Rays { per_sample, .. }, Some(o)) => (per_sample.max(1) as usize, o),
            _ => return total,
        };
        // At least FAR_RAYS / NEAR_RAYS, more for a pair that carries much of the source's row:
        // the sampled visibility's error in F is about F·√(v(1−v)/rays).
        let area: f64 = src.iter().map(|p| p.area).sum();
        let share = if area > 0.0 {
            (PAIR_RAYS_PER_FORM_FACTOR * total / area).min(MAX_PAIR_RAYS as f64) as usize
        } else {
            0
        };
        let budget = per_sample * share.max(if far { FAR_RAYS } else { NEAR_RAYS });
        let base = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 24;
        let scramble = Sample::leaf_scramble(base);
        let visible = |e: &Entry, k: u64| {
            let (s, t) = (&src[e.s as usize], &dst[e.t as usize]);
            // A near pair integrated over its target piece has its leaves there: its rays run
            // from the target to the source (visibility is symmetric).
            let (s, t) = if e.turned { (t, s) } else { (s, t) };
            // Ray ends in front of the other piece (a piece seen edge-on has points behind the
            // other's plane, and a segment to one of those leaves through the surface it
            // starts on: on a sphere, rows 0.5% low on average), at the target where the
            // kernel from the source point puts them (`ray_end`).
            let x = if e.centre || s.triangle == SITE {
                front_point(s, t, base + k + SITE_SOURCE_OFFSET)
            } else {
                let x = Sample::leaf_point(&e.leaf, k, scramble);
                if !in_front(x, t) {
                    return false;
                }
                x
            };
            let y = if t.triangle == SITE {
                front_point(t, s, base + k)
            } else {
                ray_end(x, s, t, base + k)
            };
            if s.triangle == SITE || t.triangle == SITE {
                // A site's points lie off its triangles: a segment, lifted, its own skipped.
                let lift = LIFT * occ.extent();
                occ.segment_visible_skipping(x + s.normal * lift, y + t.normal * lift, skip)
            } else {
                occ.reaches(x, y, t.triangle)
            }
        };
        if !(total > 0.0) {
            return 0.0;
        }
        let mut sampler = Systematic::new(total, budget, base);
        for (si, s) in src.iter().enumerate() {
            let (end, blocks_end) = starts.get(si + 1).copied().unwrap_or((total, blocks.len()));
            let own_blocks = starts[si].1..blocks_end;
            // Where this source piece's centre-to-centre pairs end and its near ones begin.
            let far_end = if own_blocks.is_empty() {
                end
            } else {
                blocks[own_blocks.start].0
            };
            if sampler.idle_until(far_end) {
                sampler.skip_to(far_end);
            } else {
                let (cs, rs) = sources[si];
                for (ti, t) in dst.iter().enumerate() {
                    if near(cs, rs, targets[ti]) {
                        continue;
                    }
                    if let Some(g) = centre_to_centre(s, cs, t, targets[ti].0) {
                        let e = Entry {
                            leaf: [cs; 3],
                            s: si as u32,
                            t: ti as u32,
                            centre: true,
                            turned: false,
                        };
                        sampler.feed(g, false, |k| visible(&e, k));
                    }
                }
            }
            for b in own_blocks.clone() {
                let block_end = if b + 1 < own_blocks.end {
                    blocks[b + 1].0
                } else {
                    end
                };
                if sampler.idle_until(block_end) {
                    sampler.skip_to(block_end);
                    continue;
                }
                let k = blocks[b].1;
                // Decided once per piece pair, as `near_contributions` decides it.
                let turned = integrate_over_target(sources[si].1, targets[k as usize].1);
                near_contributions(si, k as usize, &mut |leaf, g| {
                    let e = Entry {
                        leaf,
                        s: si as u32,
                        t: k,
                        centre: false,
                        turned,
                    };
                    sampler.feed(g, false, |k| visible(&e, k));
                });
            }
        }
        *rays += sampler.drawn;
        sampler.estimate(total)
    }
}

/// The fan triangles of a convex polygon, without the slivers that collinear corners (left by
/// clipping) make: their area is rounding, zero at one scale and not at another, and the
/// adaptive quadrature refined them to its depth limit (15 samples of no weight that changed a
/// pair's rays: the same room at scales 1 and 1e4 differed by 4e-4).
fn fan(v: &[DVec3]) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    let area = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).length();
    let total: f64 = (1..v.len() - 1)
        .map(|i| area(&[v[0], v[i], v[i + 1]]))
        .sum();
    (1..v.len() - 1)
        .map(move |i| [v[0], v[i], v[i + 1]])
        .filter(move |t| area(t) > 1e-12 * total)
}

/// Systematic sampling in proportion to weights that arrive one at a time (and sum to the
/// `total` given): `budget` evenly spaced positions along their running sum, from an offset set
/// by `seed`, and one visibility test for each. `total · visible / drawn` is unbiased for
/// `Σ g·V`, and a weight larger than `total / budget` is drawn at least `⌊g · budget / total⌋`
/// times. Exact pairs feed their stored contributions; clustered pairs recompute theirs and
/// skip, with [`Self::idle_until`] and [`Self::skip_to`], the stretches where no position falls.
struct Systematic {
    step: f64,
    next: f64,
    run: f64,
    budget: u64,
    drawn: u64,
    hits: u64,
}

impl Systematic {
    fn new(total: f64, budget: usize, seed: u64) -> Self {
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
    fn feed(&mut self, g: f64, last: bool, mut visible: impl FnMut(u64) -> bool) {
        self.run += g;
        while self.drawn < self.budget && (self.next < self.run || last) {
            self.hits += visible(self.drawn) as u64;
            self.drawn += 1;
            self.next += self.step;
        }
    }

    /// Whether no position falls before `end` of the running sum.
    fn idle_until(&self, end: f64) -> bool {
        self.next >= end || self.drawn >= self.budget
    }

    /// Moves the running sum to `end`, over weights in which no position falls.
    fn skip_to(&mut self, end: f64) {
        self.run = end;
    }

    /// `total · visible / drawn`.
    fn estimate(&self, total: f64) -> f64 {
        total * self.hits as f64 / self.drawn.max(1) as f64
    }
}

/// Shadow rays per pair of pieces in exact pairs, at least (times `per_sample`); more when the
/// source quadrature has more points against the target. Rows of F on the Cornell box at 256
/// patches against cosine-weighted hemisphere rays from each patch (20 000 each, a throwaway
/// probe): RMS difference 0.0110 / 0.0102 / 0.0092 with at least 1 / 4 / 8 rays, for 1 /
/// 1.9 / 3.8 times the rays at 4096 patches (12.1 M without a minimum). The in-repository
/// check (`rows_against_hemisphere_rays` in tests/tests/form_factors.rs) puts the whole change
/// at RMS 0.0143 → 0.0144 there: neutral on the Cornell box.
const MIN_PIECE_RAYS: usize = 4;

/// An exact pair's contribution that needs a shadow ray: source piece, target piece, source
/// quadrature leaf, weight.
type Contribution = (u32, u32, [DVec3; 3], f64);

/// Shadow rays for an exact patch pair sampled as a whole (times `per_sample`): when its piece
/// pairs' [`MIN_PIECE_RAYS`] alone would exceed this, it gets this many, drawn systematically
/// in proportion to the contributions of all its piece pairs, like a clustered pair. The minimum
/// per piece pair is there for pairs of one or a few pieces, which the quadrature may settle in
/// two points; a coarse patch on a finely tessellated surface has hundreds of pieces, and four
/// rays for each of their pairs cost rays in the square of the pieces a patch has, not in its
/// form factor (an icosphere of 5120 facets around one of 80, at 64 patches: 45 M rays, 61 s).
pub const EXACT_PAIR_RAYS: usize = 1024;

/// [`EXACT_PAIR_RAYS`], or more for a pair whose unoccluded exchange `sum` from a source of
/// `area` is a large form factor: as for clustered pairs, [`PAIR_RAYS_PER_FORM_FACTOR`] times
/// it, at most [`MAX_PAIR_RAYS`].
fn exact_pair_rays(sum: f64, area: f64) -> usize {
    let share = if area > 0.0 {
        (PAIR_RAYS_PER_FORM_FACTOR * sum / area).min(MAX_PAIR_RAYS as f64) as usize
    } else {
        0
    };
    share.max(EXACT_PAIR_RAYS)
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
fn ray_end(x: DVec3, s: &Piece, t: &Piece, k: u64) -> DVec3 {
    // Seeded by the draw and the pieces' triangles, never by coordinates: the same scene at
    // another scale draws the same rays (`results_do_not_depend_on_the_scale`).
    let seed = k ^ u64::from(s.triangle) << 40 ^ u64::from(t.triangle) << 20;
    kernel_point(x, s.normal, &t.polygon, t.normal, seed).unwrap_or_else(|| front_point(t, s, k))
}

/// Whether `x` lies strictly in front of piece `t`'s plane, where `t` can be seen from. A
/// visibility ray starts anywhere on its quadrature leaf (`Sample::leaf_point`), and the part
/// of a leaf behind the target's plane (a floor leaf reaching under a block whose side is the
/// target) sees the target from behind: its ray would meet the target first and count.
fn in_front(x: DVec3, t: &Piece) -> bool {
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

/// Whether a near piece pair of a clustered pair is integrated over its target piece instead
/// of its source, from their radii ([`centre_radius`]): when the target is less than half as
/// wide. The adaptive quadrature refines its domain down to leaves a fraction of their
/// distance to the other piece, so a large piece near a small one was refined to the depth
/// limit around it (1024 leaves a fan triangle), once for every small piece near it; the small
/// piece needs a few leaves, and the exact polygon kernel takes the large one whole. The conference room at 568 patches, where a
/// wall patch of four pieces meets a patch of 2080 chair facets: 8052 near piece pairs and 10 M
/// leaves for that one pair.
fn integrate_over_target(source_radius: f64, target_radius: f64) -> bool {
    2.0 * target_radius < source_radius
}

/// A lower bound of the distance from a point to anything inside the sphere `(c, r)`, for
/// [`integrate_bounded`]: a hair under `|x − c| − r`, so that rounding never puts it above the
/// distance to a polygon the sphere holds ([`centre_radius`]).
fn sphere_distance((c, r): (DVec3, f64)) -> impl Fn(DVec3) -> f64 {
    move |x: DVec3| ((x - c).length() - r) * (1.0 - 1e-9)
}

/// Whether a source piece (centre `cs`, radius `rs`) and a target piece (centre and radius
/// `ct`) are near: not more than [`POINT_RATIO`] times the sum of their radii apart.
fn near(cs: DVec3, rs: f64, ct: (DVec3, f64)) -> bool {
    (ct.0 - cs).length_squared() <= (POINT_RATIO * (rs + ct.1)).powi(2)
}

/// The unoccluded exchange of source piece `s` (centre `cs`) and target piece `t` (centre
/// `ct`) centre to centre, for pieces that are not [`near`]; `None` when they face away.
fn centre_to_centre(s: &Piece, cs: DVec3, t: &Piece, ct: DVec3) -> Option<f64> {
    // `cos θ_s cos θ_t / r²` as `(n_s·d)(−n_t·d) / r⁴`: no square root (a clustered pair of
    // two curved patches evaluates this for every piece pair).
    let d = ct - cs;
    let r2 = d.length_squared();
    let (c1, c2) = (s.normal.dot(d), -t.normal.dot(d));
    (c1 > 0.0 && c2 > 0.0).then(|| s.area * t.area * c1 * c2 / (std::f64::consts::PI * r2 * r2))
}

/// The depth limit of the source quadrature against one target piece, from the general
/// limit `depth`: less where the kernel is small everywhere. Seen from any point in front of
/// it, a target lies within its own half-space, whose factor is `b = (1 − n_s·n_t)/2`
/// whatever the distance: 1/2 for a wall over a floor, 7e-3 for neighbouring facets of a
/// sphere 10° apart. The depth limit only bounds the strip next to a shared edge or corner
/// that the distance rule cannot resolve, and that strip's error scales with the kernel, so
/// each halving of `b` below 1/2 gives back one level, down to [`MIN_PAIR_DEPTH`].
fn pair_depth(depth: u32, ns: DVec3, nt: DVec3) -> u32 {
    let bound = 0.5 * (1.0 - ns.dot(nt));
    let cut = if bound > 0.0 {
        (0.5 / bound).log2().floor().clamp(0.0, 32.0) as u32
    } else {
        32
    };
    depth.saturating_sub(cut).max(MIN_PAIR_DEPTH.min(depth))
}

/// The points of `rule` on triangle `tri`, each with its weight (the rule's times the area).
fn rule_points(tri: [DVec3; 3], rule: Rule) -> impl Iterator<Item = (DVec3, f64)> {
    let area = 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
    rule.points()
        .iter()
        .map(move |&(b, w)| (tri[0] * b[0] + tri[1] * b[1] + tri[2] * b[2], w * area))
}

/// The point-to-point kernel `cos⁺θ_x cos⁺θ_y / (π r²)` between `x` (normal `nx`) and `y`
/// (normal `ny`), per unit area of each.
#[inline]
fn point_kernel(x: DVec3, nx: DVec3, y: DVec3, ny: DVec3) -> f64 {
    let d = y - x;
    let (c1, c2) = (nx.dot(d), -ny.dot(d));
    if c1 > 0.0 && c2 > 0.0 {
        let r2 = d.length_squared();
        c1 * c2 / (std::f64::consts::PI * r2 * r2)
    } else {
        0.0
    }
}

/// A point of piece `p` (the `k`-th of [`polygon_point`]) in front of the plane of `other`:
/// drawn from the part of `p` in front of it when the first draw is not, the centre of `p` when
/// that part has no area.
fn front_point(p: &Piece, other: &Piece, k: u64) -> DVec3 {
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

/// Segments to and from flat sites leave and reach them this far (relative to the scene's
/// extent) in front of them, since a site lies off its triangles. (Rays between pieces, exact
/// or clustered, start on the source surface and ask [`Occluders::reaches`] instead.) Without
/// it, grazing rays met the surface they start on or its coplanar
/// neighbours a little beyond the segment margin (f32 rounding puts a point on a surface up to
/// ~1e-7 of the extent off it): the room bench's lowest row fell to 0.98737 and the
/// sphere-in-a-box test's to 0.99899 once the CWBVH stopped hiding hits near the origin; with
/// the lift they are 0.99575 and 0.99918, the sphere's kernel value.
const LIFT: f64 = 1e-5;

/// A contribution of a clustered pair that a ray is drawn for: the quadrature leaf of source
/// piece `s` its ray starts from (unused for a centre-to-centre pair, whose ray starts anywhere
/// on `s`), target piece `t`; `turned` when the pair was integrated over `t`
/// ([`integrate_over_target`]), so that `leaf` lies on `t` and the ray runs from it to `s`.
struct Entry {
    leaf: [DVec3; 3],
    s: u32,
    t: u32,
    centre: bool,
    turned: bool,
}

/// Per-thread scratch of the form-factor loop.
#[derive(Default)]
struct Scratch {
    /// Pairs that went through [`Pairs::clustered`] on this thread.
    clustered: u64,
    live: Vec<(usize, bool)>,
    /// Exact pairs' far target pieces (`FormFactorParams::far_pieces`), with whether they
    /// need rays.
    far: Vec<(usize, bool)>,
    /// Exact pairs' target points for far pieces (point, weight), and each target piece's
    /// span of them.
    points: Vec<(DVec3, f64)>,
    spans: Vec<(u32, u32)>,
    /// Exact pairs' contributions that need rays: (target piece, source quadrature leaf, weight).
    samples: Vec<Contribution>,
    /// A pair's target pieces' centres and radii ([`centre_radius`]).
    targets: Vec<(DVec3, f64)>,
    /// A clustered pair's source pieces' centres and radii.
    sources: Vec<(DVec3, f64)>,
    /// Per source piece of a clustered pair: the running sum of the contributions before its
    /// own, and its first near target in `blocks`.
    starts: Vec<(f64, usize)>,
    /// Per near piece pair of a clustered pair: the running sum before its quadrature, and the
    /// target piece.
    blocks: Vec<(f64, u32)>,
    /// The corners of a pair's two patches, for [`Occluders::may_block_hull`].
    hull: (Vec<DVec3>, Vec<DVec3>),
}

/// A piece's area-weighted centre and the largest distance from it to a corner.
fn centre_radius(p: &Piece) -> (DVec3, f64) {
    let c = p.polygon.centroid();
    let r = p
        .polygon
        .vertices()
        .iter()
        .map(|v| (*v - c).length())
        .fold(0f64, f64::max);
    (c, r)
}

/// What every pair of one computation shares: the visibility mode, the unblockable-pair cache
/// and the tolerance (from the scene's extent).
struct Setup<'a> {
    occ: Option<&'a Occluders>,
    cache: Option<BlockCache>,
    tol: f64,
}

impl<'a> Setup<'a> {
    fn new(patches: &Patches, occluders: Option<&'a Occluders>, params: &FormFactorParams) -> Self {
        let extent = {
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for p in &patches.pieces {
                for v in p.polygon.vertices() {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
            }
            if patches.pieces.is_empty() {
                1.0
            } else {
                (hi - lo).length()
            }
        };
        let occ = match params.visibility {
            Visibility::Off => None,
            Visibility::Rays { .. } => occluders,
        };
        let cache = match (params.visibility, occ) {
            (
                Visibility::Rays {
                    skip_unblockable: true,
                    ..
                },
                Some(o),
            ) => BlockCache::new(patches, o, &patches.triangles),
            _ => None,
        };
        // Where rays are cast, a piece pair within `CONTACT_GAP` of each other's planes is in
        // contact (or coplanar), and `Occluders::reaches` refuses every ray between them:
        // left out before its quadrature. (Contact pairs refine to the depth limit all over.)
        let tol = match occ {
            Some(o) => CONTACT_GAP * o.extent(),
            None => 1e-9 * extent,
        };
        Self { occ, cache, tol }
    }
}

/// Rows `rows` of the form-factor matrix of `patches`, each `F_i0 … F_i(n−1)` in f64, with the
/// shadow rays they cast: the same pairs, seeds and quadrature as [`form_factors`], so each
/// value is the one the whole matrix stores (before its f32 rounding) at about `rows.len() / n`
/// of its cost (each pair is computed once per row asked for, not once in all). For checking
/// a large scene's rows without computing all of them (`radiosity check-rows`).
///
/// # Panics
/// If a row index is not below `patches.len()`.
pub fn form_factor_rows(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    rows: &[usize],
    progress: Option<Progress<'_>>,
) -> (Vec<Vec<f64>>, u64) {
    let n = patches.len();
    assert!(rows.iter().all(|&i| i < n), "row index out of range");
    let setup = Setup::new(patches, occluders, params);
    let ctx = Pairs::new(patches, setup.occ, setup.cache.as_ref(), params, setup.tol);
    let done = AtomicUsize::new(0);
    let out: Vec<(Vec<f64>, u64)> = rows
        .par_iter()
        .map_init(Scratch::default, |scratch, &i| {
            let mut rays = 0u64;
            let ai = patches.patches[i].area;
            let row = (0..n)
                // In the whole matrix's order (lower index first): a tie in area is
                // integrated from the lower index.
                .map(|j| ctx.exchange(i.min(j), i.max(j), &mut rays, scratch) / ai)
                .collect();
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(d, rows.len());
            }
            (row, rays)
        })
        .collect();
    let rays = out.iter().map(|r| r.1).sum();
    (out.into_iter().map(|r| r.0).collect(), rays)
}

/// Computes the form-factor matrix of `patches`. `occluders` is needed for
/// [`Visibility::Rays`] (ignored otherwise); `progress` is told about finished rows.
pub fn form_factors(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    progress: Option<Progress<'_>>,
) -> FormFactors {
    let n = patches.len();
    let setup = Setup::new(patches, occluders, params);
    // Flat sites for patches of many pieces (an exact patch has none), and every patch's
    // radius about its centre for the near/far test.
    let ctx = Pairs::new(patches, setup.occ, setup.cache.as_ref(), params, setup.tol);
    let done = AtomicUsize::new(0);
    let clustered = std::sync::atomic::AtomicU64::new(0);
    let rows: Vec<(Vec<f64>, u64)> = (0..n)
        .into_par_iter()
        .map_init(Scratch::default, |scratch, i| {
            let mut rays = 0u64;
            let before = scratch.clustered;
            let row: Vec<f64> = (i..n)
                .map(|j| ctx.exchange(i, j, &mut rays, scratch))
                .collect();
            clustered.fetch_add(scratch.clustered - before, Ordering::Relaxed);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress {
                p(d, n);
            }
            (row, rays)
        })
        .collect();
    let mut matrix = vec![0f32; n * n];
    let mut rays_cast = 0;
    for (i, (row, rays)) in rows.iter().enumerate() {
        rays_cast += rays;
        let ai = patches.patches[i].area;
        for (k, &g) in row.iter().enumerate() {
            let j = i + k;
            let aj = patches.patches[j].area;
            matrix[i * n + j] = (g / ai) as f32;
            matrix[j * n + i] = (g / aj) as f32;
        }
    }
    let row_sums: Vec<f64> = (0..n)
        .map(|i| matrix[i * n..(i + 1) * n].iter().map(|&f| f as f64).sum())
        .collect();
    let mut reciprocity_error: f64 = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            let a = patches.patches[i].area * matrix[i * n + j] as f64;
            let b = patches.patches[j].area * matrix[j * n + i] as f64;
            let m = a.max(b);
            if m > 0.0 {
                reciprocity_error = reciprocity_error.max((a - b).abs() / m);
            }
        }
    }
    FormFactors {
        n,
        matrix,
        rays_cast,
        row_sums,
        reciprocity_error,
        pieces: patches.pieces.len(),
        sites: ctx.sites.iter().filter(|s| s.is_some()).count(),
        clustered_pairs: clustered.into_inner(),
    }
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
