//! What BC1 and BC4 share: the decode mode and the surface error.

use core::fmt;

/// Which rounding rules turn a block's endpoints into its palette.
///
/// Both modes agree on the endpoints themselves and on which index means what; they differ only
/// in how the interpolated palette entries are rounded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DecodeMode {
    /// The D3D10 rules as every CPU decoder we compare with implements them (texpresso,
    /// texture2ddecoder): 565 endpoints expanded by bit replication, then integer (truncating)
    /// division on the 8-bit values. BC1 four-colour: `c2 = (2·c0 + c1) / 3`,
    /// `c3 = (c0 + 2·c1) / 3`; three-colour (`c0 ≤ c1` as 16-bit words): `c2 = (c0 + c1) / 2`,
    /// `c3` transparent black. BC4 eight-value (`r0 > r1`): `((7−t)·r0 + t·r1) / 7`; six-value:
    /// `((5−t)·r0 + t·r1) / 5` and the constants 0 and 255.
    #[default]
    D3d10,
    /// Mesa's decoder (llvmpipe/lavapipe 22.3, measured): the same endpoints, but interpolation
    /// by a weight out of 256 with an arithmetic shift. BC1 four-colour
    /// `c2 = e0 + (((e1 − e0)·85) >> 8)`, `c3 = e0 + (((e1 − e0)·170) >> 8)`; three-colour
    /// midpoint `(e0 + e1 + 1) >> 1`; BC4 `r0 + (((r1 − r0)·w) >> 8)` with `w = ⌊255·t/7⌋`
    /// or `⌊255·t/5⌋`. Use it to make GPU tests exact where the driver is known to be Mesa.
    Mesa,
}

/// Why a whole-surface decode could not run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfaceError {
    /// The compressed data does not hold exactly `ceil(w/4)·ceil(h/4)` blocks of 8 bytes.
    DataLength {
        /// Bytes the surface size calls for.
        expected: usize,
        /// Bytes given.
        actual: usize,
    },
    /// The output slice does not hold exactly `width·height` texels.
    OutputLength {
        /// Texels the surface size calls for.
        expected: usize,
        /// Texels given.
        actual: usize,
    },
}

impl fmt::Display for SurfaceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SurfaceError::DataLength { expected, actual } => {
                write!(f, "compressed surface needs {expected} bytes, got {actual}")
            }
            SurfaceError::OutputLength { expected, actual } => {
                write!(f, "output needs {expected} texels, got {actual}")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for SurfaceError {}

/// Bytes of a `width × height` surface of 8-byte blocks, or `None` on overflow.
pub(crate) fn surface_bytes(width: usize, height: usize) -> Option<usize> {
    width
        .div_ceil(4)
        .checked_mul(height.div_ceil(4))?
        .checked_mul(8)
}

/// Runs `decode` on each block of a surface and scatters its 16 texels into `out` (row-major,
/// `width` texels a row), clipping partial blocks at the right and bottom edges.
pub(crate) fn decode_surface<T: Copy>(
    data: &[u8],
    width: usize,
    height: usize,
    out: &mut [T],
    decode: impl Fn(&[u8; 8]) -> [T; 16],
) -> Result<(), SurfaceError> {
    let expected = surface_bytes(width, height).ok_or(SurfaceError::DataLength {
        expected: usize::MAX,
        actual: data.len(),
    })?;
    if data.len() != expected {
        return Err(SurfaceError::DataLength {
            expected,
            actual: data.len(),
        });
    }
    if out.len() != width * height {
        return Err(SurfaceError::OutputLength {
            expected: width * height,
            actual: out.len(),
        });
    }
    let blocks_wide = width.div_ceil(4);
    for (b, chunk) in data.chunks_exact(8).enumerate() {
        let block: &[u8; 8] = chunk.try_into().expect("chunks_exact(8)");
        let texels = decode(block);
        let (bx, by) = (b % blocks_wide, b / blocks_wide);
        for (i, t) in texels.iter().enumerate() {
            let (x, y) = (bx * 4 + i % 4, by * 4 + i / 4);
            if x < width && y < height {
                out[y * width + x] = *t;
            }
        }
    }
    Ok(())
}
