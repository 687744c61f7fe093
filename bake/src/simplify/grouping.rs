//! Cutting the triangles by the grid and grouping the pieces of each cell into patches: by
//! object, emitting material and orientation, separate surfaces only where they see each
//! other, with small groups absorbed into their neighbours.

use super::Piece;
use crate::geometry::bvh::Occluders;
use crate::geometry::polygon::Polygon;
use crate::scene::Scene;
use glam::DVec3;
use std::collections::HashMap;

/// Cuts a polygon by the grid planes `origin + k·h` along each axis.
pub(super) fn cut(poly: Polygon, origin: DVec3, h: f64, out: &mut Vec<([i64; 3], Polygon)>) {
    let mut work = vec![poly];
    for axis in 0..3 {
        let mut next = Vec::with_capacity(work.len());
        for mut p in work {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for v in p.vertices() {
                lo = lo.min(v[axis]);
                hi = hi.max(v[axis]);
            }
            let k0 = ((lo - origin[axis]) / h).floor() as i64;
            let k1 = ((hi - origin[axis]) / h).floor() as i64;
            for k in k0 + 1..=k1 {
                let (below, above) = p.split(axis, origin[axis] + k as f64 * h);
                if !below.is_empty() {
                    next.push(below);
                }
                p = above;
                if p.is_empty() {
                    break;
                }
            }
            if !p.is_empty() {
                next.push(p);
            }
        }
        work = next;
    }
    for p in work {
        let c = p.centroid();
        let cell = [0, 1, 2].map(|a| ((c[a] - origin[a]) / h).floor() as i64);
        out.push((cell, p));
    }
}

pub(super) struct Grouping {
    /// Per group: (first material, pieces). A group's object is chosen when it becomes a
    /// patch (the object with the largest share of its area).
    pub(super) groups: Vec<(u32, Vec<Piece>)>,
    /// How many groups were split because their pieces see different surroundings (set by
    /// `super::grouped`).
    pub(super) split: usize,
    /// How many flat groups were split because their pieces cannot all see each other (set
    /// by `super::grouped`).
    pub(super) sight: usize,
}

/// Connected surfaces: for every triangle, the index of its component, where triangles sharing
/// a corner position (bit for bit, so split vertices of one mesh still join) are connected.
///
/// Pieces of different components share a patch only when they see each other ([`group`]).
/// Without that test, the floors of two rooms on either side of a thin wall, carrying the same
/// object and material names, fell into one patch wherever a cell straddled the wall, and that
/// patch carried the lit room's light into the dark one (14% of the lit room's irradiance with
/// a wall 1% of the room thick).
pub(super) fn components(scene: &Scene) -> Vec<u32> {
    fn find(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            let up = parent[parent[i as usize] as usize];
            parent[i as usize] = up;
            i = up;
        }
        i
    }
    let n = scene.triangles.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    let mut first_at: HashMap<[u64; 3], u32> = HashMap::new();
    for t in 0..n {
        for p in scene.corners(t) {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            let other = *first_at.entry(key).or_insert(t as u32);
            let (a, b) = (find(&mut parent, t as u32), find(&mut parent, other));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    (0..n as u32).map(|t| find(&mut parent, t)).collect()
}

/// A connected surface whose whole area is below this share of a cell face (`h²`) is a part (a
/// screw, a chair's leg, one slat of a blind, a bench among thousands in a yard). A part joins
/// a group of another surface of its cell and kind, of its own object or any other, when the
/// two face the same way and see each other (a segment between them that no other surface
/// blocks), and a large surface joins a group a part started; two large surfaces of different
/// connected surfaces or objects never share a patch. Parts cross objects because real assets
/// make every prop an object: a yard of 4906 boxes, each its own object, kept 4906 patches
/// whatever `--patches` asked (`docs/decisions/voxel-merges.md`, "Parts cross objects"). Without this, furniture of many parts kept the patch
/// count near the count of parts at any cell size (the conference room, 330k triangles: 18,693
/// patches asked for 256). Two large surfaces are kept apart whatever they see: the segment
/// test skips both ends' surfaces, and a room's floor joined to its wall would let the wall
/// itself be skipped between two rooms' floors.
pub(super) const LOOSE_PART: f64 = 0.5;

/// Total area of each connected surface, indexed by its [`components`] root.
pub(super) fn component_areas(scene: &Scene, component: &[u32]) -> Vec<f64> {
    let mut area = vec![0.0; component.len()];
    for (t, &c) in component.iter().enumerate() {
        area[c as usize] += scene.triangle_area(t);
    }
    area
}

/// What separate surfaces and small groups need to merge: each surface's area, the surfaces
/// and the occluders for the visibility test (built on first use: a scene of one connected
/// surface per object and no small group of fine triangles never needs them).
pub(super) struct Loose<'a> {
    pub(super) area: Vec<f64>,
    pub(super) occluders: std::cell::OnceCell<Occluders>,
    pub(super) scene: &'a Scene,
    pub(super) component: &'a [u32],
    /// Whether parts of different objects may share a patch, and parts stop blocking the
    /// visibility test ([`LOOSE_PART`]). Off unless the patch target cannot be met without
    /// (`fit_patch_count`): a scene whose objects are few keeps one object a patch.
    pub(super) cross: std::cell::Cell<bool>,
    /// Corner of the grid of cells ([`super::VoxelParams::origin`], else the scene's lowest
    /// corner).
    pub(super) origin: glam::DVec3,
}

