//! Reflectance edits at run time, without a re-bake: [`ReflectanceEdit`] and the gather that
//! applies one, [`EditedGather`].
//!
//! The stored matrix is `M = (I − F·C)⁻¹·F` with `C = diag(ρ)` (per channel). Changing the
//! reflectance of a set `S` of `k` patches by `D = diag(Δρ_S)` changes `C` by a rank-`k` term,
//! and the new frame needs no new matrix. From `H' = F·(x' + C'·H')` (`x'` the first exitance
//! under the new reflectance):
//!
//! ```text
//! (I − F·C)·H' = F·(x' + D·H'_S)   ⇒   H' = M·x̃,   x̃ = x' + D·H'_S   (on S only)
//! H'_S = (M·x')_S + M_SS·D·H'_S    ⇒   H'_S = (I − M_SS·D)⁻¹·(M·x')_S
//! ```
//!
//! so a frame is the gather of `x'`, a `k × k` solve with `M_SS` (the stored matrix's own
//! entries among the edited patches, decoded once), and the gather of the corrected `x̃`:
//! exact for a matrix that holds every bounce, whatever the edit, with no bytes beyond `k²`
//! per channel, on any [`Gather`] (CPU or GPU). The only error is the compression's.
//!
//! `docs/decisions/material-edits.md` has the measured cost and the alternatives.

use crate::{DecodeMode, Gather, GatherError, Patch, Rgb, TransferMatrix, check_gather_args};
use alloc::vec;
use alloc::vec::Vec;
use core::fmt;

/// Why an edit cannot be prepared.
#[derive(Clone, Debug, PartialEq)]
pub enum EditError {
    /// A patch index past the matrix.
    Patch {
        /// The index given.
        index: u32,
        /// Patches in the matrix.
        patches: usize,
    },
    /// The same patch edited twice.
    Duplicate(u32),
    /// A new reflectance outside `[0, 1)` or not finite.
    Reflectance {
        /// The patch.
        patch: u32,
        /// The value given.
        value: Rgb,
    },
    /// `patches` does not have one entry per matrix patch.
    Length {
        /// Patches in the matrix.
        expected: usize,
        /// Entries given.
        found: usize,
    },
    /// `I − M_SS·D` is singular (or nearly): the edited scene would not converge.
    Singular {
        /// The colour channel (0, 1, 2).
        channel: usize,
    },
}

