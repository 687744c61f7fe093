//! The runtime mesh stored in a `.rad` file (the core's [`radiosity_core::Mesh`]): the scene's
//! full-detail triangles with their materials, per-corner interpolation weights over the matrix
//! patches, and the points where direct light on each patch is sampled.

use super::{incident_triangles, triangle_patches};
use crate::patch::Patches;
use crate::scene::Scene;
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
/// object, which lend no direct-light sample. Returned with the object of every sample (the
/// mesh's sample order), which `solve` needs for patches of several objects.
pub(crate) fn runtime_mesh(
    scene: &Scene,
    patches: &Patches,
    file_index: &[Option<u32>],
    buried_points: &[Vec<bool>],
    points: &[u32],
) -> (Mesh<'static>, Vec<u32>) {
    let corners = Corners {
        scene,
        patches,
        file_index,
        tri_patches: triangle_patches(scene, &patches.patches, &patches.pieces),
        incident: incident_triangles(scene),
        radius: 2.0 * patches.cell_size,
    };
    let (corner_rows, corner_weights) = corners.weights();
    let samples = direct_samples(patches, file_index, buried_points, points);
    let mesh = Mesh {
        positions: Cow::Owned(
            scene
                .positions
                .iter()
                .map(|p| p.as_vec3().to_array())
                .collect(),
        ),
        triangles: Cow::Owned(mesh_triangles(scene)),
        corner_rows: Cow::Owned(corner_rows),
        corner_weights: Cow::Owned(corner_weights),
        sample_rows: Cow::Owned(samples.rows),
        samples: Cow::Owned(samples.samples),
    };
    (mesh, samples.objects)
}

/// The scene's triangles as the runtime stores them: vertices, object, the reflectance over
/// the whole triangle and its material's emission.
fn mesh_triangles(scene: &Scene) -> Vec<MeshTriangle> {
    let bary = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    scene
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
        .collect()
}

/// What weighing the triangles' corners over the matrix patches needs ([`Corners::weights`]).
struct Corners<'a> {
    scene: &'a Scene,
    patches: &'a Patches,
    file_index: &'a [Option<u32>],
    /// Patches cut from each triangle ([`triangle_patches`]).
    tri_patches: Vec<Vec<u32>>,
    /// Triangles around each vertex ([`incident_triangles`]).
    incident: Vec<Vec<u32>>,
    /// Distance at which a patch's weight falls to zero: two cells.
    radius: f64,
}

impl Corners<'_> {
    /// Every triangle corner's interpolation weights over the matrix patches (file indices),
    /// as rows: the row offsets (three a triangle) and the weights.
    fn weights(&self) -> (Vec<u32>, Vec<CornerWeight>) {
        let nt = self.scene.triangles.len();
        let mut corner_rows = Vec::with_capacity(3 * nt + 1);
        let mut corner_weights: Vec<CornerWeight> = Vec::new();
        corner_rows.push(0u32);
        let mut cands: Vec<u32> = Vec::new();
        for (t, tri) in self.scene.triangles.iter().enumerate() {
            let normal = self.scene.triangle_normal(t);
            for &v in &tri.vertices {
                cands.clear();
                for &s in &self.incident[v as usize] {
                    cands.extend_from_slice(&self.tri_patches[s as usize]);
                }
                cands.sort_unstable();
                cands.dedup();
                self.corner(t, normal, v, &cands, &mut corner_weights);
                corner_rows.push(corner_weights.len() as u32);
            }
        }
        (corner_rows, corner_weights)
    }

    /// Pushes onto `out` the weights of the corner of triangle `t` (of unit normal `normal`)
    /// at vertex `v` over the candidate patches `cands` (those cut from the triangles around
    /// the vertex): the live ones on the same surface by area times a smooth fall-off over
    /// [`Self::radius`], normalised; else the nearest live patch cut from the triangle.
    fn corner(&self, t: usize, normal: DVec3, v: u32, cands: &[u32], out: &mut Vec<CornerWeight>) {
        let pos = self.scene.positions[v as usize];
        let start = out.len();
        let mut sum = 0.0;
        for &k in cands {
            let p = &self.patches.patches[k as usize];
            let Some(file) = self.file_index[k as usize] else {
                continue;
            };
            if p.normal.dot(normal) < SAME_SURFACE_COS {
                continue;
            }
            let fall = (1.0 - (p.centre - pos).length() / self.radius).max(0.0);
            let w = p.area * fall * fall;
            if w > 0.0 {
                out.push(CornerWeight {
                    patch: file,
                    weight: w as f32,
                });
                sum += w;
            }
        }
        if sum > 0.0 {
            for e in &mut out[start..] {
                e.weight = ((f64::from(e.weight) / sum) as f32).min(1.0);
            }
        } else {
            // Nothing close on the same surface: the nearest live patch cut from this
            // triangle, else nothing (the corner gets no indirect light).
            let nearest = self.tri_patches[t]
                .iter()
                .filter_map(|&k| self.file_index[k as usize].map(|f| (k, f)))
                .min_by(|a, b| {
                    let d = |k: u32| (self.patches.patches[k as usize].centre - pos).length();
                    d(a.0).total_cmp(&d(b.0))
                });
            if let Some((_, f)) = nearest {
                out.push(CornerWeight {
                    patch: f,
                    weight: 1.0,
                });
            }
        }
    }
}

