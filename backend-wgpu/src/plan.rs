//! How a matrix is cut for a device: bands of block rows (and, for textures, of block columns)
//! that respect the device's limits, and the bytes of each band assembled from the file's tiles.
//!
//! The file stores the matrix tile by tile (`MatrixLayout`). On the GPU a band is a rectangle
//! of blocks inside **one tile row** (so one workgroup's four output rows share a tile row and
//! its log tables), laid out plane after plane, each plane block-row-major over the band: the
//! standard layout of a BC texture of the band's size. A band may span several tile columns;
//! the kernel switches tables at each tile boundary.

use radiosity_core::{MatrixLayout, SparseRows};

/// A rectangle of blocks of the padded matrix that one dispatch covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Band {
    /// First block row.
    pub(crate) row0: usize,
    /// Block rows (one workgroup each).
    pub(crate) rows: usize,
    /// First block column.
    pub(crate) col0: usize,
    /// Block columns.
    pub(crate) cols: usize,
    /// Which column group (slab of partial sums) the band writes.
    pub(crate) group: usize,
}

/// The device limits a plan respects.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlanLimits {
    /// Largest storage binding, bytes (`min(max_storage_buffer_binding_size, max_buffer_size)`).
    pub(crate) binding_bytes: u64,
    /// Largest texture side, texels (`max_texture_dimension_2d`).
    pub(crate) texture_side: u32,
    /// Largest dispatch along x (`max_compute_workgroups_per_dimension`).
    pub(crate) workgroups: u32,
}

/// Splits `0..len` at every multiple of `period` and into pieces of at most `most`.
fn pieces(len: usize, period: usize, most: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut a = 0;
    while a < len {
        let b = (a / period + 1) * period;
        let b = b.min(a + most).min(len);
        out.push((a, b - a));
        a = b;
    }
    out
}

/// Bands for the storage-buffer source: every block column, rows cut at tile rows and so that
/// each band's bytes (all planes) fit one binding. Errors when a single block row does not.
pub(crate) fn buffer_bands(l: &MatrixLayout, lim: &PlanLimits) -> Result<Vec<Band>, String> {
    let (blocks, tile) = (l.padded() / 4, l.tile_size() / 4);
    let row_bytes = (blocks * l.planes() * l.format().block_bytes()) as u64;
    let rows = lim.binding_bytes / row_bytes;
    if rows == 0 {
        return Err(format!(
            "one block row of the matrix takes {row_bytes} bytes, more than the device's largest storage binding ({} bytes)",
            lim.binding_bytes
        ));
    }
    let most = (rows as usize).min(lim.workgroups as usize);
    Ok(pieces(blocks, tile, most)
        .into_iter()
        .map(|(row0, rows)| Band {
            row0,
            rows,
            col0: 0,
            cols: blocks,
            group: 0,
        })
        .collect())
}

/// Bands for the texture source: rectangles whose sides fit `texture_side` (and the binding
/// limit, which a texture's bytes count against on some backends), rows cut at tile rows.
/// Returns the bands and the number of column groups.
pub(crate) fn texture_bands(
    l: &MatrixLayout,
    lim: &PlanLimits,
) -> Result<(Vec<Band>, usize), String> {
    let side = (lim.texture_side / 4) as usize;
    if side == 0 {
        return Err(format!(
            "the device's largest texture ({} texels) is smaller than one block",
            lim.texture_side
        ));
    }
    let (blocks, tile) = (l.padded() / 4, l.tile_size() / 4);
    let cols = pieces(blocks, blocks, side);
    let rows = pieces(blocks, tile, side.min(lim.workgroups as usize));
    let mut bands = Vec::with_capacity(rows.len() * cols.len());
    for &(row0, nrows) in &rows {
        for (group, &(col0, ncols)) in cols.iter().enumerate() {
            bands.push(Band {
                row0,
                rows: nrows,
                col0,
                cols: ncols,
                group,
            });
        }
    }
    Ok((bands, cols.len()))
}

/// Appends plane `plane` of `band` (block-row-major, the band's own width) to `out`, copied
/// from the file's tiled block data.
pub(crate) fn copy_plane(
    l: &MatrixLayout,
    data: &[u8],
    plane: usize,
    band: &Band,
    out: &mut Vec<u8>,
) {
    let bb = l.format().block_bytes();
    let tile = l.tile_size() / 4;
    for r in band.row0..band.row0 + band.rows {
        let ty = r / tile;
        let mut c = band.col0;
        let end = band.col0 + band.cols;
        while c < end {
            let t = l.tile(ty, c / tile);
            let stop = end.min(t.col0 / 4 + t.blocks_wide());
            let off = l.block_offset(&t, plane, r - t.row0 / 4, c - t.col0 / 4);
            out.extend_from_slice(&data[off..off + (stop - c) * bb]);
            c = stop;
        }
    }
}

