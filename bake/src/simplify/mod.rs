//! Voxel simplification (the paper's pre-processing step 1): the full-detail triangles are cut
//! by a regular grid, and inside each cell the pieces are grouped into patches by object,
//! emitting material and orientation, so the two sides of a thin wall, or a floor and the wall
//! standing on it, never become one patch; separate parts of an object join where they see
//! each other, so a scene of thousands of parts still meets its patch target. Finely tessellated parts small against a cell face join one
//! patch whatever their orientation (`SMALL_GROUP`), so that curved furniture does not take
//! the patch budget from the large surfaces. Last, a group of one connected surface whose
//! enclosed pieces and open pieces see different things (a sealed cavity's face beside the lit
//! face of one hollow slab) is split in two (`surroundings`), and a group's flat main surface
//! is cut where its pieces cannot see each other (`sight`: a slab's top running under the
//! wall between two rooms).
//!
//! Each patch keeps the exact pieces it is made of (convex polygons, counter-clockwise about
//! their triangle's normal), so form factors are computed on the true geometry, not on a disc
//! or a square standing in for it; the total area is preserved to rounding.

mod grouping;
pub mod runtime_mesh;
mod sight;
mod surroundings;

use crate::error::BakeError;
use crate::patch::{BakePatch, Patches, Piece, VertexWeights, main_object};
use crate::scene::Scene;
use glam::DVec3;
use grouping::{Grouping, Loose, component_areas, components};
use radiosity_core::Rgb;

/// How the grid's cell size is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Resolution {
    /// A fixed cell edge length, in scene units (`--voxel SIZE`).
    CellSize(f64),
    /// The cell size whose patch count is nearest this target (`--patches N`), found by
    /// bisection on the cell size.
    TargetPatches(usize),
}

/// Parameters of [`simplify`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelParams {
    /// Cell size or target patch count.
    pub resolution: Resolution,
    /// Pieces in one cell join a patch only if their normals are within this angle of the
    /// patch's first piece. Small: curved surfaces split into more patches; large (towards
    /// 90°): a floor and a wall in one cell could merge. 35° keeps every right angle apart.
    /// Groups small against the cell face, of small triangles, then merge whatever their
    /// orientation (`SMALL_GROUP`).
    pub max_normal_angle_deg: f64,
    /// Accepted relative miss of a [`Resolution::TargetPatches`] target (0.1 = ±10%).
    pub tolerance: f64,
    /// Corner of the grid of cells; `None`: the scene's lowest corner. A plan fixes it
    /// ([`crate::plan`]), so that an object's patches do not move when another object
    /// changes the scene's bounds.
    pub origin: Option<DVec3>,
}

impl Default for VoxelParams {
    fn default() -> Self {
        Self {
            resolution: Resolution::TargetPatches(1024),
            max_normal_angle_deg: 35.0,
            tolerance: 0.1,
            origin: None,
        }
    }
}

impl VoxelParams {
    /// About 256 patches: previews and tests.
    pub fn fast() -> Self {
        Self {
            resolution: Resolution::TargetPatches(256),
            ..Self::default()
        }
    }

    /// About 4096 patches: final bakes of room-sized scenes.
    pub fn high_quality() -> Self {
        Self {
            resolution: Resolution::TargetPatches(4096),
            ..Self::default()
        }
    }

    /// The default, with a target patch count.
    pub fn with_patches(n: usize) -> Self {
        Self {
            resolution: Resolution::TargetPatches(n),
            ..Self::default()
        }
    }

    /// The default, with a fixed cell size.
    pub fn with_cell_size(size: f64) -> Self {
        Self {
            resolution: Resolution::CellSize(size),
            ..Self::default()
        }
    }
}

