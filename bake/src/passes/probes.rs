//! Light probes (`bake --probes`, `radiosity_core::Probes`): where they go and what each
//! stores. Their frame and the irradiance a point takes from them are the runtime's
//! (`radiosity_runtime::probes`).
//!
//! Placement: `auto` lays a cubic lattice of about [`AUTO_PROBES`] probes over the bounding box
//! of the scene's mesh, `SPACING` a lattice of that step, `FILE.json`
//! (`{"probes": [[x, y, z], …]}`) the given points. A probe whose rays mostly meet the backs of
//! faces lies inside a solid object and is dropped.
//!
//! Weights: [`RAYS`] rays over the sphere, stratified; each ray's first front face gives its
//! direction's share `(4π/RAYS)·Y_lm(ω)/π` to the patches around the hit, with the same kernel
//! `render` interpolates with (`PatchGrid`), so a probe sees a patch where an image shows it.
//! Stored as binary16 (`radiosity_core::probes` says why not as block codes).
//!
//! Interpolation: a point takes the probes of its lattice cell that it sees (a segment from the
//! point to the probe clear of the mesh), each with its trilinear (tent) weight times
//! `FACING_FLOOR + ((1 + n·ω)/2)²`, more towards probes in front of its surface. A probe behind
//! a wall is out of sight, so light does not come through a wall from the next room. Where no
//! probe of the cell is in sight, a tent twice as wide; no probe there either: "outside the
//! probe grid".

use super::Pass;
use crate::BakeError;
use crate::hooks::Hooks;
use crate::report::{BakeReport, ProbeReport};
use crate::rng::SplitMix64;
use glam::{DVec3, Vec3};
use radiosity_core::{ProbeFactors, ProbeWeight, Probes, SH_COEFFICIENTS, probes::sh_basis};
use radiosity_runtime::BakedScene;
use radiosity_runtime::render::{PatchGrid, triangle_normal};
use rayon::prelude::*;
use serde::Deserialize;
use std::borrow::Cow;
use std::path::Path;

/// A probe error: the message alone (it names the flag or file).
fn refuse<T>(message: String) -> Result<T, BakeError> {
    Err(BakeError::Flag(message))
}

/// Rays a probe: 64 × 64 strata over the sphere.
pub const RAYS: usize = 64 * 64;
/// Probes `auto` aims at over the scene's bounding box, before those inside solids are
/// dropped: eight a side of a cube (docs/decisions/probe-interpolation.md weighs 64 to 913,
/// docs/decisions/probe-factors.md what factoring makes affordable).
pub const AUTO_PROBES: f64 = 512.0;
/// Where probes go.
#[derive(Clone, Debug, PartialEq)]
pub enum ProbeSpec {
    /// No probes.
    None,
    /// A lattice of about `AUTO_PROBES` probes over the mesh's bounds.
    Auto,
    /// A lattice of this step, in scene units.
    Spacing(f64),
    /// These points.
    Points(Vec<DVec3>),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProbesFile {
    probes: Vec<[f64; 3]>,
}

impl ProbeSpec {
    /// Parses `--probes`: `auto`, `none`, a spacing in scene units, or a JSON file of points.
    pub fn parse(s: &str) -> Result<ProbeSpec, BakeError> {
        match s {
            "none" => return Ok(Self::None),
            "auto" => return Ok(ProbeSpec::Auto),
            _ => {}
        }
        if let Ok(h) = s.parse::<f64>() {
            if !(h.is_finite() && h > 0.0) {
                return refuse(format!(
                    "--probes spacing must be positive and finite, not {s}"
                ));
            }
            return Ok(ProbeSpec::Spacing(h));
        }
        let path = Path::new(s);
        let text = std::fs::read_to_string(path).map_err(|e| {
            BakeError::Flag(format!(
                "--probes {s}: not auto, none or a spacing, and cannot read it as a file: {e}"
            ))
        })?;
        let file: ProbesFile = serde_json::from_str(&text).map_err(|e| {
            BakeError::Flag(format!(
                "bad probes file {s}: not {{\"probes\": [[x, y, z], …]}}: {e}"
            ))
        })?;
        let points: Vec<DVec3> = file.probes.iter().map(|p| DVec3::from(*p)).collect();
        if let Some(i) = points.iter().position(|p| !p.is_finite()) {
            return refuse(format!("bad probes file {s}: probe {i} is not finite"));
        }
        Ok(ProbeSpec::Points(points))
    }
}

fn bounds(rt: &BakedScene) -> Result<(DVec3, DVec3), BakeError> {
    rt.mesh("probes")
        .map_err(|e| BakeError::Flag(e.to_string()))?;
    rt.mesh_bounds()
        .ok_or_else(|| BakeError::Flag("probes need a mesh with vertices".into()))
}

/// A lattice of step `h` over `[lo, hi]`, centred on the box (two layers across a flat axis):
/// `round(size/h)` probes an axis
/// (at least one), so the outermost lie between a quarter and three quarters of a step inside
/// the bounds (a scene's walls are on its bounds, and a probe on a wall sees nothing right).
/// The step is `h` on every axis, so a point between probes takes trilinear weights.
fn grid(lo: DVec3, hi: DVec3, h: f64) -> Result<Vec<DVec3>, BakeError> {
    // An axis along which the scene is flat (a sheet, a ground: under a thousandth of a step)
    // gets two layers, half a step either side of it, not one in its plane.
    let flat = (hi - lo).cmplt(DVec3::splat(1e-3 * h));
    let cells = DVec3::select(
        flat,
        DVec3::splat(2.0),
        ((hi - lo) / h).round().max(DVec3::ONE),
    );
    let count = cells.x * cells.y * cells.z;
    if count > 1e6 {
        return refuse(format!(
            "--probes spacing {h} gives {count:.0} probes over the scene (at most 1 000 000)"
        ));
    }
    let (nx, ny, nz) = (cells.x as usize, cells.y as usize, cells.z as usize);
    let first = (lo + hi) / 2.0 - (cells - DVec3::ONE) * (h / 2.0);
    let mut out = Vec::with_capacity(nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                out.push(first + h * DVec3::new(i as f64, j as f64, k as f64));
            }
        }
    }
    Ok(out)
}

