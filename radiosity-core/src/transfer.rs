//! The stored transfer matrix: layout, per-tile scales, block data and the sparse large entries.

use crate::bc1::Bc1Block;
use crate::bc4::Bc4Block;
use crate::half::{f16_is_finite, f16_to_f32};
use crate::layout::{Format, MatrixLayout, Tile};
use crate::{BlockCorrections, DecodeMode, LogScale, RadError, SectionKind, SparseRows};
use alloc::borrow::Cow;
use alloc::vec::Vec;

/// A transfer matrix as stored: `M` in the patch numbering of the file (the reordering is
/// already applied), ready to gather from.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferMatrix<'a> {
    /// Shape and format.
    pub layout: MatrixLayout,
    /// One [`LogScale`] per tile and channel ([`MatrixLayout::scale_index`]); empty for the
    /// float formats.
    pub scales: Cow<'a, [LogScale]>,
    /// Block data in the order [`MatrixLayout`] describes.
    pub blocks: Cow<'a, [u8]>,
    /// The large entries, exact; zero in the blocks.
    pub sparse: SparseRows<'a>,
    /// Residuals added to a few whole blocks ([`BlockCorrections`]); empty for the float formats.
    pub corrections: BlockCorrections<'a>,
}

/// Decodes blocks of one matrix to values: holds the decode mode and a 256-entry table per scale.
#[derive(Clone, Debug)]
pub struct BlockDecoder {
    mode: DecodeMode,
    tables: Vec<[f32; 256]>,
}

/// The 16 values of one 4×4 block, per channel (row-major in the block). A one-channel matrix
/// fills only `[0]`.
pub type BlockValues = [[f32; 16]; 3];

impl TransferMatrix<'static> {
    /// No matrix, in `layout` ([`MatrixLayout::none`]): a level file's own, whose transfer
    /// lives in its systems.
    pub fn none(layout: MatrixLayout) -> Self {
        Self {
            layout,
            scales: Cow::Owned(Vec::new()),
            blocks: Cow::Owned(Vec::new()),
            sparse: SparseRows {
                row_ptr: Cow::Owned(alloc::vec![0; layout.n() + 1]),
                cols: Cow::Owned(Vec::new()),
                values: Cow::Owned(Vec::new()),
            },
            corrections: BlockCorrections::empty(layout.n()),
        }
    }
}

impl<'a> TransferMatrix<'a> {
    /// Checks everything a gather relies on: counts, sizes, scales, finite non-negative values,
    /// and the sparse structure. Errors name the section and the index of the first bad item.
    pub fn validate(&self) -> Result<(), RadError> {
        let l = &self.layout;
        let n = l.n();
        let bad = |section, index: usize, reason| RadError::Invalid {
            section,
            index: index as u64,
            reason,
        };
        if self.scales.len() != l.scale_count() {
            return Err(RadError::Count {
                section: SectionKind::Scales,
                expected: l.scale_count() as u64,
                found: self.scales.len() as u64,
            });
        }
        if let Some(i) = self.scales.iter().position(|s| !s.is_valid()) {
            return Err(bad(SectionKind::Scales, i, "scale not finite and positive"));
        }
        if self.blocks.len() as u64 != l.block_bytes() {
            return Err(RadError::Count {
                section: SectionKind::Blocks,
                expected: l.block_bytes(),
                found: self.blocks.len() as u64,
            });
        }
        match l.format() {
            Format::F16 => {
                for (i, h) in self.blocks.chunks_exact(2).enumerate() {
                    let h = u16::from_le_bytes([h[0], h[1]]);
                    if !f16_is_finite(h) || (h & 0x8000 != 0 && h != 0x8000) {
                        return Err(bad(
                            SectionKind::Blocks,
                            i,
                            "f16 entry not finite and non-negative",
                        ));
                    }
                }
            }
            Format::F32 => {
                for (i, v) in self.blocks.chunks_exact(4).enumerate() {
                    let v = f32::from_le_bytes([v[0], v[1], v[2], v[3]]);
                    if !(v.is_finite() && v >= 0.0) {
                        return Err(bad(
                            SectionKind::Blocks,
                            i,
                            "f32 entry not finite and non-negative",
                        ));
                    }
                }
            }
            _ => {}
        }
        let sp = &self.sparse;
        crate::sparse::validate_csr(
            &sp.row_ptr,
            &sp.cols,
            n,
            n,
            (SectionKind::SparseRows, SectionKind::SparseCols),
            "columns not strictly increasing in a row",
        )?;
        if sp.values.len() != sp.cols.len() * l.channels() {
            return Err(RadError::Count {
                section: SectionKind::SparseValues,
                expected: (sp.cols.len() * l.channels()) as u64,
                found: sp.values.len() as u64,
            });
        }
        // A sparse value corrects what the block decodes at its position, so it may be negative
        // in a channel; it must be finite.
        if let Some(i) = sp.values.iter().position(|v| !v.is_finite()) {
            return Err(bad(SectionKind::SparseValues, i, "value not finite"));
        }
        self.corrections.validate(l)
    }

