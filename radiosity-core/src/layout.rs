//! Where each matrix entry lives: formats, tiles, 4×4 blocks, channel planes.
//!
//! The `n × n` matrix is padded to a multiple of 4 and cut into square tiles of at most
//! `max_tile` rows (default 8192, so no tile exceeds a GPU's `max_texture_dimension_2d`). Tiles
//! are stored in row-major order over the tile grid. Inside a tile each channel plane is stored
//! in turn (BC1 has a single plane that carries all three channels), and inside a plane the 4×4
//! blocks are in block-row-major order, each block's 16 entries row-major. A tile's plane is
//! therefore exactly the bytes of a standard BC texture of the tile's size.

use core::fmt;

/// How the entries that are not in the sparse list are stored.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Log codes in BC1 blocks, R, G and B together: 0.5 byte per entry for all three channels.
    /// Requires three channels.
    Bc1 = 1,
    /// Log codes in one BC4 block per channel: 0.5 byte per entry per channel.
    Bc4 = 2,
    /// Plain log codes, one byte per entry per channel.
    U8 = 3,
    /// IEEE binary16 values, two bytes per entry per channel (no quantiser).
    F16 = 4,
    /// `f32` values, four bytes per entry per channel (no quantiser).
    F32 = 5,
}

impl Format {
    /// Every format, in the order reports list them.
    pub const ALL: [Format; 5] = [
        Format::Bc1,
        Format::Bc4,
        Format::U8,
        Format::F16,
        Format::F32,
    ];

    /// Every storable (format, channel count) pair: BC1 only holds three channels, the others
    /// one or three. What format-generic code and tests loop over.
    pub const CASES: [(Format, usize); 9] = [
        (Format::Bc1, 3),
        (Format::Bc4, 3),
        (Format::Bc4, 1),
        (Format::U8, 3),
        (Format::U8, 1),
        (Format::F16, 3),
        (Format::F16, 1),
        (Format::F32, 3),
        (Format::F32, 1),
    ];

    /// The format with this file code, if any.
    pub fn from_u32(v: u32) -> Option<Format> {
        Self::ALL.into_iter().find(|f| *f as u32 == v)
    }

    /// The lower-case name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Format::Bc1 => "bc1",
            Format::Bc4 => "bc4",
            Format::U8 => "u8",
            Format::F16 => "f16",
            Format::F32 => "f32",
        }
    }

    /// The format with this name, if any.
    pub fn from_name(name: &str) -> Option<Format> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// Bytes one 4×4 block takes in one plane.
    pub fn block_bytes(self) -> usize {
        match self {
            Format::Bc1 | Format::Bc4 => 8,
            Format::U8 => 16,
            Format::F16 => 32,
            Format::F32 => 64,
        }
    }

    /// Whether entries go through the log quantiser (and so each tile carries a [`crate::LogScale`]).
    pub fn is_log(self) -> bool {
        matches!(self, Format::Bc1 | Format::Bc4 | Format::U8)
    }

    /// Whether the format is block-compressed (lossy beyond quantisation).
    pub fn is_block_compressed(self) -> bool {
        matches!(self, Format::Bc1 | Format::Bc4)
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Default largest tile side: the `max_texture_dimension_2d` every wgpu adapter guarantees.
pub const DEFAULT_MAX_TILE: u32 = 8192;

/// Why a layout is impossible.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayoutError {
    /// `channels` is neither 1 nor 3.
    Channels(u32),
    /// BC1 stores RGB together and needs three channels.
    Bc1NeedsThreeChannels,
    /// `max_tile` is not a positive multiple of 4 (at most 65536).
    MaxTile(u32),
    /// The matrix has no rows.
    Empty,
    /// The sizes overflow 64-bit byte counts.
    TooLarge,
}

impl fmt::Display for LayoutError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LayoutError::Channels(c) => write!(f, "channels must be 1 or 3, not {c}"),
            LayoutError::Bc1NeedsThreeChannels => {
                f.write_str("bc1 stores RGB and needs 3 channels")
            }
            LayoutError::MaxTile(t) => {
                write!(
                    f,
                    "max tile {t} is not a positive multiple of 4 up to 65536"
                )
            }
            LayoutError::Empty => f.write_str("the matrix has no rows"),
            LayoutError::TooLarge => f.write_str("matrix too large for 64-bit byte counts"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LayoutError {}

/// The shape of a stored transfer matrix. Construct with [`MatrixLayout::new`], which checks it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct MatrixLayout {
    n: u32,
    channels: u32,
    format: Format,
    max_tile: u32,
    tile_size: u32,
    tiles_per_side: u32,
}

/// One tile: which rows and columns of the padded matrix it covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    /// Index in storage order (`ty · tiles_per_side + tx`).
    pub index: usize,
    /// First row.
    pub row0: usize,
    /// First column.
    pub col0: usize,
    /// Rows (a multiple of 4).
    pub rows: usize,
    /// Columns (a multiple of 4).
    pub cols: usize,
    /// Byte offset of the tile in the block data.
    pub offset: usize,
}

