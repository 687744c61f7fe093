//! Burial and closure: the surface that other objects bury, taken out of the patches
//! ([`expose`]); whether light leaves the scene (F's row sums, then hemisphere rays,
//! [`escape_check`]); and the matching correction of F ([`closure_effect`]).

use crate::effects::Effect;
use crate::exchange::Exchange;
use crate::form_factor::Starts;
use crate::geometry::Occluders;
use crate::patch::points::{cosine_direction, patch_point_at, patch_rng};
use crate::pipeline::{BakeParams, ClosureReport};
use crate::patch::Patches;
use crate::simplify::runtime_mesh::direct_points;
use crate::transfer::closure_of_sums;
use rayon::prelude::*;
use serde::Serialize;

/// What [`expose`] found: how much of the surface is buried under other objects.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Exposure {
    /// Patches partly buried (their areas and rows of F changed).
    pub partly: usize,
    /// Buried share of each patch's area (simplification order).
    pub share: Vec<f64>,
    /// Patches wholly buried (their rows and columns of F zeroed).
    pub wholly: usize,
    /// Buried area of each object (file object order), from the objects of the buried points.
    pub buried_area: Vec<f64>,
    /// Per patch (simplification order) holding pieces of more than one object: the exposed
    /// area of each of those objects in it (increasing object order, summing to the patch's
    /// exposed area); empty for a patch of one object.
    pub shared: Vec<Vec<(u32, f64)>>,
    /// Per patch, for each of its direct-light points
    /// ([`crate::simplify::runtime_mesh::direct_points`]), whether the point is buried (so it
    /// lends no direct-light sample to the runtime); empty for a patch nothing buries.
    pub buried_points: Vec<Vec<bool>>,
}

/// Takes out of every patch the share of its area that another object buries (a floor under a
/// block that rests on it, a face pressed against a wall): no light reaches or leaves that
/// part, so it is not surface. A patch with exposed share `e` keeps the area `e·A` and the row
/// `F/e`, the mean over its exposed part; `A·F_ij` and the column are unchanged, so
/// reciprocity holds. Without this a partly buried patch spreads its mean radiosity, dimmed by
/// the dark part, over only the exposed part: energy lost at every bounce (ARCHITECTURE.md,
/// "Buried surface": a closed room at ρ = 0.999 with 1% of its area buried gave a quarter of
/// the furnace's light). A wholly buried patch's row and column are zeroed (it is dropped as
/// dark). Nothing is done where nothing occludes (`occ` is `None`).
pub(crate) fn expose(
    patches: &mut Patches,
    occ: Option<&Occluders>,
    f: &mut Exchange,
    burial: &[Vec<u32>],
    points: &[u32],
) -> Exposure {
    let objects = patches
        .pieces
        .iter()
        .map(|p| p.object as usize + 1)
        .max()
        .unwrap_or(0);
    let mut exposure = Exposure {
        buried_area: vec![0.0; objects],
        buried_points: vec![Vec::new(); patches.len()],
        shared: vec![Vec::new(); patches.len()],
        ..Exposure::default()
    };
    let buried: Vec<(f64, Vec<(u32, f64)>)> = match occ {
        Some(_) => (0..patches.len())
            .map(|i| buried_by_object(patches, i, burial.get(i).map_or(&[], Vec::as_slice)))
            .collect(),
        None => vec![(0.0, Vec::new()); patches.len()],
    };
    for (i, (_, by)) in buried.iter().enumerate() {
        let mut shares = crate::patch::object_shares(patches.pieces_of(i));
        if shares.len() < 2 {
            continue;
        }
        for (o, a) in &mut shares {
            if let Some((_, b)) = by.iter().find(|(bo, _)| bo == o) {
                *a = (*a - b).max(0.0);
            }
        }
        shares.retain(|s| s.1 > 0.0);
        exposure.shared[i] = shares;
    }
    let Some(occ) = occ else {
        return exposure;
    };
    exposure.share = buried.iter().map(|b| b.0).collect();
    for (_, by) in &buried {
        for &(o, b) in by {
            exposure.buried_area[o as usize] += b;
        }
    }
    let mut gone = vec![false; patches.len()];
    for (i, &b) in exposure.share.iter().enumerate() {
        if b <= 0.0 {
            continue;
        }
        let p = &mut patches.patches[i];
        let e = 1.0 - b;
        if e <= 0.0 {
            exposure.wholly += 1;
            gone[i] = true;
            continue;
        }
        exposure.partly += 1;
        p.area *= e;
        f.divide_row(i, e);
    }
    // Zeroing the buried rows and columns after the division is the same as before it: a
    // zero divided stays zero.
    f.bury(&gone);
    // Which of the points the runtime samples direct light at (`runtime_mesh::runtime_mesh`)
    // lie buried, in the partly buried patches: as the surveyed starts say (`by_survey`),
    // asked where they cannot tell.
    let share = &exposure.share;
    exposure.buried_points = (0..patches.len())
        .into_par_iter()
        .map(|i| {
            if !(share[i] > 0.0 && share[i] < 1.0) {
                return Vec::new();
            }
            let survey = burial.get(i).map_or(&[][..], Vec::as_slice);
            let verdict = by_survey(patches, i, survey);
            direct_points(patches.pieces_of(i), points[i])
                .iter()
                .map(|d| verdict(d).unwrap_or_else(|| occ.buried(d.position, d.normal)))
                .collect()
        })
        .collect();
    // An object all of whose direct-light points in a shared patch lie buried is buried
    // there: its pieces in the patch were too small to hold a surveyed start (a bench's leg
    // standing on a plinth, its foot alone in the plinth's patch), so the survey left them
    // exposed, and `solve` would give them the patch's mean direct light (its sunlit
    // plinth's). Its share goes to the patch's other objects, in proportion.
    for i in 0..patches.len() {
        let marks = &exposure.buried_points[i];
        if marks.is_empty() || exposure.shared[i].len() < 2 {
            continue;
        }
        let pts = direct_points(patches.pieces_of(i), points[i]);
        let mut gone = 0.0;
        let shares = &mut exposure.shared[i];
        let before: f64 = shares.iter().map(|s| s.1).sum();
        shares.retain(|&(o, a)| {
            let mut mine = pts
                .iter()
                .zip(marks)
                .filter(|(d, _)| d.object == o)
                .peekable();
            let buried = mine.peek().is_some() && mine.all(|(_, &b)| b);
            if buried {
                gone += a;
                exposure.buried_area[o as usize] += a;
            }
            !buried
        });
        let rest = before - gone;
        if gone > 0.0 && rest > 0.0 {
            for (o, a) in shares.iter_mut() {
                let more = *a * gone / rest;
                *a += more;
                let b = &mut exposure.buried_area[*o as usize];
                *b = (*b - more).max(0.0);
            }
        }
    }
    exposure
}