    /// A decoder for this matrix under `mode` (builds the scale tables once).
    pub fn decoder(&self, mode: DecodeMode) -> BlockDecoder {
        BlockDecoder {
            mode,
            tables: self.scales.iter().map(LogScale::table).collect(),
        }
    }

    /// Bytes of block data plus sparse arrays plus corrections plus scales: what a gather reads.
    pub fn bytes(&self) -> usize {
        self.blocks.len()
            + self.sparse.bytes()
            + self.corrections.bytes()
            + self.scales.len() * core::mem::size_of::<LogScale>()
    }

    /// The whole matrix decoded, row-major, `channels` values per entry interleaved, blocks,
    /// block corrections and sparse part added. Allocates `n² · channels` floats: for tests and error measurement.
    pub fn decode_dense(&self, mode: DecodeMode) -> Vec<f32> {
        let l = &self.layout;
        let (n, ch) = (l.n(), l.channels());
        let mut out = alloc::vec![0f32; n * n * ch];
        let dec = self.decoder(mode);
        let mut vals = [[0f32; 16]; 3];
        for tile in l.tiles() {
            for br in 0..tile.blocks_high() {
                for bc in 0..tile.blocks_wide() {
                    dec.decode(self, &tile, br, bc, &mut vals);
                    for i in 0..16 {
                        let (r, c) = (tile.row0 + br * 4 + i / 4, tile.col0 + bc * 4 + i % 4);
                        if r < n && c < n {
                            for k in 0..ch {
                                out[(r * n + c) * ch + k] = vals[k][i];
                            }
                        }
                    }
                }
            }
        }
        self.for_each_correction(|r, c, v| {
            for k in 0..ch {
                out[(r * n + c) * ch + k] += v[k];
            }
        });
        for r in 0..n {
            for (c, v) in self.sparse.row(r, ch) {
                for k in 0..ch {
                    out[(r * n + c) * ch + k] += v[k];
                }
            }
        }
        out
    }

    /// Rows `rows` of the matrix decoded (each below `n`, in the order given), row-major
    /// `rows.len() × n`, `channels` values per entry interleaved, blocks, block corrections
    /// and sparse part added: the same entries as [`TransferMatrix::decode_dense`], for the
    /// block rows that hold them only.
    ///
    /// Panics if a row is not below `n` (a programming error).
    pub fn decode_rows(&self, mode: DecodeMode, rows: &[u32]) -> Vec<f32> {
        let l = &self.layout;
        let (n, ch) = (l.n(), l.channels());
        assert!(
            rows.iter().all(|&r| (r as usize) < n),
            "row past the matrix"
        );
        let mut out = alloc::vec![0f32; rows.len() * n * ch];
        // Which output rows each matrix row fills (a row may be asked for twice).
        let mut by_row: Vec<(u32, usize)> = rows.iter().enumerate().map(|(a, &r)| (r, a)).collect();
        by_row.sort_unstable();
        let wanted = |r0: usize, r1: usize| {
            let lo = by_row.partition_point(|&(r, _)| (r as usize) < r0);
            let hi = by_row.partition_point(|&(r, _)| (r as usize) < r1);
            &by_row[lo..hi]
        };
        let dec = self.decoder(mode);
        let mut vals = [[0f32; 16]; 3];
        for tile in l.tiles() {
            for br in 0..tile.blocks_high() {
                let r0 = tile.row0 + br * 4;
                let here = wanted(r0, r0 + 4);
                if here.is_empty() {
                    continue;
                }
                for bc in 0..tile.blocks_wide() {
                    dec.decode(self, &tile, br, bc, &mut vals);
                    for &(r, a) in here {
                        let i0 = (r as usize - r0) * 4;
                        for cc in 0..4 {
                            let c = tile.col0 + bc * 4 + cc;
                            if c < n {
                                for k in 0..ch {
                                    out[(a * n + c) * ch + k] = vals[k][i0 + cc];
                                }
                            }
                        }
                    }
                }
            }
        }
        self.for_each_correction(|r, c, v| {
            for &(_, a) in wanted(r, r + 1) {
                for k in 0..ch {
                    out[(a * n + c) * ch + k] += v[k];
                }
            }
        });
        for &(r, a) in &by_row {
            for (c, v) in self.sparse.row(r as usize, ch) {
                for k in 0..ch {
                    out[(a * n + c) * ch + k] += v[k];
                }
            }
        }
        out
    }

