//! Exact pairs: every piece pair of a patch pair integrated by the source quadrature and the
//! exact polygon kernel (or, far apart, the rule on both sides with the point kernel), with
//! shadow rays drawn per piece pair in proportion to the contributions (module doc of
//! [`super`]).

use super::flat::{SITE, SITE_RAYS, SITE_SOURCE_OFFSET};
use super::sampling::{Systematic, front_point, in_front, ray_end};
use super::{
    BlockCache, FormFactorParams, MAX_PAIR_RAYS, PAIR_RAYS_PER_FORM_FACTOR, Scratch, Visibility,
    centre_radius, facing, fan, pair_depth, sphere_distance,
};
use crate::geometry::Occluders;
use crate::geometry::point_polygon::point_to_polygon;
use crate::geometry::polygon::point_polygon_distance;
use crate::geometry::quadrature::{Adaptive, Rule, Sample, integrate_bounded};
use crate::patch::Piece;
use glam::DVec3;

/// The exchange `A_src·F(src → dst)` by integrating over `src`.
pub(super) fn exchange(
    src: &[Piece],
    dst: &[Piece],
    occ: Option<&Occluders>,
    cache: Option<&BlockCache>,
    params: &FormFactorParams,
    tol: f64,
    rays: &mut u64,
    scratch: &mut Scratch,
    skips: &Skips<'_>,
    pair: u64,
) -> f64 {
    lay_out_targets(dst, params.quadrature.rule, scratch);
    // Where on its leaf each ray starts is drawn from a stream of its own per patch pair: the
    // rays' numbers below repeat in every pair of one-piece patches, and rays from the same
    // points to every target would make a row's visibility a handful of draws.
    let leaf_stream = pair.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    // Sampled as a whole (`EXACT_PAIR_RAYS`): the minimum per piece pair would cost more.
    let whole = src.len() * dst.len() * MIN_PIECE_RAYS > EXACT_PAIR_RAYS;
    let mut total = 0.0;
    scratch.samples.clear();
    // A pair sampled as a whole keeps at most KEPT_CONTRIBUTIONS; past them it only sums
    // what needs rays, and streams its contributions again below.
    let mut kept = Kept::new(if whole {
        KEPT_CONTRIBUTIONS
    } else {
        usize::MAX
    });
    for (si, s) in src.iter().enumerate() {
        source_contributions(
            si, s, dst, occ, cache, params, tol, whole, scratch, &mut total, &mut kept,
        );
    }
    if scratch.samples.is_empty() && kept.spilled.is_none() {
        return total;
    }
    let o = occ.expect("rays need occluders");
    let ctx = RayContext {
        src,
        dst,
        occ: o,
        params,
        skips,
        leaf_stream,
    };
    let Some(spilled) = kept.spilled else {
        return ctx.sample(&mut scratch.samples, whole, rays, total);
    };
    // Too many to keep: the same contributions again, one source piece at a time, each
    // piece's sorted by target as the kept list would be, fed to one sampler in that order.
    let sum = scratch.samples.iter().map(|e| e.3).sum::<f64>() + spilled;
    let mut sampler = ctx.whole_sampler(sum);
    let mut unused = 0.0;
    for (si, s) in src.iter().enumerate().take(kept.last as usize + 1) {
        scratch.samples.clear();
        let mut all = Kept::new(usize::MAX);
        source_contributions(
            si,
            s,
            dst,
            occ,
            cache,
            params,
            tol,
            whole,
            scratch,
            &mut unused,
            &mut all,
        );
        scratch.samples.sort_by_key(|e| e.1);
        let last_piece = si == kept.last as usize;
        ctx.feed_whole(&mut sampler, &scratch.samples, last_piece);
    }
    scratch.samples.clear();
    *rays += sampler.0.drawn;
    total + sampler.0.estimate(sum)
}

/// Contributions that need rays a pair sampled as a whole keeps in its list, at most: 92 MB
/// of them a thread. A patch of thousands of pieces against another (a finely modelled railing
/// beside a tessellated roof in one coarse patch each) held hundreds of millions, and a bake of
/// 8 962 triangles at 64 patches asked for 5.9 GB in one list.
const KEPT_CONTRIBUTIONS: usize = 1 << 20;

