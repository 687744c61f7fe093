//! OBJ + MTL scenes written by code, for bake and solve tests: closed and open boxes with
//! chosen materials, oriented so that every face's front (counter-clockwise side) faces the
//! room.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A material: diffuse reflectance `Kd` and emitted radiance `Ke`.
#[derive(Clone, Debug)]
pub struct Material {
    /// MTL name.
    pub name: String,
    /// Reflectance per channel.
    pub kd: [f64; 3],
    /// Emitted radiance per channel (W·sr⁻¹·m⁻²).
    pub ke: [f64; 3],
}

impl Material {
    /// A material.
    pub fn new(name: &str, kd: [f64; 3], ke: [f64; 3]) -> Self {
        Self {
            name: name.into(),
            kd,
            ke,
        }
    }
}

/// A planar quad of an object with a material.
#[derive(Clone, Debug)]
pub struct Quad {
    /// OBJ object name.
    pub object: String,
    /// Material name.
    pub material: String,
    /// Corners in order around the quad.
    pub corners: [[f64; 3]; 4],
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Quad {
    /// A quad whose front faces the point `towards`.
    pub fn facing(
        object: &str,
        material: &str,
        mut corners: [[f64; 3]; 4],
        towards: [f64; 3],
    ) -> Self {
        let n = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]));
        if dot(n, sub(towards, corners[0])) < 0.0 {
            corners.reverse();
        }
        Self {
            object: object.into(),
            material: material.into(),
            corners,
        }
    }
}

/// The six inward-facing faces of the box `[0, size]³`, each split into `split × split` quads,
/// named `floor`, `ceiling`, `left`, `right`, `back`, `front`; `material(face, i, j)` picks
/// each quad's material.
pub fn closed_box(
    size: f64,
    split: usize,
    material: impl Fn(&str, usize, usize) -> String,
) -> Vec<Quad> {
    let centre = [size / 2.0; 3];
    let s = size;
    // (name, fixed axis, its value)
    let faces = [
        ("floor", 1, 0.0),
        ("ceiling", 1, s),
        ("left", 0, 0.0),
        ("right", 0, s),
        ("back", 2, s),
        ("front", 2, 0.0),
    ];
    let mut quads = Vec::new();
    for (name, axis, value) in faces {
        let (u, v) = match axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let step = s / split as f64;
        for i in 0..split {
            for j in 0..split {
                let corner = |a: f64, b: f64| {
                    let mut p = [0.0; 3];
                    p[axis] = value;
                    p[u] = a;
                    p[v] = b;
                    p
                };
                let (a0, a1, b0, b1) = (
                    i as f64 * step,
                    (i + 1) as f64 * step,
                    j as f64 * step,
                    (j + 1) as f64 * step,
                );
                let corners = [
                    corner(a0, b0),
                    corner(a1, b0),
                    corner(a1, b1),
                    corner(a0, b1),
                ];
                quads.push(Quad::facing(name, &material(name, i, j), corners, centre));
            }
        }
    }
    quads
}

