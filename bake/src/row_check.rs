//! An independent check of the form factors: rows of F against hemisphere rays.
//!
//! In a scene whose surfaces are all patches, `Σ_j F_ij` is the share of the light leaving
//! patch `i` that lands on some patch: the fraction of cosine-weighted rays from a uniform point
//! of `i` whose first hit is the front face of a patch's triangle. That share is estimated here
//! by casting such rays against the full-detail triangles, with none of the machinery the form
//! factors use (no kernel, no quadrature, no flat sites, no clustering), so the two can be
//! compared row by row. `radiosity check-rows` prints the comparison; a large scene's sampled
//! rows come from [`crate::form_factor::form_factor_rows`] without the whole matrix.
//!
//! Rays start on the surface itself ([`Occluders::closest_hit_from_surface`]: triangles whose
//! planes hold the start are passed through), so two parts modelled a hair apart see each
//! other, and the other sheet of a zero-thickness panel is not met. A ray lifted off the
//! surface by even 1e-6 of the extent stepped over such gaps in the conference room and made
//! the estimate, not the form factors, wrong on a fifth of its rows.
//!
//! The report splits off the rows whose rays mostly meet **back faces** first: patches inside
//! other objects or behind a second layer of their own surface (a chair leg inside its
//! sleeve). What such a patch sees is a question of the model more than of the method; rows
//! with a back-face share of at least [`RowCheckParams::enclosed_share`] are *enclosed*.

use crate::BakeError;
use crate::bvh::Occluders;
use crate::form_factor::{FormFactorParams, Progress, Visibility, form_factor_rows};
use crate::rng::SplitMix64;
use crate::scene::Scene;
use crate::voxel::{Patches, Piece, VoxelParams, simplify};
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Parameters of [`check_rows`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowCheckParams {
    /// Hemisphere rays per row; the share's standard error is at most `0.5 / √rays`.
    pub rays: u32,
    /// Seed of the row sample and of the rays.
    pub seed: u64,
    /// A row whose rays meet back faces first at least this often is *enclosed*.
    pub enclosed_share: f64,
    /// A row sum above this counts as over-full (`Σ_j F_ij ≤ 1` in any scene).
    pub over_full: f64,
}

impl Default for RowCheckParams {
    fn default() -> Self {
        Self {
            rays: 4000,
            seed: 11,
            enclosed_share: 0.3,
            over_full: 1.05,
        }
    }
}

/// One checked row.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RowSample {
    /// Patch index (the simplification's numbering, before dark patches are dropped).
    pub patch: usize,
    /// `Σ_j F_ij` from the form factors.
    pub row_sum: f64,
    /// Share of hemisphere rays whose first hit is the front face of a patch's triangle.
    pub hemisphere: f64,
    /// Standard error of `hemisphere` (binomial).
    pub std_error: f64,
    /// Share of hemisphere rays whose first hit is a back face.
    pub back_faces: f64,
}

impl RowSample {
    /// `row_sum − hemisphere`.
    pub fn difference(&self) -> f64 {
        self.row_sum - self.hemisphere
    }
}

/// Differences over a group of rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RowGroup {
    /// Rows in the group.
    pub rows: usize,
    /// RMS of `row_sum − hemisphere`.
    pub rms: f64,
    /// Mean of `row_sum − hemisphere`.
    pub mean: f64,
    /// The largest `|row_sum − hemisphere|` and its patch.
    pub worst: f64,
    /// Patch of `worst` (`None` for an empty group).
    pub worst_patch: Option<usize>,
    /// RMS of the hemisphere estimates' standard errors: the part of `rms` that is the
    /// estimate's own noise.
    pub noise: f64,
    /// Rows whose sum exceeds [`RowCheckParams::over_full`].
    pub over_full: usize,
}

impl RowGroup {
    fn of<'a>(rows: impl Iterator<Item = &'a RowSample>, over_full: f64) -> Self {
        let mut g = Self::default();
        let (mut sq, mut sum, mut noise) = (0.0, 0.0, 0.0);
        for r in rows {
            let d = r.difference();
            g.rows += 1;
            sq += d * d;
            sum += d;
            noise += r.std_error * r.std_error;
            if g.worst_patch.is_none() || d.abs() > g.worst {
                g.worst = d.abs();
                g.worst_patch = Some(r.patch);
            }
            g.over_full += usize::from(r.row_sum > over_full);
        }
        if g.rows > 0 {
            let m = g.rows as f64;
            (g.rms, g.mean, g.noise) = ((sq / m).sqrt(), sum / m, (noise / m).sqrt());
        }
        g
    }
}