/// Decides whether the scene is closed, corrects `f` (of exposed patches, [`expose`]) to
/// match, and says why: a closed scene's rows are rebalanced to sum to 1, an open scene's rows
/// above 1 are capped where they would create energy.
pub(crate) fn closure_effect(
    patches: &Patches,
    f: &mut Exchange,
    areas: &[f64],
    exposure: &Exposure,
    params: &BakeParams,
    escape: &dyn Fn(&[bool]) -> Escape,
) -> (ClosureReport, Effect) {
    let tol = params.closure_tolerance;
    // A partly buried patch's row is F's mean over its whole area divided by the exposed
    // share, two estimates with their own errors: a patch a few per cent exposed carries both
    // magnified (on a room with a block resting on its floor those rows range over [0.85,
    // 1.17] at 1368 patches; 0.68 to 1.86 before shadow rays started across their quadrature
    // leaf). Those rows are rebalanced or capped with the rest, but only the others say
    // whether light escapes. Among those, a patch whose buried sliver the first look
    // (`row_check::BURIED_FIRST`) misses keeps a row short by that sliver (0.955–0.968 at
    // 4358 patches on the same room with a 32-point look, 0.992 at worst with 64).
    let partly = |i: usize| exposure.share.get(i).is_some_and(|&b| b > 0.0 && b < 1.0);
    let n = f.n();
    let sums: Vec<f64> = (0..n).map(|i| f.row_sum(i)).collect();
    let rest = (0..n).filter(|&i| !partly(i) && sums[i] > 0.0);
    let closure = if rest.clone().next().is_some() {
        closure_of_sums(rest.map(|i| sums[i]), tol)
    } else {
        closure_of_sums(sums.iter().copied(), tol)
    };
    let mut report = ClosureReport {
        min_row_sum: closure.min_row_sum,
        max_row_sum: closure.max_row_sum,
        max_row_patch: (0..n).max_by(|&a, &b| sums[a].total_cmp(&sums[b])),
        correction: 0.0,
        escaped: None,
    };
    let mut range = format!(
        "row sums of F in [{:.5}, {:.5}]",
        closure.min_row_sum, closure.max_row_sum
    );
    if exposure.partly > 0 {
        let buried: f64 = exposure.buried_area.iter().sum();
        let (lo, hi) = (0..n)
            .filter(|&i| partly(i))
            .fold((f64::INFINITY, 0f64), |(lo, hi), i| {
                (lo.min(sums[i]), hi.max(sums[i]))
            });
        report.max_row_sum = report.max_row_sum.max(hi);
        range += &format!(
            " ({} patches partly buried under other objects, {:.4} of the area, by {BURIED_POINTS} points each: their rows, over the exposed part, in [{lo:.3}, {hi:.3}])",
            exposure.partly,
            buried / (areas.iter().sum::<f64>() + buried)
        );
    }
    // Rows within the tolerance can still hide an opening smaller than it: the geometry has
    // the last word (`escape_check`).
    let mut opening = String::new();
    let closed = closure.closed
        && {
            let live: Vec<bool> = sums.iter().map(|s| *s > 0.0).collect();
            let e = escape(&live);
            report.escaped = Some(e.share());
            range += &format!(
                "; {} of {} hemisphere rays from the patches leave the scene",
                e.escaped, e.rays
            );
            if e.share() > ESCAPE_LIMIT {
                opening = format!(
                    " through an opening (more than {ESCAPE_LIMIT:.0e} of the rays), though every row is within {tol} of 1"
                );
            }
            e.share() <= ESCAPE_LIMIT
        };
    if closed {
        f.enforce_closure(areas);
        // The largest relative change of a row sum, apart from and among the partly buried.
        let (mut rest, mut buried) = (0f64, 0f64);
        for (i, b) in sums.iter().enumerate().filter(|(_, b)| **b > 0.0) {
            let change = (f.row_sum(i) - b).abs() / b;
            let m = if partly(i) { &mut buried } else { &mut rest };
            *m = m.max(change);
        }
        report.correction = rest;
        let why = format!(
            "{range}: closed; rebalanced to 1 keeping reciprocity (largest correction {rest:.2e}{})",
            if exposure.partly > 0 {
                format!(", {buried:.2e} on the partly buried")
            } else {
                String::new()
            }
        );
        return (report, Effect::new(true, why));
    }
    // Open. Rows above 1 send out more light than the patch gives: beyond the tolerance that
    // is coincident faces (both seen through the same solid angle), scaled down to 1 keeping
    // reciprocity. Excesses within the tolerance are quadrature error and stay (capping the
    // Cornell box's 1% near-field excess raised its BC1 lighting error from 3.8% to 5.1%),
    // unless some row's reflected light would then reach 1: the transfer could not converge.
    if report.max_row_sum > 1.0 + tol || f.largest_gain(patches) >= 1.0 {
        report.correction = f.cap_row_sums(areas);
    }
    let why = format!(
        "{range}: light escapes{opening}; {}",
        if report.correction > 0.0 {
            format!(
                "rows above 1 scaled down to 1 keeping reciprocity (largest correction {:.2e})",
                report.correction
            )
        } else {
            "no closure correction".to_owned()
        }
    );
    (report, Effect::new(false, why))
}

