//! Ray-cast form factors for scenes of many pieces (module doc of [`super`], "many pieces"):
//! each patch casts the same number of cosine-weighted rays from points spread over its pieces
//! by area, and every ray that first meets the front of another patch's triangle counts one
//! hit for that patch. The cost is rays × log(triangles): it follows the patch count, not the
//! scene's triangles, which the piece-by-piece quadrature's near field cannot do on a scene of
//! tiny facets.
//!
//! **The estimator.** Patch `i` casting `R_i` rays, `c_ij` of which reach `j`, estimates the
//! exchange `G_ij = A_i F_ij` as `A_i c_ij / R_i`, with a variance of about `A_i G / R_i`
//! (Poisson). Both sides of a pair estimate the same `G`, so the two estimates are pooled with
//! weights inverse to their variances: `G = (c_ij + c_ji) / (R_i/A_i + R_j/A_j)`, all hits over
//! all ray density. Reciprocity then holds by construction, and the smaller patch, which sends
//! its rays at the larger from close, carries the pair as in the quadrature ("integrate over
//! the smaller patch").
//!
//! **The samples.** A patch's ray `k` starts at point `k` of a scrambled Sobol' (0, 2)-sequence
//! mapped onto its pieces by area ([`patch_point_at`]) and leaves in the direction of point
//! `π(k)` of a second scrambled sequence (π a random permutation: the padding of Kollig &
//! Keller, "Efficient multidimensional sampling", Eurographics 2002), cosine-weighted about the
//! piece's own normal. Every stream is seeded by the patch alone, so the matrix is the same on
//! any thread count. A ray that first meets a back face (the point lies under or inside
//! something) or nothing counts for no patch, and none leaves a buried start (inside a solid a
//! ray may meet the front of a face inside it too, as in boxes standing inside boxes): the row
//! is the mean over the patch's whole area, as the quadrature's is, and the closure divides by
//! the exposed share afterwards. A partly buried patch's rays start at the points the burial
//! survey looked at ([`crate::form_factor::burial::survey`]: 512, eight rays each at 4096 a patch), so
//! that each start's burial is asked once and the share divided by is measured at the very
//! starts (`docs/decisions/burial-survey.md`).

use super::Progress;
use crate::form_factor::burial::{BURIED_POINTS, EXPOSED};
use crate::geometry::Occluders;
use crate::patch::points::{Owners, cosine_at, patch_point_at};
use crate::patch::{Patches, Piece};
use crate::rng::{SplitMix64, sobol2};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Seed of the ray streams (any fixed value: it only has to differ from the checks' seeds).
const SEED: u64 = 0x5EED_CA57_F0F0_0001;

/// The ray streams of a patch's `seed`: the two scrambles and the permutation's generator.
fn streams(seed: u64) -> ([u32; 2], [u32; 2], SplitMix64) {
    let mut rng = SplitMix64(SEED ^ seed);
    let mut scramble = || {
        let v = rng.next_u64();
        [v as u32, (v >> 32) as u32]
    };
    let (a, b) = (scramble(), scramble());
    (a, b, rng)
}

/// Where patch `i`'s rays start: point `k` of a scrambled Sobol' (0, 2)-sequence mapped onto
/// its pieces by area. The burial survey ([`crate::form_factor::burial::survey`]) looks at the first
/// [`BURIED_POINTS`] of them, so that a partly buried patch's rays start only where it knows.
pub(crate) struct Starts<'a> {
    pieces: &'a [Piece],
    /// Running areas, so that a ray's piece is a binary search away (a curved patch of a real
    /// scene holds tens of thousands of pieces, and a walk over them cost more than the ray).
    cumulative: Vec<f64>,
    at: [u32; 2],
}

impl<'a> Starts<'a> {
    /// Patch `i`'s starts; `None` for a patch without area.
    pub(crate) fn new(patches: &'a Patches, i: usize) -> Option<Self> {
        let pieces = patches.pieces_of(i);
        let mut cumulative = Vec::with_capacity(pieces.len());
        let mut total = 0.0;
        for q in pieces {
            total += q.area;
            cumulative.push(total);
        }
        (!pieces.is_empty() && total > 0.0).then(|| Self {
            pieces,
            cumulative,
            at: streams(patches.patches[i].seed).0,
        })
    }