/// The comparison: every row, and the rows grouped.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RowCheck {
    /// Rays per row.
    pub rays: u32,
    /// Rows whose rays meet front faces mostly (back-face share below the threshold).
    pub open: RowGroup,
    /// Rows of patches inside other objects or behind a second layer (module doc).
    pub enclosed: RowGroup,
    /// All rows.
    pub all: RowGroup,
    /// Each row, in the order asked.
    pub samples: Vec<RowSample>,
}

/// `count` distinct patch indices below `n` drawn without replacement (all of them when
/// `count ≥ n`), ascending.
pub fn sample_rows(n: usize, count: usize, seed: u64) -> Vec<usize> {
    let mut all: Vec<usize> = (0..n).collect();
    let mut rng = SplitMix64(seed);
    let k = count.min(n);
    // Partial Fisher–Yates: the first k slots are a uniform sample.
    for i in 0..k {
        let j = i + rng.below((n - i) as u64) as usize;
        all.swap(i, j);
    }
    all.truncate(k);
    all.sort_unstable();
    all
}

/// Which patch a point of a scene triangle belongs to: the piece of that triangle nearest to it.
struct Owners {
    /// `(triangle, piece)` sorted by triangle.
    by_triangle: Vec<(u32, u32)>,
    /// Patch of each piece.
    patch_of: Vec<u32>,
}

impl Owners {
    fn new(patches: &Patches) -> Self {
        let mut patch_of = vec![0u32; patches.pieces.len()];
        for (i, p) in patches.patches.iter().enumerate() {
            patch_of[p.pieces.clone()].fill(i as u32);
        }
        let mut by_triangle: Vec<(u32, u32)> = patches
            .pieces
            .iter()
            .enumerate()
            .map(|(k, p)| (p.triangle, k as u32))
            .collect();
        by_triangle.sort_unstable();
        Self {
            by_triangle,
            patch_of,
        }
    }

    fn patch_at(&self, pieces: &[Piece], triangle: u32, x: DVec3) -> Option<usize> {
        let start = self.by_triangle.partition_point(|e| e.0 < triangle);
        self.by_triangle[start..]
            .iter()
            .take_while(|e| e.0 == triangle)
            .map(|e| {
                let p = &pieces[e.1 as usize];
                let d = crate::polygon::point_polygon_distance(x, p.polygon.vertices(), p.normal);
                (d, e.1)
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, k)| self.patch_of[k as usize] as usize)
    }
}

/// A uniform point of a polygon (fan triangles chosen by area).
fn uniform_point(v: &[DVec3], rng: &mut SplitMix64) -> DVec3 {
    let fan = |k: usize| (v[k] - v[0]).cross(v[k + 1] - v[0]).length();
    let total: f64 = (1..v.len() - 1).map(fan).sum();
    let mut pick = rng.next_f64() * total;
    let mut k = 1;
    while k + 2 < v.len() && pick > fan(k) {
        pick -= fan(k);
        k += 1;
    }
    let (mut a, mut b) = (rng.next_f64(), rng.next_f64());
    if a + b > 1.0 {
        (a, b) = (1.0 - a, 1.0 - b);
    }
    v[0] + (v[k] - v[0]) * a + (v[k + 1] - v[0]) * b
}

/// A cosine-weighted direction about the unit normal `n` (two draws from `rng`).
fn cosine_direction(n: DVec3, rng: &mut SplitMix64) -> DVec3 {
    let (t1, t2) = n.any_orthonormal_pair();
    let (r, phi) = (rng.next_f64(), std::f64::consts::TAU * rng.next_f64());
    (t1 * phi.cos() + t2 * phi.sin()) * r.sqrt() + n * (1.0 - r).sqrt()
}