/// The runtime's direct-light samples as rows in matrix order ([`direct_samples`]).
struct Samples {
    /// Row offsets, one row a matrix patch.
    rows: Vec<u32>,
    samples: Vec<PatchSample>,
    /// The object of each sample.
    objects: Vec<u32>,
}

/// Direct-light samples: every patch's [`direct_points`] not buried under another object
/// (`buried_points`), in matrix order; a patch all of whose points are buried keeps its
/// centre.
fn direct_samples(
    patches: &Patches,
    file_index: &[Option<u32>],
    buried_points: &[Vec<bool>],
    points: &[u32],
) -> Samples {
    let n = file_index.iter().flatten().count();
    let mut by_file: Vec<Vec<(PatchSample, u32)>> = vec![Vec::new(); n];
    for (k, p) in patches.patches.iter().enumerate() {
        let Some(f) = file_index[k] else { continue };
        let buried = buried_points.get(k).map_or(&[][..], Vec::as_slice);
        for (j, d) in direct_points(patches.pieces_of(k), points[k])
            .into_iter()
            .enumerate()
        {
            if buried.get(j) != Some(&true) {
                by_file[f as usize].push((sample(d.position, d.normal, d.area), d.object));
            }
        }
        if by_file[f as usize].is_empty() {
            by_file[f as usize].push((sample(p.centre, p.normal, p.area), p.object));
        }
    }
    let mut rows = Vec::with_capacity(n + 1);
    rows.push(0u32);
    let mut samples = Vec::new();
    let mut objects = Vec::new();
    for s in by_file {
        for (sample, object) in s {
            samples.push(sample);
            objects.push(object);
        }
        rows.push(samples.len() as u32);
    }
    Samples {
        rows,
        samples,
        objects,
    }
}

/// Direct-light points a patch has at least, by default. A patch cut from a few large
/// triangles (a ground plane of two) otherwise samples a shadow edge across it at one or two
/// points, all lit or all dark, and passes that error on to every surface its light reaches
/// (`docs/decisions/direct-light-points.md`: on an outdoor scene at 3923 patches the
/// area-weighted error against the path tracer fell from 1.47% with one point a piece to 0.28%
/// with four a patch; each point is 28 bytes of the file).
pub const DIRECT_POINTS: u32 = 4;

/// The most direct-light points a patch may be given.
pub const MAX_DIRECT_POINTS: u32 = 64;

/// Points an object of many pieces keeps in a patch of more than [`MAX_DIRECT_POINTS`] pieces
/// ([`direct_points`]): enough for the facets of a curved part to be seen from most sides.
const MIN_OBJECT_POINTS: u32 = 16;

