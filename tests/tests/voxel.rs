//! Voxel simplification: patch targets, area preservation, orientation splitting, small curved
//! parts merging, vertex interpolation weights.

mod bake_support;

use bake_support::*;
use glam::{DVec3, dvec3};
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use std::path::Path;

fn cornell() -> Scene {
    Scene::load_obj(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenes/cornell-box/CornellBox-Original.obj"),
    )
    .unwrap()
}

#[test]
fn hits_the_target_within_ten_percent_and_keeps_the_area() {
    let s = cornell();
    let total: f64 = (0..s.triangles.len()).map(|t| s.triangle_area(t)).sum();
    for n in [64, 256, 1024, 4096] {
        let p = simplify(&s, &VoxelParams::with_patches(n)).unwrap();
        let got = p.len() as f64;
        assert!(
            (got - n as f64).abs() <= 0.1 * n as f64,
            "target {n}: {got} patches"
        );
        let area: f64 = p.patches.iter().map(|q| q.area).sum();
        // The bound: total area to 1e-6 relative (cutting is exact up to rounding).
        assert!(
            (area - total).abs() <= 1e-6 * total,
            "target {n}: area {area} vs {total}"
        );
        for q in &p.patches {
            assert!(q.area > 0.0 && (q.normal.length() - 1.0).abs() < 1e-9);
            assert!(q.reflectance.max_channel() < 1.0);
        }
        assert_eq!(p.to_core().len(), p.len());
    }
}

#[test]
fn fixed_cell_size() {
    // A 1×1 quad and 0.25 cells: exactly 16 patches of area 1/16.
    let s = Scene::from_triangles(
        vec!["q".into()],
        &[
            (
                [
                    dvec3(0.0, 0.0, 0.0),
                    dvec3(1.0, 0.0, 0.0),
                    dvec3(1.0, 1.0, 0.0),
                ],
                0,
            ),
            (
                [
                    dvec3(0.0, 0.0, 0.0),
                    dvec3(1.0, 1.0, 0.0),
                    dvec3(0.0, 1.0, 0.0),
                ],
                0,
            ),
        ],
    );
    let p = simplify(&s, &VoxelParams::with_cell_size(0.25)).unwrap();
    assert_eq!(p.len(), 16);
    for q in &p.patches {
        assert!((q.area - 1.0 / 16.0).abs() < 1e-12, "area {}", q.area);
    }
    assert!(simplify(&s, &VoxelParams::with_cell_size(-1.0)).is_err());
    assert!(simplify(&s, &VoxelParams::with_cell_size(f64::NAN)).is_err());
}

/// The two sides of a thin wall, and a floor with a wall standing on it, fall in the same
/// cells but never share a patch.
#[test]
fn orientation_splits_patches() {
    let wall_front = facing(
        vec![
            dvec3(0.5, 0.0, 0.0),
            dvec3(0.5, 1.0, 0.0),
            dvec3(0.5, 1.0, 1.0),
            dvec3(0.5, 0.0, 1.0),
        ],
        DVec3::X,
    );
    let wall_back: Vec<DVec3> = wall_front
        .iter()
        .rev()
        .map(|p| *p + dvec3(1e-3, 0.0, 0.0))
        .collect();
    let objs = vec![Obj::new(
        "room",
        vec![rect_z(0.0, 1.0, 0.0, 1.0, 0.0, true), wall_front, wall_back],
    )];
    let dir = tempfile::tempdir().unwrap();
    let s = load(dir.path(), "thin", &objs, Placement::general(1.0));
    let p = simplify(&s, &VoxelParams::with_cell_size(2.0)).unwrap();
    // One cell for everything (cell 2 > scene 1): floor, wall front, wall back.
    assert_eq!(p.len(), 3, "{} patches", p.len());
    let ns: Vec<DVec3> = p.patches.iter().map(|q| q.normal).collect();
    for i in 0..3 {
        for j in 0..i {
            assert!(
                ns[i].dot(ns[j]) < 0.1,
                "patches {i} and {j} share an orientation"
            );
        }
    }
}

