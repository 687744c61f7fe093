//! Block corrections: a few whole 4×4 blocks made nearly exact by a coarse residual.
//!
//! After the block fit and the sparse list, the error of a well-ordered matrix is concentrated
//! in few blocks (near-field blocks, where neighbouring entries differ by O(1)): on the Cornell
//! box in the paper's order the worst 2% of BC1 blocks hold about half of the squared error,
//! in a random order about a tenth. A correction adds to one block, per channel, sixteen signed
//! 4-bit multiples of a scale:
//!
//! `value[k][t] += (nibble[k][t] − 8) · scale_k(e_k)`, `scale_k(e) = base_k · 2^(−e/8)`,
//!
//! `e_k` a byte per block and channel, `base_k` one `f32` per channel for the whole matrix. A
//! correction costs `4 + 9·channels` bytes (31 for RGB), about two sparse entries, and fixes
//! sixteen texels. The corrections are stored in compressed sparse rows over block rows, like
//! the sparse entries over rows: block row `i` (matrix rows `4i..4i+4`) owns
//! `cols[row_ptr[i]..row_ptr[i+1]]`, block columns strictly increasing.
//!
//! `scale_k(e)` is `base_k · F[e & 7]` rounded once to `f32`, times the exact power of two
//! `2^−(e >> 3)`, with `F[j] = 2^(−j/8)` written out below: no transcendental function, so every
//! decoder (reference, CPU, GPU, `std` or not) gets the same bits.

use crate::layout::{Format, MatrixLayout};
use crate::{BlockValues, RadError, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;

/// `2^(−j/8)` for `j` in `0..8`, rounded to `f32`.
const EIGHTH_OCTAVES: [f32; 8] = [
    1.0,
    0.917_004_05,
    0.840_896_4,
    0.771_105_4,
    0.707_106_77,
    0.648_419_8,
    0.594_603_54,
    0.545_253_9,
];

/// The nibble that means "no correction" (multiple 0).
pub const ZERO_NIBBLE: u32 = 8;

/// Exponent steps per octave of the scale (`scale = base · 2^(−e/STEPS)`).
pub const EXPONENT_STEPS: u32 = 8;

/// The block corrections of a matrix (module docs). Empty in files without any.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockCorrections<'a> {
    /// `padded / 4 + 1` offsets into `cols`, one per block row and one past the end.
    pub row_ptr: Cow<'a, [u32]>,
    /// Block column of each correction, strictly increasing within a block row.
    pub cols: Cow<'a, [u32]>,
    /// `channels` scale exponents per correction.
    pub exponents: Cow<'a, [u8]>,
    /// `2 · channels` words per correction: channel `k`'s sixteen nibbles in words `2k` and
    /// `2k + 1`, texel `t` (row-major in the block) at bits `4·(t % 8)` of word `t / 8`.
    pub codes: Cow<'a, [u32]>,
    /// Per channel, the scale of exponent 0; 0 in unused channels and when there are no
    /// corrections.
    pub base: [f32; 3],
}

impl BlockCorrections<'static> {
    /// No corrections for a matrix of `n` patches.
    pub fn empty(n: usize) -> Self {
        Self {
            row_ptr: Cow::Owned(alloc::vec![0; n.div_ceil(4) + 1]),
            cols: Cow::Owned(Vec::new()),
            exponents: Cow::Owned(Vec::new()),
            codes: Cow::Owned(Vec::new()),
            base: [0.0; 3],
        }
    }
}