/// Mean reflectance of a piece: `Kd` times the mean texture over it.
fn piece_reflectance(scene: &Scene, piece: &Piece) -> [f64; 3] {
    let t = piece.triangle as usize;
    let mat = &scene.materials[scene.triangles[t].material as usize];
    if (mat.texture.is_none() || scene.triangles[t].texcoords.is_none())
        && scene.vertex_colours.is_empty()
    {
        return scene.limited(mat.reflectance.to_array().map(f64::from));
    }
    let p = scene.corners(t);
    let n2 = (p[1] - p[0]).cross(p[2] - p[0]);
    let bary = |x: DVec3| {
        let b1 = (x - p[0]).cross(p[2] - p[0]).dot(n2) / n2.length_squared();
        let b2 = (p[1] - p[0]).cross(x - p[0]).dot(n2) / n2.length_squared();
        [1.0 - b1 - b2, b1, b2]
    };
    let v = piece.polygon.vertices();
    let mut acc = [0.0; 3];
    let mut wsum = 0.0;
    for k in 1..v.len() - 1 {
        let w = 0.5 * (v[k] - v[0]).cross(v[k + 1] - v[0]).length();
        let r = scene.reflectance_over(t, [bary(v[0]), bary(v[k]), bary(v[k + 1])]);
        for c in 0..3 {
            acc[c] += w * r[c];
        }
        wsum += w;
    }
    if wsum > 0.0 {
        acc.map(|a| a / wsum)
    } else {
        scene.limited(mat.reflectance.to_array().map(f64::from))
    }
}

/// Builds the patches of `scene` (see the module docs).
pub fn simplify(scene: &Scene, params: &VoxelParams) -> Result<Patches, BakeError> {
    if !(params.max_normal_angle_deg > 0.0 && params.max_normal_angle_deg < 90.0) {
        return Err(BakeError::InvalidParams(format!(
            "max_normal_angle_deg {} must be in (0, 90)",
            params.max_normal_angle_deg
        )));
    }
    if scene.triangles.is_empty() {
        return Err(BakeError::Scene(crate::scene::SceneError::EmptyScene {
            path: scene.path.clone(),
            why: String::new(),
        }));
    }
    let cos_max = params.max_normal_angle_deg.to_radians().cos();
    let component = components(scene);
    let loose = Loose {
        area: component_areas(scene, &component),
        occluders: std::cell::OnceCell::new(),
        scene,
        component: &component,
        cross: std::cell::Cell::new(false),
        origin: params.origin.unwrap_or(scene.bounds().0),
    };
    let mut warnings = Vec::new();
    let (lo, hi) = scene.bounds();
    let extent = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    let (h, grouping) = match params.resolution {
        Resolution::CellSize(h) => {
            if !(h.is_finite() && h > 0.0) {
                return Err(BakeError::InvalidParams(format!(
                    "cell size {h} must be finite and positive"
                )));
            }
            // Bound the work: a cell size a million times below the scene would never finish.
            if extent / h > 1e5 {
                return Err(BakeError::InvalidParams(format!(
                    "cell size {h} is too small for a scene {extent} across"
                )));
            }
            (h, grouped(scene, &component, &loose, h, cos_max))
        }
        Resolution::TargetPatches(n) => fit_patch_count(
            scene,
            &component,
            &loose,
            n,
            params,
            extent,
            cos_max,
            &mut warnings,
        )?,
    };

    let (split_by_surroundings, split_by_sight) = (grouping.split, grouping.sight);
    let (patches, pieces) = build_patches(scene, grouping);
    // The file stores patches in f32: a scene so large (or small) that a patch's area or centre
    // leaves the f32 range would be refused when writing, or light nothing.
    if let Some((i, p)) = patches.iter().enumerate().find(|(_, p)| {
        let area = p.area as f32;
        !(area.is_finite() && area >= f32::MIN_POSITIVE && p.centre.as_vec3().is_finite())
    }) {
        return Err(BakeError::Unbakeable(format!(
            "the scene's scale is out of range: patch {i} has area {:e} at ({:e}, {:e}, {:e}); areas must be normal f32 numbers (about 1.2e-38 to 3.4e38: coordinates within about ±1e18)",
            p.area, p.centre.x, p.centre.y, p.centre.z
        )));
    }
    let vertex_weights = vertex_weights(scene, &patches, &pieces, h);
    let triangles = (0..scene.triangles.len())
        .map(|t| scene.corners(t))
        .collect();
    Ok(Patches {
        patches,
        pieces,
        triangles,
        cell_size: h,
        vertex_weights,
        split_by_surroundings,
        split_by_sight,
        warnings,
    })
}

