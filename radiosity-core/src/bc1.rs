//! BC1 (DXT1): 4×4 RGB texels in 8 bytes, two 565 endpoints and 2-bit indices.

use crate::bc::{DecodeMode, SurfaceError, decode_surface};
use bytemuck::{Pod, Zeroable};

/// One BC1 block as stored: `c0: u16 LE`, `c1: u16 LE`, 16 two-bit indices (texel 0 in the
/// lowest bits), texels row-major within the 4×4 block.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Pod, Zeroable)]
pub struct Bc1Block(pub [u8; 8]);

impl Bc1Block {
    /// First endpoint as a 565 word.
    #[inline]
    pub fn c0(&self) -> u16 {
        u16::from_le_bytes([self.0[0], self.0[1]])
    }

    /// Second endpoint as a 565 word.
    #[inline]
    pub fn c1(&self) -> u16 {
        u16::from_le_bytes([self.0[2], self.0[3]])
    }

    /// Whether the block is in four-colour mode (`c0 > c1`); otherwise it has three colours and
    /// index 3 means transparent black.
    #[inline]
    pub fn is_four_colour(&self) -> bool {
        self.c0() > self.c1()
    }

    /// The 2-bit palette index of texel `i` (row-major, `i < 16`).
    #[inline]
    pub fn index(&self, i: usize) -> u8 {
        let bits = u32::from_le_bytes([self.0[4], self.0[5], self.0[6], self.0[7]]);
        ((bits >> (2 * i)) & 3) as u8
    }

    /// The four palette entries (RGBA) under `mode`.
    pub fn palette(&self, mode: DecodeMode) -> [[u8; 4]; 4] {
        let e0 = expand_565(self.c0());
        let e1 = expand_565(self.c1());
        let mut p = [[0u8; 4]; 4];
        p[0] = [e0[0], e0[1], e0[2], 255];
        p[1] = [e1[0], e1[1], e1[2], 255];
        let four = self.is_four_colour();
        for ch in 0..3 {
            let (a, b) = (i32::from(e0[ch]), i32::from(e1[ch]));
            let (c2, c3) = match (mode, four) {
                (DecodeMode::D3d10, true) => ((2 * a + b) / 3, (a + 2 * b) / 3),
                (DecodeMode::D3d10, false) => ((a + b) / 2, 0),
                // `>>` on i32 is an arithmetic shift, as Mesa's.
                (DecodeMode::Mesa, true) => (a + (((b - a) * 85) >> 8), a + (((b - a) * 170) >> 8)),
                (DecodeMode::Mesa, false) => ((a + b + 1) >> 1, 0),
            };
            p[2][ch] = c2 as u8;
            p[3][ch] = c3 as u8;
        }
        p[2][3] = 255;
        p[3][3] = if four { 255 } else { 0 };
        p
    }

    /// The 16 texels (RGBA, row-major) under `mode`.
    pub fn decode(&self, mode: DecodeMode) -> [[u8; 4]; 16] {
        let palette = self.palette(mode);
        core::array::from_fn(|i| palette[self.index(i) as usize])
    }
}

/// Expands a 565 word to 8-bit RGB by bit replication (`r8 = r5 << 3 | r5 >> 2`, and so on).
#[inline]
pub fn expand_565(c: u16) -> [u8; 3] {
    let r = ((c >> 11) & 0x1f) as u8;
    let g = ((c >> 5) & 0x3f) as u8;
    let b = (c & 0x1f) as u8;
    [
        (r << 3) | (r >> 2),
        (g << 2) | (g >> 4),
        (b << 3) | (b >> 2),
    ]
}

/// Decodes one BC1 block with the [`DecodeMode::D3d10`] rules: 16 RGBA texels, row-major.
pub fn decode_bc1_block(block: &[u8; 8]) -> [[u8; 4]; 16] {
    Bc1Block(*block).decode(DecodeMode::D3d10)
}

/// Decodes one BC1 block under `mode`.
pub fn decode_bc1_block_with(block: &[u8; 8], mode: DecodeMode) -> [[u8; 4]; 16] {
    Bc1Block(*block).decode(mode)
}

/// Decodes a BC1 surface of `width × height` texels (blocks row-major, `ceil(width/4)` a row)
/// into `out`, row-major RGBA. Partial edge blocks are clipped.
pub fn decode_bc1_surface_into(
    data: &[u8],
    width: usize,
    height: usize,
    mode: DecodeMode,
    out: &mut [[u8; 4]],
) -> Result<(), SurfaceError> {
    decode_surface(data, width, height, out, |b| decode_bc1_block_with(b, mode))
}

/// Decodes a BC1 surface into a new row-major RGBA vector.
pub fn decode_bc1_surface(
    data: &[u8],
    width: usize,
    height: usize,
    mode: DecodeMode,
) -> Result<alloc::vec::Vec<[u8; 4]>, SurfaceError> {
    // Check the length before allocating: the output is bounded by the input's size.
    let expected = crate::bc::surface_bytes(width, height).unwrap_or(usize::MAX);
    if data.len() != expected {
        return Err(SurfaceError::DataLength {
            expected,
            actual: data.len(),
        });
    }
    let mut out = alloc::vec![[0u8; 4]; width * height];
    decode_bc1_surface_into(data, width, height, mode, &mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expansion_replicates_bits() {
        assert_eq!(expand_565(0xffff), [255, 255, 255]);
        assert_eq!(expand_565(0), [0, 0, 0]);
        // r5 = 16 → 0b10000_100 = 132; g6 = 32 → 0b100000_10 = 130; b5 = 1 → 8.
        assert_eq!(expand_565((16 << 11) | (32 << 5) | 1), [132, 130, 8]);
    }

    #[test]
    fn modes_differ_only_in_rounding() {
        // c0 = pure red (0xf800) > c1 = pure green (0x07e0): four-colour; texels 0..4 use
        // indices 0, 1, 2, 3.
        let block = [0x00, 0xf8, 0xe0, 0x07, 0b11_10_01_00, 0, 0, 0];
        let d = decode_bc1_block(&block);
        // Red falls 255 → 0: (2·255)/3 = 170, 255/3 = 85. Green rises 0 → 255: 85, 170.
        assert_eq!(
            &d[..4],
            &[
                [255, 0, 0, 255],
                [0, 255, 0, 255],
                [170, 85, 0, 255],
                [85, 170, 0, 255]
            ]
        );
        let m = decode_bc1_block_with(&block, DecodeMode::Mesa);
        // Red: 255 + ((−255·85) >> 8) = 255 − 85 = 170 (the shift floors −84.7 to −85), the same.
        // Green: 0 + ((255·85) >> 8) = 84 and (255·170) >> 8 = 169: one lower than D3D10.
        assert_eq!(
            &m[..4],
            &[
                [255, 0, 0, 255],
                [0, 255, 0, 255],
                [170, 84, 0, 255],
                [85, 169, 0, 255]
            ]
        );
    }

    #[test]
    fn three_colour_index_3_is_transparent_black() {
        // c0 = c1 → three-colour mode.
        let block = [0x10, 0x84, 0x10, 0x84, 0xff, 0xff, 0xff, 0xff];
        let d = decode_bc1_block(&block);
        assert!(d.iter().all(|t| *t == [0, 0, 0, 0]));
    }
}