/// Cosine-weighted hemisphere rays in all for [`escape_check`], spread over the patches in
/// proportion to their area: an opening of 0.1% of the area lets about 16 of them out.
pub(crate) const ESCAPE_RAYS: u64 = 16_384;

/// Largest share of [`escape_check`]'s rays that may leave the scene for it to count as closed.
/// A watertight enclosure lets none out; the allowance is for rays that slip through where two
/// triangles meet. Above it the scene has an opening of about that share of its area, and
/// calling it closed would trap light that leaves: at ρ = 0.999 an opening of 0.1% of the area
/// halves the furnace's radiosity.
pub(crate) const ESCAPE_LIMIT: f64 = 1e-3;

/// What [`escape_check`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub(crate) struct Escape {
    /// Rays cast.
    pub rays: u64,
    /// Rays that met no triangle.
    pub escaped: u64,
}

impl Escape {
    /// Share of the rays that left the scene: about the openings' share of the area.
    pub(crate) fn share(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            self.escaped as f64 / self.rays as f64
        }
    }
}

/// Whether light leaves the scene, asked of the geometry rather than of F's row sums: about
/// [`ESCAPE_RAYS`] cosine-weighted hemisphere rays from stratified points of the patches for
/// which `live` is true (those that see anything; a wall's outer face sees nothing and is
/// dropped), in proportion to area, counting those that meet no triangle at all. By
/// reciprocity the area-weighted share that escapes is the openings' share of the area, so
/// a small opening that F's rows hide within their tolerance still shows.
pub(crate) fn escape_check(patches: &Patches, occ: &Occluders, live: &[bool], seed: u64) -> Escape {
    let area = |i: usize| {
        if live[i] {
            patches.patches[i].area
        } else {
            0.0
        }
    };
    let total: f64 = (0..patches.len()).map(area).sum();
    if !(total > 0.0) {
        return Escape::default();
    }
    // Rays per patch by systematic rounding of the cumulative area, so they sum to the budget.
    let mut before = 0.0;
    let counts: Vec<u64> = (0..patches.len())
        .map(|i| {
            let start = (ESCAPE_RAYS as f64 * before / total).floor() as u64;
            before += area(i);
            (ESCAPE_RAYS as f64 * before / total).floor() as u64 - start
        })
        .collect();
    let far = 10.0 * occ.extent();
    let escaped: u64 = (0..patches.len())
        .into_par_iter()
        .filter(|&i| counts[i] > 0)
        .map(|i| {
            let pieces = patches.pieces_of(i);
            let piece_area: f64 = pieces.iter().map(|q| q.area).sum();
            if pieces.is_empty() || !(piece_area > 0.0) {
                return 0;
            }
            let mut rng = patch_rng(seed ^ ESCAPE_STREAM, i);
            let scramble = [rng.next_u64() as u32, (rng.next_u64() >> 32) as u32];
            (0..counts[i])
                .filter(|&k| {
                    let [u, v] = crate::rng::sobol2(scramble, k as u32);
                    let (x, n) = patch_point_at(pieces, piece_area, u, v);
                    let d = cosine_direction(n, &mut rng);
                    occ.closest_hit_from_surface(x, d, far).is_none()
                })
                .count() as u64
        })
        .sum();
    Escape {
        rays: counts.iter().sum(),
        escaped,
    }
}