/// The cell size whose grouping comes nearest `n` patches (bisection on the cell size), with
/// its grouping; a warning in `warnings` when the nearest misses by more than the tolerance.
fn fit_patch_count(
    scene: &Scene,
    component: &[u32],
    loose: &Loose<'_>,
    n: usize,
    params: &VoxelParams,
    extent: f64,
    cos_max: f64,
    warnings: &mut Vec<String>,
) -> Result<(f64, Grouping), BakeError> {
    if n == 0 || n > 1 << 24 {
        return Err(BakeError::InvalidParams(format!(
            "target patch count {n} must be in 1..=2^24"
        )));
    }
    let fit = Fit {
        scene,
        component,
        loose,
        target: n as f64,
        tolerance: params.tolerance,
        extent,
        cos_max,
        total_area: (0..scene.triangles.len())
            .map(|t| scene.triangle_area(t))
            .sum(),
    };
    // Parts of different objects share patches only where the target cannot be met without
    // (`Loose::cross`): a scene of thousands of separate props, each its own object.
    let mut best = fit.bisect();
    if best.2 > params.tolerance {
        loose.cross.set(true);
        let crossed = fit.bisect();
        if crossed.2 < best.2 {
            best = crossed;
        } else {
            loose.cross.set(false);
        }
    }
    let (h, g, miss) = best;
    if miss > params.tolerance {
        let count = fit.count_of(&g);
        let why = fit.why_missed(h, count, n);
        warnings.push(format!(
            "asked for {n} patches, the nearest the grid gives is {count} (cell size {h:.6}){why}"
        ));
    }
    Ok((h, g))
}

/// The search of [`fit_patch_count`] for a cell size giving `target` patches.
struct Fit<'a> {
    scene: &'a Scene,
    /// Each triangle's connected surface ([`components`]).
    component: &'a [u32],
    loose: &'a Loose<'a>,
    /// Patches asked for.
    target: f64,
    /// Accepted relative miss ([`VoxelParams::tolerance`]).
    tolerance: f64,
    /// The scene's largest extent.
    extent: f64,
    /// Cosine of [`VoxelParams::max_normal_angle_deg`].
    cos_max: f64,
    /// The scene's surface area.
    total_area: f64,
}