/// What [`Tally`] keeps of the contributions that need rays.
struct Kept {
    /// At most this many in the list.
    limit: usize,
    /// The sum of those past it (none: nothing left out).
    spilled: Option<f64>,
    /// The last source piece with a contribution that needs rays.
    last: u32,
}

impl Kept {
    fn new(limit: usize) -> Self {
        Self {
            limit,
            spilled: None,
            last: 0,
        }
    }
}

/// Far piece pairs (`FormFactorParams::far_pieces`) take the rule on both sides: each target
/// piece's centre and radius, and its rule points, laid out once per pair in `scratch`.
fn lay_out_targets(dst: &[Piece], rule: Rule, scratch: &mut Scratch) {
    let Scratch {
        targets,
        points,
        spans,
        ..
    } = scratch;
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
}

/// The contributions of source piece `si` (`s`) to every target piece it faces: added to
/// `total` where no ray is needed, kept in `scratch.samples` where one is.
fn source_contributions(
    si: usize,
    s: &Piece,
    dst: &[Piece],
    occ: Option<&Occluders>,
    cache: Option<&BlockCache>,
    params: &FormFactorParams,
    tol: f64,
    whole: bool,
    scratch: &mut Scratch,
    total: &mut f64,
    kept: &mut Kept,
) {
    let Scratch {
        live,
        far,
        samples,
        targets,
        points,
        spans,
        ..
    } = scratch;
    let sv = s.polygon.vertices();
    let (cs, rs) = centre_radius(s);
    live.clear();
    far.clear();
    for (k, t) in dst.iter().enumerate() {
        if !facing(sv, s.normal, t.polygon.vertices(), t.normal, tol) {
            continue;
        }
        let need_rays = needs_rays(s, t, occ, cache, params, whole);
        let (ct, rt) = targets[k];
        if (ct - cs).length_squared() > (params.far_pieces * (rs + rt)).powi(2) {
            far.push((k, need_rays));
        } else {
            live.push((k, need_rays));
        }
    }
    if live.is_empty() && far.is_empty() {
        return;
    }
    // Contributions that need rays are kept, per piece pair, and their visibility is
    // sampled afterwards: at least MIN_PIECE_RAYS rays per piece pair, drawn in proportion
    // to the contributions (or EXACT_PAIR_RAYS for the whole patch pair). One ray per quadrature point left a pair that the adaptive
    // quadrature settles in two points all or nothing (the Cornell box at 256 patches: a
    // face of the tall box saw two back-wall patches through the short box, row 1.04).
    let mut tally = Tally {
        si: si as u32,
        samples,
        total,
        kept,
    };
    if !far.is_empty() {
        let rule = params.quadrature.rule;
        far_contributions(s, dst, far, points, spans, rule, &mut tally);
    }
    near_contributions(s, dst, live, targets, params, &mut tally);
}

/// Whether the contribution of source piece `s` to target piece `t` needs shadow rays: where
/// visibility is sampled and something occludes, unless `skip_unblockable` and the block
/// cache (where neither piece is a site's) or the occluders prove the pair unblocked; a pair
/// sampled as a whole (`whole`) asks only the cache.
fn needs_rays(
    s: &Piece,
    t: &Piece,
    occ: Option<&Occluders>,
    cache: Option<&BlockCache>,
    params: &FormFactorParams,
    whole: bool,
) -> bool {
    match (params.visibility, occ) {
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
                    _ => o.may_block(
                        s.polygon.vertices(),
                        s.normal,
                        t.polygon.vertices(),
                        t.normal,
                    ),
                }
        }
    }
}

/// Where a source piece's contributions go: kept in `samples` where they need rays, else
/// added to `total`.
struct Tally<'a> {
    /// The source piece.
    si: u32,
    samples: &'a mut Vec<Contribution>,
    total: &'a mut f64,
    kept: &'a mut Kept,
}