    /// Start `k`: its piece (and the piece's index among the patch's pieces), the point and
    /// the piece's normal.
    pub(crate) fn point(&self, k: u32) -> (&'a Piece, usize, DVec3, DVec3) {
        let [u, v] = sobol2(self.at, k);
        let total = self.cumulative[self.cumulative.len() - 1];
        let pick = u * total;
        let q = self
            .cumulative
            .partition_point(|&c| c < pick)
            .min(self.pieces.len() - 1);
        let below = if q == 0 { 0.0 } else { self.cumulative[q - 1] };
        let piece = &self.pieces[q];
        // A piece without area is picked only by `pick` 0 at the front: its first point.
        let within = if piece.area > 0.0 {
            ((pick - below) / piece.area).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (x, n) = patch_point_at(&self.pieces[q..=q], piece.area, within, v);
        (piece, q, x, n)
    }
}

/// Casts `rays` rays from patch `i` and calls `hit(j)` for each that reaches patch `j`.
/// `buried`: the survey of the patch's first [`BURIED_POINTS`] starts, empty where it found
/// none buried; then ray `k` starts at start `k mod BURIED_POINTS`, and none from a buried
/// one (a start inside a solid, a step's top under the step above, meets the faces inside
/// it, which are buried too: `docs/decisions/shaded-steps.md`). The row stays the mean over
/// the patch's whole area with the buried part at 0, as the quadrature's, and the closure's
/// division by the exposed share, measured at the same starts, makes it the mean over the
/// exposed ones exactly.
fn cast_row(
    patches: &Patches,
    owners: &Owners,
    occ: &Occluders,
    i: usize,
    rays: u32,
    buried: &[u32],
    mut hit: impl FnMut(usize),
) {
    let far = 10.0 * occ.extent();
    rays_of(patches, i, rays, buried, |x, d| {
        if let Some(j) = first_patch(patches, owners, occ, x, d, far) {
            hit(j);
        }
    });
}

/// The patch a ray from `x` along `d` first meets the front of, if any ([`cast_row`]).
pub(crate) fn first_patch(
    patches: &Patches,
    owners: &Owners,
    occ: &Occluders,
    x: DVec3,
    d: DVec3,
    far: f64,
) -> Option<usize> {
    match occ.first_surface_from_surface(x, d, far) {
        Some((h, true)) => owners.patch_at(&patches.pieces, h.triangle, x + d * h.distance),
        _ => None,
    }
}

/// Calls `ray(start, direction)` for each of patch `i`'s rays in [`cast_row`]'s order.
pub(crate) fn rays_of(
    patches: &Patches,
    i: usize,
    rays: u32,
    buried: &[u32],
    mut ray: impl FnMut(DVec3, DVec3),
) {
    let Some(starts) = Starts::new(patches, i) else {
        return;
    };
    let (_, towards, mut rng) = streams(patches.patches[i].seed);
    let mut order: Vec<u32> = (0..rays).collect();
    rng.shuffle(&mut order);
    for (k, &p) in order.iter().enumerate() {
        let mut k = k as u32;
        if !buried.is_empty() {
            k %= BURIED_POINTS;
            if buried[k as usize] != EXPOSED {
                continue;
            }
        }
        let (_, _, x, n) = starts.point(k);
        let [a, b] = sobol2(towards, p);
        ray(x, cosine_at(n, a, b));
    }
}

/// The ray-cast form-factor matrix (module doc): `matrix` (n × n, zeroed) receives `F_ij`;
/// returns the rays cast. `rays` per patch must stay below 2²⁴ so that counts are exact in f32.
pub(super) fn cast(
    patches: &Patches,
    occ: &Occluders,
    rays: u32,
    burial: &[Vec<u32>],
    coverage: Option<&[f64]>,
    matrix: &mut [f32],
    progress: Option<Progress<'_>>,
) -> u64 {
    let n = patches.len();
    assert!(rays < 1 << 24, "ray counts must be exact in f32");
    assert_eq!(matrix.len(), n * n);
    let owners = Owners::new(patches);
    let done = AtomicUsize::new(0);
    let stopped = AtomicBool::new(false);
    // Counts first, each row written by its own patch (no shared output).
    matrix
        .par_chunks_mut(n.max(1))
        .enumerate()
        .for_each(|(i, row)| {
            if stopped.load(Ordering::Relaxed) {
                return;
            }
            let buried = burial.get(i).map_or(&[][..], Vec::as_slice);
            cast_row(patches, &owners, occ, i, rays, buried, |j| row[j] += 1.0);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress
                && !p(d, n)
            {
                stopped.store(true, Ordering::Relaxed);
            }
        });
    // Then the pooled exchange of every pair, in place: `c_ij + c_ji` over the two sides' ray
    // densities, divided by each side's area. Equal ray counts per patch: the density of `i`
    // is `R / A_i`.
    let r = f64::from(rays);
    // A patch of coverage c (`super::coverage`) exchanges light over its area c·A: its rays
    // meet a partly covered target by the target's share already.
    let area = |i: usize| patches.patches[i].area * coverage.map_or(1.0, |c| c[i]);
    for i in 0..n {
        let d = i * n + i;
        matrix[d] = (f64::from(matrix[d]) / r) as f32;
        for j in i + 1..n {
            let (ij, ji) = (i * n + j, j * n + i);
            let hits = f64::from(matrix[ij]) + f64::from(matrix[ji]);
            if hits == 0.0 {
                continue;
            }
            let (ai, aj) = (area(i), area(j));
            let g = hits / (r / ai + r / aj);
            matrix[ij] = (g / ai) as f32;
            matrix[ji] = (g / aj) as f32;
        }
    }
    n as u64 * u64::from(rays)
}

/// A form-factor matrix by rows of its non-zero entries (compressed sparse rows), each row's
/// columns increasing: what [`cast`] computes, without the n² floats a dense matrix needs (a
/// level of 65 536 patches would need 17 GB; its rays hit a few hundred patches a row).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseFormFactors {
    /// Patches.
    pub n: usize,
    /// Row `i`'s entries are `row_ptr[i]..row_ptr[i + 1]` of [`Self::cols`] and
    /// [`Self::values`].
    pub row_ptr: Vec<usize>,
    /// Column of each entry.
    pub cols: Vec<u32>,
    /// `F_ij` of each entry.
    pub values: Vec<f32>,
    /// Rays cast.
    pub rays_cast: u64,
    /// Rays cast from each patch.
    pub rays_per_patch: u32,
}