/// The random stream of patch `i`'s rays.
fn patch_rng(seed: u64, i: usize) -> SplitMix64 {
    SplitMix64(seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
}

/// A uniform point of a patch (its pieces, of total area `total`, chosen by area) and the
/// normal of the piece it lies on.
fn patch_point(pieces: &[Piece], total: f64, rng: &mut SplitMix64) -> (DVec3, DVec3) {
    let mut pick = rng.next_f64() * total;
    let piece = pieces
        .iter()
        .find(|q| {
            pick -= q.area;
            pick <= 0.0
        })
        .unwrap_or(&pieces[pieces.len() - 1]);
    (uniform_point(piece.polygon.vertices(), rng), piece.normal)
}

/// Points in the first look at a patch in [`buried_share`] (stratified, see
/// [`crate::rng::sobol2`]). At 32, slivers of about 3.5% along a patch's edge went unseen: on a
/// room with a block resting on its floor at 4358 patches their rows stayed 0.955–0.968 (the
/// exposed share alone), the lowest rows of the scene; at 64 its lowest is 0.992.
pub const BURIED_FIRST: u32 = 64;

/// Points in all for a patch the first look finds partly buried. Independent uniform points
/// would give the share a standard error of up to `0.5 / √512 = 0.022`; the stratified ones
/// measured within ±0.003 of a 20 000-point estimate on strips along a patch's edge.
pub const BURIED_POINTS: u32 = 512;

/// The share of patch `i`'s area that is buried ([`Occluders::buried`]: covered by another
/// object, so that no light reaches it or leaves it), from [`BURIED_FIRST`] stratified points,
/// and [`BURIED_POINTS`] in all when any of those is buried.
pub fn buried_share(patches: &Patches, occ: &Occluders, i: usize, seed: u64) -> f64 {
    let pieces = patches.pieces_of(i);
    let total: f64 = pieces.iter().map(|q| q.area).sum();
    if pieces.is_empty() || !(total > 0.0) {
        return 0.0;
    }
    let mut rng = patch_rng(seed, i);
    let scramble = [rng.next_u64() as u32, (rng.next_u64() >> 32) as u32];
    let look = |points: core::ops::Range<u32>| {
        points
            .filter(|&k| {
                let [u, v] = crate::rng::sobol2(scramble, k);
                let (x, n) = patch_point_at(pieces, total, u, v);
                occ.buried(x, n)
            })
            .count()
    };
    let first = look(0..BURIED_FIRST);
    if first == 0 {
        return 0.0;
    }
    let all = first + look(BURIED_FIRST..BURIED_POINTS);
    all as f64 / f64::from(BURIED_POINTS)
}

/// The point of a patch (its pieces, of total area `total`) at `(u, v)` of the unit square,
/// by a map that keeps area: `u` picks the piece, then its fan triangle, by area (each time
/// rescaled to what is left of it), and places the point along the triangle with `v`. Returns
/// it with its piece's normal.
fn patch_point_at(pieces: &[Piece], total: f64, u: f64, v: f64) -> (DVec3, DVec3) {
    let mut pick = u * total;
    let last = pieces.len() - 1;
    let (piece, mut u) = pieces
        .iter()
        .enumerate()
        .find_map(|(k, q)| {
            if pick <= q.area || k == last {
                Some((q, (pick / q.area).clamp(0.0, 1.0)))
            } else {
                pick -= q.area;
                None
            }
        })
        .expect("a patch has pieces");
    let w = piece.polygon.vertices();
    if w.len() < 3 {
        return (piece.polygon.centroid(), piece.normal);
    }
    let fan = |k: usize| (w[k] - w[0]).cross(w[k + 1] - w[0]).length();
    let fans = w.len() - 2;
    let mut pick = u * (1..=fans).map(fan).sum::<f64>();
    let mut k = 1;
    while k < fans && pick > fan(k) {
        pick -= fan(k);
        k += 1;
    }
    let area = fan(k);
    if area > 0.0 {
        u = (pick / area).clamp(0.0, 1.0);
    }
    let r = u.sqrt();
    (
        w[0] * (1.0 - r) + (w[k] * (1.0 - v) + w[k + 1] * v) * r,
        piece.normal,
    )
}

/// Share of cosine-weighted rays from uniform points of patch `i` that first meet the front
/// face of a patch's triangle, and share that first meet a back face.
fn hemisphere(
    patches: &Patches,
    owners: &Owners,
    occ: &Occluders,
    i: usize,
    rays: u32,
    seed: u64,
) -> (f64, f64) {
    let pieces = patches.pieces_of(i);
    let total: f64 = pieces.iter().map(|q| q.area).sum();
    if pieces.is_empty() || !(total > 0.0) || rays == 0 {
        return (0.0, 0.0);
    }
    let far = 10.0 * occ.extent();
    let mut rng = patch_rng(seed, i);
    let (mut seen, mut back) = (0u32, 0u32);
    for _ in 0..rays {
        let (x, n) = patch_point(pieces, total, &mut rng);
        let d = cosine_direction(n, &mut rng);
        let Some((h, front)) = occ.first_surface_from_surface(x, d, far) else {
            continue;
        };
        if !front {
            back += 1;
        } else if owners
            .patch_at(&patches.pieces, h.triangle, x + d * h.distance)
            .is_some()
        {
            seen += 1;
        }
    }
    let r = f64::from(rays);
    (f64::from(seen) / r, f64::from(back) / r)
}

/// Cosine-weighted hemisphere rays in all for [`escape_check`], spread over the patches in
/// proportion to their area: an opening of 0.1% of the area lets about 16 of them out.
pub const ESCAPE_RAYS: u64 = 16_384;

/// Largest share of [`escape_check`]'s rays that may leave the scene for it to count as closed.
/// A watertight enclosure lets none out; the allowance is for rays that slip through where two
/// triangles meet. Above it the scene has an opening of about that share of its area, and
/// calling it closed would trap light that leaves: at ρ = 0.999 an opening of 0.1% of the area
/// halves the furnace's radiosity.
pub const ESCAPE_LIMIT: f64 = 1e-3;

/// What [`escape_check`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Escape {
    /// Rays cast.
    pub rays: u64,
    /// Rays that met no triangle.
    pub escaped: u64,
}