/// Salt of [`escape_check`]'s streams, apart from the other checks' rays of the same patch.
const ESCAPE_STREAM: u64 = 0x6573_6361_7065;

/// Points in the first look at a patch in [`survey`] (stratified, see [`crate::rng::sobol2`]).
/// At 32, slivers of about 3.5% along a patch's edge went unseen: on a room with a block
/// resting on its floor at 4358 patches their rows stayed 0.955–0.968 (the exposed share
/// alone), the lowest rows of the scene; at 64 its lowest is 0.992.
pub(crate) const BURIED_FIRST: u32 = 64;

/// Points in all for a patch the first look finds partly buried. Independent uniform points
/// would give the share a standard error of up to `0.5 / √512 = 0.022`; the stratified ones
/// measured within ±0.003 of a 20 000-point estimate on strips along a patch's edge.
pub(crate) const BURIED_POINTS: u32 = 512;

/// A surveyed start that nothing buries ([`survey`]).
pub(crate) const EXPOSED: u32 = u32::MAX;

/// The burial survey: per patch, for each of its first [`BURIED_POINTS`] ray starts
/// ([`crate::form_factor::Starts`]), the object of the piece it lies on where another object
/// buries it ([`Occluders::covered`] or [`Occluders::buried`]: no light reaches it or leaves
/// it), [`EXPOSED`] where not; empty for a patch whose first [`BURIED_FIRST`] starts are all
/// exposed. The ray-cast rows start their rays only at surveyed starts of a partly buried
/// patch and [`expose`] takes its buried share from the same starts, so each start's burial
/// (up to 4 fans of 9 rays deep) is asked once (`docs/decisions/burial-survey.md`).
pub(crate) fn survey(patches: &Patches, occ: &Occluders) -> Vec<Vec<u32>> {
    (0..patches.len())
        .into_par_iter()
        .map(|i| survey_one(patches, occ, i).0)
        .collect()
}

/// [`survey`] of the patches `rows` only, in that order (a shard's, [`crate::plan`]), with
/// whether each one's burial questions asked about other points too
/// ([`Occluders::buried_traced`]).
pub(crate) fn survey_rows(
    patches: &Patches,
    occ: &Occluders,
    rows: &[u32],
) -> (Vec<Vec<u32>>, Vec<bool>) {
    rows.par_iter()
        .map(|&i| survey_one(patches, occ, i as usize))
        .unzip()
}

