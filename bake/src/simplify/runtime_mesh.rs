//! The runtime mesh stored in a `.rad` file (the core's [`radiosity_core::Mesh`]): the scene's
//! full-detail triangles with their materials, per-corner interpolation weights over the matrix
//! patches, and the points where direct light on each patch is sampled.

use crate::scene::Scene;
use crate::simplify::Patches;
use glam::DVec3;
use radiosity_core::{CornerWeight, Mesh, MeshTriangle, PatchSample, Rgb};
use std::borrow::Cow;

/// Smallest cosine between a triangle's normal and a patch's for the patch to take part in
/// the triangle's corner interpolation (about 37°): curved tessellations blend across
/// neighbouring faces, a room's corner does not blend the floor into the walls.
const SAME_SURFACE_COS: f64 = 0.8;

/// Builds the runtime mesh. `file_index[k]` is the matrix (file) index of simplification patch
/// `k`, or `None` for a patch left out of the matrix (one that sees nothing); `buried_points`
/// (per patch, may be empty) marks which of its [`direct_points`] are buried under another
/// object, which lend no direct-light sample.
pub(crate) fn runtime_mesh(
    scene: &Scene,
    patches: &Patches,
    file_index: &[Option<u32>],
    buried_points: &[Vec<bool>],
) -> Mesh<'static> {
    let nt = scene.triangles.len();
    let bary = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let triangles: Vec<MeshTriangle> = scene
        .triangles
        .iter()
        .enumerate()
        .map(|(t, tri)| {
            let rho = scene.reflectance_over(t, bary);
            MeshTriangle {
                vertices: tri.vertices,
                object: tri.object,
                reflectance: Rgb::new(rho[0] as f32, rho[1] as f32, rho[2] as f32),
                emission: scene.materials[tri.material as usize].emission,
            }
        })
        .collect();

    // Patches cut from each triangle, and triangles around each vertex.
    let mut tri_patches: Vec<Vec<u32>> = vec![Vec::new(); nt];
    for (k, p) in patches.patches.iter().enumerate() {
        for piece in &patches.pieces[p.pieces.clone()] {
            let list = &mut tri_patches[piece.triangle as usize];
            if list.last() != Some(&(k as u32)) {
                list.push(k as u32);
            }
        }
    }
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); scene.positions.len()];
    for (t, tri) in scene.triangles.iter().enumerate() {
        for &v in &tri.vertices {
            incident[v as usize].push(t as u32);
        }
    }

    let radius = 2.0 * patches.cell_size;
    let mut corner_rows = Vec::with_capacity(3 * nt + 1);
    let mut corner_weights: Vec<CornerWeight> = Vec::new();
    corner_rows.push(0u32);
    let mut cands: Vec<u32> = Vec::new();
    for (t, tri) in scene.triangles.iter().enumerate() {
        let normal = scene.triangle_normal(t);
        for &v in &tri.vertices {
            let pos = scene.positions[v as usize];
            cands.clear();
            for &s in &incident[v as usize] {
                cands.extend_from_slice(&tri_patches[s as usize]);
            }
            cands.sort_unstable();
            cands.dedup();
            let start = corner_weights.len();
            let mut sum = 0.0;
            for &k in &cands {
                let p = &patches.patches[k as usize];
                let Some(file) = file_index[k as usize] else {
                    continue;
                };
                if p.normal.dot(normal) < SAME_SURFACE_COS {
                    continue;
                }
                let fall = (1.0 - (p.centre - pos).length() / radius).max(0.0);
                let w = p.area * fall * fall;
                if w > 0.0 {
                    corner_weights.push(CornerWeight {
                        patch: file,
                        weight: w as f32,
                    });
                    sum += w;
                }
            }
            if sum > 0.0 {
                for e in &mut corner_weights[start..] {
                    e.weight = ((f64::from(e.weight) / sum) as f32).min(1.0);
                }
            } else {
                // Nothing close on the same surface: the nearest live patch cut from this
                // triangle, else nothing (the corner gets no indirect light).
                let nearest = tri_patches[t]
                    .iter()
                    .filter_map(|&k| file_index[k as usize].map(|f| (k, f)))
                    .min_by(|a, b| {
                        let d = |k: u32| (patches.patches[k as usize].centre - pos).length();
                        d(a.0).total_cmp(&d(b.0))
                    });
                if let Some((_, f)) = nearest {
                    corner_weights.push(CornerWeight {
                        patch: f,
                        weight: 1.0,
                    });
                }
            }
            corner_rows.push(corner_weights.len() as u32);
        }
    }

    // Direct-light samples: every patch's [`direct_points`] not buried under another object,
    // in matrix order.
    let n = file_index.iter().flatten().count();
    let mut by_file: Vec<Vec<PatchSample>> = vec![Vec::new(); n];
    for (k, p) in patches.patches.iter().enumerate() {
        let Some(f) = file_index[k] else { continue };
        let buried = buried_points.get(k).map_or(&[][..], Vec::as_slice);
        for (j, (x, normal, area)) in direct_points(patches.pieces_of(k)).into_iter().enumerate() {
            if buried.get(j) != Some(&true) {
                by_file[f as usize].push(sample(x, normal, area));
            }
        }
        if by_file[f as usize].is_empty() {
            by_file[f as usize].push(sample(p.centre, p.normal, p.area));
        }
    }
    let mut sample_rows = Vec::with_capacity(n + 1);
    sample_rows.push(0u32);
    let mut samples = Vec::new();
    for s in by_file {
        samples.extend(s);
        sample_rows.push(samples.len() as u32);
    }

    Mesh {
        positions: Cow::Owned(
            scene
                .positions
                .iter()
                .map(|p| p.as_vec3().to_array())
                .collect(),
        ),
        triangles: Cow::Owned(triangles),
        corner_rows: Cow::Owned(corner_rows),
        corner_weights: Cow::Owned(corner_weights),
        sample_rows: Cow::Owned(sample_rows),
        samples: Cow::Owned(samples),
    }
}