impl Escape {
    /// Share of the rays that left the scene: about the openings' share of the area.
    pub fn share(&self) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            self.escaped as f64 / self.rays as f64
        }
    }
}

/// Whether light leaves the scene, asked of the geometry rather than of F's row sums: about
/// [`ESCAPE_RAYS`] cosine-weighted hemisphere rays from stratified points of the patches for
/// which `live` is true (those that see anything; a wall's outer face sees nothing and is
/// dropped), in proportion to area, counting those that meet no triangle at all. By
/// reciprocity the area-weighted share that escapes is the openings' share of the area, so
/// a small opening that F's rows hide within their tolerance still shows.
pub fn escape_check(patches: &Patches, occ: &Occluders, live: &[bool], seed: u64) -> Escape {
    let area = |i: usize| {
        if live[i] {
            patches.patches[i].area
        } else {
            0.0
        }
    };
    let total: f64 = (0..patches.len()).map(area).sum();
    if !(total > 0.0) {
        return Escape::default();
    }
    // Rays per patch by systematic rounding of the cumulative area, so they sum to the budget.
    let mut before = 0.0;
    let counts: Vec<u64> = (0..patches.len())
        .map(|i| {
            let start = (ESCAPE_RAYS as f64 * before / total).floor() as u64;
            before += area(i);
            (ESCAPE_RAYS as f64 * before / total).floor() as u64 - start
        })
        .collect();
    let far = 10.0 * occ.extent();
    let escaped: u64 = (0..patches.len())
        .into_par_iter()
        .filter(|&i| counts[i] > 0)
        .map(|i| {
            let pieces = patches.pieces_of(i);
            let piece_area: f64 = pieces.iter().map(|q| q.area).sum();
            if pieces.is_empty() || !(piece_area > 0.0) {
                return 0;
            }
            let mut rng = patch_rng(seed ^ ESCAPE_STREAM, i);
            let scramble = [rng.next_u64() as u32, (rng.next_u64() >> 32) as u32];
            (0..counts[i])
                .filter(|&k| {
                    let [u, v] = crate::rng::sobol2(scramble, k as u32);
                    let (x, n) = patch_point_at(pieces, piece_area, u, v);
                    let d = cosine_direction(n, &mut rng);
                    occ.closest_hit_from_surface(x, d, far).is_none()
                })
                .count() as u64
        })
        .sum();
    Escape {
        rays: counts.iter().sum(),
        escaped,
    }
}