impl fmt::Display for EditError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EditError::Patch { index, patches } => {
                write!(f, "patch {index} is past the matrix's {patches} patches")
            }
            EditError::Duplicate(p) => write!(f, "patch {p} is edited twice"),
            EditError::Reflectance { patch, value } => write!(
                f,
                "reflectance [{}, {}, {}] of patch {patch} is outside [0, 1)",
                value.r, value.g, value.b
            ),
            EditError::Length { expected, found } => {
                write!(f, "{found} patches given for a matrix of {expected}")
            }
            EditError::Singular { channel } => write!(
                f,
                "the edited scene does not converge in channel {channel} (I − M·ΔC is singular)"
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EditError {}

/// A reflectance edit of some patches, prepared against one matrix: the edited patches, their
/// change of reflectance, and per channel the LU factors of `I − M_SS·D` (`k × k`, partial
/// pivoting; factored in f64, kept in f32).
#[derive(Clone, Debug)]
pub struct ReflectanceEdit {
    n: usize,
    /// Edited patches, ascending.
    patches: Vec<u32>,
    /// New reflectance of each.
    reflectance: Vec<Rgb>,
    /// Δρ of each.
    delta: Vec<Rgb>,
    /// Per colour channel: the LU factors (row-major `k × k`) and the row permutation.
    lu: [(Vec<f32>, Vec<usize>); 3],
}

impl ReflectanceEdit {
    /// Prepares the edit `edits` (patch, new reflectance; any order) of a scene whose patches
    /// are `patches` (the file's, as baked) and whose matrix is `matrix`, decoding `M_SS`
    /// under `mode` (the gather's decode rules; [`DecodeMode::D3d10`] for the CPU backends).
    /// Costs the decode of the block rows holding the edited patches and `k³` per channel.
    pub fn new(
        matrix: &TransferMatrix<'_>,
        mode: DecodeMode,
        patches: &[Patch],
        edits: &[(u32, Rgb)],
    ) -> Result<Self, EditError> {
        let n = matrix.layout.n();
        if patches.len() != n {
            return Err(EditError::Length {
                expected: n,
                found: patches.len(),
            });
        }
        let mut sorted: Vec<(u32, Rgb)> = edits.to_vec();
        sorted.sort_by_key(|e| e.0);
        for w in sorted.windows(2) {
            if w[0].0 == w[1].0 {
                return Err(EditError::Duplicate(w[0].0));
            }
        }
        for &(p, rho) in &sorted {
            if p as usize >= n {
                return Err(EditError::Patch {
                    index: p,
                    patches: n,
                });
            }
            let ok = |v: f32| v.is_finite() && (0.0..1.0).contains(&v);
            if !(ok(rho.r) && ok(rho.g) && ok(rho.b)) {
                return Err(EditError::Reflectance {
                    patch: p,
                    value: rho,
                });
            }
        }
        let ids: Vec<u32> = sorted.iter().map(|e| e.0).collect();
        let reflectance: Vec<Rgb> = sorted.iter().map(|e| e.1).collect();
        let delta: Vec<Rgb> = sorted
            .iter()
            .map(|&(p, rho)| {
                let old = patches[p as usize].reflectance;
                Rgb::new(rho.r - old.r, rho.g - old.g, rho.b - old.b)
            })
            .collect();
        let k = ids.len();
        let ch = matrix.layout.channels();
        // M_SS, `ch` values per entry, decoded 64 rows at a time (rows are n long).
        let mut mss = vec![0f32; k * k * ch];
        for (chunk, rows) in ids.chunks(64).enumerate() {
            let decoded = matrix.decode_rows(mode, rows);
            for a in 0..rows.len() {
                for (b, &col) in ids.iter().enumerate() {
                    for c in 0..ch {
                        mss[((chunk * 64 + a) * k + b) * ch + c] =
                            decoded[(a * n + col as usize) * ch + c];
                    }
                }
            }
        }
        let lu = [0, 1, 2].map(|c| {
            let mc = c.min(ch - 1);
            let mut a = vec![0f64; k * k];
            for i in 0..k {
                for j in 0..k {
                    let m = f64::from(mss[(i * k + j) * ch + mc]);
                    a[i * k + j] = f64::from(u8::from(i == j)) - m * f64::from(delta[j].channel(c));
                }
            }
            // Factored in f64, kept in f32: a frame reads the factors once (k² per channel),
            // and f32 halves what it reads; the solve still sums in f64.
            lu_factor(&mut a, k).map(|piv| (a.iter().map(|&v| v as f32).collect(), piv))
        });
        let [l0, l1, l2] = lu;
        Ok(ReflectanceEdit {
            n,
            patches: ids,
            reflectance,
            delta,
            lu: [
                l0.ok_or(EditError::Singular { channel: 0 })?,
                l1.ok_or(EditError::Singular { channel: 1 })?,
                l2.ok_or(EditError::Singular { channel: 2 })?,
            ],
        })
    }

    /// The edited patches, ascending, with their new reflectance.
    pub fn edits(&self) -> impl Iterator<Item = (u32, Rgb)> + '_ {
        self.patches
            .iter()
            .copied()
            .zip(self.reflectance.iter().copied())
    }

    /// Patches edited.
    pub fn len(&self) -> usize {
        self.patches.len()
    }

    /// Whether the edit changes nothing.
    pub fn is_empty(&self) -> bool {
        self.patches.is_empty()
    }

    /// Sets the new reflectance on `patches` (the scene's, in the matrix's numbering): the
    /// patches [`first_exitance`](crate::first_exitance) and
    /// [`finish_frame`](crate::finish_frame) of an edited frame take.
    pub fn apply_to(&self, patches: &mut [Patch]) {
        for (p, rho) in self.edits() {
            patches[p as usize].reflectance = rho;
        }
    }

    /// Bytes the edit holds: the LU factors and the lists.
    pub fn bytes(&self) -> usize {
        let k = self.patches.len();
        3 * (k * k * 4 + k * 8) + k * (4 + 2 * 12)
    }

    /// The correction as one dense `k × k` matrix per channel, for a device that applies it
    /// as a product rather than by triangular solves: `K_c = diag(Δρ_c)·(I − M_SS·D)_c⁻¹`
    /// (row-major), so that the correction on edited patch `a` is
    /// `Σ_b K_c[a·k + b]·(M·x')_{S_b}` in channel `c`. Built column by column from the LU
    /// factors (`k` solves of `k²` each per channel, summed in f64), kept in f32: `12·k²`
    /// bytes. The edited patches are [`ReflectanceEdit::edits`]' order.
    pub fn correction_matrices(&self) -> [Vec<f32>; 3] {
        let k = self.patches.len();
        [0, 1, 2].map(|c| {
            let (lu, piv) = &self.lu[c];
            let mut out = vec![0f32; k * k];
            let (mut col, mut tmp) = (vec![0f64; k], vec![0f64; k]);
            for b in 0..k {
                col.fill(0.0);
                col[b] = 1.0;
                lu_solve(lu, piv, k, &mut col, &mut tmp);
                for a in 0..k {
                    out[a * k + b] = (f64::from(self.delta[a].channel(c)) * col[a]) as f32;
                }
            }
            out
        })
    }

    /// The edited patches, ascending (the rows and columns of
    /// [`ReflectanceEdit::correction_matrices`]).
    pub fn patches(&self) -> &[u32] {
        &self.patches
    }

    /// Patches of the matrix the edit was prepared against.
    pub fn matrix_patches(&self) -> usize {
        self.n
    }

    /// Turns `gathered = (M·x')` (the gather of the first exitance under the new reflectance)
    /// into the correction of the exitance: `x̃ = x' + D·H'_S` is `exitance` with
    /// `correction` added on the edited patches.
    /// `scratch` is reused from frame to frame (resized to `k`, four vectors).
    fn correction(
        &self,
        gathered: &[Rgb],
        scratch: &mut [Vec<f64>; 4],
        out: &mut Vec<(usize, Rgb)>,
    ) {
        let k = self.patches.len();
        out.clear();
        for v in scratch.iter_mut() {
            v.resize(k, 0.0);
        }
        let [u0, u1, u2, tmp] = scratch;
        for (c, uc) in [&mut *u0, &mut *u1, &mut *u2].into_iter().enumerate() {
            for (a, &p) in self.patches.iter().enumerate() {
                uc[a] = f64::from(gathered[p as usize].channel(c));
            }
            let (lu, piv) = &self.lu[c];
            lu_solve(lu, piv, k, uc, tmp);
        }
        let u = [&*u0, &*u1, &*u2];
        for (a, &p) in self.patches.iter().enumerate() {
            let d = self.delta[a];
            out.push((
                p as usize,
                Rgb::new(
                    (f64::from(d.r) * u[0][a]) as f32,
                    (f64::from(d.g) * u[1][a]) as f32,
                    (f64::from(d.b) * u[2][a]) as f32,
                ),
            ));
        }
    }
}