/// Direct-light points a patch has at least: a patch cut from a few large triangles (a ground
/// plane of two) otherwise samples a shadow edge across it at one or two points, all lit or
/// all dark, and passes that error on to every surface its light reaches
/// (`docs/decisions/direct-light-points.md`).
pub(crate) const DIRECT_POINTS: usize = 16;

/// Most points on one piece's fan triangle (a grid of `m²` sub-triangles, `m` at most 16).
const MAX_GRID: usize = 16;

/// The points where the runtime samples direct light on a patch made of `pieces`: position,
/// unit normal and the area each stands for. A piece gets points in proportion to its share of
/// the patch's area, at least one, together at least [`DIRECT_POINTS`]: each fan triangle of
/// the piece is cut into an `m × m` grid of similar sub-triangles, a point at each one's
/// centroid (the midpoint rule, stratified, no randomness). A patch of many small pieces keeps
/// one point per piece, its centroid.
pub(crate) fn direct_points(pieces: &[crate::simplify::Piece]) -> Vec<(DVec3, DVec3, f64)> {
    let total: f64 = pieces.iter().map(|q| q.area).filter(|a| *a > 0.0).sum();
    let mut out = Vec::new();
    for q in pieces {
        if !(q.area > 0.0) {
            continue;
        }
        let dp: f64 = std::env::var("RADIOSITY_DIRECT_POINTS").ok().and_then(|v| v.parse().ok()).unwrap_or(DIRECT_POINTS as f64);
        let want = (dp * q.area / total).ceil().max(1.0);
        if want <= 1.0 {
            out.push((q.polygon.centroid(), q.normal, q.area));
            continue;
        }
        let v = q.polygon.vertices();
        for w in 1..v.len().saturating_sub(1) {
            let (a, b, c) = (v[0], v[w], v[w + 1]);
            let at = 0.5 * (b - a).cross(c - a).length();
            if !(at > 0.0) {
                continue;
            }
            let m = ((want * at / q.area).sqrt().ceil() as usize).clamp(1, MAX_GRID);
            let (e1, e2) = ((b - a) / m as f64, (c - a) / m as f64);
            let each = at / (m * m) as f64;
            for i in 0..m {
                for j in 0..m - i {
                    let up = a + e1 * (i as f64 + 1.0 / 3.0) + e2 * (j as f64 + 1.0 / 3.0);
                    out.push((up, q.normal, each));
                    if i + j + 1 < m {
                        let down = a + e1 * (i as f64 + 2.0 / 3.0) + e2 * (j as f64 + 2.0 / 3.0);
                        out.push((down, q.normal, each));
                    }
                }
            }
        }
    }
    out
}

fn sample(position: DVec3, normal: DVec3, area: f64) -> PatchSample {
    PatchSample {
        position: position.as_vec3().to_array(),
        normal: normal.normalize().as_vec3().to_array(),
        area: (area as f32).max(f32::MIN_POSITIVE),
    }
}