    /// Copies borrowed parts so the matrix outlives its source bytes.
    pub fn into_owned(self) -> TransferMatrix<'static> {
        TransferMatrix {
            layout: self.layout,
            scales: Cow::Owned(self.scales.into_owned()),
            blocks: Cow::Owned(self.blocks.into_owned()),
            sparse: self.sparse.into_owned(),
            corrections: self.corrections.into_owned(),
        }
    }

    /// The sparse list with the block corrections folded in: every corrected texel with a
    /// non-zero multiple becomes an entry (added to the sparse entry already there, if any),
    /// valued as [`BlockCorrections::add`] values it. For a backend without a corrections pass
    /// of its own; 16 entries per correction at most, so it costs more memory than the
    /// corrections themselves.
    pub fn sparse_with_corrections(&self) -> SparseRows<'static> {
        let l = &self.layout;
        let (n, ch) = (l.n(), l.channels());
        let tables = self.correction_tables();
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut cols = Vec::new();
        let mut values = Vec::new();
        row_ptr.push(0u32);
        let mut fixes: Vec<(usize, BlockValues)> = Vec::new();
        for r in 0..n {
            if r % 4 == 0 {
                fixes.clear();
                for (bc, index) in self.corrections.row(r / 4) {
                    let mut fix = [[0f32; 16]; 3];
                    self.corrections.add(index, ch, &tables, &mut fix);
                    fixes.push((bc, fix));
                }
            }
            let mut sparse = self.sparse.row(r, ch).peekable();
            let mut corrected = fixes
                .iter()
                .flat_map(|(bc, fix)| {
                    (0..4).map(move |j| {
                        let t = (r % 4) * 4 + j;
                        (bc * 4 + j, core::array::from_fn::<f32, 3, _>(|k| fix[k][t]))
                    })
                })
                .filter(|(c, v)| *c < n && v[..ch].iter().any(|x| *x != 0.0))
                .peekable();
            loop {
                let next_sparse = sparse.peek().map(|(c, _)| *c);
                let next_fix = corrected.peek().map(|(c, _)| *c);
                let (c, v): (usize, [f32; 3]) = match (next_sparse, next_fix) {
                    (None, None) => break,
                    (Some(a), Some(b)) if a == b => {
                        let (_, s) = sparse.next().expect("peeked");
                        let (_, f) = corrected.next().expect("peeked");
                        (
                            a,
                            core::array::from_fn(|k| if k < ch { s[k] + f[k] } else { 0.0 }),
                        )
                    }
                    (Some(a), b) if b.is_none_or(|b| a < b) => {
                        let (_, s) = sparse.next().expect("peeked");
                        (a, core::array::from_fn(|k| if k < ch { s[k] } else { 0.0 }))
                    }
                    _ => corrected.next().expect("peeked"),
                };
                cols.push(c as u32);
                values.extend_from_slice(&v[..ch]);
            }
            row_ptr.push(cols.len() as u32);
        }
        SparseRows {
            row_ptr: Cow::Owned(row_ptr),
            cols: Cow::Owned(cols),
            values: Cow::Owned(values),
        }
    }

    /// Calls `f(row, column, values)` for every texel of every block correction inside the
    /// matrix (padding left out), with the values [`BlockCorrections::add`] gives (`channels`
    /// of them used), block rows in order.
    pub fn for_each_correction(&self, mut f: impl FnMut(usize, usize, &[f32; 3])) {
        let n = self.layout.n();
        let ch = self.layout.channels();
        let tables = self.correction_tables();
        for br in 0..self.layout.padded() / 4 {
            for (bc, index) in self.corrections.row(br) {
                let mut fix = [[0f32; 16]; 3];
                self.corrections.add(index, ch, &tables, &mut fix);
                for t in 0..16 {
                    let (r, c) = (br * 4 + t / 4, bc * 4 + t % 4);
                    if r < n && c < n {
                        f(r, c, &[fix[0][t], fix[1][t], fix[2][t]]);
                    }
                }
            }
        }
    }

    /// The scale tables of the block corrections, one per channel
    /// ([`BlockCorrections::scale_table`]; unused channels all zero).
    pub fn correction_tables(&self) -> [[f32; 256]; 3] {
        core::array::from_fn(|k| self.corrections.scale_table(k))
    }
}