impl Fit<'_> {
    /// The patch count of grouping `g`. Where parts cross objects the count is what the
    /// matrix will hold: patches buried whole leave it (`grouping::matrix_count`); a yard of
    /// 4906 boxes standing on the ground, their bottoms buried, asked for 1024 got 1002
    /// patches and 897 in the matrix. Elsewhere it is the patches before that, as the figures
    /// the documents give for the Cornell box were measured.
    fn count_of(&self, g: &Grouping) -> usize {
        if self.loose.cross.get() {
            grouping::matrix_count(self.loose, g)
        } else {
            g.groups.len()
        }
    }

    /// The nearest the grid comes to the target, as cell size, grouping and relative miss:
    /// bisection on log(h), the count falling as h grows (about area/h² for flat surfaces).
    fn bisect(&self) -> (f64, Grouping, f64) {
        let (target, tolerance) = (self.target, self.tolerance);
        let group_at = |h: f64| grouped(self.scene, self.component, self.loose, h, self.cos_max);
        let mut h_small = (self.total_area / target).sqrt() / 8.0;
        let mut h_large = self.extent * 2.0;
        let mut best: Option<(f64, Grouping, f64)> = None;
        // The coarsest grid first: where even it gives more patches than the target allows
        // (a scene of more objects and orientations than patches asked for), no finer grid
        // does better, and the search would only creep towards it.
        let coarsest = group_at(h_large);
        let fewest = self.count_of(&coarsest) as f64;
        if fewest > target * (1.0 + tolerance) {
            best = Some((h_large, coarsest, (fewest - target) / target));
        }
        let mut h = (self.total_area / target).sqrt();
        for _ in 0..if best.is_some() { 0 } else { 48 } {
            let g = group_at(h);
            let count = self.count_of(&g) as f64;
            let miss = (count - target).abs() / target;
            let better = best.as_ref().is_none_or(|b| miss < b.2);
            // Where parts cross objects the count moves in coarse steps (a cell more or less
            // merges many parts at once) and lands near the tolerance's edge: aiming at half of
            // it gives margin (4906 boxes asked for 1024 stopped at 928, −9.4%, aiming at all
            // of it; 1057, +3.2%, aiming at half). One object a patch keeps the whole
            // tolerance, so the Cornell box bakes as its documented figures were measured.
            let aim = if self.loose.cross.get() {
                tolerance / 2.0
            } else {
                tolerance
            };
            let done = miss <= aim;
            if count > target {
                h_small = h;
            } else {
                h_large = h;
            }
            if better {
                best = Some((h, g, miss));
            }
            if done || h_large / h_small < 1.0 + 1e-3 {
                break;
            }
            h = (h_small * h_large).sqrt();
        }
        best.expect("one evaluation at least")
    }

    /// Why the nearest cell size `h` misses the target, as a clause to append to the warning:
    /// where its `count` patches are too many (`n` asked for) and a count of things a patch
    /// never spans (emitting materials, large separate surfaces) is what holds the count up,
    /// that count; else empty.
    fn why_missed(&self, h: f64, count: usize, n: usize) -> String {
        let scene = self.scene;
        let mut kinds: Vec<u32> = scene
            .triangles
            .iter()
            .map(|t| grouping::kind_of(scene, t.material))
            .filter(|&k| k != u32::MAX)
            .collect();
        kinds.sort_unstable();
        kinds.dedup();
        let mut roots = self.component.to_vec();
        roots.sort_unstable();
        roots.dedup();
        let large = roots
            .iter()
            .filter(|&&r| self.loose.area[r as usize] >= grouping::LOOSE_PART * h * h)
            .count();
        let held = |k: usize| count > n && k as f64 > 0.5 * self.target;
        if held(kinds.len()) {
            format!(
                "; the scene has {} emitting materials, and a patch never spans two",
                kinds.len()
            )
        } else if held(large) {
            format!(
                "; the scene has {large} separate connected surfaces of at least {} of a cell face, and two never share a patch",
                grouping::LOOSE_PART
            )
        } else if held(roots.len()) {
            format!(
                "; the scene has {} separate connected surfaces, and a patch joins two only where they see each other",
                roots.len()
            )
        } else {
            String::new()
        }
    }
}

/// The groups at cell size `h` ([`grouping::group`]), each split where its pieces see
/// different surroundings ([`surroundings::split_by_surroundings`]).
fn grouped(scene: &Scene, component: &[u32], loose: &Loose<'_>, h: f64, cos_max: f64) -> Grouping {
    let merged = grouping::group(scene, component, loose, h, cos_max);
    let (groups, split) = surroundings::split_by_surroundings(merged.groups, loose, h);
    let (groups, sight) = sight::split_by_sight(groups, loose, h);
    Grouping {
        groups,
        split,
        sight,
    }
}