/// The step of `auto`'s lattice over a box of `size`: about [`AUTO_PROBES`] cells over the axes
/// that have extent (at least a thousandth of the largest); a flat scene (a sheet, a ground)
/// gets its probes in one layer, a line of them along a thin one.
fn auto_spacing(size: DVec3) -> f64 {
    let largest = size.max_element().max(f64::MIN_POSITIVE);
    let axes: Vec<f64> = size
        .to_array()
        .into_iter()
        .filter(|&s| s >= 1e-3 * largest)
        .collect();
    let measure: f64 = axes.iter().product();
    (measure / AUTO_PROBES).powf(1.0 / axes.len() as f64)
}

/// A uniform direction on the sphere from `(u1, u2)` in [0, 1)².
fn sphere_direction(u1: f64, u2: f64) -> DVec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// One probe's weights, or `None` when most of its rays meet back faces (inside a solid).
fn weigh(rt: &BakedScene, grid: &PatchGrid, at: DVec3, seed: u64) -> Option<Vec<ProbeWeight>> {
    let mesh = rt.mesh("probes").expect("checked by the caller");
    let occ = rt.occluders().expect("a mesh has a BVH");
    let side = (RAYS as f64).sqrt() as usize;
    let mut rng = SplitMix64(seed);
    let mut acc: std::collections::BTreeMap<u32, [f64; SH_COEFFICIENTS]> = Default::default();
    let mut backs = 0usize;
    let mut weights = Vec::new();
    let share = 4.0 / RAYS as f64; // (4π / RAYS) / π
    for s in 0..side * side {
        let u1 = ((s % side) as f64 + rng.next_f64()) / side as f64;
        let u2 = ((s / side) as f64 + rng.next_f64()) / side as f64;
        let dir = sphere_direction(u1, u2);
        let Some((hit, front)) = occ.first_surface(at, dir, 0.0, f64::INFINITY) else {
            continue;
        };
        if !front {
            backs += 1;
            continue;
        }
        let t = hit.triangle as usize;
        let normal = triangle_normal(mesh, t);
        let p = at + dir * hit.distance;
        weights.clear();
        let uv = (hit.u, hit.v);
        grid.weights_at_hit(&rt.file.patches, mesh, t, uv, p, normal, None, &mut weights);
        let y = sh_basis(dir.as_vec3().to_array());
        for &(patch, w) in &weights {
            let e = acc.entry(patch).or_insert([0.0; SH_COEFFICIENTS]);
            for k in 0..SH_COEFFICIENTS {
                e[k] += share * f64::from(w) * f64::from(y[k]);
            }
        }
    }
    if backs * 2 > side * side {
        return None;
    }
    Some(
        acc.into_iter()
            .map(|(patch, sh)| ProbeWeight::new(patch, sh.map(|v| v as f32)))
            .collect(),
    )
}

