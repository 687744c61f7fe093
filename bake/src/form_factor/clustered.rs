//! Clustered pairs (module doc of [`super`], "clustered pairs"): the pairs of scenes above
//! [`super::FormFactorParams::exact_pieces`] pieces, piece pairs far apart for their size
//! centre to centre, the rest by quadrature, and visibility sampled once per patch pair.

use super::flat::{SITE, SITE_SOURCE_OFFSET};
use super::sampling::{Systematic, front_point, in_front, ray_end};
use super::{
    FormFactorParams, Pairs, Scratch, Visibility, centre_radius, facing, fan, pair_depth,
    sphere_distance,
};
use crate::geometry::Occluders;
use crate::geometry::point_polygon::point_to_polygon;
use crate::geometry::polygon::point_polygon_distance;
use crate::geometry::quadrature::{Adaptive, Sample, integrate_bounded};
use crate::patch::Piece;
use glam::DVec3;

impl Pairs<'_> {
    /// The exchange of a pair of many pieces (module doc, "clustered pairs"): piece pairs far
    /// apart compared with their sizes meet centre to centre, the rest through the source
    /// quadrature and the exact kernel, and visibility is sampled in proportion to the
    /// unoccluded contributions instead of one ray for each of them.
    pub(super) fn clustered(
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
        let near = Near {
            src,
            dst,
            sources,
            targets,
            params: self.params,
        };
        let total = near.sum(live, starts, blocks, self.tol);
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
        let ends = RayEnds {
            src,
            dst,
            occ,
            skip,
            base,
            scramble: Sample::leaf_scramble(base),
        };
        if !(total > 0.0) {
            return 0.0;
        }
        let mut sampler = Systematic::new(total, budget, base);
        near.draw(&mut sampler, &ends, starts, blocks, total);
        *rays += sampler.drawn;
        sampler.estimate(total)
    }
}

/// The pieces of a clustered pair, with their centres and radii ([`centre_radius`]).
struct Near<'a> {
    src: &'a [Piece],
    dst: &'a [Piece],
    sources: &'a [(DVec3, f64)],
    targets: &'a [(DVec3, f64)],
    params: &'a FormFactorParams,
}

impl Near<'_> {
    /// The near contributions of source piece `si` and target piece `ti`: each near target
    /// gets its own adaptive quadrature of the source, so that a source piece that touches
    /// one target is refined next to that one only. The exchange is symmetric, so each piece
    /// pair is integrated over the smaller of its two pieces (`integrate_over_target`): a
    /// piece the size of a wall against a chair's facet a hand away from it was refined to the
    /// depth limit once per facet.
    fn contributions(&self, si: usize, ti: usize, out: &mut dyn FnMut([DVec3; 3], f64)) {
        let (sources, targets) = (self.sources, self.targets);
        let (s, t) = (&self.src[si], &self.dst[ti]);
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
    }

    /// The unoccluded exchange of the pair. The contributions come in a fixed order (per
    /// source piece: its centre-to-centre pairs in target order, then the quadrature of each
    /// near target), and visibility is drawn along their running sum. None is kept: they are
    /// about `|src|·|dst|` many, and a touching pair of pieces has hundreds of quadrature
    /// points (48 bytes each: with patches of up to 25 000 pieces, the conference room's bake
    /// needed 21–24 GB to keep them). This pass sums them and records the running sum where
    /// each source piece (`starts`) and each near piece pair (`blocks`) starts; the drawing
    /// pass ([`Self::draw`]) recomputes them, in the same order and to the same bits, only
    /// where a ray falls.
    fn sum(
        &self,
        live: &mut Vec<(usize, bool)>,
        starts: &mut Vec<(f64, usize)>,
        blocks: &mut Vec<(f64, u32)>,
        tol: f64,
    ) -> f64 {
        let mut total = 0.0;
        for (si, s) in self.src.iter().enumerate() {
            let sv = s.polygon.vertices();
            let (cs, rs) = self.sources[si];
            starts.push((total, blocks.len()));
            live.clear();
            for (ti, t) in self.dst.iter().enumerate() {
                if near(cs, rs, self.targets[ti]) {
                    if facing(sv, s.normal, t.polygon.vertices(), t.normal, tol) {
                        live.push((ti, true));
                    }
                } else if let Some(g) = centre_to_centre(s, cs, t, self.targets[ti].0) {
                    total += g;
                }
            }
            for &(k, _) in live.iter() {
                blocks.push((total, k as u32));
                self.contributions(si, k, &mut |_, g| total += g);
            }
        }
        total
    }

    /// The drawing pass: feeds the contributions to `sampler` in the order [`Self::sum`]
    /// summed them, recomputing only the stretches (source pieces' centre-to-centre pairs,
    /// near piece pairs) where a position falls.
    fn draw(
        &self,
        sampler: &mut Systematic,
        ends: &RayEnds<'_>,
        starts: &[(f64, usize)],
        blocks: &[(f64, u32)],
        total: f64,
    ) {
        let (sources, targets) = (self.sources, self.targets);
        for (si, s) in self.src.iter().enumerate() {
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
                for (ti, t) in self.dst.iter().enumerate() {
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
                        sampler.feed(g, false, |k| ends.visible(&e, k));
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
                // Decided once per piece pair, as `contributions` decides it.
                let turned = integrate_over_target(sources[si].1, targets[k as usize].1);
                self.contributions(si, k as usize, &mut |leaf, g| {
                    let e = Entry {
                        leaf,
                        s: si as u32,
                        t: k,
                        centre: false,
                        turned,
                    };
                    sampler.feed(g, false, |k| ends.visible(&e, k));
                });
            }
        }
    }
}

/// Where the shadow rays of a clustered pair start and end, and what they test.
struct RayEnds<'a> {
    src: &'a [Piece],
    dst: &'a [Piece],
    occ: &'a Occluders,
    skip: &'a dyn Fn(u32) -> bool,
    base: u64,
    scramble: [u32; 2],
}

impl RayEnds<'_> {
    /// Whether draw `k`'s ray for contribution `e` is unblocked.
    fn visible(&self, e: &Entry, k: u64) -> bool {
        let (base, occ) = (self.base, self.occ);
        let (s, t) = (&self.src[e.s as usize], &self.dst[e.t as usize]);
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
            let x = Sample::leaf_point(&e.leaf, k, self.scramble);
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
            occ.segment_visible_skipping(x + s.normal * lift, y + t.normal * lift, self.skip)
        } else {
            occ.reaches(x, y, t.triangle)
        }
    }
}

/// In a clustered pair, two pieces whose centres are more than this many times the sum of
/// their radii apart meet centre to centre (`A_s A_t cos cos / (π r² + A_s + A_t)`, exact
/// for a point on the axis of a disc, 0.3% off for two equal coaxial discs at this distance).
const POINT_RATIO: f64 = 4.0;

/// Shadow rays per far clustered pair (times `per_sample`), drawn in proportion to the
/// unoccluded contributions of its piece pairs. 16 left the wall rows of the sphere-in-a-box
/// test in [0.9841, 1.0071], 32 in [0.9877, 1.0046] (exact pairs: [0.9874, 1.0109]).
pub(crate) const FAR_RAYS: usize = 32;

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
pub(crate) const MAX_PAIR_RAYS: usize = 4096;

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