/// Rows `[row0, row0 + rows)` of the sparse part, each slice fitting one binding and one
/// dispatch of `workgroups` × 64 invocations.
pub(crate) fn sparse_bands(
    sp: &SparseRows<'_>,
    channels: usize,
    lim: &PlanLimits,
) -> Result<Vec<(usize, usize)>, String> {
    let n = sp.row_ptr.len() - 1;
    let most_rows = (lim.workgroups as usize) * 64;
    // Per entry: the value(s); the column array is smaller. Row offsets: 4 bytes a row.
    let entry = 4 * channels as u64;
    let mut out = Vec::new();
    let mut a = 0;
    while a < n {
        let mut b = a;
        while b < n && b - a < most_rows {
            let nnz = u64::from(sp.row_ptr[b + 1] - sp.row_ptr[a]);
            let ptr_bytes = 4 * (b + 2 - a) as u64;
            if nnz * entry > lim.binding_bytes || ptr_bytes > lim.binding_bytes {
                break;
            }
            b += 1;
        }
        if b == a {
            return Err(format!(
                "row {a} of the sparse part does not fit the device's largest storage binding ({} bytes)",
                lim.binding_bytes
            ));
        }
        out.push((a, b - a));
        a = b;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use radiosity_core::Format;

    const BIG: PlanLimits = PlanLimits {
        binding_bytes: 1 << 27,
        texture_side: 16384,
        workgroups: 65535,
    };

    #[test]
    fn pieces_cut_at_periods_and_sizes() {
        assert_eq!(pieces(10, 4, 100), vec![(0, 4), (4, 4), (8, 2)]);
        assert_eq!(pieces(10, 100, 3), vec![(0, 3), (3, 3), (6, 3), (9, 1)]);
        assert_eq!(
            pieces(10, 4, 3),
            vec![(0, 3), (3, 1), (4, 3), (7, 1), (8, 2)]
        );
    }

    /// Band bytes are the blocks the layout says are at each (row, column), whatever the tiling
    /// and the cut.
    #[test]
    fn copied_planes_follow_the_layout() {
        for (format, channels, max_tile) in [
            (Format::Bc4, 3, 16),
            (Format::U8, 1, 8),
            (Format::Bc1, 3, 12),
            (Format::F16, 3, 8192),
        ] {
            let l = MatrixLayout::new(37, channels, format, max_tile).unwrap();
            let data: Vec<u8> = (0..l.block_bytes()).map(|i| (i * 7 % 251) as u8).collect();
            let lim = PlanLimits {
                texture_side: 12,
                binding_bytes: 3 * 10 * 64,
                ..BIG
            };
            let (tex, groups) = texture_bands(&l, &lim).unwrap();
            assert_eq!(
                groups, 4,
                "40 columns in textures of 12: 3 + 3 + 3 + 1 blocks"
            );
            let buf = buffer_bands(&l, &lim).unwrap();
            for band in tex.iter().chain(&buf) {
                assert!(band.cols * 4 <= 40 && band.rows > 0);
                let ty = band.row0 / (l.tile_size() / 4);
                assert_eq!(
                    (band.row0 + band.rows - 1) / (l.tile_size() / 4),
                    ty,
                    "a band stays in one tile row"
                );
                for plane in 0..l.planes() {
                    let mut out = Vec::new();
                    copy_plane(&l, &data, plane, band, &mut out);
                    let bb = format.block_bytes();
                    assert_eq!(out.len(), band.rows * band.cols * bb);
                    for r in 0..band.rows {
                        for c in 0..band.cols {
                            let (t, br, bc) = l.locate((band.row0 + r) * 4, (band.col0 + c) * 4);
                            let off = l.block_offset(&t, plane, br, bc);
                            let got = &out[(r * band.cols + c) * bb..][..bb];
                            assert_eq!(got, &data[off..off + bb], "{format} band {band:?}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn buffer_bands_fit_the_binding() {
        // 40 padded columns = 10 blocks; BC4 RGB: 240 bytes a block row.
        let l = MatrixLayout::new(40, 3, Format::Bc4, 8192).unwrap();
        let lim = PlanLimits {
            binding_bytes: 1000,
            ..BIG
        };
        let bands = buffer_bands(&l, &lim).unwrap();
        assert_eq!(
            bands.iter().map(|b| b.rows).collect::<Vec<_>>(),
            vec![4, 4, 2]
        );
        let tiny = PlanLimits {
            binding_bytes: 100,
            ..BIG
        };
        assert!(buffer_bands(&l, &tiny).unwrap_err().contains("240 bytes"));
    }

    #[test]
    fn sparse_bands_cover_every_row() {
        let sp = SparseRows {
            row_ptr: vec![0, 3, 3, 9, 10].into(),
            cols: vec![0; 10].into(),
            values: vec![0.0; 30].into(),
        };
        let lim = PlanLimits {
            binding_bytes: 6 * 12,
            ..BIG
        };
        assert_eq!(
            sparse_bands(&sp, 3, &lim).unwrap(),
            vec![(0, 2), (2, 1), (3, 1)],
            "rows 0-1 hold 3 entries (36 bytes), 0-2 would hold 9 (108); row 2 holds 6 (72), 2-3 would hold 7 (84)"
        );
        let tight = PlanLimits {
            binding_bytes: 5 * 12,
            ..BIG
        };
        assert!(
            sparse_bands(&sp, 3, &tight).is_err(),
            "row 2 alone needs 72 bytes"
        );
    }
}