impl Loose<'_> {
    pub(super) fn occluders(&self) -> &Occluders {
        self.occluders.get_or_init(|| self.scene.occluders())
    }

    /// Whether two pieces see each other past the large surfaces: no surface of at least
    /// `part` area ([`LOOSE_PART`]) but their own two blocks the segment between their
    /// centres, both lifted `lift` off their surfaces along their normals so that pieces
    /// lying in one plane (tiles, slats) do not block each other. Each end is `(centre, unit
    /// normal, connected surface)`. Parts do not block: a wall keeps the parts of two rooms
    /// apart, but in a yard of thousands of boxes a segment between two of them passes through
    /// others, and with parts blocking the boxes kept 4751 patches asked for 1024 (cells the
    /// size of the scene).
    fn sees(&self, a: (DVec3, DVec3, u32), b: (DVec3, DVec3, u32), lift: f64, part: f64) -> bool {
        self.occluders()
            .segment_visible_skipping(a.0 + a.1 * lift, b.0 + b.1 * lift, &|id| {
                let c = self.component[id as usize];
                c == a.2 || c == b.2 || (self.cross.get() && self.area[c as usize] < part)
            })
    }
}

/// Cuts and groups at cell size `h`; returns the groups (first material, pieces).
/// Pieces join a group only within one cell, of the same emitting material or of
/// non-emitting ones ([`kind_of`]), with normals within the angle of the group's first piece.
/// A piece joins, without a test, a group its own connected surface ([`components`]) and
/// object joined in the cell; any other group only where one of the two surfaces is a part
/// ([`LOOSE_PART`]) and they see each other ([`Loose::sees`]). Furniture and props of
/// thousands of separate parts (legs, slats, trim, each maybe its own object) thus become one
/// patch per cell and orientation, and the patch target is met; two floors on either side of a
/// wall stay apart. Small groups then merge whatever their orientation
/// ([`absorb_small_groups`]).
pub(super) fn group(
    scene: &Scene,
    component: &[u32],
    loose: &Loose<'_>,
    h: f64,
    cos_max: f64,
) -> Grouping {
    let origin = loose.origin;
    // Candidate groups per (cell, kind): every group of the cell and kind, and per (cell,
    // kind, connected surface, object) the groups that surface of that object already joined.
    let mut lookup: HashMap<([i64; 3], u32, u32), Vec<usize>> = HashMap::new();
    // Groups are per object too unless parts may cross objects (`Loose::cross`).
    let by_object = |object: u32| if loose.cross.get() { u32::MAX } else { object };
    let mut joined: HashMap<([i64; 3], u32, u32, u32), Vec<usize>> = HashMap::new();
    // Each group's first piece (centre, surface), to test visibility against.
    let mut first: Vec<(DVec3, u32)> = Vec::new();
    let mut groups: Vec<(u32, Vec<Piece>)> = Vec::new();
    let mut seeds: Vec<DVec3> = Vec::new();
    let mut cells = Vec::new();
    let mut cell_of: Vec<[i64; 3]> = Vec::new();
    let lift = LIFT * h;
    let small = LOOSE_PART * h * h;
    for (t, tri) in scene.triangles.iter().enumerate() {
        let p = scene.corners(t);
        let normal = scene.triangle_normal(t);
        let tri_area = scene.triangle_area(t);
        let own = component[t];
        let is_part = loose.area[own as usize] < small;
        let kind = kind_of(scene, tri.material);
        cells.clear();
        cut(Polygon::triangle(p[0], p[1], p[2]), origin, h, &mut cells);
        for &(cell, poly) in &cells {
            let area = 0.5 * poly.doubled_area_vector().length();
            // Rounding slivers from cutting exactly along a grid plane.
            if !(area > 1e-14 * tri_area) {
                continue;
            }
            let piece = Piece {
                polygon: poly,
                normal,
                area,
                triangle: t as u32,
                object: tri.object,
            };
            let cands = lookup
                .entry((cell, kind, by_object(tri.object)))
                .or_default();
            let fits = |g: usize| seeds[g].dot(normal) >= cos_max;
            let mine = joined.entry((cell, kind, own, tri.object)).or_default();
            // A group this surface already joined here, else another surface's group it sees,
            // where one of the two is a part (`LOOSE_PART`).
            let found = mine.iter().copied().find(|&g| fits(g)).or_else(|| {
                let end = (piece.polygon.centroid(), normal, own);
                let g = cands.iter().copied().find(|&g| {
                    let (at, other) = first[g];
                    fits(g)
                        && (is_part || loose.area[other as usize] < small)
                        && loose.sees(end, (at, seeds[g], other), lift, small)
                })?;
                mine.push(g);
                Some(g)
            });
            match found {
                Some(g) => groups[g].1.push(piece),
                None => {
                    let g = groups.len();
                    cands.push(g);
                    mine.push(g);
                    first.push((piece.polygon.centroid(), own));
                    seeds.push(normal);
                    cell_of.push(cell);
                    groups.push((tri.material, vec![piece]));
                }
            }
        }
    }
    let ends: Vec<(DVec3, DVec3, u32)> = first
        .iter()
        .zip(&seeds)
        .map(|(&(centre, surface), &normal)| (centre, normal, surface))
        .collect();
    Grouping {
        groups: absorb_small_groups(groups, &cell_of, &ends, loose, h),
        split: 0,
        sight: 0,
    }
}

