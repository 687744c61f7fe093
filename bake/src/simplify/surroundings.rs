//! Enclosed pieces kept out of the patches of open ones: a few rays from each piece of a group
//! of one connected surface, the same directions from every piece, and where the pieces that
//! see out of the scene and those that see only an enclosure disagree, two patches.
//!
//! A patch has one irradiance and sends one radiosity, so its pieces must see about the same
//! things. The grouping rules (one cell, one orientation, one connected surface or parts that
//! see each other) do not ensure it: a hollow slab is one connected surface, and the face of its
//! sealed cavity lies within a cell of the sunlit face above it with the same normal. In one
//! patch the cavity face took the sunlit face's light and sent it into the cavity, whose other
//! faces (in patches with the slab's lit faces too) sent it back out: pavilions of hollow slabs
//! came out 11–20% over-lit per object under a sun and a sky (`scripts/sealed_voids.py`,
//! `docs/decisions/surroundings-split.md`). The test is geometric, so it holds for every light
//! and needs no re-bake when lights move.

use super::grouping::{LOOSE_PART, Loose};
use crate::geometry::bvh::Occluders;
use crate::patch::Piece;
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;

/// Directions each piece of a group looks along: a 4 × 4 stratified cosine-weighted set about
/// the group's mean normal, the same for every piece, so two pieces are compared ray by ray
/// with no sampling noise between them.
const LOOKS: usize = 16;

/// Share of [`LOOKS`] on which the largest enclosed and the largest open piece of a group must
/// agree for it to stay whole. Pieces of one surface in one cell agree on nearly every
/// direction (a floor piece by a wall and one a cell away from it meet the wall at distances
/// within a cell of each other); a cavity's face and the lit face over it agree on none. At a
/// half, roofs' undersides by their beams split too on `scripts/architecture.py`
/// (`docs/decisions/surroundings-split.md`).
const AGREE: f64 = 0.25;

/// What one look from a piece met.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Seen {
    /// Nothing asked: the direction lies under the piece's own surface (a piece of a curved
    /// surface tilted from the group's mean normal). It agrees with anything.
    Below,
    /// Nothing: the ray leaves the scene.
    Open,
    /// A surface: its connected surface, the distance, and whether its front faces the ray.
    Surface {
        component: u32,
        distance: f64,
        front: bool,
    },
}

/// Whether two looks along the same direction from two pieces of one cell (cell edge `h`) see
/// the same surroundings: both leave the scene, or both meet the same side of one connected
/// surface at distances within a cell, or within half the farther one, of each other.
fn agree(a: Seen, b: Seen, h: f64) -> bool {
    match (a, b) {
        (Seen::Below, _) | (_, Seen::Below) => true,
        (Seen::Open, Seen::Open) => true,
        (
            Seen::Surface {
                component: ca,
                distance: da,
                front: fa,
            },
            Seen::Surface {
                component: cb,
                distance: db,
                front: fb,
            },
        ) => ca == cb && fa == fb && (da - db).abs() <= h.max(0.5 * da.max(db)),
        _ => false,
    }
}

/// The [`LOOKS`] directions about unit `normal`.
fn looks(normal: DVec3) -> [DVec3; LOOKS] {
    let (t1, t2) = normal.any_orthonormal_pair();
    std::array::from_fn(|k| {
        let u = ((k % 4) as f64 + 0.5) / 4.0;
        let v = ((k / 4) as f64 + 0.5) / 4.0;
        let r = u.sqrt();
        let phi = std::f64::consts::TAU * v;
        t1 * (r * phi.cos()) + t2 * (r * phi.sin()) + normal * (1.0 - u).sqrt()
    })
}

/// What each of `looks` (about the group's mean normal) meets from the centre of `piece`.
fn seen(
    occ: &Occluders,
    component: &[u32],
    piece: &Piece,
    looks: &[DVec3; LOOKS],
) -> [Seen; LOOKS] {
    let origin = piece.polygon.centroid();
    looks.map(|d| {
        if d.dot(piece.normal) <= 0.0 {
            return Seen::Below;
        }
        match occ.first_surface_from_surface(origin, d, f64::INFINITY) {
            None => Seen::Open,
            Some((hit, front)) => Seen::Surface {
                component: component[hit.triangle as usize],
                distance: hit.distance,
                front,
            },
        }
    })
}