#[test]
fn vertex_weights_sum_to_one_over_compatible_patches() {
    let s = cornell();
    let p = simplify(&s, &VoxelParams::with_patches(512)).unwrap();
    let mut used = vec![false; s.positions.len()];
    for t in &s.triangles {
        for &v in &t.vertices {
            used[v as usize] = true;
        }
    }
    for v in 0..s.positions.len() {
        let w = p.vertex_weights.of(v);
        if !used[v] {
            assert!(w.is_empty());
            continue;
        }
        assert!(!w.is_empty(), "vertex {v} has no weights");
        let sum: f32 = w.iter().map(|e| e.1).sum();
        assert!((sum - 1.0).abs() < 1e-5, "vertex {v}: weights sum {sum}");
        for &(patch, _) in w {
            // Nearby: within two cells and a half-diagonal of the vertex.
            let d = (p.patches[patch as usize].centre - s.positions[v]).length();
            assert!(
                d <= 2.0 * p.cell_size * 1.8,
                "vertex {v}: patch {patch} at distance {d}"
            );
        }
    }
}

/// A floor strewn with 400 loose tiles (separate surfaces, as furniture of many parts is):
/// loose parts that face the same way and see each other share patches, so the target is met
/// (before, a patch never spanned two surfaces and 20 asked gave 400 or more).
#[test]
fn loose_parts_merge_to_meet_the_target() {
    let mut tiles = Vec::new();
    for i in 0..20 {
        for j in 0..20 {
            let (x, y) = (i as f64 * 0.05, j as f64 * 0.05);
            tiles.push(rect_z(x, x + 0.04, y, y + 0.04, 0.0, true));
        }
    }
    let objs = vec![Obj::new("tiles", tiles)];
    let dir = tempfile::tempdir().unwrap();
    let s = load(dir.path(), "tiles", &objs, Placement::general(1.0));
    let p = simplify(&s, &VoxelParams::with_patches(20)).unwrap();
    // The target's own tolerance (VoxelParams: ±10%).
    assert!((18..=22).contains(&p.len()), "{} patches", p.len());
    assert!(p.warnings.is_empty(), "{:?}", p.warnings);
    let area: f64 = p.patches.iter().map(|q| q.area).sum();
    // 400 tiles of 0.04², to rounding.
    assert!((area - 0.64).abs() < 1e-9, "area {area}");
}

/// Two small tiles facing up on either side of a thin wall (another object) stay apart at a
/// cell size that holds both: the wall blocks the segment between them. Without the wall they
/// share one patch.
#[test]
fn loose_parts_behind_a_wall_stay_apart() {
    let tile_a = rect_z(0.40, 0.44, 0.5, 0.54, 0.0, true);
    let tile_b = rect_z(0.56, 0.60, 0.5, 0.54, 0.0, true);
    let wall = facing(
        vec![
            dvec3(0.5, -1.0, -0.5),
            dvec3(0.5, 2.0, -0.5),
            dvec3(0.5, 2.0, 1.0),
            dvec3(0.5, -1.0, 1.0),
        ],
        DVec3::X,
    );
    let dir = tempfile::tempdir().unwrap();
    let count = |with_wall: bool, name: &str| {
        let mut objs = vec![Obj::new("tiles", vec![tile_a.clone(), tile_b.clone()])];
        if with_wall {
            objs.push(Obj::new("wall", vec![wall.clone()]));
        }
        let s = load(dir.path(), name, &objs, Placement::general(1.0));
        // One cell of side 8 holds the whole scene; each tile (0.0016) is far below half a
        // cell face, so both are loose parts.
        let p = simplify(&s, &VoxelParams::with_cell_size(8.0)).unwrap();
        p.patches.iter().filter(|q| q.object == 0).count()
    };
    assert_eq!(
        count(false, "open"),
        1,
        "open floor: the tiles see each other"
    );
    assert_eq!(count(true, "walled"), 2, "the wall stands between them");
}