/// Places and weighs the probes of `spec` over the runtime's file (which needs its mesh).
pub fn bake(
    rt: &BakedScene,
    spec: &ProbeSpec,
    rank: ProbeRank,
    hooks: Hooks<'_>,
) -> Result<Option<(Probes<'static>, ProbeReport)>, BakeError> {
    let t = std::time::Instant::now();
    let (candidates, spacing) = match spec {
        ProbeSpec::None => return Ok(None),
        ProbeSpec::Points(p) => (p.clone(), None),
        ProbeSpec::Auto | ProbeSpec::Spacing(_) => {
            let (lo, hi) = bounds(rt)?;
            let h = match spec {
                ProbeSpec::Spacing(h) => *h,
                _ => auto_spacing(hi - lo),
            };
            (grid(lo, hi, h)?, Some(h))
        }
    };
    rt.mesh("--probes")
        .map_err(|e| BakeError::Flag(e.to_string()))?;
    let patch_grid = PatchGrid::new(&rt.file.patches);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let rows: Vec<Option<Vec<ProbeWeight>>> = candidates
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            if hooks.cancelled() {
                return None;
            }
            let row = weigh(rt, &patch_grid, p, 0x9e37_79b9 ^ i as u64);
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            hooks.report(d, candidates.len());
            row
        })
        .collect();
    hooks.check()?;
    let mut positions = Vec::new();
    let mut kept = Vec::new();
    for (p, row) in candidates.iter().zip(rows) {
        if let Some(r) = row {
            positions.push(p.as_vec3().to_array());
            kept.push(r);
        }
    }
    let dropped = candidates.len() - kept.len();
    let found: usize = kept.iter().map(Vec::len).sum();
    let n = rt.file.patches.len();
    let factors = match rank {
        ProbeRank::Full => None,
        // Factors where their frame is cheaper than the rows'.
        ProbeRank::Auto
            if auto_rank(n) * (n + SH_COEFFICIENTS * kept.len()) >= SH_COEFFICIENTS * found =>
        {
            None
        }
        ProbeRank::Auto => factor(&kept, n, auto_rank(n)),
        ProbeRank::Rank(k) => factor(&kept, n, k),
    };
    let (starts, weights) = if factors.is_some() {
        (vec![0u32; kept.len() + 1], Vec::new())
    } else {
        let mut starts = vec![0u32];
        let mut weights = Vec::with_capacity(found);
        for r in kept {
            weights.extend(r);
            starts.push(weights.len() as u32);
        }
        (starts, weights)
    };
    let spacing = spacing.unwrap_or_else(|| {
        let pos: Vec<DVec3> = positions
            .iter()
            .map(|p| Vec3::from(*p).as_dvec3())
            .collect();
        let size = bounds(rt).map_or(1.0, |(lo, hi)| (hi - lo).max_element());
        median_spacing(&pos, size)
    });
    let probes = Probes {
        spacing: spacing as f32,
        positions: Cow::Owned(positions),
        rows: Cow::Owned(starts),
        weights: Cow::Owned(weights),
        factors,
    };
    let report = ProbeReport {
        placed: probes.len(),
        dropped_inside: dropped,
        weights: found,
        rank: probes.factors.as_ref().map(|f| f.rank as usize),
        bytes: probes.to_bytes().len(),
        spacing,
        seconds: t.elapsed().as_secs_f64(),
    };
    Ok(Some((probes, report)))
}

