//! Pieces of one flat surface that cannot see each other kept out of one patch: a floor slab
//! under several rooms, cut at the walls standing on it.
//!
//! A patch has one irradiance and sends one radiosity. The grouping joins the pieces of one
//! connected surface in a cell without a test, and BIM slabs and walls are modelled whole: a
//! house's ground floor is one slab whose top face (two triangles) runs under every inner
//! wall, and an outer wall's inner face runs past the ends of the walls meeting it. Wherever a
//! cell straddled such a wall, the patch held the floor of both rooms, took the lit room's
//! light and sent it into the other: of two rooms under one slab, one lit through a window
//! and one sealed, the sealed room's box got 6% of the lit room's box's irradiance where the
//! path tracer reads 0 (`docs/decisions/sight-split.md`).
//!
//! So the flat main surface of each group is cut again on a finer grid ([`SUB`] cells a cell
//! edge) and its sub-pieces are joined where the segment between their centres, lifted off
//! the surface, meets nothing: the sub-pieces on one side of a wall join, the two sides do
//! not. A furniture leg between two sub-pieces leaves them joined through others. Sub-pieces
//! whose centres lie inside a solid (under the wall) are cut [`SUB`] times finer again, and
//! those fine pieces sorted the same way, so that a strip of the room beyond, narrower than a
//! sub-cell, is not left with the wrong side; what is still inside the solid joins the
//! largest side. A group that stays one keeps its original pieces, and a split group keeps
//! every original piece whose sub-pieces all fell on one side. The test is geometric, so it
//! holds for every light and needs no re-bake when lights move.

use super::grouping::{LIFT, LOOSE_PART, Loose, cut};
use crate::geometry::bvh::Occluders;
use crate::patch::Piece;
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;

/// Sub-cells a cell edge, and again within a sub-cell under a wall: a piece straddling a wall
/// keeps at most a strip a [`SUB`]²th of a cell wide on the wrong side of it.
const SUB: f64 = 4.0;

/// Cosine of the largest angle between a flat group's normals (0.5°): BIM faces are planar to
/// rounding; a curved surface's chords would pass under it and meet its own back faces.
const FLAT_COS: f64 = 0.999_96;

/// Members of a cluster a new sub-piece is tested against before it starts a cluster of its
/// own: the cluster's first, last and middle members.
const PROBES: usize = 3;

/// Pairs tested between two clusters before they are left apart: a sub-piece hidden from
/// another by a leg is seen by its neighbours.
const MERGE_PAIRS: usize = 8;

/// Splits each group whose flat main surface has pieces that cannot all see each other into
/// one group per side. Returns the groups and how many were split.
pub(super) fn split_by_sight(
    groups: Vec<(u32, Vec<Piece>)>,
    loose: &Loose<'_>,
    h: f64,
) -> (Vec<(u32, Vec<Piece>)>, usize) {
    let at = Surfaces {
        occ: loose.occluders(),
        component: loose.component,
        area: &loose.area,
        scene: loose.scene,
        cross: loose.cross.get(),
        origin: loose.origin,
        part: LOOSE_PART * h * h,
    };
    let split: Vec<Vec<(u32, Vec<Piece>)>> = groups
        .into_par_iter()
        .map(|(material, pieces)| match flat_set(&pieces, &at, h) {
            Some(flat) => sides(material, pieces, &flat, &at, h),
            None => vec![(material, pieces)],
        })
        .collect();
    let count = split.iter().filter(|c| c.len() > 1).count();
    (split.into_iter().flatten().collect(), count)
}

/// What the test reads of the grid's [`Loose`], shareable between threads.
struct Surfaces<'a> {
    occ: &'a Occluders,
    component: &'a [u32],
    area: &'a [f64],
    scene: &'a Scene,
    cross: bool,
    origin: DVec3,
    /// Area under which a connected surface is a part ([`LOOSE_PART`] of a cell face).
    part: f64,
}

/// The group's flat main surface, per piece: the pieces of the largest piece's connected
/// surface (not a part) whose normals lie within [`FLAT_COS`] of its normal and whose corners
/// lie within a quarter of the visibility lift of its plane. `None` where that set is no wider
/// than a sub-cell (nothing of it can lie on two sides of a wall). The other pieces (small
/// groups absorbed whatever their orientation, another plane of the same surface) follow the
/// side nearest them.
fn flat_set(pieces: &[Piece], loose: &Surfaces<'_>, h: f64) -> Option<Vec<bool>> {
    let main = pieces.iter().max_by(|a, b| a.area.total_cmp(&b.area))?;
    let surface = loose.component[main.triangle as usize];
    if loose.area[surface as usize] < loose.part {
        return None;
    }
    let (n, c) = (main.normal, main.polygon.centroid());
    let tol = 0.25 * LIFT * h;
    let flat: Vec<bool> = pieces
        .iter()
        .map(|p| {
            loose.component[p.triangle as usize] == surface
                && p.normal.dot(n) >= FLAT_COS
                && p.polygon
                    .vertices()
                    .iter()
                    .all(|v| (*v - c).dot(n).abs() <= tol)
        })
        .collect();
    let area: f64 = pieces
        .iter()
        .zip(&flat)
        .filter(|(_, f)| **f)
        .map(|(p, _)| p.area)
        .sum();
    (area > (h / SUB) * (h / SUB)).then_some(flat)
}

