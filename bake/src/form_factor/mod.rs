//! The patch-to-patch form-factor matrix F (n × n, f64 accumulation, f32 storage).
//!
//! `F_ij = (1/A_i) ∫_{A_i} Σ_{t ∈ pieces(j)} F(x → t) · V(x, t) dA(x)`:
//! - the inner factor `F(x → t)` is the exact point-to-polygon kernel ([`crate::geometry::point_polygon`]), so
//!   neighbours that share an edge or nearly touch are as accurate as distant ones;
//! - the outer integral is an adaptive quadrature ([`crate::geometry::quadrature`]) that subdivides the
//!   source where it is large compared with its distance to the target, each target piece on
//!   its own (refining it against the nearest target and reading the others on those leaves
//!   took twice the time on an icosphere);
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
//! **Many pieces.** Above [`FormFactorParams::exact_pieces`] pieces (a real scene of tens of
//! thousands of triangles), the matrix is ray-cast by default ([`ManyPieces::Rays`], `cast`):
//! every patch casts the same number of cosine-weighted rays against the full-detail
//! triangles, each hit counts for the patch whose piece it lands on, and the two sides of each
//! pair are pooled into one exchange, so reciprocity holds and the cost is rays × log
//! triangles, following the patches. The quadrature below stays for smaller scenes, where it
//! is exact to 1e-5; [`ManyPieces::Clustered`] keeps clustered pairs for large ones
//! (`docs/decisions/ray-cast-form-factors.md` has the comparison).
//!
//! **Clustered pairs.** With [`ManyPieces::Clustered`], in the same large scenes every pair (after flat sites) is integrated by
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
//!   1000-unit floor triangle seen through furniture is otherwise all or nothing).
//!
//! On Greg Ward's conference room (330 000 triangles, 4410 patches) this took the form factors
//! from an estimated 4 h to minutes on 2 cores (ARCHITECTURE.md has the measurements).

pub(crate) mod burial;
pub(crate) mod cast;
mod clustered;
mod cost;
mod exact;
mod flat;
pub(crate) mod matrix;
mod params;
mod sampling;

pub use cast::SparseFormFactors;
pub(crate) use cast::Starts;
pub use clustered::{NEAR_RAYS, PAIR_RAYS_PER_FORM_FACTOR};
pub use exact::EXACT_PAIR_RAYS;
pub use params::{FormFactorParams, FormFactorSummary, ManyPieces, RAYS_PER_PATCH, Visibility};

pub(crate) use clustered::{FAR_RAYS, MAX_PAIR_RAYS};
pub(crate) use cost::{RAYS_PER_PIECE_PAIR, exact_costs_too_much, piece_pairs};

use crate::geometry::bvh::{CONTACT_GAP, Occluders};
use crate::patch::{Patches, Piece};
use exact::Contribution;
use flat::Sites;
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

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
    /// Rays cast per patch where the matrix was ray-cast (module doc, "many pieces"; 0 when
    /// it was integrated).
    pub rays_per_patch: u32,
    /// The piece pairs exact pairs would integrate ([`piece_pairs`]).
    pub piece_pairs: f64,
}

impl FormFactors {
    /// `F_ij`.
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f32 {
        self.matrix[i * self.n + j]
    }
}

/// Progress callback: `(rows done, rows in all)`, called from worker threads; returns whether
/// to go on. Once it returns `false` the rows not yet started are skipped (left zero), so the
/// matrix is incomplete and the caller discards it (a cancelled bake).
pub type Progress<'a> = &'a (dyn Fn(usize, usize) -> bool + Sync);

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
pub(crate) const MAX_EXACT_PIECES: usize = 16;

/// The lowest depth limit [`pair_depth`] gives a nearly coplanar pair. Measured on an
/// icosphere of 1280 triangles at 398 patches (3668 pieces): rows of F differ from the full
/// depth by 8e-6 (L1, worst row) at 3, 2.7e-5 at 2, 1.0e-4 at 1; the form factors took 2.4 s
/// at 3 against 4.8 s at the full depth.
const MIN_PAIR_DEPTH: u32 = 3;

/// A pair is far when its centres are more than this many times the sum of the patches' radii
/// apart (their bounding spheres do not meet): each side then sees the other as one flat site.
/// Near pairs (neighbours) keep their pieces: touching patches are where the kernel is most
/// sensitive to the shape, and a flattened stand-in there cost a closed box's rows up to 2%.
const FAR_RATIO: f64 = 1.0;

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
    /// Exact pairs: per piece of `patches.pieces`, whether a point of it was found buried
    /// ([`partly_buried`]); empty without occluders or when pairs are clustered.
    buried: Vec<bool>,
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
        let buried = match occ {
            Some(o) if !use_sites => patches
                .pieces
                .par_iter()
                .map(|p| partly_buried(p, o))
                .collect(),
            _ => Vec::new(),
        };
        Self {
            patches,
            occ,
            cache,
            params,
            tol,
            sites,
            radius,
            clustered: use_sites,
            buried,
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
        let src_buried = self
            .buried
            .get(self.patches.patches[a].pieces.clone())
            .unwrap_or(&[]);
        exact::exchange(
            src,
            dst,
            occ,
            self.cache,
            self.params,
            self.tol,
            rays,
            scratch,
            &exact::Skips {
                triangle: &skip,
                buried: src_buried,
            },
            (a as u64) << 32 | b as u64,
        )
    }
}