impl Tile {
    /// Blocks per block row.
    pub fn blocks_wide(&self) -> usize {
        self.cols / 4
    }
    /// Block rows.
    pub fn blocks_high(&self) -> usize {
        self.rows / 4
    }
}

impl MatrixLayout {
    /// Checks and builds the layout of an `n × n` matrix with `channels` (1 or 3) in `format`,
    /// tiles at most `max_tile` on a side.
    pub fn new(n: u32, channels: u32, format: Format, max_tile: u32) -> Result<Self, LayoutError> {
        if channels != 1 && channels != 3 {
            return Err(LayoutError::Channels(channels));
        }
        if format == Format::Bc1 && channels != 3 {
            return Err(LayoutError::Bc1NeedsThreeChannels);
        }
        if max_tile == 0 || !max_tile.is_multiple_of(4) || max_tile > 65536 {
            return Err(LayoutError::MaxTile(max_tile));
        }
        if n == 0 {
            return Err(LayoutError::Empty);
        }
        let padded = u64::from(n).div_ceil(4) * 4;
        let tile_size = padded.min(u64::from(max_tile)) as u32;
        let tiles_per_side = padded.div_ceil(u64::from(tile_size)) as u32;
        let layout = Self {
            n,
            channels,
            format,
            max_tile,
            tile_size,
            tiles_per_side,
        };
        layout.checked_block_bytes().ok_or(LayoutError::TooLarge)?;
        Ok(layout)
    }

    /// The layout of no matrix: a level file's own, whose transfer lives in its systems
    /// ([`crate::container::LevelSystems`]). No rows, tiles, blocks or scales; `channels`,
    /// `format` and `max_tile` are its systems' and checked as [`MatrixLayout::new`] does.
    pub fn none(channels: u32, format: Format, max_tile: u32) -> Result<Self, LayoutError> {
        // Checked with one row, then emptied: the same refusals as a real layout.
        let one = Self::new(1, channels, format, max_tile)?;
        Ok(Self {
            n: 0,
            tile_size: 0,
            tiles_per_side: 0,
            ..one
        })
    }

    /// Whether this is [`MatrixLayout::none`]'s layout (no matrix).
    pub fn is_none(&self) -> bool {
        self.n == 0
    }

    /// Patches (rows and columns).
    pub fn n(&self) -> usize {
        self.n as usize
    }
    /// Rows and columns after padding to a multiple of 4.
    pub fn padded(&self) -> usize {
        self.n().div_ceil(4) * 4
    }
    /// Stored channels: 1 for a grey scene, 3 for colour.
    pub fn channels(&self) -> usize {
        self.channels as usize
    }
    /// Storage format.
    pub fn format(&self) -> Format {
        self.format
    }
    /// The largest tile side requested.
    pub fn max_tile(&self) -> u32 {
        self.max_tile
    }
    /// The side of a full tile.
    pub fn tile_size(&self) -> usize {
        self.tile_size as usize
    }
    /// Tiles per row (and per column) of the tile grid.
    pub fn tiles_per_side(&self) -> usize {
        self.tiles_per_side as usize
    }
    /// Total tiles.
    pub fn tile_count(&self) -> usize {
        self.tiles_per_side() * self.tiles_per_side()
    }
    /// Planes per tile: 1 for BC1, else one per channel.
    pub fn planes(&self) -> usize {
        if self.format == Format::Bc1 {
            1
        } else {
            self.channels()
        }
    }
    /// Log scales stored: one per tile and channel for log formats, none otherwise.
    pub fn scale_count(&self) -> usize {
        if self.format.is_log() {
            self.tile_count() * self.channels()
        } else {
            0
        }
    }
    /// Index of the scale of `tile`, `channel`.
    pub fn scale_index(&self, tile: usize, channel: usize) -> usize {
        tile * self.channels() + channel
    }

    /// Bytes of block data, or `None` when it or the scale table would not fit in memory
    /// (`usize`): checked once in [`MatrixLayout::new`] so that every later `usize` product
    /// (offsets, counts) is free of overflow on any target.
    fn checked_block_bytes(&self) -> Option<u64> {
        let padded = u64::from(self.n).div_ceil(4) * 4;
        let blocks = (padded / 4).checked_mul(padded / 4)?;
        let bytes = blocks
            .checked_mul(self.planes() as u64)?
            .checked_mul(self.format.block_bytes() as u64)?;
        let tiles = u64::from(self.tiles_per_side).checked_mul(u64::from(self.tiles_per_side))?;
        let scale_bytes = tiles
            .checked_mul(u64::from(self.channels))?
            .checked_mul(8)?;
        let limit = usize::MAX as u64;
        let entries = padded.checked_mul(padded)?;
        (bytes <= limit && scale_bytes <= limit && entries <= limit).then_some(bytes)
    }

    /// Total bytes of block data.
    pub fn block_bytes(&self) -> u64 {
        self.checked_block_bytes().expect("checked in new")
    }