/// Splits each group of several pieces of one connected surface in two where its enclosed
/// pieces (no look leaves the scene) and its open pieces see different things: the largest of
/// each [`agree`] on fewer than [`AGREE`] of the looks. The cluster of the group's first piece
/// keeps its place, the other follows it. `h` is the cell edge. Returns the groups and how many
/// were split.
pub(super) fn split_by_surroundings(
    groups: Vec<(u32, Vec<Piece>)>,
    loose: &Loose<'_>,
    h: f64,
) -> (Vec<(u32, Vec<Piece>)>, usize) {
    if groups.iter().all(|(_, pieces)| pieces.len() < 2) {
        return (groups, 0);
    }
    let occ = loose.occluders();
    let component = loose.component;
    let scene = loose.scene;
    let (area, part) = (&loose.area, LOOSE_PART * h * h);
    let split: Vec<Vec<(u32, Vec<Piece>)>> = groups
        .into_par_iter()
        .map(|(material, pieces)| {
            // Only a group of one connected surface is split: pieces of different surfaces
            // share a patch only as parts that see each other or small groups absorbed
            // (`grouping`), at the grid's resolution by design. Split too, a tessellated
            // sphere's pieces absorbed into a box's walls moved between patches and its view
            // factors to the walls came out 2% apart.
            // Nor is a part (a connected surface under `LOOSE_PART` of a cell face): parts share
            // patches by design where the target needs it. Split, a yard of 250 boxes, each its
            // own object, that must share patches to meet `--patches 128` gave a patch per box
            // face at every cell size, and the target's search fell to cells the size of the
            // scene.
            let surface = component[pieces[0].triangle as usize];
            if pieces.len() < 2
                || area[surface as usize] < part
                || pieces
                    .iter()
                    .any(|p| component[p.triangle as usize] != surface)
            {
                return vec![(material, pieces)];
            }
            // One set of directions for the whole group, about its mean normal, so that pieces
            // of a curved surface are compared along the same directions.
            let mean = pieces.iter().map(|p| p.normal * p.area).sum::<DVec3>();
            let dirs = looks(mean.normalize_or(pieces[0].normal));
            clusters(
                material,
                pieces,
                |p| seen(occ, component, p, &dirs),
                scene,
                h,
            )
        })
        .collect();
    let count = split.iter().filter(|c| c.len() > 1).count();
    (split.into_iter().flatten().collect(), count)
}

/// The clusters of one group's `pieces` (see [`split_by_surroundings`]).
fn clusters(
    material: u32,
    pieces: Vec<Piece>,
    seen: impl Fn(&Piece) -> [Seen; LOOKS],
    scene: &Scene,
    h: f64,
) -> Vec<(u32, Vec<Piece>)> {
    let mut order: Vec<usize> = (0..pieces.len()).collect();
    order.sort_by(|&a, &b| pieces[b].area.total_cmp(&pieces[a].area).then(a.cmp(&b)));
    let views: Vec<[Seen; LOOKS]> = pieces.iter().map(&seen).collect();
    let need = (AGREE * LOOKS as f64).ceil() as usize;
    // A piece whose looks mostly meet back faces lies inside a solid (buried, [`Occluders::buried`]
    // decides it point by point later): what it sees says nothing of the air beside it. It
    // joins the larger cluster rather than deciding one; kept apart, such pieces took patches of
    // their own that were then dropped as buried whole, and a patch target had to be simplified
    // again for them (the architecture of `scripts/architecture.py` at 1024 patches: 463 of
    // 1217 patches buried whole, the bake 3.4× slower).
    let inside = |p: usize| {
        let back = views[p]
            .iter()
            .filter(|s| matches!(s, Seen::Surface { front: false, .. }))
            .count();
        2 * back >= LOOKS
    };
    let judged: Vec<usize> = order.iter().copied().filter(|&p| !inside(p)).collect();
    // The split is between enclosed pieces (no look leaves the scene) and open ones, where
    // the largest of each disagree: a sealed cavity's face and the sunlit face beside it.
    // Pieces of one enclosure are not split among themselves: in a closed box, the floor
    // under a sphere and beside it, split, moved the grid so that the sphere's view factors
    // to the walls came out 2% apart.
    let open = |p: usize| views[p].contains(&Seen::Open);
    let (Some(&first_open), Some(&first_sealed)) = (
        judged.iter().find(|&&p| open(p)),
        judged.iter().find(|&&p| !open(p)),
    ) else {
        return vec![(material, pieces)];
    };
    let same = (0..LOOKS)
        .filter(|&k| agree(views[first_open][k], views[first_sealed][k], h))
        .count();
    if same >= need {
        return vec![(material, pieces)];
    }
    // Cluster 0 is the larger head's; pieces inside solids join it.
    let lead_open = judged[0] == first_open;
    let mut of = vec![0usize; pieces.len()];
    for &p in &judged {
        of[p] = usize::from(open(p) != lead_open);
    }
    // Clusters in the order of their first piece in the group, pieces in their order, so an
    // unsplit group's patch keeps its place; each takes its first piece's material (a group's
    // material is its first piece's: `grouping::Grouping`).
    let mut slot = [usize::MAX; 2];
    let mut out: Vec<(u32, Vec<Piece>)> = Vec::with_capacity(2);
    for (p, piece) in pieces.into_iter().enumerate() {
        let c = of[p];
        if slot[c] == usize::MAX {
            slot[c] = out.len();
            let m = if p == 0 {
                material
            } else {
                scene.triangles[piece.triangle as usize].material
            };
            out.push((m, Vec::new()));
        }
        out[slot[c]].1.push(piece);
    }
    out
}