/// A UV sphere of radius `r` about `c`: `stacks` bands of `slices` quads, triangles at the
/// poles, facing out. Shared corners are computed by one formula, so the sphere is one
/// connected surface.
fn sphere(c: DVec3, r: f64, stacks: usize, slices: usize) -> Vec<Vec<DVec3>> {
    let at = |i: usize, j: usize| {
        let theta = std::f64::consts::PI * i as f64 / stacks as f64;
        let phi = std::f64::consts::TAU * (j % slices) as f64 / slices as f64;
        c + r * dvec3(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    };
    let mut faces = Vec::new();
    for i in 0..stacks {
        for j in 0..slices {
            let mut poly = vec![at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            // The poles' quads degenerate to triangles.
            if i == 0 {
                poly.remove(0);
            } else if i == stacks - 1 {
                poly.remove(1);
            }
            let centre = poly.iter().copied().sum::<DVec3>() / poly.len() as f64;
            faces.push(facing(poly, centre - c));
        }
    }
    faces
}

/// A large floor of two triangles under 25 small tessellated balls: curved parts must not eat
/// the patch budget. Each ball splits into a group per 35° normal cone in every cell it
/// touches; with the orientation rule applied to every group the balls kept the count near the
/// target at any cell size (226 of 233 patches), the bisection ended at cells of 5.9 on a floor
/// 10 wide, and the floor was 7 patches. Small groups of finely tessellated parts
/// (`voxel::SMALL_GROUP`) now merge, and the floor gets the budget (measured: 244 patches, cell
/// 1.03, floor 187, balls 57).
#[test]
fn small_curved_parts_leave_the_budget_to_a_large_floor() {
    let place = Placement::general(1.0);
    let centres: Vec<DVec3> = (0..25)
        .map(|k| dvec3(1.0 + 2.0 * (k / 5) as f64, 1.0 + 2.0 * (k % 5) as f64, 0.5))
        .collect();
    let objs = vec![
        Obj::new("floor", vec![rect_z(0.0, 10.0, 0.0, 10.0, 0.0, true)]),
        Obj::new(
            "balls",
            centres
                .iter()
                .flat_map(|&c| sphere(c, 0.2, 12, 24))
                .collect(),
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let s = load(dir.path(), "balls", &objs, place);
    let total: f64 = (0..s.triangles.len()).map(|t| s.triangle_area(t)).sum();
    let n = 256;
    let p = simplify(&s, &VoxelParams::with_patches(n)).unwrap();
    let floor = p.patches.iter().filter(|q| q.object == 0).count();
    let summary = format!("{} patches, cell {}, floor {floor}", p.len(), p.cell_size);
    // The target's own tolerance (VoxelParams: ±10%).
    assert!(
        (p.len() as f64 - n as f64).abs() <= 0.1 * n as f64,
        "{summary}"
    );
    assert!(p.warnings.is_empty(), "{:?}", p.warnings);
    // The floor is 89% of the area. Its cells are larger than sqrt(area / n) because the balls
    // take a share (each cell a ball touches costs a patch) and cells on the floor's rim are
    // partly empty: about 1.5 times here. Twice bounds that with room for the bisection's
    // ±10%, and leaves the floor at least half the budget (before: cells 8.9 times, 7 patches).
    let fair = (total / n as f64).sqrt();
    assert!(p.cell_size <= 2.0 * fair, "{summary}; fair size {fair}");
    assert!(floor >= n / 2, "{summary}");
    // Each ball (diameter 0.4, less than a cell) lies in at most 8 cells, and all its groups
    // in one cell share a patch: at most 8 patches a ball, whatever the orientations.
    for &c in &centres {
        let c = place.apply(c);
        let own = p
            .patches
            .iter()
            .filter(|q| q.object == 1 && (q.centre - c).length() < 0.3)
            .count();
        assert!(
            (1..=8).contains(&own),
            "{summary}; ball at {c}: {own} patches"
        );
    }
}