/// A [`Gather`] of the edited scene over any gather of the baked matrix: each call gathers
/// twice (`M·x'`, then `M·x̃`) and solves `k × k` in between. Give it the first exitance
/// under the new reflectance ([`ReflectanceEdit::apply_to`] the patches first).
pub struct EditedGather<G> {
    inner: G,
    edit: ReflectanceEdit,
    name: alloc::string::String,
    corrected: Vec<Rgb>,
    correction: Vec<(usize, Rgb)>,
    /// The solve's vectors, kept between frames.
    scratch: [Vec<f64>; 4],
}

impl<G: Gather> EditedGather<G> {
    /// Wraps `inner` (a gather of the matrix `edit` was prepared against).
    pub fn new(inner: G, edit: ReflectanceEdit) -> Result<Self, EditError> {
        if inner.patches() != edit.n {
            return Err(EditError::Length {
                expected: edit.n,
                found: inner.patches(),
            });
        }
        let name = alloc::format!("{}+edit", inner.name());
        Ok(EditedGather {
            inner,
            name,
            corrected: vec![Rgb::ZERO; edit.n],
            correction: Vec::with_capacity(edit.len()),
            scratch: Default::default(),
            edit,
        })
    }

    /// The edit applied.
    pub fn edit(&self) -> &ReflectanceEdit {
        &self.edit
    }

