//! The large entries, kept exactly in compressed sparse rows.

use crate::{RadError, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;

/// Entries of the transfer matrix too large to quantise, stored exactly (CSR). Each value is
/// the exact entry minus what the blocks decode at its position (the encoder leaves those texels
/// out of the block fit), so a gather adds both parts and gets the exact entry back.
#[derive(Clone, Debug, PartialEq)]
pub struct SparseRows<'a> {
    /// `n + 1` offsets into `cols`; row `i` owns `cols[row_ptr[i]..row_ptr[i+1]]`.
    pub row_ptr: Cow<'a, [u32]>,
    /// Column of each entry, strictly increasing within a row.
    pub cols: Cow<'a, [u32]>,
    /// `channels` values per entry, interleaved.
    pub values: Cow<'a, [f32]>,
}

impl SparseRows<'static> {
    /// No entries for `n` rows.
    pub fn empty(n: usize) -> Self {
        Self {
            row_ptr: Cow::Owned(alloc::vec![0; n + 1]),
            cols: Cow::Owned(Vec::new()),
            values: Cow::Owned(Vec::new()),
        }
    }
}

impl SparseRows<'_> {
    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.cols.len()
    }

    /// The entries of `row`: `(column, values)` pairs.
    pub fn row(&self, row: usize, channels: usize) -> impl Iterator<Item = (usize, &[f32])> + '_ {
        let (a, b) = (self.row_ptr[row] as usize, self.row_ptr[row + 1] as usize);
        self.cols[a..b]
            .iter()
            .zip(self.values[a * channels..b * channels].chunks_exact(channels))
            .map(|(c, v)| (*c as usize, v))
    }

    /// Bytes the three arrays take.
    pub fn bytes(&self) -> usize {
        4 * (self.row_ptr.len() + self.cols.len() + self.values.len())
    }

    /// Copies borrowed arrays so the value outlives its source bytes.
    pub fn into_owned(self) -> SparseRows<'static> {
        SparseRows {
            row_ptr: Cow::Owned(self.row_ptr.into_owned()),
            cols: Cow::Owned(self.cols.into_owned()),
            values: Cow::Owned(self.values.into_owned()),
        }
    }
}

/// Checks a compressed-sparse-row structure of `rows` rows whose columns lie in `0..bound`:
/// `rows + 1` offsets from 0, never decreasing, ending at `cols.len()`, and columns strictly
/// increasing within each row. Errors name `sections` (offsets, columns) and the first bad
/// index; `row` is what a row is called in them.
pub(crate) fn validate_csr(
    row_ptr: &[u32],
    cols: &[u32],
    rows: usize,
    bound: usize,
    sections: (SectionKind, SectionKind),
    row: &'static str,
) -> Result<(), RadError> {
    let (rows_kind, cols_kind) = sections;
    let bad = |section, index: usize, reason| RadError::Invalid {
        section,
        index: index as u64,
        reason,
    };
    if row_ptr.len() != rows + 1 {
        return Err(RadError::Count {
            section: rows_kind,
            expected: rows as u64 + 1,
            found: row_ptr.len() as u64,
        });
    }
    if row_ptr[0] != 0 {
        return Err(bad(rows_kind, 0, "first row offset is not 0"));
    }
    if let Some(i) = row_ptr.windows(2).position(|w| w[1] < w[0]) {
        return Err(bad(rows_kind, i + 1, "row offsets decrease"));
    }
    if row_ptr[rows] as usize != cols.len() {
        return Err(RadError::Count {
            section: cols_kind,
            expected: u64::from(row_ptr[rows]),
            found: cols.len() as u64,
        });
    }
    for r in 0..rows {
        let (a, b) = (row_ptr[r] as usize, row_ptr[r + 1] as usize);
        for k in a..b {
            if cols[k] as usize >= bound {
                return Err(bad(cols_kind, k, "column out of range"));
            }
            if k > a && cols[k] <= cols[k - 1] {
                return Err(bad(cols_kind, k, row));
            }
        }
    }
    Ok(())
}