/// One group's sides (see [`split_by_sight`]); `flat` marks its flat main surface
/// ([`flat_set`]).
fn sides(
    material: u32,
    pieces: Vec<Piece>,
    flat: &[bool],
    loose: &Surfaces<'_>,
    h: f64,
) -> Vec<(u32, Vec<Piece>)> {
    // Sub-pieces of the flat pieces, each with the index of the piece it was cut from.
    let mut subs: Vec<(usize, Piece)> = Vec::new();
    for (k, p) in pieces.iter().enumerate().filter(|(k, _)| flat[*k]) {
        subs.extend(cut_finer(p, loose.origin, h / SUB).map(|q| (k, q)));
    }
    if subs.len() < 2 {
        return vec![(material, pieces)];
    }
    let occ = loose.occ;
    let lift = LIFT * h;
    let lifted = |q: &Piece| q.polygon.centroid() + q.normal * lift;
    let mut at: Vec<DVec3> = subs.iter().map(|(_, q)| lifted(q)).collect();
    // Surfaces that block: any but parts where parts may share patches (as `Loose::sees`).
    let sees = |a: DVec3, b: DVec3| {
        occ.segment_visible_skipping(a, b, &|id| {
            loose.cross && loose.area[loose.component[id as usize] as usize] < loose.part
        })
    };
    let buried = |q: &Piece| occ.buried(q.polygon.centroid(), q.normal);
    let all: Vec<usize> = (0..subs.len()).collect();
    let (mut kept, inside) = sides_of(Vec::new(), &all, &subs, &at, &sees, &buried);
    if kept.is_empty() {
        return vec![(material, pieces)];
    }
    // A sub-piece whose centre lies under a wall may reach out on either side of it (a strip
    // of the room beyond, narrower than a sub-cell, all of whose sub-pieces' centres lie in
    // the wall): it is cut [`SUB`] times finer again and the fine pieces are sorted the same
    // way, joining the sides found or making their own. The two rooms of `tests/tests/sky.rs`
    // kept 2.3% of the lit room's light in the sealed one with whole sub-pieces.
    let mut fine = Vec::new();
    for s in inside {
        let (p, sub) = subs[s];
        for q in cut_finer(&sub, loose.origin, h / (SUB * SUB)) {
            fine.push(subs.len());
            at.push(lifted(&q));
            subs.push((p, q));
        }
    }
    let (more, inside) = sides_of(kept, &fine, &subs, &at, &sees, &buried);
    kept = more;
    if kept.len() < 2 {
        return vec![(material, pieces)];
    }
    let mut side_of_sub = vec![usize::MAX; subs.len()];
    for (k, m) in kept.iter().enumerate() {
        for &s in m {
            side_of_sub[s] = k;
        }
    }
    // Fine pieces inside the solid join the largest side.
    for s in inside {
        side_of_sub[s] = 0;
    }
    assemble(
        (material, pieces),
        flat,
        (subs, &at, &side_of_sub),
        kept.len(),
        loose.scene,
    )
}