/// What a material keeps apart in the grouping key: an emitting material is its own kind (a
/// patch has one emission), every other material shares one (a patch's reflectance is its
/// pieces' area-weighted mean, so parts of different materials may share a patch).
pub(super) fn kind_of(scene: &Scene, material: u32) -> u32 {
    let m = &scene.materials[material as usize];
    if m.emission.to_array().iter().any(|&e| e > 0.0) {
        material
    } else {
        u32::MAX
    }
}

/// How far visibility tests lift their ends off the surfaces, in cells (see [`Loose::sees`]).
pub(super) const LIFT: f64 = 1e-3;

/// A group whose area, and the area of each triangle it was cut from, are below this share of
/// a cell face (`h²`) is small, and is not kept apart by orientation ([`absorb_small_groups`]).
///
/// The orientation rule exists for large surfaces: a floor and the wall standing on it, or the
/// two sides of a thin wall. Curved furniture instead splits into a group per normal cone in
/// every cell it touches, each a small part of the cell face, so that in the conference room
/// (330k triangles) the patch count stayed near 4400 at any cell size, and `--patches 4096`
/// gave cells of 1093 units, a third of the room, for a floor of 4.4 million square units in 6
/// patches. Form factors are computed on a patch's true pieces with their own normals, so a
/// patch of pieces facing different ways is still integrated right; what merging loses is that
/// they share one radiosity, which for a part small against the cell is the resolution the
/// grid gives anyway.
///
/// The triangle condition keeps every guarantee of the orientation rule for surfaces modelled
/// with polygons of at least a tenth of a cell face (floors, walls, thin walls, boxes: the
/// Cornell box bakes as before): their slivers at the rim of a surface or in a corner cell are
/// small groups by area but stay apart. Only finely tessellated parts merge; a thin wall
/// tessellated that finely may, at its rim, put a sliver of one side (under a tenth of a face)
/// in a patch of the other. A tenth: the conference room at `--patches 4096` gets cells of 130
/// units and 294 floor patches with it, 148 and 228 with 0.05, 130 and 294 with 0.2
/// (`docs/decisions/voxel-merges.md`).
pub(super) const SMALL_GROUP: f64 = 0.1;