/// Each patch's coverage (glTF `alphaMode`): the area-weighted mean of its pieces'
/// triangles' ([`Occluders::coverage`]), or `None` when every patch is whole. A form factor
/// `F_ij` is the share of the light leaving `i` that reaches the part of `j` that is there,
/// `c_j` times the geometric one (whose rays pass partly covered triangles on the way by their
/// share, [`Occluders::with_coverage`]); the exchange between the two covered parts is
/// `c_i c_j A_i F^geo_ij`, so reciprocity holds with the areas `c·A`.
pub(crate) fn coverage(patches: &Patches, occ: Option<&Occluders>) -> Option<Vec<f64>> {
    let occ = occ?;
    let c: Vec<f64> = (0..patches.len())
        .map(|i| {
            let (mut covered, mut area) = (0.0, 0.0);
            for p in patches.pieces_of(i) {
                covered += f64::from(occ.coverage(p.triangle)) * p.area;
                area += p.area;
            }
            if area > 0.0 { covered / area } else { 1.0 }
        })
        .collect();
    c.iter().any(|&c| c < 1.0).then_some(c)
}

/// Whether some point of `piece` is buried ([`Occluders::buried`]): its centre or a point a
/// tenth of the way in from a corner. Only such a piece's shadow rays ask whether their start
/// is buried (`exact::Skips`), so the test's rays are paid once per piece, not per ray.
fn partly_buried(piece: &Piece, occ: &Occluders) -> bool {
    let v = piece.polygon.vertices();
    if v.is_empty() {
        return false;
    }
    let centre = v.iter().copied().sum::<DVec3>() / v.len() as f64;
    std::iter::once(centre)
        .chain(v.iter().map(|&c| c + 0.1 * (centre - c)))
        .any(|x| occ.buried(x, piece.normal))
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

/// A lower bound of the distance from a point to anything inside the sphere `(c, r)`, for
/// [`integrate_bounded`]: a hair under `|x − c| − r`, so that rounding never puts it above the
/// distance to a polygon the sphere holds ([`centre_radius`]).
fn sphere_distance((c, r): (DVec3, f64)) -> impl Fn(DVec3) -> f64 {
    move |x: DVec3| ((x - c).length() - r) * (1.0 - 1e-9)
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
    if let Some((occ, per_patch)) = cast_rays(patches, occluders, params) {
        // Every row of a ray-cast matrix pools both sides of its pairs, so the rows come from
        // the whole matrix, whose cost follows the patches anyway.
        let mut matrix = vec![0f32; n * n];
        let burial = crate::form_factor::burial::survey(patches, occ);
        let cover = coverage(patches, Some(occ));
        let rays = cast::cast(
            patches,
            occ,
            per_patch,
            &burial,
            cover.as_deref(),
            &mut matrix,
            progress,
        );
        let out = rows
            .iter()
            .map(|&i| {
                matrix[i * n..(i + 1) * n]
                    .iter()
                    .map(|&f| f64::from(f))
                    .collect()
            })
            .collect();
        return (out, rays);
    }
    let setup = Setup::new(patches, occluders, params);
    let ctx = Pairs::new(patches, setup.occ, setup.cache.as_ref(), params, setup.tol);
    let cover = coverage(patches, occluders);
    let done = AtomicUsize::new(0);
    let stopped = AtomicBool::new(false);
    let out: Vec<(Vec<f64>, u64)> = rows
        .par_iter()
        .map_init(Scratch::default, |scratch, &i| {
            if stopped.load(Ordering::Relaxed) {
                return (vec![0.0; n], 0);
            }
            let mut rays = 0u64;
            let ai = patches.patches[i].area;
            let row = (0..n)
                // In the whole matrix's order (lower index first): a tie in area is
                // integrated from the lower index.
                .map(|j| {
                    let cj = cover.as_ref().map_or(1.0, |c| c[j]);
                    cj * ctx.exchange(i.min(j), i.max(j), &mut rays, scratch) / ai
                })
                .collect();
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress
                && !p(d, rows.len())
            {
                stopped.store(true, Ordering::Relaxed);
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
    form_factors_surveyed(patches, occluders, params, None, progress)
}

/// [`form_factors`], with the burial survey ([`crate::form_factor::burial::survey`]) where the caller has
/// it; the ray-cast rows take one of their own otherwise.
pub(crate) fn form_factors_surveyed(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    burial: Option<&[Vec<u32>]>,
    progress: Option<Progress<'_>>,
) -> FormFactors {
    let n = patches.len();
    if let Some((occ, per_patch)) = cast_rays(patches, occluders, params) {
        let mut matrix = vec![0f32; n * n];
        let own;
        let burial = match burial {
            Some(b) => b,
            None => {
                own = crate::form_factor::burial::survey(patches, occ);
                &own
            }
        };
        let cover = coverage(patches, Some(occ));
        let rays_cast = cast::cast(
            patches,
            occ,
            per_patch,
            burial,
            cover.as_deref(),
            &mut matrix,
            progress,
        );
        return FormFactors {
            rays_per_patch: per_patch,
            ..FormFactors::new(patches, matrix, rays_cast, 0, 0)
        };
    }
    let setup = Setup::new(patches, occluders, params);
    // Flat sites for patches of many pieces (an exact patch has none), and every patch's
    // radius about its centre for the near/far test.
    let ctx = Pairs::new(patches, setup.occ, setup.cache.as_ref(), params, setup.tol);
    let done = AtomicUsize::new(0);
    let stopped = AtomicBool::new(false);
    let clustered = std::sync::atomic::AtomicU64::new(0);
    let rows: Vec<(Vec<f64>, u64)> = (0..n)
        .into_par_iter()
        .map_init(Scratch::default, |scratch, i| {
            if stopped.load(Ordering::Relaxed) {
                return (vec![0.0; n - i], 0);
            }
            let mut rays = 0u64;
            let before = scratch.clustered;
            let row: Vec<f64> = (i..n)
                .map(|j| ctx.exchange(i, j, &mut rays, scratch))
                .collect();
            clustered.fetch_add(scratch.clustered - before, Ordering::Relaxed);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress
                && !p(d, n)
            {
                stopped.store(true, Ordering::Relaxed);
            }
            (row, rays)
        })
        .collect();
    let mut matrix = vec![0f32; n * n];
    let mut rays_cast = 0;
    let cover = coverage(patches, occluders);
    let c = |i: usize| cover.as_ref().map_or(1.0, |c| c[i]);
    for (i, (row, rays)) in rows.iter().enumerate() {
        rays_cast += rays;
        let ai = patches.patches[i].area;
        for (k, &g) in row.iter().enumerate() {
            let j = i + k;
            let aj = patches.patches[j].area;
            matrix[i * n + j] = (c(j) * g / ai) as f32;
            matrix[j * n + i] = (c(i) * g / aj) as f32;
        }
    }
    let sites = ctx.sites.iter().filter(|s| s.is_some()).count();
    FormFactors::new(patches, matrix, rays_cast, sites, clustered.into_inner())
}

/// The ray-cast form factors ([`ManyPieces::Rays`]) as sparse rows: entry for entry the
/// matrix [`form_factors`] gives for them, without its n² floats. `None` where the rows would
/// not be ray-cast (the scene has at most [`FormFactorParams::exact_pieces`] pieces, or no
/// visibility rays or occluders).
pub fn form_factors_sparse(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    progress: Option<Progress<'_>>,
) -> Option<SparseFormFactors> {
    form_factors_sparse_surveyed(patches, occluders, params, None, progress)
}

/// [`form_factors_sparse`], with the burial survey ([`crate::form_factor::burial::survey`]) where the
/// caller has it.
pub(crate) fn form_factors_sparse_surveyed(
    patches: &Patches,
    occluders: Option<&Occluders>,
    params: &FormFactorParams,
    burial: Option<&[Vec<u32>]>,
    progress: Option<Progress<'_>>,
) -> Option<SparseFormFactors> {
    let (occ, per_patch) = cast_rays(patches, occluders, params)?;
    let own;
    let burial = match burial {
        Some(b) => b,
        None => {
            own = crate::form_factor::burial::survey(patches, occ);
            &own
        }
    };
    let cover = coverage(patches, Some(occ));
    Some(cast::cast_sparse(
        patches,
        occ,
        per_patch,
        burial,
        cover.as_deref(),
        progress,
    ))
}

/// Whether `patches` take ray-cast form factors ([`ManyPieces::Rays`], with visibility rays
/// and occluders: above [`FormFactorParams::exact_pieces`] pieces, or where integrating every
/// piece pair would cost too much against the rays, [`exact_costs_too_much`]), and with how
/// many rays per patch.
fn cast_rays<'a>(
    patches: &Patches,
    occluders: Option<&'a Occluders>,
    params: &FormFactorParams,
) -> Option<(&'a Occluders, u32)> {
    match (params.many_pieces, params.visibility, occluders) {
        (ManyPieces::Rays { per_patch }, Visibility::Rays { .. }, Some(occ))
            if patches.pieces.len() > params.exact_pieces
                || exact_costs_too_much(piece_pairs(patches), patches.len(), per_patch) =>
        {
            Some((occ, per_patch))
        }
        _ => None,
    }
}

impl FormFactors {
    /// The matrix with its diagnostics (row sums, reciprocity).
    fn new(
        patches: &Patches,
        matrix: Vec<f32>,
        rays_cast: u64,
        sites: usize,
        clustered_pairs: u64,
    ) -> Self {
        let n = patches.len();
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
            sites,
            clustered_pairs,
            rays_per_patch: 0,
            piece_pairs: piece_pairs(patches),
        }
    }
}
