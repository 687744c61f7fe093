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