/// Merges the small groups ([`SMALL_GROUP`]) into others of their cell and kind ([`kind_of`]),
/// of any object, whatever their orientation: each joins the first large group of its own connected surface,
/// else the first large group it sees ([`Loose::sees`] between the two groups' first pieces),
/// else in the same way a small group kept before it, else stays as one. Large groups never
/// merge with one another, and two surfaces join only by the same visibility test as loose
/// parts, so a small part behind a wall stays on its side.
///
/// `groups`, `cell` and `ends` (each group's first piece: centre, normal, surface) are in
/// creation order, which the result keeps (a merged patch sits where its first group was).
pub(super) fn absorb_small_groups(
    mut groups: Vec<(u32, Vec<Piece>)>,
    cell: &[[i64; 3]],
    ends: &[(DVec3, DVec3, u32)],
    loose: &Loose<'_>,
    h: f64,
) -> Vec<(u32, Vec<Piece>)> {
    let small = SMALL_GROUP * h * h;
    let is_small: Vec<bool> = groups
        .iter()
        .map(|(_, pieces)| {
            pieces.iter().map(|p| p.area).sum::<f64>() < small
                && pieces
                    .iter()
                    .all(|p| loose.scene.triangle_area(p.triangle as usize) < small)
        })
        .collect();
    let mut by_key: HashMap<([i64; 3], u32, u32), Vec<usize>> = HashMap::new();
    for (g, (material, pieces)) in groups.iter().enumerate() {
        let object = if loose.cross.get() {
            u32::MAX
        } else {
            pieces[0].object
        };
        by_key
            .entry((cell[g], kind_of(loose.scene, *material), object))
            .or_default()
            .push(g);
    }
    let lift = LIFT * h;
    let part = LOOSE_PART * h * h;
    // The group each one joins (itself when it stays); a group that others join never joins
    // another, so one step reaches the end.
    let mut into: Vec<usize> = (0..groups.len()).collect();
    for list in by_key.values() {
        if list.iter().all(|&g| !is_small[g]) {
            continue;
        }
        // Large groups first, then the small groups that stayed, each in creation order.
        let mut targets: Vec<usize> = list.iter().copied().filter(|&g| !is_small[g]).collect();
        let large = targets.len();
        for &g in list.iter().filter(|&&g| is_small[g]) {
            let own = |t: &usize| ends[*t].2 == ends[g].2;
            let seen = |t: &usize| loose.sees(ends[*t], ends[g], lift, part);
            let (big, kept) = targets.split_at(large);
            let found = big
                .iter()
                .find(|t| own(t))
                .or_else(|| big.iter().find(|t| seen(t)))
                .or_else(|| kept.iter().find(|t| own(t)))
                .or_else(|| kept.iter().find(|t| seen(t)));
            match found {
                Some(&t) => into[g] = t,
                None => targets.push(g),
            }
        }
    }
    let mut slot = vec![usize::MAX; groups.len()];
    let mut merged: Vec<(u32, Vec<Piece>)> = Vec::new();
    for g in 0..groups.len() {
        let t = into[g];
        if slot[t] == usize::MAX {
            slot[t] = merged.len();
            merged.push((groups[t].0, Vec::new()));
        }
        let pieces = std::mem::take(&mut groups[g].1);
        merged[slot[t]].1.extend(pieces);
    }
    merged
}

/// Points per group at which [`matrix_count`] looks for burial.
const BURIED_LOOK: u32 = 4;

/// How many of `grouping`'s groups stay in the matrix: all but those buried whole (the bake
/// drops a patch that no light can reach, `dark`: a box's bottom face on the ground,
/// one per box in a yard of boxes). A group counts as buried whole when each of
/// [`BURIED_LOOK`] points spread over its area ((k + ½)/K, and the radical inverse of k) is
/// buried ([`Occluders::buried`]); the bake's own test then looks at 512.
pub(super) fn matrix_count(loose: &Loose<'_>, grouping: &Grouping) -> usize {
    use rayon::prelude::*;
    let occ = loose.occluders();
    let buried = grouping
        .groups
        .par_iter()
        .filter(|(_, pieces)| {
            let total: f64 = pieces.iter().map(|p| p.area).sum();
            total > 0.0
                && (0..BURIED_LOOK).all(|k| {
                    let u = (f64::from(k) + 0.5) / f64::from(BURIED_LOOK);
                    let v = f64::from(k.reverse_bits()) / 2f64.powi(32);
                    let (x, n) = crate::patch::points::patch_point_at(pieces, total, u, v);
                    occ.buried(x, n)
                })
        })
        .count();
    grouping.groups.len() - buried
}