/// The groups of one split group: its `pieces` (the first of `material`, `flat` marking its
/// flat main surface), the sub-pieces cut from the flat ones with their lifted centres and
/// sides (`usize::MAX`: cut finer again, left out), and the count of sides.
fn assemble(
    (material, pieces): (u32, Vec<Piece>),
    flat: &[bool],
    (subs, at, side_of_sub): (Vec<(usize, Piece)>, &[DVec3], &[usize]),
    sides: usize,
    scene: &Scene,
) -> Vec<(u32, Vec<Piece>)> {
    // A flat piece whose sub-pieces all lie on one side stays whole; a piece off the flat
    // surface goes to the side of the sub-piece nearest its centre.
    let mut side_of_piece: Vec<Option<usize>> = vec![None; pieces.len()];
    let mut whole = vec![true; pieces.len()];
    for (s, (p, _)) in subs.iter().enumerate() {
        if side_of_sub[s] == usize::MAX {
            continue;
        }
        match side_of_piece[*p] {
            None => side_of_piece[*p] = Some(side_of_sub[s]),
            Some(k) if k != side_of_sub[s] => whole[*p] = false,
            Some(_) => {}
        }
    }
    for (p, piece) in pieces.iter().enumerate().filter(|(p, _)| !flat[*p]) {
        let c = piece.polygon.centroid();
        let nearest = (0..at.len())
            .filter(|&s| side_of_sub[s] != usize::MAX)
            .min_by(|&a, &b| {
                (at[a] - c)
                    .length_squared()
                    .total_cmp(&(at[b] - c).length_squared())
            });
        side_of_piece[p] = nearest.map(|s| side_of_sub[s]);
    }
    // The side of the group's first piece comes first and keeps the group's material; each
    // other side takes its first piece's material (`grouping::Grouping`).
    let lead = if whole[0] {
        side_of_piece[0].unwrap_or(0)
    } else {
        (0..subs.len())
            .find(|&s| subs[s].0 == 0 && side_of_sub[s] != usize::MAX)
            .map_or(0, |s| side_of_sub[s])
    };
    let mut out: Vec<Vec<Piece>> = vec![Vec::new(); sides];
    for (p, piece) in pieces.iter().enumerate() {
        if whole[p] {
            out[side_of_piece[p].unwrap_or(0)].push(*piece);
        }
    }
    for (s, (p, sub)) in subs.into_iter().enumerate() {
        if !whole[p] && side_of_sub[s] != usize::MAX {
            out[side_of_sub[s]].push(sub);
        }
    }
    out.swap(0, lead);
    out.into_iter()
        .filter(|side| !side.is_empty())
        .enumerate()
        .map(|(k, side)| {
            let m = if k == 0 {
                material
            } else {
                scene.triangles[side[0].triangle as usize].material
            };
            (m, side)
        })
        .collect()
}

/// The pieces `piece` is cut into by the grid of cell `h` from `origin`, rounding slivers left
/// out.
fn cut_finer(piece: &Piece, origin: DVec3, h: f64) -> impl Iterator<Item = Piece> + '_ {
    let mut cells = Vec::new();
    cut(piece.polygon, origin, h, &mut cells);
    cells.into_iter().filter_map(move |(_, polygon)| {
        let area = 0.5 * polygon.doubled_area_vector().length();
        (area > 1e-14 * piece.area).then_some(Piece {
            polygon,
            area,
            ..*piece
        })
    })
}

/// Sorts sub-pieces `new` (indices into `subs` and their lifted centres `at`) into sides
/// that see each other, starting from the sides `kept` (largest first): each joins the first
/// side one of whose first, middle and last members it sees, or starts one; sides that see
/// each other along any of [`MERGE_PAIRS`] spread pairs join. Returns the sides, largest
/// first, and apart the sub-pieces of new sides most of whose area lies inside a solid
/// (`buried`).
fn sides_of(
    mut kept: Vec<Vec<usize>>,
    new: &[usize],
    subs: &[(usize, Piece)],
    at: &[DVec3],
    sees: &dyn Fn(DVec3, DVec3) -> bool,
    buried: &dyn Fn(&Piece) -> bool,
) -> (Vec<Vec<usize>>, Vec<usize>) {
    let old = kept.len();
    let mut order = new.to_vec();
    order.sort_by(|&a, &b| subs[b].1.area.total_cmp(&subs[a].1.area).then(a.cmp(&b)));
    for s in order {
        let joined = kept.iter_mut().find(|members| {
            let m = members.len();
            let probes = [members[0], members[m - 1], members[m / 2]];
            probes[..PROBES.min(m)].iter().any(|&q| sees(at[s], at[q]))
        });
        match joined {
            Some(members) => members.push(s),
            None => kept.push(vec![s]),
        }
    }
    // Sides that see each other join (new sides only: the old ones were kept apart before).
    let mut c = 0;
    while c < kept.len() {
        let mut d = (c + 1).max(old);
        while d < kept.len() {
            let (a, b) = (&kept[c], &kept[d]);
            let seen = (0..MERGE_PAIRS).any(|k| {
                let i = a[k * a.len() / MERGE_PAIRS];
                let j = b[(k * b.len() / MERGE_PAIRS + k) % b.len()];
                sees(at[i], at[j])
            });
            if seen {
                let moved = kept.remove(d);
                kept[c].extend(moved);
            } else {
                d += 1;
            }
        }
        c += 1;
    }
    if kept.len() < 2 {
        return (kept, Vec::new());
    }
    // New sides inside a solid (most of their area buried) are set apart.
    let area = |m: &Vec<usize>| m.iter().map(|&s| subs[s].1.area).sum::<f64>();
    let mut inside = Vec::new();
    let mut sides: Vec<Vec<usize>> = Vec::new();
    for (k, m) in kept.into_iter().enumerate() {
        let hidden: f64 = if k < old {
            0.0
        } else {
            m.iter()
                .filter(|&&s| buried(&subs[s].1))
                .map(|&s| subs[s].1.area)
                .sum()
        };
        if 2.0 * hidden < area(&m) {
            sides.push(m);
        } else {
            inside.extend(m);
        }
    }
    sides.sort_by(|a, b| area(b).total_cmp(&area(a)));
    (sides, inside)
}