impl Tally<'_> {
    /// The contribution `v` to target piece `k` from the source's quadrature leaf `leaf`.
    fn add(&mut self, k: usize, leaf: [DVec3; 3], v: f64, need_rays: bool) {
        if !need_rays {
            *self.total += v;
            return;
        }
        self.kept.last = self.si;
        if self.samples.len() < self.kept.limit {
            self.samples.push((self.si, k as u32, leaf, v));
        } else {
            *self.kept.spilled.get_or_insert(0.0) += v;
        }
    }
}

/// The source piece `s`'s contributions to its far targets (`far`: target piece, whether it
/// needs rays): the rule's points of each source leaf (the whole fan triangle: at
/// `far_pieces` ≥ 5 the distance rule would not split it) against the target's (`points`,
/// each target's span of them in `spans`, [`lay_out_targets`]).
fn far_contributions(
    s: &Piece,
    dst: &[Piece],
    far: &[(usize, bool)],
    points: &[(DVec3, f64)],
    spans: &[(u32, u32)],
    rule: Rule,
    tally: &mut Tally<'_>,
) {
    for tri in fan(s.polygon.vertices()) {
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
                tally.add(k, tri, wx * g, need_rays);
            }
        }
    }
}

/// The source piece `s`'s contributions to its near targets (`live`: target piece, whether
/// it needs rays): each refines the source against itself alone, by the adaptive quadrature
/// bounded by the target's sphere (`targets`) and the exact polygon kernel.
fn near_contributions(
    s: &Piece,
    dst: &[Piece],
    live: &[(usize, bool)],
    targets: &[(DVec3, f64)],
    params: &FormFactorParams,
    tally: &mut Tally<'_>,
) {
    for &(k, need_rays) in live.iter() {
        let t = &dst[k];
        let dist = |x: DVec3| point_polygon_distance(x, t.polygon.vertices(), t.normal);
        let bound = sphere_distance(targets[k]);
        let quadrature = Adaptive {
            max_depth: pair_depth(params.quadrature.max_depth, s.normal, t.normal),
            ..params.quadrature
        };
        for tri in fan(s.polygon.vertices()) {
            integrate_bounded(tri, &quadrature, &bound, &dist, &mut |q| {
                let f = point_to_polygon(q.x, s.normal, &t.polygon, t.normal);
                if f > 0.0 {
                    tally.add(k, q.leaf, q.w * f, need_rays);
                }
            });
        }
    }
}

/// What a pair's shadow rays leave out.
pub(super) struct Skips<'a> {
    /// Triangles no ray of the pair stops at (a site's own).
    pub triangle: &'a dyn Fn(u32) -> bool,
    /// Per source piece, whether some point of it is buried: a ray from such a piece asks
    /// whether its start is, and one that is reaches nothing. A start inside a solid (a step's
    /// top under the step above, `docs/decisions/shaded-steps.md`) sees the faces inside that
    /// solid, which are buried too; the ray-cast rows leave such hits out the same way.
    /// Empty: no piece is.
    pub buried: &'a [bool],
}

/// What drawing the shadow rays of one exact pair needs.
struct RayContext<'a> {
    src: &'a [Piece],
    dst: &'a [Piece],
    occ: &'a Occluders,
    params: &'a FormFactorParams,
    skips: &'a Skips<'a>,
    leaf_stream: u64,
}

