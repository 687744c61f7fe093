//! Buried surface: the share of each patch that other objects bury (its burial survey,
//! [`crate::form_factor::burial`]), taken out of its area and its row of F ([`expose`]).

use crate::form_factor::Starts;
use crate::form_factor::burial::{BURIED_POINTS, EXPOSED};
use crate::form_factor::matrix::Exchange;
use crate::geometry::Occluders;
use crate::patch::Patches;
use crate::simplify::runtime_mesh::direct_points;
use rayon::prelude::*;

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
    let buried: Vec<(f64, Vec<(u32, f64)>)> = match occ {
        Some(_) => (0..patches.len())
            .map(|i| buried_by_object(patches, i, burial.get(i).map_or(&[], Vec::as_slice)))
            .collect(),
        None => vec![(0.0, Vec::new()); patches.len()],
    };
    let mut exposure = Exposure {
        buried_area: vec![0.0; objects],
        buried_points: vec![Vec::new(); patches.len()],
        shared: exposed_shares(patches, &buried),
        ..Exposure::default()
    };
    let Some(occ) = occ else {
        return exposure;
    };
    exposure.share = buried.iter().map(|b| b.0).collect();
    for (_, by) in &buried {
        for &(o, b) in by {
            exposure.buried_area[o as usize] += b;
        }
    }
    take_out(patches, f, &mut exposure);
    exposure.buried_points = buried_points(patches, occ, burial, points, &exposure.share);
    bury_covered_objects(patches, points, &mut exposure);
    exposure
}

/// Per patch of more than one object, the exposed area of each of its objects (its area in
/// the patch less what `buried`, [`buried_by_object`] of every patch, says is buried),
/// those left with none dropped; empty for a patch of one object.
fn exposed_shares(patches: &Patches, buried: &[(f64, Vec<(u32, f64)>)]) -> Vec<Vec<(u32, f64)>> {
    let mut shared = vec![Vec::new(); patches.len()];
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
        shared[i] = shares;
    }
    shared
}

/// Takes the buried shares (`exposure.share`) out of the patches' areas and rows of `f`: a
/// partly buried patch's area times its exposed share, its row divided by it; a wholly
/// buried patch's row and column zeroed. Counts both in `exposure`.
fn take_out(patches: &mut Patches, f: &mut Exchange, exposure: &mut Exposure) {
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
}

/// Which of the points the runtime samples direct light at (`runtime_mesh::runtime_mesh`)
/// lie buried, in the partly buried patches (buried share `share`): as the surveyed starts
/// say ([`by_survey`]), asked of `occ` where they cannot tell. Empty for the other patches.
fn buried_points(
    patches: &Patches,
    occ: &Occluders,
    burial: &[Vec<u32>],
    points: &[u32],
    share: &[f64],
) -> Vec<Vec<bool>> {
    (0..patches.len())
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
        .collect()
}

/// An object all of whose direct-light points in a shared patch lie buried is buried
/// there: its pieces in the patch were too small to hold a surveyed start (a bench's leg
/// standing on a plinth, its foot alone in the plinth's patch), so the survey left them
/// exposed, and `solve` would give them the patch's mean direct light (its sunlit
/// plinth's). Its share goes to the patch's other objects, in proportion.
fn bury_covered_objects(patches: &Patches, points: &[u32], exposure: &mut Exposure) {
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