/// The median distance from a probe to its nearest neighbour, over at most 1024 of them
/// (evenly picked), for scattered probes; `alone` (the scene's size) for fewer than two.
fn median_spacing(pos: &[DVec3], alone: f64) -> f64 {
    let stride = pos.len().div_ceil(1024).max(1);
    let mut nearest: Vec<f64> = (0..pos.len())
        .step_by(stride)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&i| {
            pos.iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, b)| pos[i].distance(*b))
                .fold(f64::INFINITY, f64::min)
        })
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    nearest.sort_by(f64::total_cmp);
    nearest
        .get(nearest.len() / 2)
        .copied()
        .unwrap_or(alone.max(1e-9))
}

/// What `bake --probe-rank` keeps of the probes' weights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeRank {
    /// [`auto_rank`], or rows of weights where those cost no more a frame.
    Auto,
    /// Rows of weights, every one the rays found.
    Full,
    /// Factors of this rank (at most the smaller side of `P`).
    Rank(usize),
}

/// The rank `auto` factors the probes' weights to over `patches` patches: a sixteenth of them,
/// from 128 to 512 (468 probes in the Cornell box meet the bounds at rank 128 over
/// 1008 patches and at 256 over 4098, not at 128: docs/decisions/probe-factors.md).
pub(crate) fn auto_rank(patches: usize) -> usize {
    (patches / 16).clamp(128, 512)
}

/// Columns the randomized factoring samples beyond the rank (docs/decisions/probe-factors.md).
const OVERSAMPLE: usize = 64;

impl ProbeRank {
    /// Parses `--probe-rank`: `auto`, `full` or a positive integer.
    pub fn parse(s: &str) -> Result<Self, BakeError> {
        match s {
            "auto" => Ok(ProbeRank::Auto),
            "full" => Ok(ProbeRank::Full),
            _ => match s.parse::<usize>() {
                Ok(k) if k > 0 => Ok(ProbeRank::Rank(k)),
                _ => refuse(format!(
                    "--probe-rank must be auto, full or a positive integer, not {s}"
                )),
            },
        }
    }
}

/// The irradiance weight of each SH band (`sh_irradiance`'s `Â_l`): the factors minimise the
/// error of what a normal receives, not of the radiance's coefficients.
const BAND: [f64; SH_COEFFICIENTS] = [
    std::f64::consts::PI,
    2.0 * std::f64::consts::PI / 3.0,
    2.0 * std::f64::consts::PI / 3.0,
    2.0 * std::f64::consts::PI / 3.0,
    std::f64::consts::PI / 4.0,
    std::f64::consts::PI / 4.0,
    std::f64::consts::PI / 4.0,
    std::f64::consts::PI / 4.0,
    std::f64::consts::PI / 4.0,
];

/// `A` = the probes' weights, one row per probe and SH coefficient (scaled by [`BAND`]), as
/// sparse rows of `(patch, value)`. Its products take and give row-major `l`-column
/// matrices, so each weight's inner loop runs over contiguous columns.
struct Weights<'a> {
    rows: &'a [Vec<ProbeWeight>],
    patches: usize,
}

impl Weights<'_> {
    fn height(&self) -> usize {
        SH_COEFFICIENTS * self.rows.len()
    }

    /// The band-scaled coefficients of a weight.
    fn scaled(w: &ProbeWeight) -> [f64; SH_COEFFICIENTS] {
        let sh = w.sh();
        std::array::from_fn(|c| BAND[c] * f64::from(sh[c]))
    }

    /// `A·X` for `X` of `patches` rows of `l`.
    fn times(&self, x: &[f64], l: usize) -> Vec<f64> {
        let mut out = vec![0.0; self.height() * l];
        out.par_chunks_mut(SH_COEFFICIENTS * l)
            .zip(self.rows)
            .for_each(|(out, row)| {
                for w in row {
                    let sh = Self::scaled(w);
                    let xr = &x[w.patch as usize * l..][..l];
                    for (c, o) in out.chunks_exact_mut(l).enumerate() {
                        for (o, x) in o.iter_mut().zip(xr) {
                            *o += sh[c] * x;
                        }
                    }
                }
            });
        out
    }

    /// `Aᵀ·Y` for `Y` of `height` rows of `l`: each thread's share of the probes into its own
    /// matrix, then the sum.
    fn transposed_times(&self, y: &[f64], l: usize) -> Vec<f64> {
        let n = self.patches;
        let per = self
            .rows
            .len()
            .div_ceil(rayon::current_num_threads())
            .max(1);
        let parts: Vec<Vec<f64>> = self
            .rows
            .par_chunks(per)
            .enumerate()
            .map(|(chunk, rows)| {
                let mut out = vec![0.0; n * l];
                for (i, row) in rows.iter().enumerate() {
                    let p = chunk * per + i;
                    let yp = &y[SH_COEFFICIENTS * p * l..][..SH_COEFFICIENTS * l];
                    for w in row {
                        let sh = Self::scaled(w);
                        let o = &mut out[w.patch as usize * l..][..l];
                        for (c, yc) in yp.chunks_exact(l).enumerate() {
                            for (o, y) in o.iter_mut().zip(yc) {
                                *o += sh[c] * y;
                            }
                        }
                    }
                }
                out
            })
            .collect();
        let mut parts = parts.into_iter();
        let mut sum = parts.next().unwrap_or_else(|| vec![0.0; n * l]);
        for part in parts {
            for (a, b) in sum.iter_mut().zip(&part) {
                *a += b;
            }
        }
        sum
    }
}