/// A furnace room with objects resting on its surfaces: the closed box `[0, 2]³` (split 2 × 2)
/// with a block `standing` on its floor and a cube `pressed` against its left wall, everything
/// one white material of reflectance `rho` emitting radiance `1/π` (exitance 1). Returns the
/// quads, the material, and each object's exposed area (full area less the part in contact:
/// the block's footprint 0.6 × 0.6 on the floor and its bottom, the cube's back 0.5 × 0.5 and
/// the wall behind it).
pub fn resting_blocks_room(rho: f64) -> (Vec<Quad>, Vec<Material>, Vec<(&'static str, f64)>) {
    let mut quads = closed_box(2.0, 2, |_, _, _| "white".into());
    quads.extend(block([0.3, 0.0, 0.4], [0.9, 0.7, 1.0], "standing", "white"));
    quads.extend(block([0.0, 0.8, 1.2], [0.5, 1.3, 1.7], "pressed", "white"));
    let mats = vec![Material::new(
        "white",
        [rho; 3],
        [1.0 / std::f64::consts::PI; 3],
    )];
    let exposed = vec![
        ("floor", 4.0 - 0.36),
        ("left", 4.0 - 0.25),
        ("ceiling", 4.0),
        ("right", 4.0),
        ("back", 4.0),
        ("front", 4.0),
        ("standing", 4.0 * 0.42 + 0.36),
        ("pressed", 5.0 * 0.25),
    ];
    (quads, mats, exposed)
}

/// Each object's whole area in [`resting_blocks_room`], the parts in contact included: the
/// room's faces 2 × 2, the block 0.6 × 0.7 × 0.6 (four sides 0.6 × 0.7, top and bottom
/// 0.6 × 0.6), the cube 0.5 on a side.
pub fn resting_blocks_surface_areas() -> Vec<(&'static str, f64)> {
    let mut areas: Vec<(&'static str, f64)> =
        ["floor", "left", "ceiling", "right", "back", "front"]
            .into_iter()
            .map(|f| (f, 4.0))
            .collect();
    areas.push(("standing", 4.0 * 0.42 + 2.0 * 0.36));
    areas.push(("pressed", 6.0 * 0.25));
    areas
}

/// Writes `name.obj` and `name.mtl` into `dir`; returns the OBJ path.
pub fn write_scene(dir: &Path, name: &str, quads: &[Quad], materials: &[Material]) -> PathBuf {
    let mut mtl = String::new();
    for m in materials {
        let [r, g, b] = m.kd;
        let [er, eg, eb] = m.ke;
        writeln!(
            mtl,
            "newmtl {}\nKd {r} {g} {b}\nKe {er} {eg} {eb}\n",
            m.name
        )
        .unwrap();
    }
    let mut obj = format!("mtllib {name}.mtl\n");
    let mut current = (String::new(), String::new());
    for (k, q) in quads.iter().enumerate() {
        if current.0 != q.object {
            writeln!(obj, "o {}", q.object).unwrap();
            current.0 = q.object.clone();
            current.1.clear();
        }
        if current.1 != q.material {
            writeln!(obj, "usemtl {}", q.material).unwrap();
            current.1 = q.material.clone();
        }
        for c in &q.corners {
            writeln!(obj, "v {} {} {}", c[0], c[1], c[2]).unwrap();
        }
        let base = 4 * k + 1;
        writeln!(obj, "f {} {} {} {}", base, base + 1, base + 2, base + 3).unwrap();
    }
    std::fs::write(dir.join(format!("{name}.mtl")), mtl).unwrap();
    let path = dir.join(format!("{name}.obj"));
    std::fs::write(&path, obj).unwrap();
    path
}

/// A unit icosphere: the icosahedron with every triangle split in four `subdivisions` times,
/// new corners pushed onto the sphere. Triangles are counter-clockwise seen from outside.
pub fn icosphere(subdivisions: usize) -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let unit = |p: [f64; 3]| {
        let l = dot(p, p).sqrt();
        [p[0] / l, p[1] / l, p[2] / l]
    };
    let mut v: Vec<[f64; 3]> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(unit)
    .to_vec();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::HashMap::new();
        let mut split = |a: usize, b: usize, v: &mut Vec<[f64; 3]>| -> usize {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (v[a], v[b]);
                v.push(unit([
                    (p[0] + q[0]) / 2.0,
                    (p[1] + q[1]) / 2.0,
                    (p[2] + q[2]) / 2.0,
                ]));
                v.len() - 1
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (
                split(a, b, &mut v),
                split(b, c, &mut v),
                split(c, a, &mut v),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}

/// The six outward-facing faces of the cube `[lo, hi]³`, object `object`, material `material`:
/// a floating blocker inside a room.
pub fn floating_cube(lo: f64, hi: f64, object: &str, material: &str) -> Vec<Quad> {
    block([lo; 3], [hi; 3], object, material)
}

/// The six outward-facing faces of the box from `lo` to `hi` (one quad each): a block, which
/// may rest on a floor (`lo[1] = 0` in [`closed_box`]) or stand against a wall.
pub fn block(lo: [f64; 3], hi: [f64; 3], object: &str, material: &str) -> Vec<Quad> {
    let mid: Vec<f64> = (0..3).map(|k| (lo[k] + hi[k]) / 2.0).collect();
    let mut quads = Vec::new();
    for axis in 0..3 {
        for (value, out) in [(lo[axis], -1.0), (hi[axis], 1.0)] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f64, b: f64| {
                let mut p = [0.0; 3];
                p[axis] = value;
                p[u] = a;
                p[v] = b;
                p
            };
            let mut towards = [mid[0], mid[1], mid[2]];
            towards[axis] = value + out * (hi[axis] - lo[axis]);
            quads.push(Quad::facing(
                object,
                material,
                [
                    corner(lo[u], lo[v]),
                    corner(hi[u], lo[v]),
                    corner(hi[u], hi[v]),
                    corner(lo[u], hi[v]),
                ],
                towards,
            ));
        }
    }
    quads
}

/// Two rooms under one floor slab and one ceiling slab, each slab a single block whose faces
/// run under and over the wall between the rooms; room A has a window, room B none. A box
/// stands in each room.
pub fn rooms_under_one_slab(dir: &Path) -> PathBuf {
    let (t, top) = (0.3, 2.6);
    let mut quads = Vec::new();
    let mut add =
        |lo: [f64; 3], hi: [f64; 3], name: &str| quads.extend(block(lo, hi, name, "grey"));
    add([0.0, -t, 0.0], [10.0, 0.0, 6.0], "floor");
    add([0.0, top, 0.0], [10.0, top + t, 6.0], "ceiling");
    add([0.0, 0.0, 5.7], [10.0, top, 6.0], "wall_n");
    add([0.0, 0.0, 0.3], [0.3, top, 5.7], "wall_w");
    add([9.7, 0.0, 0.3], [10.0, top, 5.7], "wall_e");
    // The south wall round a window into room A (x 1.5–3.5, y 0.8–2.2).
    add([0.0, 0.0, 0.0], [1.5, top, 0.3], "wall_s");
    add([3.5, 0.0, 0.0], [10.0, top, 0.3], "wall_s");
    add([1.5, 0.0, 0.0], [3.5, 0.8, 0.3], "wall_s");
    add([1.5, 2.2, 0.0], [3.5, top, 0.3], "wall_s");
    // Inside a 2 m cell of the grid from the scene's corner (x 6–8).
    add([6.2, 0.0, 0.3], [6.4, top, 5.7], "inner");
    add([2.2, 0.8, 2.7], [2.8, 1.4, 3.3], "box_a");
    add([7.7, 0.8, 2.7], [8.3, 1.4, 3.3], "box_b");
    let mats = [Material::new("grey", [0.6; 3], [0.0; 3])];
    write_scene(dir, "rooms", &quads, &mats)
}
