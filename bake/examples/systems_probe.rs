//! The systems probe of `docs/decisions/systems.md` (sections 1 and 2): form factors of a
//! level (exact pairs, or ray-cast rows with `cast`), their non-zeros, the exchange crossing a
//! k-d cut into systems and what truncating it drops, and (with `iterate`) block Jacobi and
//! Gauss–Seidel frames after a sun jump against the one-matrix steady state.
//!
//!     python3 scripts/city.py /tmp/city
//!     cargo run --release -p radiosity-bake --example systems_probe -- /tmp/city/city.obj 8192 8 iterate [cast]
use radiosity_bake::form_factor::{FormFactorParams, form_factors};
use radiosity_bake::patch::Patches;
use radiosity_bake::scene::Scene;
use radiosity_bake::simplify::{VoxelParams, simplify};
use std::time::Instant;

fn kd(c: &[[f64; 3]], idx: &mut [usize], parts: usize, out: &mut [usize], next: &mut usize) {
    if parts <= 1 {
        for &i in idx.iter() {
            out[i] = *next;
        }
        *next += 1;
        return;
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in idx.iter() {
        for k in 0..3 {
            lo[k] = lo[k].min(c[i][k]);
            hi[k] = hi[k].max(c[i][k]);
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap();
    idx.sort_by(|&a, &b| c[a][axis].total_cmp(&c[b][axis]));
    let left = parts / 2;
    let m = idx.len() * left / parts;
    let (a, b) = idx.split_at_mut(m);
    kd(c, a, left, out, next);
    kd(c, b, parts - left, out, next);
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = Scene::load(std::path::Path::new(&a[1])).unwrap();
    let want: usize = a[2].parse().unwrap();
    let systems: usize = a[3].parse().unwrap();
    let iterate = a.get(4).is_some_and(|s| s == "iterate");
    let mut params = FormFactorParams::default();
    if a.get(5).is_some_and(|s| s == "cast") {
        params.exact_pieces = 0;
    }
    let t = Instant::now();
    let patches = simplify(&scene, &VoxelParams::with_patches(want)).unwrap();
    let n = patches.len();
    eprintln!("simplify: {n} patches, {:.1} s", t.elapsed().as_secs_f64());
    let (f, nnz) = form_factor_matrix(&scene, &patches, &params);
    let area: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    let sys = cut(&patches, &f, &area, systems, nnz);
    if !iterate {
        return;
    }
    let level = Level {
        n,
        f: &f,
        area: &area,
        sys: &sys,
        rho: patches
            .patches
            .iter()
            .map(|p| f64::from(p.reflectance.g))
            .collect(),
    };
    level.sun_jump(&patches, systems);
}

/// The form factors of `patches` (row-major, `n × n`), timed, and their non-zeros.
fn form_factor_matrix(
    scene: &Scene,
    patches: &Patches,
    params: &FormFactorParams,
) -> (Vec<f32>, usize) {
    let n = patches.len();
    let occ = scene.occluders();
    let t = Instant::now();
    let ff = form_factors(patches, Some(&occ), params, None);
    eprintln!(
        "form factors: {:.1} s, {} rays",
        t.elapsed().as_secs_f64(),
        ff.rays_cast
    );
    let f = ff.matrix;
    let nnz = f.iter().filter(|&&v| v > 0.0).count();
    eprintln!(
        "nnz {nnz} ({:.2}% of n², {:.0} a row)",
        100.0 * nnz as f64 / (n * n) as f64,
        nnz as f64 / n as f64
    );
    (f, nnz)
}

/// The k-d cut of `patches` into `systems` by their centres: each patch's system, after
/// the exchange (`A_i F_ij`, `nnz` non-zeros in `f`) crossing the cut and what truncating
/// it at a few thresholds drops.
fn cut(patches: &Patches, f: &[f32], area: &[f64], systems: usize, nnz: usize) -> Vec<usize> {
    let n = patches.len();
    let centres: Vec<[f64; 3]> = patches
        .patches
        .iter()
        .map(|p| p.centre.to_array())
        .collect();
    let mut sys = vec![0usize; n];
    let mut idx: Vec<usize> = (0..n).collect();
    let mut next = 0;
    kd(&centres, &mut idx, systems, &mut sys, &mut next);
    let (mut total, mut cross, mut cross_nnz) = (0.0, 0.0, 0usize);
    for i in 0..n {
        for j in 0..n {
            let v = f64::from(f[i * n + j]);
            if v > 0.0 {
                total += area[i] * v;
                if sys[i] != sys[j] {
                    cross += area[i] * v;
                    cross_nnz += 1;
                }
            }
        }
    }
    eprintln!(
        "{systems} systems: cross energy {:.2}% of the exchange, cross nnz {cross_nnz} ({:.1}% of nnz)",
        100.0 * cross / total,
        100.0 * cross_nnz as f64 / nnz as f64
    );
    for tau in [1e-4f32, 1e-3, 1e-2] {
        let (mut kept, mut kept_nnz) = (0.0, 0usize);
        for i in 0..n {
            for j in 0..n {
                let v = f[i * n + j];
                if sys[i] != sys[j] && v >= tau {
                    kept += area[i] * f64::from(v);
                    kept_nnz += 1;
                }
            }
        }
        eprintln!(
            "  cross entries ≥ {tau}: {kept_nnz}, energy dropped {:.3}% of the exchange",
            100.0 * (cross - kept) / total
        );
    }
    sys
}

/// A level cut into systems, as the frames after a sun jump iterate it.
struct Level<'a> {
    n: usize,
    /// Form factors, row-major.
    f: &'a [f32],
    area: &'a [f64],
    /// Each patch's system.
    sys: &'a [usize],
    /// Each patch's reflectance (green).
    rho: Vec<f64>,
}

impl Level<'_> {
    /// Frames after a sun jump: steady state for sun A, then sun B; block Jacobi (one outer
    /// iteration a frame, each system solved exactly by inner Gauss–Seidel sweeps), then block
    /// Gauss–Seidel, each frame's error against the steady state for sun B.
    fn sun_jump(&self, patches: &Patches, systems: usize) {
        let (n, rho, sys) = (self.n, &self.rho, self.sys);
        let members: Vec<Vec<usize>> = (0..systems)
            .map(|s| (0..n).filter(|&i| sys[i] == s).collect())
            .collect();
        let sun_a = [0.3f64, -0.8, 0.52];
        let sun_b = [-0.6f64, -0.5, -0.62];
        let hda = direct(patches, sun_a);
        let hdb = direct(patches, sun_b);
        let xa: Vec<f64> = (0..n).map(|i| rho[i] * hda[i]).collect();
        let xb: Vec<f64> = (0..n).map(|i| rho[i] * hdb[i]).collect();
        let t = Instant::now();
        let ya = self.solve_full(&xa);
        let yb = self.solve_full(&xb);
        eprintln!("full solves {:.1} s", t.elapsed().as_secs_f64());
        let hb: Vec<f64> = (0..n).map(|i| hdb[i] + yb[i]).collect();
        for gauss_seidel in [false, true] {
            let mut y = ya.clone();
            let mut line = String::new();
            for _frame in 0..8 {
                self.frame(&members, gauss_seidel, &xb, &mut y);
                let h: Vec<f64> = (0..n).map(|i| hdb[i] + y[i]).collect();
                line += &format!(" {:.3}%", 100.0 * self.err(&h, &hb));
            }
            eprintln!(
                "{}: error after frames 1..8:{line}",
                if gauss_seidel {
                    "Gauss–Seidel"
                } else {
                    "Jacobi"
                }
            );
        }
    }

    /// The indirect light of direct light `x` on the one matrix: 200 Gauss–Seidel sweeps.
    fn solve_full(&self, x: &[f64]) -> Vec<f64> {
        let (n, f, rho) = (self.n, self.f, &self.rho);
        let mut y = vec![0.0; n];
        for _ in 0..200 {
            for i in 0..n {
                let row = &f[i * n..(i + 1) * n];
                let mut s = 0.0;
                for j in 0..n {
                    s += f64::from(row[j]) * (x[j] + rho[j] * y[j]);
                }
                y[i] = s;
            }
        }
        y
    }

    /// One frame's outer iteration over the systems (`members`) of the indirect light `y` of
    /// direct light `xb`: each system solved exactly against the others' exitance from the
    /// frame before (Jacobi), or as updated by the systems before it (`gauss_seidel`).
    fn frame(&self, members: &[Vec<usize>], gauss_seidel: bool, xb: &[f64], y: &mut [f64]) {
        let (n, f, rho, sys) = (self.n, self.f, &self.rho, self.sys);
        let b_prev: Vec<f64> = (0..n).map(|i| xb[i] + rho[i] * y[i]).collect();
        let mut b_now = b_prev.clone();
        for (s, m) in members.iter().enumerate() {
            let src = if gauss_seidel { &b_now } else { &b_prev };
            // g_s from the other systems' exitance.
            let g: Vec<f64> = m
                .iter()
                .map(|&i| {
                    let row = &f[i * n..(i + 1) * n];
                    (0..n)
                        .filter(|&j| sys[j] != s)
                        .map(|j| f64::from(row[j]) * src[j])
                        .sum()
                })
                .collect();
            // Inner: y_s = g_s + F_ss (x_s + C_s y_s), to convergence.
            for _ in 0..60 {
                for (k, &i) in m.iter().enumerate() {
                    let row = &f[i * n..(i + 1) * n];
                    let mut v = g[k];
                    for &j in m {
                        v += f64::from(row[j]) * (xb[j] + rho[j] * y[j]);
                    }
                    y[i] = v;
                }
            }
            for &i in m {
                b_now[i] = xb[i] + rho[i] * y[i];
            }
        }
    }

    /// The area-weighted relative error of `h` against `want`.
    fn err(&self, h: &[f64], want: &[f64]) -> f64 {
        let (mut e, mut w) = (0.0, 0.0);
        for i in 0..self.n {
            e += self.area[i] * (h[i] - want[i]).abs();
            w += self.area[i] * want[i];
        }
        e / w
    }
}

/// Each patch's direct light from a sun shining along `dir`: the cosine at its normal.
fn direct(patches: &Patches, dir: [f64; 3]) -> Vec<f64> {
    patches
        .patches
        .iter()
        .map(|p| (-(p.normal.x * dir[0] + p.normal.y * dir[1] + p.normal.z * dir[2])).max(0.0))
        .collect()
}