    /// Replaces the edit (for a matrix of the same patches), keeping the gather.
    pub fn set_edit(&mut self, edit: ReflectanceEdit) -> Result<(), EditError> {
        if edit.n != self.edit.n {
            return Err(EditError::Length {
                expected: self.edit.n,
                found: edit.n,
            });
        }
        self.edit = edit;
        Ok(())
    }

    /// The wrapped gather.
    pub fn into_inner(self) -> G {
        self.inner
    }
}

impl<G: Gather> Gather for EditedGather<G> {
    fn name(&self) -> &str {
        &self.name
    }

    fn patches(&self) -> usize {
        self.edit.n
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        check_gather_args(self.edit.n, exitance, irradiance)?;
        if self.edit.is_empty() {
            return self.inner.gather(exitance, irradiance);
        }
        self.inner.gather(exitance, irradiance)?;
        self.edit
            .correction(irradiance, &mut self.scratch, &mut self.correction);
        self.corrected.copy_from_slice(exitance);
        for &(p, d) in &self.correction {
            self.corrected[p] += d;
        }
        if let Some(index) = self.corrected.iter().position(|x| !x.is_finite()) {
            return Err(GatherError::NonFinite { index });
        }
        self.inner.gather(&self.corrected, irradiance)
    }
}

impl<G> fmt::Debug for EditedGather<G> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EditedGather")
            .field("name", &self.name)
            .field("edited", &self.edit.len())
            .finish()
    }
}