/// A row-major `rows × l` matrix as faer's.
fn to_mat(v: &[f64], rows: usize, l: usize) -> faer::Mat<f64> {
    faer::Mat::from_fn(rows, l, |r, c| v[r * l + c])
}

/// A faer matrix as a row-major one.
fn from_mat(m: faer::MatRef<'_, f64>) -> Vec<f64> {
    let (rows, l) = (m.nrows(), m.ncols());
    let mut out = vec![0.0; rows * l];
    for c in 0..l {
        for r in 0..rows {
            out[r * l + c] = m[(r, c)];
        }
    }
    out
}

/// An orthonormal basis of `y`'s columns (thin QR, faer).
fn orthonormal(y: &[f64], rows: usize, l: usize) -> Vec<f64> {
    from_mat(to_mat(y, rows, l).qr().compute_thin_Q().as_ref())
}

/// The probes' weights `rows` over `patches` as factors of rank `k`: randomized subspace
/// iteration (Halko, Martinsson & Tropp 2011, "Finding structure with randomness",
/// algorithm 4.4: `k + 64` columns, two power iterations), then the SVD of the small
/// projected matrix (faer). `None` when `k` reaches the smaller side of `P` (nothing to gain)
/// or the SVD does not converge.
fn factor(rows: &[Vec<ProbeWeight>], patches: usize, k: usize) -> Option<ProbeFactors<'static>> {
    let a = Weights { rows, patches };
    let height = a.height();
    if k >= height.min(patches) {
        return None;
    }
    let l = (k + OVERSAMPLE).min(height).min(patches);
    let mut rng = SplitMix64(0x5eed_f00d);
    let omega: Vec<f64> = (0..patches * l)
        .map(|_| {
            // Box–Muller: a standard normal.
            let (u1, u2) = (1.0 - rng.next_f64(), rng.next_f64());
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        })
        .collect();
    let mut q = orthonormal(&a.times(&omega, l), height, l);
    for _ in 0..2 {
        let z = orthonormal(&a.transposed_times(&q, l), patches, l);
        q = orthonormal(&a.times(&z, l), height, l);
    }
    // B = Qᵀ·A, as its transpose Aᵀ·Q (patches × l); Bᵀ = V·Σ·Ũᵀ.
    let bt = to_mat(&a.transposed_times(&q, l), patches, l);
    let svd = bt.thin_svd().ok()?;
    let (v, sigma, u) = (svd.U(), svd.S().column_vector(), svd.V());
    let q = to_mat(&q, height, l);
    // C = Q·Ũ_k·Σ_k, unscaled by the bands; V_k ᵀ as the basis.
    let mut coefficients = vec![0u16; height * k];
    let qu = &q * u.subcols(0, k);
    for r in 0..height {
        for col in 0..k {
            let c = qu[(r, col)] * sigma[col] / BAND[r % SH_COEFFICIENTS];
            coefficients[r * k + col] = radiosity_core::half::f32_to_f16(c as f32);
        }
    }
    let mut basis = vec![0u16; k * patches];
    for col in 0..k {
        for j in 0..patches {
            basis[col * patches + j] = radiosity_core::half::f32_to_f16(v[(j, col)] as f32);
        }
    }
    Some(ProbeFactors {
        rank: k as u32,
        basis: Cow::Owned(basis),
        coefficients: Cow::Owned(coefficients),
    })
}