/// The patches of `grouping` (area-weighted centre, normal and reflectance of their pieces)
/// and every piece, each patch's pieces contiguous.
fn build_patches(scene: &Scene, grouping: Grouping) -> (Vec<BakePatch>, Vec<Piece>) {
    let mut patches = Vec::with_capacity(grouping.groups.len());
    let mut pieces = Vec::new();
    for (material, group) in grouping.groups {
        let start = pieces.len();
        let object = main_object(&group);
        let mut area = 0.0;
        let mut centre = DVec3::ZERO;
        let mut nsum = DVec3::ZERO;
        let mut refl = [0.0; 3];
        for p in &group {
            area += p.area;
            centre += p.polygon.centroid() * p.area;
            nsum += p.normal * p.area;
            let r = piece_reflectance(scene, p);
            for c in 0..3 {
                refl[c] += r[c] * p.area;
            }
        }
        pieces.extend(group);
        let mat = &scene.materials[material as usize];
        patches.push(BakePatch {
            centre: centre / area,
            area,
            normal: nsum.normalize_or(pieces[start].normal),
            object,
            material,
            reflectance: Rgb::new(
                (refl[0] / area) as f32,
                (refl[1] / area) as f32,
                (refl[2] / area) as f32,
            ),
            emission: mat.emission,
            pieces: start..pieces.len(),
            seed: crate::patch::identity::index_seed(patches.len()),
        });
    }
    (patches, pieces)
}

/// Interpolation weights: every vertex over the patches cut from its own triangles, whose
/// normals are within 60° of the vertex's mean normal, by area times a smooth fall-off over two
/// cells; the nearest such patch when none is that close.
fn vertex_weights(scene: &Scene, patches: &[BakePatch], pieces: &[Piece], h: f64) -> VertexWeights {
    let tri_patches = triangle_patches(scene, patches, pieces);
    let nv = scene.positions.len();
    let incident = incident_triangles(scene);
    let radius = 2.0 * h;
    let mut offsets = Vec::with_capacity(nv + 1);
    let mut entries = Vec::new();
    offsets.push(0);
    let mut cands: Vec<u32> = Vec::new();
    for v in 0..nv {
        let pos = scene.positions[v];
        let mut nrm = DVec3::ZERO;
        cands.clear();
        for &t in &incident[v] {
            nrm += scene.triangle_normal(t as usize) * scene.triangle_area(t as usize);
            cands.extend_from_slice(&tri_patches[t as usize]);
        }
        cands.sort_unstable();
        cands.dedup();
        let nrm = nrm.normalize_or_zero();
        let row_start = entries.len();
        let mut sum = 0.0;
        let mut nearest: Option<(f64, u32)> = None;
        for &p in &cands {
            let patch = &patches[p as usize];
            if nrm != DVec3::ZERO && patch.normal.dot(nrm) < 0.5 {
                continue;
            }
            let d = (patch.centre - pos).length();
            if nearest.is_none_or(|(dn, _)| d < dn) {
                nearest = Some((d, p));
            }
            let fall = (1.0 - d / radius).max(0.0);
            let w = patch.area * fall * fall;
            if w > 0.0 {
                entries.push((p, w as f32));
                sum += w;
            }
        }
        if sum > 0.0 {
            for e in &mut entries[row_start..] {
                e.1 = (e.1 as f64 / sum) as f32;
            }
        } else if let Some((_, p)) = nearest.or_else(|| cands.first().map(|&p| (0.0, p))) {
            entries.push((p, 1.0));
        }
        offsets.push(entries.len());
    }
    VertexWeights { offsets, entries }
}

/// The patches cut from each of the scene's triangles, increasing.
fn triangle_patches(scene: &Scene, patches: &[BakePatch], pieces: &[Piece]) -> Vec<Vec<u32>> {
    let mut tri_patches: Vec<Vec<u32>> = vec![Vec::new(); scene.triangles.len()];
    for (i, p) in patches.iter().enumerate() {
        for piece in &pieces[p.pieces.clone()] {
            let list = &mut tri_patches[piece.triangle as usize];
            if list.last() != Some(&(i as u32)) {
                list.push(i as u32);
            }
        }
    }
    tri_patches
}

/// The triangles around each of the scene's vertices, increasing.
fn incident_triangles(scene: &Scene) -> Vec<Vec<u32>> {
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); scene.positions.len()];
    for (t, tri) in scene.triangles.iter().enumerate() {
        for &v in &tri.vertices {
            incident[v as usize].push(t as u32);
        }
    }
    incident
}