impl RayContext<'_> {
    /// Shadow rays per contribution's leaf: the pair's `per_sample` (0 without visibility).
    fn per_sample(&self) -> u32 {
        match self.params.visibility {
            Visibility::Rays { per_sample, .. } => per_sample.max(1),
            Visibility::Off => 0,
        }
    }

    /// One shadow ray from a point of source piece `si` (drawn with `ray` on its quadrature
    /// leaf `leaf`) to target piece `t`: whether it arrives.
    fn visible(
        &self,
        si: u32,
        t: &Piece,
        leaf: &[DVec3; 3],
        ray: u64,
        k: u64,
        scramble: [u32; 2],
    ) -> bool {
        let (o, skips) = (self.occ, self.skips);
        let s = &self.src[si as usize];
        // A site stands for a whole patch, usually at one quadrature point: its rays are
        // spread over both polygons, not sent from the point.
        if s.triangle == SITE || t.triangle == SITE {
            let x = if s.triangle == SITE {
                front_point(s, t, k + SITE_SOURCE_OFFSET)
            } else {
                Sample::leaf_point(leaf, ray, scramble)
            };
            o.segment_visible_skipping(x, front_point(t, s, k), skips.triangle)
        } else {
            let x = Sample::leaf_point(leaf, ray, scramble);
            in_front(x, t)
                && o.reaches(x, ray_end(x, s, t, k), t.triangle)
                && !(skips.buried.get(si as usize) == Some(&true) && o.buried(x, s.normal))
        }
    }

    /// The sampler of a pair sampled as a whole, whose contributions that need rays sum to
    /// `sum`: [`exact_pair_rays`] of them, numbered from the pair's stream; with that stream's
    /// leaf scramble.
    fn whole_sampler(&self, sum: f64) -> (Systematic, u64, [u32; 2]) {
        let area: f64 = self.src.iter().map(|p| p.area).sum();
        let pair_budget = exact_pair_rays(sum, area) * self.per_sample() as usize;
        let base = self.leaf_stream >> 24;
        (
            Systematic::new(sum, pair_budget, base),
            base,
            Sample::leaf_scramble(base),
        )
    }

    /// Feeds `samples` (in order) to a pair's whole sampler; `last`: they end the pair.
    fn feed_whole(
        &self,
        sampler: &mut (Systematic, u64, [u32; 2]),
        samples: &[Contribution],
        last: bool,
    ) {
        let (sampler, base, scramble) = (&mut sampler.0, sampler.1, sampler.2);
        for (i, e) in samples.iter().enumerate() {
            let t = &self.dst[e.1 as usize];
            sampler.feed(e.3, last && i + 1 == samples.len(), |ray| {
                self.visible(e.0, t, &e.2, ray, base + ray, scramble)
            });
        }
    }

    /// `total` plus the visible part of the contributions in `samples`, whose rays are drawn
    /// per piece pair (at least `MIN_PIECE_RAYS` each), or for the patch pair as a whole
    /// (`EXACT_PAIR_RAYS`) when `whole`; the rays cast are added to `rays`.
    fn sample(
        &self,
        samples: &mut [Contribution],
        whole: bool,
        rays: &mut u64,
        mut total: f64,
    ) -> f64 {
        let per_sample = self.per_sample();
        // Stable: within a piece pair the contributions keep their order.
        samples.sort_by_key(|e| (e.0, e.1));
        if whole {
            let sum: f64 = samples.iter().map(|e| e.3).sum();
            let mut sampler = self.whole_sampler(sum);
            self.feed_whole(&mut sampler, samples, true);
            *rays += sampler.0.drawn;
            return total + sampler.0.estimate(sum);
        }
        let same_pieces = |a: &Contribution, b: &Contribution| (a.0, a.1) == (b.0, b.1);
        for group in samples.chunk_by(same_pieces) {
            let (s, t) = (
                &self.src[group[0].0 as usize],
                &self.dst[group[0].1 as usize],
            );
            let site = s.triangle == SITE || t.triangle == SITE;
            let per_point = per_sample * if site { SITE_RAYS } else { 1 };
            // Rays start anywhere on their leaf, so a leaf's points share its rays: the budget
            // counts leaves, and a finer rule costs kernel evaluations, not rays.
            let leaves = group
                .len()
                .div_ceil(self.params.quadrature.rule.points().len());
            let budget = (leaves * per_point as usize).max(MIN_PIECE_RAYS * per_sample as usize);
            // Each piece pair numbers its own rays: a quadrature that differs in one pair (by
            // rounding) must not renumber the rays of the others.
            let base = u64::from(group[0].0) << 40 | u64::from(group[0].1) << 20;
            let sum: f64 = group.iter().map(|e| e.3).sum();
            let mut sampler = Systematic::new(sum, budget, base);
            let scramble = Sample::leaf_scramble(base ^ self.leaf_stream);
            for (i, e) in group.iter().enumerate() {
                sampler.feed(e.3, i + 1 == group.len(), |ray| {
                    self.visible(e.0, t, &e.2, ray, base + ray, scramble)
                });
            }
            *rays += sampler.drawn;
            total += sampler.estimate(sum);
        }
        total
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
pub(super) type Contribution = (u32, u32, [DVec3; 3], f64);

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