/// The starts [`survey`] looked at for a patch whose survey is `seen`: the first
/// [`BURIED_FIRST`], or all [`BURIED_POINTS`] where it found one buried.
pub(crate) fn surveyed_starts(seen: &[u32]) -> u32 {
    if seen.is_empty() {
        BURIED_FIRST
    } else {
        BURIED_POINTS
    }
}

/// [`survey`] of patch `i`, and whether a burial question asked about other points too.
pub(crate) fn survey_one(patches: &Patches, occ: &Occluders, i: usize) -> (Vec<u32>, bool) {
    let Some(starts) = Starts::new(patches, i) else {
        return (Vec::new(), false);
    };
    let recursed = std::cell::Cell::new(false);
    let look = |k: u32| {
        let (piece, _, x, n) = starts.point(k);
        let buried = occ.covered(piece.triangle, x) || {
            let (b, r) = occ.buried_traced(x, n);
            if r {
                recursed.set(true);
            }
            b
        };
        if buried { piece.object } else { EXPOSED }
    };
    let mut seen: Vec<u32> = (0..BURIED_FIRST).map(look).collect();
    if seen.iter().all(|&o| o == EXPOSED) {
        return (Vec::new(), recursed.get());
    }
    seen.extend((BURIED_FIRST..BURIED_POINTS).map(look));
    (seen, recursed.get())
}

/// The buried share of patch `i`'s area and its buried area per object of its pieces
/// (increasing object order; empty when none is buried), from its survey (`buried`, empty or
/// [`BURIED_POINTS`] long): each buried start counts `area / BURIED_POINTS` to its object.
fn buried_by_object(patches: &Patches, i: usize, buried: &[u32]) -> (f64, Vec<(u32, f64)>) {
    let mut counts: Vec<(u32, u32)> = Vec::new();
    for &o in buried.iter().filter(|&&o| o != EXPOSED) {
        match counts.iter_mut().find(|c| c.0 == o) {
            Some(c) => c.1 += 1,
            None => counts.push((o, 1)),
        }
    }
    counts.sort_unstable_by_key(|c| c.0);
    let all: u32 = counts.iter().map(|c| c.1).sum();
    let total: f64 = patches.pieces_of(i).iter().map(|q| q.area).sum();
    let each = total / f64::from(BURIED_POINTS);
    (
        f64::from(all) / f64::from(BURIED_POINTS),
        counts
            .into_iter()
            .map(|(o, c)| (o, f64::from(c) * each))
            .collect(),
    )
}

/// Whether a direct-light point of patch `i` is buried, as its survey (`survey`, [`survey`])
/// tells: the surveyed starts on the point's piece where they agree, else the nearest start
/// of the same object facing the same way (normals within 25°) if it lies within two start
/// spacings (`2·√(A/512)`, A the patch's area) and on no piece whose starts disagree; `None`
/// where the survey cannot tell. Asked at every point, a patch of the conference room's chairs
/// (one point on each of ~350 pieces, most of them too small to hold a start) cost 350
/// questions of up to 4 fans of 9 rays: 14 s of a 35 s bake
/// (`docs/decisions/burial-survey.md`).
fn by_survey<'a>(
    patches: &'a Patches,
    i: usize,
    survey: &'a [u32],
) -> impl Fn(&crate::simplify::runtime_mesh::DirectPoint) -> Option<bool> + 'a {
    let pieces = patches.pieces_of(i);
    // Per piece: bit 0 an exposed start seen on it, bit 1 a buried one.
    let mut seen = vec![0u8; pieces.len()];
    let mut looked: Vec<(glam::DVec3, glam::DVec3, u32, bool)> = Vec::new();
    let mut reach = 0.0;
    if let Some(starts) = Starts::new(patches, i) {
        for (k, &o) in survey.iter().enumerate() {
            let (piece, q, x, n) = starts.point(k as u32);
            let buried = o != EXPOSED;
            seen[q] |= if buried { 2 } else { 1 };
            looked.push((x, n, piece.object, buried));
        }
        let area: f64 = pieces.iter().map(|q| q.area).sum();
        reach = 2.0 * (area / f64::from(BURIED_POINTS)).sqrt();
    }
    let facing = 25f64.to_radians().cos();
    move |d| match seen.get(d.piece as usize).copied() {
        Some(1) => Some(false),
        Some(2) => Some(true),
        Some(3) | None => None,
        Some(_) => looked
            .iter()
            .filter(|s| s.2 == d.object && s.1.dot(d.normal) >= facing)
            .map(|s| (s.0.distance_squared(d.position), s.3))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .filter(|s| s.0 <= reach * reach)
            .map(|s| s.1),
    }
}
