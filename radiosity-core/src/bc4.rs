//! BC4 (ATI1/RGTC1 unsigned): 4×4 single-channel texels in 8 bytes, two 8-bit endpoints and
//! 3-bit indices.

use crate::bc::{DecodeMode, SurfaceError, decode_surface};
use bytemuck::{Pod, Zeroable};

/// One BC4 block as stored: `r0`, `r1`, then 48 bits of 3-bit indices (texel 0 in the lowest
/// bits), texels row-major within the 4×4 block.
#[repr(transparent)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Pod, Zeroable)]
pub struct Bc4Block(pub [u8; 8]);

impl Bc4Block {
    /// The 3-bit palette index of texel `i` (row-major, `i < 16`).
    #[inline]
    pub fn index(&self, i: usize) -> u8 {
        let bits = u64::from_le_bytes(self.0) >> 16;
        ((bits >> (3 * i)) & 7) as u8
    }

    /// Whether the block uses eight interpolated values (`r0 > r1`) rather than six plus the
    /// constants 0 and 255.
    #[inline]
    pub fn is_eight_value(&self) -> bool {
        self.0[0] > self.0[1]
    }

    /// The eight palette entries under `mode`.
    pub fn palette(&self, mode: DecodeMode) -> [u8; 8] {
        let (r0, r1) = (i32::from(self.0[0]), i32::from(self.0[1]));
        let mut p = [0u8; 8];
        p[0] = r0 as u8;
        p[1] = r1 as u8;
        let steps = if self.is_eight_value() { 7 } else { 5 };
        for t in 1..steps {
            let v = match mode {
                DecodeMode::D3d10 => ((steps - t) * r0 + t * r1) / steps,
                DecodeMode::Mesa => r0 + (((r1 - r0) * ((255 * t) / steps)) >> 8),
            };
            p[1 + t as usize] = v as u8;
        }
        if steps == 5 {
            p[6] = 0;
            p[7] = 255;
        }
        p
    }

    /// The 16 texels, row-major, under `mode`.
    pub fn decode(&self, mode: DecodeMode) -> [u8; 16] {
        let palette = self.palette(mode);
        core::array::from_fn(|i| palette[self.index(i) as usize])
    }
}

/// Decodes one BC4 block with the [`DecodeMode::D3d10`] rules: 16 values, row-major.
pub fn decode_bc4_block(block: &[u8; 8]) -> [u8; 16] {
    Bc4Block(*block).decode(DecodeMode::D3d10)
}

/// Decodes one BC4 block under `mode`.
pub fn decode_bc4_block_with(block: &[u8; 8], mode: DecodeMode) -> [u8; 16] {
    Bc4Block(*block).decode(mode)
}

/// Decodes a BC4 surface of `width × height` texels into `out`, row-major.
pub fn decode_bc4_surface_into(
    data: &[u8],
    width: usize,
    height: usize,
    mode: DecodeMode,
    out: &mut [u8],
) -> Result<(), SurfaceError> {
    decode_surface(data, width, height, out, |b| decode_bc4_block_with(b, mode))
}

/// Decodes a BC4 surface into a new row-major vector.
pub fn decode_bc4_surface(
    data: &[u8],
    width: usize,
    height: usize,
    mode: DecodeMode,
) -> Result<alloc::vec::Vec<u8>, SurfaceError> {
    let expected = crate::bc::surface_bytes(width, height).unwrap_or(usize::MAX);
    if data.len() != expected {
        return Err(SurfaceError::DataLength {
            expected,
            actual: data.len(),
        });
    }
    let mut out = alloc::vec![0u8; width * height];
    decode_bc4_surface_into(data, width, height, mode, &mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_value_palette() {
        let b = Bc4Block([255, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            b.palette(DecodeMode::D3d10),
            [255, 0, 218, 182, 145, 109, 72, 36]
        );
        // Mesa: 255 + ((−255·⌊255t/7⌋) >> 8): t=1 → w=36 → 255 − 36 = 219; t=2 → w=72,
        // ⌊−71.7⌋ = −72 → 183 where D3D10 truncates 1275/7 to 182.
        assert_eq!(
            b.palette(DecodeMode::Mesa),
            [255, 0, 219, 183, 146, 110, 73, 37]
        );
    }

    #[test]
    fn six_value_palette_has_constants() {
        let b = Bc4Block([0, 255, 0, 0, 0, 0, 0, 0]);
        assert_eq!(
            b.palette(DecodeMode::D3d10),
            [0, 255, 51, 102, 153, 204, 0, 255]
        );
        assert_eq!(
            b.palette(DecodeMode::Mesa),
            [0, 255, 50, 101, 152, 203, 0, 255]
        );
    }

    #[test]
    fn indices_are_three_bits_little_endian() {
        // Texel 0 index 7, texel 1 index 1, texel 15 index 2.
        let bits: u64 = 7 | (1 << 3) | (2 << 45);
        let mut raw = [10u8, 20, 0, 0, 0, 0, 0, 0];
        raw[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
        let b = Bc4Block(raw);
        assert_eq!((b.index(0), b.index(1), b.index(15)), (7, 1, 2));
    }
}