/// Salt of [`escape_check`]'s streams, apart from the other checks' rays of the same patch.
const ESCAPE_STREAM: u64 = 0x6573_6361_7065;

/// Hemisphere rays per patch in [`check_dark`]: a patch that sends [`DARK_SHARE`] of its light
/// to other patches shows it in 13 rays on average, and a patch that truly sees nothing in none.
pub const DARK_CHECK_RAYS: u32 = 256;

/// At most this many dark patches are checked (spread evenly over them): 131 k rays.
pub const DARK_CHECK_MAX: usize = 512;

/// A dark patch whose hemisphere rays land on patches at least this often contradicts its zero
/// row of F: the bake warns.
pub const DARK_SHARE: f64 = 0.05;

/// What hemisphere rays say of the patches whose row of F is zero (which the bake drops).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct DarkCheck {
    /// Patches checked: every dark patch, or [`DARK_CHECK_MAX`] of them spread evenly.
    pub checked: usize,
    /// Rays per patch.
    pub rays: u32,
    /// The largest share of rays that landed on a patch's front face.
    pub largest_share: f64,
    /// Patch of `largest_share` (`None` when nothing was checked).
    pub worst_patch: Option<usize>,
    /// Patches whose share reached [`DARK_SHARE`].
    pub seeing: usize,
    /// Patches whose rays mostly meet back faces first: covered by or inside other objects
    /// (a floor under a block).
    pub covered: usize,
}

/// Casts [`DARK_CHECK_RAYS`] hemisphere rays from each of the `dark` patches (those whose row
/// of F is zero) and reports how many of them land on patches. A patch facing out of a room
/// sends every ray into the void, one covered by another object (a floor under a block) into
/// that object's back faces, and both confirm their zero rows; a patch whose rays land on
/// other patches lost its light to a fault in the form factors, and with it the light it would
/// have passed on.
pub fn check_dark(patches: &Patches, occ: &Occluders, dark: &[usize], seed: u64) -> DarkCheck {
    let picked: Vec<usize> = if dark.len() > DARK_CHECK_MAX {
        (0..DARK_CHECK_MAX)
            .map(|k| dark[k * dark.len() / DARK_CHECK_MAX])
            .collect()
    } else {
        dark.to_vec()
    };
    let owners = Owners::new(patches);
    let (shares, back): (Vec<f64>, Vec<f64>) = picked
        .par_iter()
        .map(|&i| hemisphere(patches, &owners, occ, i, DARK_CHECK_RAYS, seed))
        .unzip();
    let worst = shares
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, &s)| (picked[k], s));
    DarkCheck {
        checked: picked.len(),
        rays: DARK_CHECK_RAYS,
        largest_share: worst.map_or(0.0, |w| w.1),
        worst_patch: worst.map(|w| w.0),
        seeing: shares.iter().filter(|&&s| s >= DARK_SHARE).count(),
        covered: back.iter().filter(|&&b| b > 0.5).count(),
    }
}

/// Compares `row_sums[k]` (`Σ_j F_ij` for patch `rows[k]`) with hemisphere rays from that
/// patch against `occ` (built from the scene whose triangles the patches' pieces index).
///
/// # Panics
/// If `rows` and `row_sums` differ in length or a row is not a patch.
pub fn check_rows(
    patches: &Patches,
    occ: &Occluders,
    rows: &[usize],
    row_sums: &[f64],
    params: &RowCheckParams,
) -> RowCheck {
    assert_eq!(rows.len(), row_sums.len(), "one row sum per row");
    let owners = Owners::new(patches);
    let samples: Vec<RowSample> = rows
        .par_iter()
        .zip(row_sums)
        .map(|(&i, &row_sum)| {
            let (h, back) = hemisphere(patches, &owners, occ, i, params.rays, params.seed);
            RowSample {
                patch: i,
                row_sum,
                hemisphere: h,
                std_error: (h * (1.0 - h) / f64::from(params.rays.max(1))).sqrt(),
                back_faces: back,
            }
        })
        .collect();
    let enclosed = |r: &&RowSample| r.back_faces >= params.enclosed_share;
    RowCheck {
        rays: params.rays,
        open: RowGroup::of(samples.iter().filter(|r| !enclosed(r)), params.over_full),
        enclosed: RowGroup::of(samples.iter().filter(enclosed), params.over_full),
        all: RowGroup::of(samples.iter(), params.over_full),
        samples,
    }
}