/// The points where the runtime samples direct light on a patch made of `pieces`: position,
/// unit normal, the area each stands for and its piece's object, `K = min_points` at least.
/// A patch of fewer than `K` pieces gets `K` points spread over its area, each standing for an
/// equal share: the centred Hammersley set `((k + ½)/K, φ₂(k) + ½/K)` mapped through the
/// pieces' areas (`hemisphere::patch_point_at`), the first coordinate picking the piece by
/// area. A patch of `K` pieces or more gives each piece points in proportion to its area,
/// `max(1, ⌈K·a/A⌉)` for a piece of area `a` in a patch of area `A` (its centroid for one, else
/// the same set through the piece): where the small parts of several objects share a patch
/// with a large surface (the tops of boxes in a yard with the ground around them), each part
/// keeps a point of its own and the large surface about `K`, where one centroid a piece left
/// the ground of a cell full of boxes' shadows one point. A patch of more than
/// [`MAX_DIRECT_POINTS`] pieces (a finely tessellated chair: the conference room's patches
/// hold ~350) gives each of its objects `max(1, ⌈K·a/A⌉)` points instead, `a` the object's
/// area in it, the same set through the object's pieces: each object keeps points of its own,
/// and the frame does not pay a shadow ray per facet (`docs/decisions/direct-light-points.md`).
/// No randomness: the same patch gets the same points.
pub(crate) fn direct_points(pieces: &[crate::patch::Piece], min_points: u32) -> Vec<DirectPoint> {
    let live: Vec<crate::patch::Piece> = pieces.iter().filter(|q| q.area > 0.0).cloned().collect();
    // Where each live piece stands in `pieces`.
    let index: Vec<u32> = (0..pieces.len() as u32)
        .filter(|&q| pieces[q as usize].area > 0.0)
        .collect();
    let total: f64 = live.iter().map(|q| q.area).sum();
    if live.is_empty() || !(total > 0.0) {
        return Vec::new();
    }
    // `at[j]`: where `within[j]` stands among the live pieces.
    let hammersley = |within: &[crate::patch::Piece],
                      at: &dyn Fn(usize) -> usize,
                      area: f64,
                      n: u32,
                      out: &mut Vec<DirectPoint>| {
        let nf = f64::from(n);
        for k in 0..n {
            let u = (f64::from(k) + 0.5) / nf;
            let v = (f64::from(k.reverse_bits()) / 4_294_967_296.0 + 0.5 / nf).fract();
            let (piece, x, normal) = crate::patch::points::patch_point_on(within, area, u, v);
            let j = within
                .iter()
                .position(|q| core::ptr::eq(q, piece))
                .unwrap_or(0);
            out.push(DirectPoint {
                position: x,
                normal,
                area: area / nf,
                object: piece.object,
                piece: index[at(j)],
            });
        }
    };
    let mut points = Vec::new();
    let one_object = live.iter().all(|q| q.object == live[0].object);
    if live.len() < min_points as usize && one_object {
        hammersley(&live, &|j| j, total, min_points, &mut points);
        return points;
    }
    let k_all = f64::from(min_points);
    // The 1e-9 keeps an exact multiple (half of a patch, K even) from rounding up.
    let share = |a: f64| (k_all * a / total - 1e-9).ceil().max(1.0) as u32;
    // Per piece: its count and where it stands among the live pieces.
    let each_piece = |at: usize, q: &crate::patch::Piece, points: &mut Vec<DirectPoint>| {
        let n = share(q.area);
        if n == 1 {
            points.push(DirectPoint {
                position: q.polygon.centroid(),
                normal: q.normal,
                area: q.area,
                object: q.object,
                piece: index[at],
            });
        } else {
            hammersley(core::slice::from_ref(q), &|_| at, q.area, n, points);
        }
    };
    if live.len() > MAX_DIRECT_POINTS as usize {
        // An object of more pieces than its share of MAX_DIRECT_POINTS (at least
        // MIN_OBJECT_POINTS) gets that share over its pieces; the others a point a piece.
        let budget = f64::from(MAX_DIRECT_POINTS.max(min_points));
        let mut objects: Vec<u32> = live.iter().map(|q| q.object).collect();
        objects.sort_unstable();
        objects.dedup();
        for o in objects {
            let at: Vec<usize> = (0..live.len()).filter(|&j| live[j].object == o).collect();
            let within: Vec<crate::patch::Piece> = at.iter().map(|&j| live[j]).collect();
            let area: f64 = within.iter().map(|q| q.area).sum();
            let n = ((budget * area / total - 1e-9).ceil() as u32).max(MIN_OBJECT_POINTS);
            if within.len() > n as usize {
                hammersley(&within, &|j| at[j], area, n, &mut points);
            } else {
                for &j in &at {
                    each_piece(j, &live[j], &mut points);
                }
            }
        }
        return points;
    }
    for (at, q) in live.iter().enumerate() {
        each_piece(at, q, &mut points);
    }
    points
}

/// A point where the runtime samples direct light on a patch ([`direct_points`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DirectPoint {
    pub(crate) position: DVec3,
    /// Unit normal of its piece.
    pub(crate) normal: DVec3,
    /// The area it stands for.
    pub(crate) area: f64,
    /// The scene object of its piece.
    pub(crate) object: u32,
    /// Its piece: the index among the patch's pieces.
    pub(crate) piece: u32,
}

