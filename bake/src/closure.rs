//! The closure: whether light leaves the scene (F's row sums, then hemisphere rays,
//! [`escape_check`]), and the matching correction of F ([`closure_effect`]): a closed scene's
//! rows rebalanced to sum to 1, an open scene's rows above 1 capped.

use crate::effect_plan::Effect;
use crate::exposure::Exposure;
use crate::form_factor::burial::BURIED_POINTS;
use crate::form_factor::matrix::Exchange;
use crate::form_factor::matrix::dense::closure_of_sums;
use crate::geometry::Occluders;
use crate::patch::Patches;
use crate::patch::points::{cosine_direction, patch_point_at, patch_rng};
use rayon::prelude::*;
use serde::Serialize;

/// Closure measurements.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClosureReport {
    /// Smallest row sum of F over patches that see anything and are not partly buried (whose
    /// rows mix two estimates, see `closure_effect`), before any correction.
    pub min_row_sum: f64,
    /// Largest row sum, before any correction.
    pub max_row_sum: f64,
    /// The patch of the largest row sum, in simplification order (`Patches::patches`, the
    /// numbering `radiosity check-rows --patch` takes).
    pub max_row_patch: Option<usize>,
    /// Largest relative change of a row sum made by the closure correction (0 when open), apart
    /// from the rows of partly buried patches.
    pub correction: f64,
    /// Share of hemisphere rays from the patches that left the scene
    /// (`row_check::escape_check`), asked only when the row sums say closed; above
    /// `row_check::ESCAPE_LIMIT` the scene is open after all.
    pub escaped: Option<f64>,
}
/// Decides whether the scene is closed, corrects `f` (of exposed patches, [`expose`]) to
/// match, and says why: a closed scene's rows are rebalanced to sum to 1, an open scene's rows
/// above 1 are capped where they would create energy.
pub(crate) fn closure_effect(
    patches: &Patches,
    f: &mut Exchange,
    areas: &[f64],
    exposure: &Exposure,
    tol: f64,
    escape: &dyn Fn(&[bool]) -> Escape,
) -> (ClosureReport, Effect) {
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
        let (hi, rows) = partly_buried_rows(exposure, &sums, areas, &partly);
        report.max_row_sum = report.max_row_sum.max(hi);
        range += &rows;
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
        let effect = rebalance(f, areas, &sums, &partly, exposure, &range, &mut report);
        return (report, effect);
    }
    let effect = cap_open(
        patches,
        f,
        areas,
        tol,
        &format!("{range}: light escapes{opening}"),
        &mut report,
    );
    (report, effect)
}

/// The largest row sum of the partly buried patches (`partly`), and a clause on them for the
/// closure's why: how many, their share of the area, the range of their rows.
fn partly_buried_rows(
    exposure: &Exposure,
    sums: &[f64],
    areas: &[f64],
    partly: &dyn Fn(usize) -> bool,
) -> (f64, String) {
    let buried: f64 = exposure.buried_area.iter().sum();
    let (lo, hi) = (0..sums.len())
        .filter(|&i| partly(i))
        .fold((f64::INFINITY, 0f64), |(lo, hi), i| {
            (lo.min(sums[i]), hi.max(sums[i]))
        });
    let rows = format!(
        " ({} patches partly buried under other objects, {:.4} of the area, by {BURIED_POINTS} points each: their rows, over the exposed part, in [{lo:.3}, {hi:.3}])",
        exposure.partly,
        buried / (areas.iter().sum::<f64>() + buried)
    );
    (hi, rows)
}

/// A closed scene: `f`'s rows rebalanced to sum to 1 keeping reciprocity, the largest
/// relative change of a row sum (`sums` before it) apart from the partly buried (`partly`)
/// in `report`, and the effect saying so after `range`.
fn rebalance(
    f: &mut Exchange,
    areas: &[f64],
    sums: &[f64],
    partly: &dyn Fn(usize) -> bool,
    exposure: &Exposure,
    range: &str,
    report: &mut ClosureReport,
) -> Effect {
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
    Effect::new(true, why)
}

/// An open scene. Rows above 1 send out more light than the patch gives: beyond the
/// tolerance `tol` that is coincident faces (both seen through the same solid angle), scaled
/// down to 1 keeping reciprocity. Excesses within the tolerance are quadrature error and stay
/// (capping the Cornell box's 1% near-field excess raised its BC1 lighting error from 3.8% to
/// 5.1%), unless some row's reflected light would then reach 1: the transfer could not
/// converge. The correction goes in `report`, the effect says it after `open` (why light
/// escapes).
fn cap_open(
    patches: &Patches,
    f: &mut Exchange,
    areas: &[f64],
    tol: f64,
    open: &str,
    report: &mut ClosureReport,
) -> Effect {
    if report.max_row_sum > 1.0 + tol || f.largest_gain(patches) >= 1.0 {
        report.correction = f.cap_row_sums(areas);
    }
    let why = format!(
        "{open}; {}",
        if report.correction > 0.0 {
            format!(
                "rows above 1 scaled down to 1 keeping reciprocity (largest correction {:.2e})",
                report.correction
            )
        } else {
            "no closure correction".to_owned()
        }
    );
    Effect::new(false, why)
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