    /// Side lengths of tile row/column `t`.
    fn span(&self, t: usize) -> (usize, usize) {
        let start = t * self.tile_size();
        (start, self.tile_size().min(self.padded() - start))
    }

    /// The tile at grid position (`ty`, `tx`).
    pub fn tile(&self, ty: usize, tx: usize) -> Tile {
        let tps = self.tiles_per_side();
        assert!(
            ty < tps && tx < tps,
            "tile ({ty}, {tx}) outside a {tps}×{tps} grid"
        );
        let (row0, rows) = self.span(ty);
        let (col0, cols) = self.span(tx);
        // Every tile row above holds `padded` columns of `rows_above` rows; tiles to the left in
        // this row hold `col0` columns of `rows` rows.
        let per_entry_plane =
            |entries: usize| entries / 16 * self.format.block_bytes() * self.planes();
        let offset = per_entry_plane(row0 * self.padded()) + per_entry_plane(rows * col0);
        Tile {
            index: ty * tps + tx,
            row0,
            col0,
            rows,
            cols,
            offset,
        }
    }

    /// Every tile in storage order.
    pub fn tiles(&self) -> impl Iterator<Item = Tile> + '_ {
        let tps = self.tiles_per_side();
        (0..tps * tps).map(move |i| self.tile(i / tps, i % tps))
    }

    /// Byte offset of block (`block_row`, `block_col`) of `plane` within `tile`.
    pub fn block_offset(
        &self,
        tile: &Tile,
        plane: usize,
        block_row: usize,
        block_col: usize,
    ) -> usize {
        let plane_bytes = tile.blocks_high() * tile.blocks_wide() * self.format.block_bytes();
        tile.offset
            + plane * plane_bytes
            + (block_row * tile.blocks_wide() + block_col) * self.format.block_bytes()
    }

    /// The tile and in-tile block holding entry (`row`, `col`) of the padded matrix.
    pub fn locate(&self, row: usize, col: usize) -> (Tile, usize, usize) {
        let ts = self.tile_size();
        let tile = self.tile(row / ts, col / ts);
        (tile, (row - tile.row0) / 4, (col - tile.col0) / 4)
    }
}

#[cfg(test)]
mod tests {

    /// `Format::CASES` is exactly the (format, channels) pairs a layout accepts among 1 and 3
    /// channels.
    #[test]
    fn cases_are_the_storable_pairs() {
        for format in Format::ALL {
            for channels in [1usize, 3] {
                let ok = MatrixLayout::new(8, channels as u32, format, 16).is_ok();
                assert_eq!(
                    ok,
                    Format::CASES.contains(&(format, channels)),
                    "{format:?} × {channels}"
                );
            }
        }
    }
    use super::*;

    #[test]
    fn tiles_cover_the_padded_matrix_once() {
        let l = MatrixLayout::new(37, 3, Format::Bc4, 16).unwrap();
        assert_eq!((l.padded(), l.tile_size(), l.tiles_per_side()), (40, 16, 3));
        let mut seen = alloc::vec![0u8; 40 * 40];
        let mut next_offset = 0;
        for t in l.tiles() {
            assert_eq!(
                t.offset, next_offset,
                "tiles are contiguous in storage order"
            );
            next_offset += t.blocks_high() * t.blocks_wide() * 8 * 3;
            for r in t.row0..t.row0 + t.rows {
                for c in t.col0..t.col0 + t.cols {
                    seen[r * 40 + c] += 1;
                }
            }
        }
        assert_eq!(next_offset as u64, l.block_bytes());
        assert!(seen.iter().all(|&s| s == 1));
    }

    #[test]
    fn locate_agrees_with_tiles() {
        let l = MatrixLayout::new(100, 1, Format::U8, 32).unwrap();
        let (t, br, bc) = l.locate(70, 35);
        assert_eq!((t.row0, t.col0, br, bc), (64, 32, 1, 0));
        assert_eq!(t.rows, 32);
        // 100 rows in tiles of 32: the last tile row is 96..100.
        let (last, br, _) = l.locate(99, 0);
        assert_eq!((last.row0, last.rows, br), (96, 4, 0));
    }

    #[test]
    fn bad_layouts_are_refused() {
        assert_eq!(
            MatrixLayout::new(8, 2, Format::U8, 8),
            Err(LayoutError::Channels(2))
        );
        assert_eq!(
            MatrixLayout::new(8, 1, Format::Bc1, 8),
            Err(LayoutError::Bc1NeedsThreeChannels)
        );
        assert_eq!(
            MatrixLayout::new(8, 1, Format::U8, 6),
            Err(LayoutError::MaxTile(6))
        );
        assert_eq!(
            MatrixLayout::new(0, 1, Format::U8, 8),
            Err(LayoutError::Empty)
        );
        assert_eq!(
            MatrixLayout::new(u32::MAX, 3, Format::F32, 65536),
            Err(LayoutError::TooLarge)
        );
    }
}