fn sample(position: DVec3, normal: DVec3, area: f64) -> PatchSample {
    PatchSample {
        position: position.as_vec3().to_array(),
        normal: normal.normalize().as_vec3().to_array(),
        area: (area as f32).max(f32::MIN_POSITIVE),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patch::Piece;
    use glam::dvec3;

    fn piece(a: DVec3, b: DVec3, c: DVec3) -> Piece {
        let polygon = crate::geometry::polygon::Polygon::triangle(a, b, c);
        Piece {
            area: 0.5 * (b - a).cross(c - a).length(),
            polygon,
            normal: (b - a).cross(c - a).normalize(),
            triangle: 0,
            object: 0,
        }
    }

    /// A patch of two pieces (a unit square in two triangles) gets exactly the points asked
    /// for, each standing for an equal share, inside the square, the two halves the same count
    /// (by area); a patch of as many pieces as points keeps the centroids; a sliver beside
    /// large pieces keeps a point of its own and the large pieces about all those asked for.
    #[test]
    fn few_pieces_get_the_points_asked_for_and_every_piece_of_many_gets_one() {
        let (o, x, y, xy) = (
            DVec3::ZERO,
            dvec3(1.0, 0.0, 0.0),
            dvec3(0.0, 1.0, 0.0),
            dvec3(1.0, 1.0, 0.0),
        );
        let square = [piece(o, x, xy), piece(o, xy, y)];
        for n in [1, 4, 9, 64] {
            let pts = direct_points(&square, n);
            if n <= 2 {
                assert_eq!(pts.len(), 2, "one point a piece");
                continue;
            }
            assert_eq!(pts.len(), n as usize);
            let area: f64 = pts.iter().map(|p| p.area).sum();
            // Equal shares of the unit area, to rounding.
            assert!((area - 1.0).abs() < 1e-12, "{area}");
            for q in &pts {
                let p = q.position;
                assert!((0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y) && p.z == 0.0);
                assert_eq!(q.normal, dvec3(0.0, 0.0, 1.0));
            }
            // The first piece is the half below the diagonal (x ≥ y).
            let below = pts.iter().filter(|p| p.position.x >= p.position.y).count();
            assert_eq!(2 * below, n as usize + (n as usize % 2), "{pts:?}");
        }
        // As many pieces as points asked: the centroids.
        let pts = direct_points(&square, 2);
        assert!((pts[0].position - (o + x + xy) / 3.0).length() < 1e-12);
        // A sliver of a thousandth of the patch beside the square, 3 points asked: the
        // sliver keeps one point, its centroid; each half of the square ⌈3/2⌉ = 2.
        let sliver = piece(
            dvec3(2.0, 0.0, 0.0),
            dvec3(2.0447, 0.0, 0.0),
            dvec3(2.0, 0.0447, 0.0),
        );
        let pts = direct_points(&[square[0], square[1], sliver], 3);
        assert_eq!(pts.len(), 5);
        assert_eq!(pts.iter().filter(|p| p.position.x >= 2.0).count(), 1);
        let area: f64 = pts.iter().map(|p| p.area).sum();
        assert!((area - 1.0 - sliver.area).abs() < 1e-12, "{area}");
    }

    /// A patch of more than `MAX_DIRECT_POINTS` pieces: an object of many facets (a fan of 200
    /// slivers over the unit square, object 0) gets its share of 64 points spread over them,
    /// not a point a facet; a small object of six pieces (object 1, a thousandth of the area)
    /// keeps a point on each of its pieces, as in a patch of few pieces.
    #[test]
    fn an_object_of_many_facets_gets_its_share_not_a_point_a_facet() {
        let c = dvec3(0.5, 0.5, 0.0);
        let mut pieces: Vec<Piece> = (0..200)
            .map(|k| {
                let t = |k: u32| {
                    let a = f64::from(k) / 200.0 * std::f64::consts::TAU;
                    c + 0.5 * dvec3(a.cos(), a.sin(), 0.0)
                };
                piece(c, t(k), t(k + 1))
            })
            .collect();
        let fan_area: f64 = pieces.iter().map(|q| q.area).sum();
        for k in 0..6 {
            let o = dvec3(3.0 + f64::from(k), 0.0, 0.0);
            let mut q = piece(o, o + dvec3(0.02, 0.0, 0.0), o + dvec3(0.0, 0.02, 0.0));
            q.object = 1;
            pieces.push(q);
        }
        let pts = direct_points(&pieces, 32);
        let fan: Vec<_> = pts.iter().filter(|p| p.object == 0).collect();
        let small: Vec<_> = pts.iter().filter(|p| p.object == 1).collect();
        // ⌈64 · a/A⌉ with a/A ≈ 0.998: 64 points over the fan, each an equal share of it.
        assert_eq!(fan.len(), 64);
        for p in &fan {
            assert!((p.area - fan_area / 64.0).abs() < 1e-12, "{}", p.area);
            assert!((p.position - c).length() <= 0.5 + 1e-9);
        }
        // The small object: one point on each of its six pieces (their centroids).
        assert_eq!(small.len(), 6);
        let mut on: Vec<u32> = small.iter().map(|p| p.piece).collect();
        on.sort_unstable();
        assert_eq!(on, (200..206).collect::<Vec<u32>>());
    }
}