impl SparseFormFactors {
    /// Row `i`: `(j, F_ij)` for its non-zero entries, `j` increasing.
    pub fn row(&self, i: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        let r = self.row_ptr[i]..self.row_ptr[i + 1];
        self.cols[r.clone()]
            .iter()
            .zip(&self.values[r])
            .map(|(&j, &v)| (j as usize, v))
    }

    /// Entries in all.
    pub fn nnz(&self) -> usize {
        self.cols.len()
    }
}

/// [`cast`] into [`SparseFormFactors`]: the same rays and the same pooling of each pair's two
/// sides, so every entry is bit for bit the dense matrix's. Each row's hits are counted by
/// patch; a pair hit from one side only gets its entry on both (the pooled exchange is shared).
pub(super) fn cast_sparse(
    patches: &Patches,
    occ: &Occluders,
    rays: u32,
    burial: &[Vec<u32>],
    coverage: Option<&[f64]>,
    progress: Option<Progress<'_>>,
) -> SparseFormFactors {
    let all: Vec<u32> = (0..patches.len() as u32).collect();
    let counts = count_rows(
        patches,
        occ,
        rays,
        &all,
        &|i| burial.get(i).map_or(&[][..], Vec::as_slice),
        progress,
    );
    pool(patches, &counts, rays, coverage)
}

/// Hits of a patch's rays: `(patch, count)` with patches increasing.
pub(crate) type HitCounts = Vec<(u32, u32)>;

/// The hit counts of the rows `rows` (each patch's rays, [`cast_row`]), in that order:
/// the part of [`cast_sparse`] that each shard of a distributed bake does for its own
/// patches ([`crate::plan`]). `burial(i)`: patch `i`'s survey.
pub(crate) fn count_rows<'b>(
    patches: &Patches,
    occ: &Occluders,
    rays: u32,
    rows: &[u32],
    burial: &(dyn Fn(usize) -> &'b [u32] + Sync),
    progress: Option<Progress<'_>>,
) -> Vec<HitCounts> {
    assert!(rays < 1 << 24, "ray counts must be exact in f32");
    let owners = Owners::new(patches);
    let done = AtomicUsize::new(0);
    let stopped = AtomicBool::new(false);
    let total = rows.len();
    rows.par_iter()
        .map(|&i| {
            let i = i as usize;
            if stopped.load(Ordering::Relaxed) {
                return Vec::new();
            }
            let row = count_row(patches, &owners, occ, i, rays, burial(i));
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(p) = progress
                && !p(d, total)
            {
                stopped.store(true, Ordering::Relaxed);
            }
            row
        })
        .collect()
}