impl BlockDecoder {
    /// A decoder for blocks quantised with `scales` (one per tile and channel, in
    /// [`MatrixLayout::scale_index`] order), e.g. blocks encoded one at a time before a whole
    /// matrix exists.
    pub fn from_scales(scales: &[LogScale], mode: DecodeMode) -> Self {
        BlockDecoder {
            mode,
            tables: scales.iter().map(LogScale::table).collect(),
        }
    }

    /// The decode mode in use.
    pub fn mode(&self) -> DecodeMode {
        self.mode
    }

    /// Decodes block (`br`, `bc`) of `tile` into `out[channel][texel]`.
    ///
    /// Panics if `m` is not the matrix this decoder was made for (table count differs) or the
    /// block lies outside the tile: both are programming errors, not bad input, since
    /// [`TransferMatrix::validate`] has checked the sizes.
    pub fn decode(
        &self,
        m: &TransferMatrix<'_>,
        tile: &Tile,
        br: usize,
        bc: usize,
        out: &mut BlockValues,
    ) {
        let l = &m.layout;
        assert_eq!(
            self.tables.len(),
            l.scale_count(),
            "decoder made for another matrix"
        );
        let bb = l.format().block_bytes();
        for plane in 0..l.planes() {
            let off = l.block_offset(tile, plane, br, bc);
            self.decode_plane(l, tile.index, plane, &m.blocks[off..off + bb], out);
        }
    }

    /// Decodes one plane's bytes of one block (`layout.format().block_bytes()` of them) of tile
    /// `tile_index` into `out`: every channel for BC1, channel `plane` otherwise.
    pub fn decode_plane(
        &self,
        layout: &MatrixLayout,
        tile_index: usize,
        plane: usize,
        raw: &[u8],
        out: &mut BlockValues,
    ) {
        let table = |ch: usize| &self.tables[layout.scale_index(tile_index, ch)];
        match layout.format() {
            Format::Bc1 => {
                let block = Bc1Block(raw.try_into().expect("8 bytes"));
                let texels = block.decode(self.mode);
                for ch in 0..3 {
                    let t = table(ch);
                    for i in 0..16 {
                        out[ch][i] = t[usize::from(texels[i][ch])];
                    }
                }
            }
            Format::Bc4 => {
                let codes = Bc4Block(raw.try_into().expect("8 bytes")).decode(self.mode);
                let t = table(plane);
                for i in 0..16 {
                    out[plane][i] = t[usize::from(codes[i])];
                }
            }
            Format::U8 => {
                let t = table(plane);
                for i in 0..16 {
                    out[plane][i] = t[usize::from(raw[i])];
                }
            }
            Format::F16 => {
                for i in 0..16 {
                    out[plane][i] = f16_to_f32(u16::from_le_bytes([raw[2 * i], raw[2 * i + 1]]));
                }
            }
            Format::F32 => {
                for i in 0..16 {
                    let b = &raw[4 * i..4 * i + 4];
                    out[plane][i] = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
        }
    }
}