/// The probes pass: places and weighs the probes of `spec` in a bake's file, and records
/// them in the report (its `probes`, the PROBES section's bytes and the `probes` and `total`
/// timings). Nothing for [`ProbeSpec::None`].
pub struct ProbesPass {
    /// Where probes go.
    pub spec: ProbeSpec,
    /// How their weights are stored.
    pub rank: ProbeRank,
}

impl Pass for ProbesPass {
    fn run(
        &self,
        rt: &mut BakedScene,
        report: &mut BakeReport,
        hooks: Hooks<'_>,
    ) -> Result<(), BakeError> {
        if self.spec == ProbeSpec::None {
            return Ok(());
        }
        hooks.start("probes")?;
        let t = std::time::Instant::now();
        if let Some((probes, r)) = bake(rt, &self.spec, self.rank, hooks)? {
            rt.file.probes = Some(probes);
            report.bytes.probes = r.bytes;
            report.probes = Some(r);
        }
        let ms = t.elapsed().as_secs_f64() * 1e3;
        report.timings_ms.insert("probes", ms);
        *report.timings_ms.entry("total").or_insert(0.0) += ms;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn auto_spacing_of_a_flat_scene_is_one_layer() {
        use super::{AUTO_PROBES, auto_spacing};
        use glam::DVec3;
        let cube = auto_spacing(DVec3::splat(8.0));
        assert!((cube - 8.0 / AUTO_PROBES.cbrt()).abs() < 1e-12);
        // A 10 × 10 sheet: 512 probes over its area, not 512³ over a hair of thickness.
        let sheet = auto_spacing(DVec3::new(10.0, 0.0, 10.0));
        assert!(
            (sheet - (100.0 / AUTO_PROBES).sqrt()).abs() < 1e-12,
            "{sheet}"
        );
        let line = auto_spacing(DVec3::new(0.0, 0.0, 4.0));
        assert!((line - 4.0 / AUTO_PROBES).abs() < 1e-12, "{line}");
    }

    use super::*;

    #[test]
    fn factors_of_a_rank_three_matrix_give_it_back() {
        // 20 probes over 50 patches whose weights are a sum of three products.
        let (m, n) = (20usize, 50usize);
        let a = |p: usize, c: usize, q: usize| ((p * 7 + c * 3 + q * 5) % 11) as f32 / 11.0 - 0.4;
        let b = |q: usize, j: usize| ((j * 13 + q * 17) % 19) as f32 / 19.0;
        let exact = |p: usize, j: usize| -> [f32; SH_COEFFICIENTS] {
            std::array::from_fn(|c| (0..3).map(|q| a(p, c, q) * b(q, j)).sum())
        };
        let rows: Vec<Vec<ProbeWeight>> = (0..m)
            .map(|p| {
                (0..n)
                    .map(|j| ProbeWeight::new(j as u32, exact(p, j)))
                    .collect()
            })
            .collect();
        let factors = factor(&rows, n, 3).expect("rank 3 of a 180 × 50 matrix");
        let probes = Probes {
            spacing: 1.0,
            positions: Cow::Owned(vec![[0.0; 3]; m]),
            rows: Cow::Owned(vec![0; m + 1]),
            weights: Cow::Owned(Vec::new()),
            factors: Some(factors),
        };
        probes.validate(n).unwrap();
        let back = probes.to_rows();
        for p in 0..m {
            for (w, want) in back.weights_of(p).iter().zip(&rows[p]) {
                for (x, y) in w.sh().iter().zip(want.sh()) {
                    // The weights reach 1.8 in size; binary16 factors of rank 3 round each of
                    // three products to a relative 2⁻¹¹, and the result once more.
                    assert!((x - y).abs() <= 4.0 * 1.8 * 2f32.powi(-11), "{x} {y}");
                }
            }
        }
        // Nothing to gain at the matrix's smaller side.
        assert!(factor(&rows, n, 50).is_none());
    }
}