/// [`check_rows`] on a scene as the bake sees it: simplified with `voxel`, occlusion planned as
/// [`crate::pipeline::discretise`] plans it (a convex enclosure casts no visibility rays), and
/// `count` sampled rows of F computed alone ([`form_factor_rows`]), or the rows `only` names
/// when it is not empty (patches in simplification order, as the bake's
/// `closure.max_row_patch` names them; an error if one is not a patch). Returns the check, the
/// patch count, the shadow rays the rows cast and the seconds spent on the rows and on the
/// hemisphere rays. `progress` is told about finished rows of F.
pub fn check_scene(
    scene: &Scene,
    voxel: &VoxelParams,
    form_factors: &FormFactorParams,
    count: usize,
    only: &[usize],
    params: &RowCheckParams,
    progress: Option<Progress<'_>>,
) -> Result<SceneCheck, BakeError> {
    let patches = simplify(scene, voxel)?;
    if let Some(&bad) = only.iter().find(|&&i| i >= patches.len()) {
        return Err(BakeError::InvalidParams(format!(
            "--patch {bad}: the scene simplifies to {} patches (0 to {})",
            patches.len(),
            patches.len().saturating_sub(1)
        )));
    }
    let occ = Occluders::new(scene);
    let mut ffp = *form_factors;
    if !crate::effects::plan_occlusion(scene).on {
        ffp.visibility = Visibility::Off;
    }
    let rows = if only.is_empty() {
        sample_rows(patches.len(), count, params.seed)
    } else {
        let mut rows = only.to_vec();
        rows.sort_unstable();
        rows.dedup();
        rows
    };
    let clock = Instant::now();
    let (f, shadow_rays) = form_factor_rows(&patches, Some(&occ), &ffp, &rows, progress);
    let rows_s = clock.elapsed().as_secs_f64();
    let sums: Vec<f64> = f.iter().map(|r| r.iter().sum()).collect();
    let clock = Instant::now();
    let check = check_rows(&patches, &occ, &rows, &sums, params);
    Ok(SceneCheck {
        patches: patches.len(),
        shadow_rays,
        form_factor_seconds: rows_s,
        hemisphere_seconds: clock.elapsed().as_secs_f64(),
        check,
    })
}

/// What [`check_scene`] returns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneCheck {
    /// Patches after simplification (dark ones included).
    pub patches: usize,
    /// Shadow rays the sampled rows of F cast.
    pub shadow_rays: u64,
    /// Seconds spent computing the sampled rows of F.
    pub form_factor_seconds: f64,
    /// Seconds spent on the hemisphere rays.
    pub hemisphere_seconds: f64,
    /// The comparison.
    pub check: RowCheck,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_row_sample_is_distinct_sorted_and_covers_small_scenes() {
        let s = sample_rows(1000, 120, 5);
        assert_eq!(s.len(), 120);
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        assert!(s.iter().all(|&i| i < 1000));
        assert_eq!(sample_rows(7, 120, 5), (0..7).collect::<Vec<_>>());
        assert_ne!(sample_rows(1000, 120, 6), s);
    }

    #[test]
    fn uniform_points_fill_a_fan_by_area() {
        // A quad made of a 1 × 1 and a 3 × 1 half (fan triangles of areas 0.5 and 1.5): a
        // quarter of the points must land in the first. 40 000 points: the share's standard
        // error is 0.0022, the bound 0.01 is 4.5 of them.
        let v = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-2.0, 1.0, 0.0),
        ];
        let mut rng = SplitMix64(3);
        let first = (0..40_000)
            .map(|_| uniform_point(&v, &mut rng))
            .filter(|p| p.x >= p.y) // below the diagonal (0,0)–(1,1): the first fan triangle
            .count();
        let share = first as f64 / 40_000.0;
        assert!((share - 0.25).abs() < 0.01, "{share}");
    }
}
