//! The patch model, beneath every stage: a patch, its pieces (the exact convex polygons of the
//! full-detail triangles it is made of), the simplified scene they form, and the per-patch
//! helpers every stage shares: points on a patch and hemisphere directions from them
//! ([`points`]), a patch's seeds and identity ([`identity`]).

pub mod identity;
pub(crate) mod points;

use crate::geometry::polygon::Polygon;
use glam::DVec3;
use radiosity_core::Rgb;
use std::ops::Range;

/// A convex piece of one full-detail triangle inside one cell.
#[derive(Clone, Copy, Debug)]
pub struct Piece {
    /// The polygon, counter-clockwise about `normal`.
    pub polygon: Polygon,
    /// Unit front normal (its triangle's).
    pub normal: DVec3,
    /// Area.
    pub area: f64,
    /// Index of the scene triangle it was cut from.
    pub triangle: u32,
    /// Scene object of that triangle (a patch may hold pieces of several objects' parts).
    pub object: u32,
}

/// A patch of the simplified scene, with everything the bake needs.
#[derive(Clone, Debug)]
pub struct BakePatch {
    /// Area-weighted centre.
    pub centre: DVec3,
    /// Total area of its pieces.
    pub area: f64,
    /// Unit area-weighted mean normal.
    pub normal: DVec3,
    /// Scene object index: the object with the largest share of the patch's area, where the
    /// patch holds parts of several objects.
    pub object: u32,
    /// Scene material index.
    pub material: u32,
    /// Area-weighted mean reflectance (`Kd` times the mean of `map_Kd`).
    pub reflectance: Rgb,
    /// Emitted exitance E = π·Ke (W/m²).
    pub emission: Rgb,
    /// Its pieces: a range of [`Patches::pieces`].
    pub pieces: Range<usize>,
    /// Seed of its ray streams (where its rays start and leave, `form_factor::cast`): from
    /// its index, or under a plan from its identity ([`crate::patch::identity::patch_keys`]), so
    /// that its rays stay the same when other patches are renumbered.
    pub seed: u64,
}

/// Per-vertex interpolation weights over patches, in compressed-row form: the weights of
/// scene vertex `v` are `entries[offsets[v]..offsets[v+1]]`, `(patch, weight)` pairs summing to 1
/// (empty for a vertex no triangle uses).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexWeights {
    /// Row starts, one per scene vertex plus one.
    pub offsets: Vec<usize>,
    /// `(patch, weight)` pairs.
    pub entries: Vec<(u32, f32)>,
}

impl VertexWeights {
    /// The weights of vertex `v`.
    pub fn of(&self, v: usize) -> &[(u32, f32)] {
        &self.entries[self.offsets[v]..self.offsets[v + 1]]
    }
}

/// The simplified scene.
#[derive(Clone, Debug)]
pub struct Patches {
    /// The patches, in matrix order.
    pub patches: Vec<BakePatch>,
    /// All pieces, grouped by patch.
    pub pieces: Vec<Piece>,
    /// Corners of the full-detail triangles the pieces were cut from ([`Piece::triangle`]
    /// indexes it; the scene's triangle order).
    pub triangles: Vec<[DVec3; 3]>,
    /// The cell size used.
    pub cell_size: f64,
    /// Interpolation weights for every scene vertex.
    pub vertex_weights: VertexWeights,
    /// Groups of pieces the simplification split because their pieces see different
    /// surroundings (a sealed cavity's face beside a lit face of one slab).
    pub split_by_surroundings: usize,
    /// Flat groups the simplification split because their pieces cannot all see each other
    /// (a floor slab's top under the wall between two rooms).
    pub split_by_sight: usize,
    /// Warnings (a patch target that could not be met).
    pub warnings: Vec<String>,
}

impl Patches {
    /// Number of patches.
    pub fn len(&self) -> usize {
        self.patches.len()
    }

    /// Whether there is no patch.
    pub fn is_empty(&self) -> bool {
        self.patches.is_empty()
    }

    /// The pieces of patch `i`.
    pub fn pieces_of(&self, i: usize) -> &[Piece] {
        &self.pieces[self.patches[i].pieces.clone()]
    }

    /// The patches in the stored `.rad` format.
    pub fn to_core(&self) -> Vec<radiosity_core::Patch> {
        self.patches
            .iter()
            .map(|p| radiosity_core::Patch {
                centre: p.centre.as_vec3().to_array(),
                area: p.area as f32,
                normal: p.normal.as_vec3().to_array(),
                object: p.object,
                reflectance: p.reflectance,
                emission: p.emission,
            })
            .collect()
    }
}

/// The object with the largest share of `pieces`' area (the lowest index among equals): the
/// object a patch of several objects' parts is filed under.
pub(crate) fn main_object(pieces: &[Piece]) -> u32 {
    object_shares(pieces)
        .iter()
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
        .map_or(0, |s| s.0)
}

/// The area of `pieces` per object, in increasing object order.
pub(crate) fn object_shares(pieces: &[Piece]) -> Vec<(u32, f64)> {
    let mut by: Vec<(u32, f64)> = pieces.iter().map(|p| (p.object, p.area)).collect();
    by.sort_unstable_by_key(|s| s.0);
    let mut shares: Vec<(u32, f64)> = Vec::with_capacity(1);
    for (o, a) in by {
        match shares.last_mut() {
            Some(s) if s.0 == o => s.1 += a,
            _ => shares.push((o, a)),
        }
    }
    shares
}