/// LU factorisation with partial pivoting of the row-major `k × k` matrix `a`, in place;
/// the row permutation, or `None` for a pivot below `1e-12` of the largest entry (singular).
/// Written here because the core is `no_std` and `k` is the count of edited patches, small
/// against the gather's `n`.
fn lu_factor(a: &mut [f64], k: usize) -> Option<Vec<usize>> {
    let scale = a
        .iter()
        .fold(0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let mut piv: Vec<usize> = (0..k).collect();
    for col in 0..k {
        let (best, big) = (col..k)
            .map(|r| (r, a[r * k + col].abs()))
            .fold((col, -1.0), |b, x| if x.1 > b.1 { x } else { b });
        if !(big > 1e-12 * scale) {
            return None;
        }
        if best != col {
            for j in 0..k {
                a.swap(col * k + j, best * k + j);
            }
            piv.swap(col, best);
        }
        let p = a[col * k + col];
        for r in col + 1..k {
            let f = a[r * k + col] / p;
            a[r * k + col] = f;
            if f != 0.0 {
                for j in col + 1..k {
                    a[r * k + j] -= f * a[col * k + j];
                }
            }
        }
    }
    Some(piv)
}

/// Solves `A·x = b` in place with [`lu_factor`]'s factors: `k²` multiply-adds, row by row as
/// contiguous dot products. `x` is scratch of length `k`.
fn lu_solve(lu: &[f32], piv: &[usize], k: usize, b: &mut [f64], x: &mut [f64]) {
    for (xi, &p) in x.iter_mut().zip(piv) {
        *xi = b[p];
    }
    for i in 0..k {
        let row = &lu[i * k..(i + 1) * k];
        x[i] -= dot(&row[..i], &x[..i]);
    }
    for i in (0..k).rev() {
        let row = &lu[i * k..(i + 1) * k];
        x[i] = (x[i] - dot(&row[i + 1..], &x[i + 1..])) / f64::from(row[i]);
    }
    b.copy_from_slice(x);
}

/// `Σ a_i·b_i` in four interleaved partial sums (which the compiler can keep in one vector
/// register; the order is fixed, so the result is the same on every run).
fn dot(a: &[f32], b: &[f64]) -> f64 {
    let mut acc = [0f64; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            acc[l] += f64::from(x[l]) * y[l];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| f64::from(*x) * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dense_correction_equals_the_solve() {
        // A 3-patch f32 matrix with some coupling, two patches edited.
        use crate::{BlockCorrections, Format, MatrixLayout, SparseRows};
        use alloc::borrow::Cow;
        // One grey channel in one 4×4 block, entry (i, j) at `4·i + j`.
        let n = 3usize;
        let layout = MatrixLayout::new(n as u32, 1, Format::F32, crate::DEFAULT_MAX_TILE).unwrap();
        let mut blocks = vec![0f32; 16];
        for i in 0..n {
            for j in 0..n {
                if i != j {
                    blocks[i * 4 + j] = 0.1 + 0.05 * (i + 2 * j) as f32;
                }
            }
        }
        let matrix = TransferMatrix {
            layout,
            scales: Cow::Owned(vec![]),
            blocks: Cow::Owned(bytemuck::cast_slice(&blocks).to_vec()),
            sparse: SparseRows::empty(n),
            corrections: BlockCorrections::empty(n),
        };
        let patches = vec![
            Patch {
                reflectance: Rgb::splat(0.5),
                area: 1.0,
                ..Patch::default()
            };
            n
        ];
        let edits = [(0, Rgb::new(0.9, 0.1, 0.3)), (2, Rgb::new(0.2, 0.8, 0.6))];
        let edit = ReflectanceEdit::new(&matrix, DecodeMode::D3d10, &patches, &edits).unwrap();
        let gathered = [
            Rgb::new(1.0, 2.0, 3.0),
            Rgb::splat(5.0),
            Rgb::new(0.5, 0.25, 4.0),
        ];
        let mut want = Vec::new();
        edit.correction(&gathered, &mut Default::default(), &mut want);
        let k = edit.len();
        let dense = edit.correction_matrices();
        for (a, &(p, w)) in want.iter().enumerate() {
            assert_eq!(p, edit.patches()[a] as usize);
            for c in 0..3 {
                let got: f32 = (0..k)
                    .map(|b| dense[c][a * k + b] * gathered[edit.patches()[b] as usize].channel(c))
                    .sum();
                // Two f32 roundings of each entry against the solve's f64 sums.
                assert!(
                    (got - w.channel(c)).abs() <= 1e-5 * w.channel(c).abs().max(1.0),
                    "{got} {w:?}"
                );
            }
        }
    }

    #[test]
    fn lu_solves_a_pivoting_system() {
        // [[0, 2], [3, 1]] x = [4, 5] → x = [1, 2]; the zero pivot forces a swap.
        let mut a = vec![0.0, 2.0, 3.0, 1.0];
        let piv = lu_factor(&mut a, 2).unwrap();
        let a: Vec<f32> = a.iter().map(|&v| v as f32).collect();
        let mut b = vec![4.0, 5.0];
        lu_solve(&a, &piv, 2, &mut b, &mut [0.0; 2]);
        assert!(
            (b[0] - 1.0).abs() < 1e-12 && (b[1] - 2.0).abs() < 1e-12,
            "{b:?}"
        );
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(lu_factor(&mut singular, 2).is_none());
    }
}