/// The hit counts of patch `i`'s rays (`buried`: its survey), through `owners` built once for
/// many rows.
pub(crate) fn count_row(
    patches: &Patches,
    owners: &Owners,
    occ: &Occluders,
    i: usize,
    rays: u32,
    buried: &[u32],
) -> HitCounts {
    let mut hits: Vec<u32> = Vec::new();
    cast_row(patches, owners, occ, i, rays, buried, |j| {
        hits.push(j as u32)
    });
    tally(hits)
}

/// `(patch, count)` of a list of hits, patches increasing.
pub(crate) fn tally(mut hits: Vec<u32>) -> HitCounts {
    hits.sort_unstable();
    let mut row: HitCounts = Vec::new();
    for j in hits {
        match row.last_mut() {
            Some((k, c)) if *k == j => *c += 1,
            _ => row.push((j, 1)),
        }
    }
    row
}

/// The pooled form factors of every patch's hit counts (`counts[i]`, [`count_rows`]): the
/// second half of [`cast_sparse`].
pub(crate) fn pool(
    patches: &Patches,
    counts: &[HitCounts],
    rays: u32,
    coverage: Option<&[f64]>,
) -> SparseFormFactors {
    let n = patches.len();
    assert_eq!(counts.len(), n, "a row of counts for every patch");
    // The other side of each pair: row i of the transpose holds (j, hits from j to i).
    let mut transpose: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    for (j, row) in counts.iter().enumerate() {
        for &(i, c) in row {
            transpose[i as usize].push((j as u32, c));
        }
    }
    let r = f64::from(rays);
    // As [`cast`]: a patch of coverage c exchanges over c·A.
    let area = |i: usize| patches.patches[i].area * coverage.map_or(1.0, |c| c[i]);
    let rows: Vec<Vec<(u32, f32)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (own, other) = (&counts[i], &transpose[i]);
            let mut out = Vec::with_capacity(own.len().max(other.len()));
            let (mut a, mut b) = (0, 0);
            while a < own.len() || b < other.len() {
                let ja = own.get(a).map_or(u32::MAX, |e| e.0);
                let jb = other.get(b).map_or(u32::MAX, |e| e.0);
                let j = ja.min(jb);
                let mine = if ja == j {
                    a += 1;
                    own[a - 1].1
                } else {
                    0
                };
                let theirs = if jb == j {
                    b += 1;
                    other[b - 1].1
                } else {
                    0
                };
                let ju = j as usize;
                let v = if ju == i {
                    (f64::from(mine) / r) as f32
                } else {
                    // Counts below 2^24 are exact in f32, as the dense matrix holds them.
                    let hits = f64::from(mine as f32) + f64::from(theirs as f32);
                    let (ai, aj) = (area(i), area(ju));
                    let g = hits / (r / ai + r / aj);
                    (g / ai) as f32
                };
                out.push((j, v));
            }
            out
        })
        .collect();
    let mut row_ptr = Vec::with_capacity(n + 1);
    row_ptr.push(0);
    let nnz: usize = rows.iter().map(Vec::len).sum();
    let (mut cols, mut values) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
    for row in rows {
        for (j, v) in row {
            cols.push(j);
            values.push(v);
        }
        row_ptr.push(cols.len());
    }
    SparseFormFactors {
        n,
        row_ptr,
        cols,
        values,
        rays_cast: n as u64 * u64::from(rays),
        rays_per_patch: rays,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_stay_in_the_hemisphere_and_keep_the_mean_cosine() {
        // Over a stratified grid of the square, the mean cosine of a cosine-weighted
        // direction is 2/3 (∫cos² / ∫cos over the hemisphere); 64² points put the grid's
        // quadrature error near 1e-3, the bound is 5e-3.
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let mut sum = 0.0;
        let m = 64;
        for a in 0..m {
            for b in 0..m {
                let d = cosine_at(n, (a as f64 + 0.5) / m as f64, (b as f64 + 0.5) / m as f64);
                assert!((d.length() - 1.0).abs() < 1e-12);
                assert!(d.dot(n) >= 0.0);
                sum += d.dot(n);
            }
        }
        let mean = sum / (m * m) as f64;
        assert!((mean - 2.0 / 3.0).abs() < 5e-3, "{mean}");
    }
}