impl BlockCorrections<'_> {
    /// Number of corrected blocks.
    pub fn count(&self) -> usize {
        self.cols.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.cols.is_empty()
    }

    /// Bytes the four arrays take.
    pub fn bytes(&self) -> usize {
        4 * (self.row_ptr.len() + self.cols.len() + self.codes.len()) + self.exponents.len()
    }

    /// The corrections of block row `block_row`: `(block column, correction index)` pairs.
    pub fn row(&self, block_row: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        let (a, b) = (
            self.row_ptr[block_row] as usize,
            self.row_ptr[block_row + 1] as usize,
        );
        self.cols[a..b]
            .iter()
            .enumerate()
            .map(move |(i, c)| (*c as usize, a + i))
    }

    /// The 256 scales of channel `k`: `scale_k(e)` (module docs).
    pub fn scale_table(&self, k: usize) -> [f32; 256] {
        let base = self.base[k];
        core::array::from_fn(|e| scale(base, e as u8))
    }

    /// Adds correction `index` to `out` (a block's decoded values, `channels` of them), using
    /// `tables` from [`BlockCorrections::scale_table`].
    pub fn add(
        &self,
        index: usize,
        channels: usize,
        tables: &[[f32; 256]; 3],
        out: &mut BlockValues,
    ) {
        for (k, values) in out.iter_mut().enumerate().take(channels) {
            let s = tables[k][usize::from(self.exponents[index * channels + k])];
            let words = &self.codes[(index * channels + k) * 2..][..2];
            for (t, v) in values.iter_mut().enumerate() {
                *v += multiple(words, t) as f32 * s;
            }
        }
    }

    /// Copies borrowed arrays so the value outlives its source bytes.
    pub fn into_owned(self) -> BlockCorrections<'static> {
        BlockCorrections {
            row_ptr: Cow::Owned(self.row_ptr.into_owned()),
            cols: Cow::Owned(self.cols.into_owned()),
            exponents: Cow::Owned(self.exponents.into_owned()),
            codes: Cow::Owned(self.codes.into_owned()),
            base: self.base,
        }
    }

    /// Checks what a gather relies on for a matrix of `layout`: counts, offsets, columns, bases,
    /// and that texels beyond the last patch are not corrected.
    pub fn validate(&self, layout: &MatrixLayout) -> Result<(), RadError> {
        let bad = |section, index: usize, reason| RadError::Invalid {
            section,
            index: index as u64,
            reason,
        };
        let (n, ch) = (layout.n(), layout.channels());
        let side = layout.padded() / 4;
        let count = self.cols.len();
        crate::sparse::validate_csr(
            &self.row_ptr,
            &self.cols,
            side,
            side,
            (SectionKind::CorrectionRows, SectionKind::CorrectionCols),
            "columns not strictly increasing in a block row",
        )?;
        if self.exponents.len() != count * ch {
            return Err(RadError::Count {
                section: SectionKind::CorrectionExponents,
                expected: (count * ch) as u64,
                found: self.exponents.len() as u64,
            });
        }
        if self.codes.len() != count * ch * 2 {
            return Err(RadError::Count {
                section: SectionKind::CorrectionCodes,
                expected: (count * ch * 2) as u64,
                found: self.codes.len() as u64,
            });
        }
        if count > 0 && !matches!(layout.format(), Format::Bc1 | Format::Bc4) {
            return Err(bad(
                SectionKind::Meta,
                0,
                "block corrections on a format other than BC1 and BC4",
            ));
        }
        for (k, b) in self.base.iter().enumerate() {
            let ok = if k < ch && count > 0 {
                b.is_finite() && *b > 0.0
            } else {
                *b == 0.0
            };
            if !ok {
                return Err(bad(
                    SectionKind::Meta,
                    0,
                    "correction base not finite and positive, or set where unused",
                ));
            }
        }
        for br in 0..side {
            let (a, b) = (self.row_ptr[br] as usize, self.row_ptr[br + 1] as usize);
            for i in a..b {
                let bc = self.cols[i] as usize;
                // Texels beyond the last patch must carry the zero multiple, so that every
                // decoder sees the same matrix whether or not it skips the padding.
                if 4 * br + 4 > n || 4 * bc + 4 > n {
                    for k in 0..ch {
                        let words = &self.codes[(i * ch + k) * 2..][..2];
                        let stray = (0..16).any(|t| {
                            (4 * br + t / 4 >= n || 4 * bc + t % 4 >= n) && multiple(words, t) != 0
                        });
                        if stray {
                            return Err(bad(
                                SectionKind::CorrectionCodes,
                                (i * ch + k) * 2,
                                "correction of a texel beyond the last patch",
                            ));
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// The signed multiple `nibble − 8` of texel `t` in a channel's two code words.
pub fn multiple(words: &[u32], t: usize) -> i32 {
    ((words[t / 8] >> (4 * (t % 8))) & 15) as i32 - ZERO_NIBBLE as i32
}

/// `base · 2^(−e/8)` as every decoder computes it (module docs).
pub fn scale(base: f32, e: u8) -> f32 {
    let octave = u32::from(e) / EXPONENT_STEPS;
    // 2^−octave, exact: octave ≤ 31 keeps it a normal f32.
    let pow2 = f32::from_bits((127 - octave) << 23);
    base * EIGHTH_OCTAVES[usize::from(e) % EXPONENT_STEPS as usize] * pow2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_step_by_an_eighth_of_an_octave() {
        // Each step is 2^(−1/8) to f32 precision (two roundings: 2 ulp, 2.4e-7 relative).
        for e in 0..255u8 {
            let (a, b) = (scale(1.5, e), scale(1.5, e + 1));
            let ratio = f64::from(b) / f64::from(a);
            assert!(
                (ratio - 2f64.powf(-1.0 / 8.0)).abs() < 3e-7,
                "e = {e}: {ratio}"
            );
        }
        assert_eq!(scale(1.5, 0), 1.5);
        assert_eq!(scale(1.5, 8), 0.75);
        for (j, f) in EIGHTH_OCTAVES.iter().enumerate() {
            assert!((f64::from(*f) - 2f64.powf(-(j as f64) / 8.0)).abs() < 6e-8);
        }
    }

    #[test]
    fn multiples_read_nibbles_in_texel_order() {
        // Texel t holds t − 8 (nibble t): words 0x76543210 and 0xfedcba98.
        let words = [0x7654_3210, 0xfedc_ba98];
        for t in 0..16 {
            assert_eq!(multiple(&words, t), t as i32 - 8);
        }
    }
}
