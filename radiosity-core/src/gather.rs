//! The `Gather` trait every backend implements, and the scalar reference gather (the oracle).

use crate::{DecodeMode, Rgb, TransferMatrix};
use alloc::string::String;
use alloc::vec::Vec;
use core::fmt;

/// Why a gather could not run.
#[derive(Clone, Debug, PartialEq)]
pub enum GatherError {
    /// The exitance or irradiance slice does not have one entry per patch.
    Length {
        /// Patches in the matrix.
        expected: usize,
        /// Entries in the exitance slice.
        exitance: usize,
        /// Entries in the irradiance slice.
        irradiance: usize,
    },
    /// An exitance entry is NaN or infinite.
    NonFinite {
        /// The first such patch.
        index: usize,
    },
    /// The backend failed for a reason of its own (a lost device, an allocation refused).
    Backend(String),
}

impl fmt::Display for GatherError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GatherError::Length {
                expected,
                exitance,
                irradiance,
            } => write!(
                f,
                "gather needs {expected} patches, got exitance of {exitance} and irradiance of {irradiance}"
            ),
            GatherError::NonFinite { index } => {
                write!(f, "exitance of patch {index} is not finite")
            }
            GatherError::Backend(why) => write!(f, "gather backend failed: {why}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for GatherError {}

/// One gather per frame: irradiance `y = M · x` from first exitance `x`.
///
/// Both slices are in the matrix's patch numbering, one RGB entry per patch, in W/m². A
/// one-channel (grey) matrix still carries coloured light: each channel of `x` is multiplied by
/// the same entry.
pub trait Gather {
    /// A short name for logs and reports (`"reference"`, `"cpu-bc1"`, …).
    fn name(&self) -> &str;

    /// Patches the matrix has.
    fn patches(&self) -> usize;

    /// Computes `irradiance = M · exitance`, overwriting `irradiance`.
    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError>;
}

/// A boxed or borrowed gather gathers as the gather it points to.
macro_rules! forward_gather {
    ($($ty:ty),*) => {$(
        impl<G: Gather + ?Sized> Gather for $ty {
            fn name(&self) -> &str {
                (**self).name()
            }

            fn patches(&self) -> usize {
                (**self).patches()
            }

            fn gather(
                &mut self,
                exitance: &[Rgb],
                irradiance: &mut [Rgb],
            ) -> Result<(), GatherError> {
                (**self).gather(exitance, irradiance)
            }
        }
    )*};
}

forward_gather!(alloc::boxed::Box<G>, &mut G);

/// Checks the slices a gather is given; shared by every backend.
pub fn check_gather_args(
    n: usize,
    exitance: &[Rgb],
    irradiance: &[Rgb],
) -> Result<(), GatherError> {
    if exitance.len() != n || irradiance.len() != n {
        return Err(GatherError::Length {
            expected: n,
            exitance: exitance.len(),
            irradiance: irradiance.len(),
        });
    }
    if let Some(index) = exitance.iter().position(|x| !x.is_finite()) {
        return Err(GatherError::NonFinite { index });
    }
    Ok(())
}

/// The scalar reference gather: decodes each block with the core's reference decoder and
/// accumulates in `f64`, in one fixed order. It is slow on purpose; every fast backend is tested
/// against it.
#[derive(Debug)]
pub struct ReferenceGather<'m> {
    matrix: TransferMatrix<'m>,
    decoder: crate::BlockDecoder,
    acc: Vec<[f64; 3]>,
}

impl<'m> ReferenceGather<'m> {
    /// A reference gather over `matrix`, decoding blocks under `mode` (use
    /// [`DecodeMode::Mesa`] to predict a Mesa GPU bit for bit).
    pub fn new(matrix: TransferMatrix<'m>, mode: DecodeMode) -> Self {
        let decoder = matrix.decoder(mode);
        let acc = alloc::vec![[0.0; 3]; matrix.layout.n()];
        Self {
            matrix,
            decoder,
            acc,
        }
    }

    /// The matrix gathered from.
    pub fn matrix(&self) -> &TransferMatrix<'m> {
        &self.matrix
    }
}

impl Gather for ReferenceGather<'_> {
    fn name(&self) -> &str {
        "reference"
    }

    fn patches(&self) -> usize {
        self.matrix.layout.n()
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        let l = self.matrix.layout;
        let n = l.n();
        check_gather_args(n, exitance, irradiance)?;
        let grey = l.channels() == 1;
        self.acc.iter_mut().for_each(|a| *a = [0.0; 3]);
        let mut vals = [[0f32; 16]; 3];
        for tile in l.tiles() {
            for br in 0..tile.blocks_high() {
                for bc in 0..tile.blocks_wide() {
                    self.decoder.decode(&self.matrix, &tile, br, bc, &mut vals);
                    for i in 0..16 {
                        let (r, c) = (tile.row0 + br * 4 + i / 4, tile.col0 + bc * 4 + i % 4);
                        if r >= n || c >= n {
                            continue;
                        }
                        let x = exitance[c].to_array();
                        for k in 0..3 {
                            let v = if grey { vals[0][i] } else { vals[k][i] };
                            self.acc[r][k] += f64::from(v) * f64::from(x[k]);
                        }
                    }
                }
            }
        }
        let ch = l.channels();
        let acc = &mut self.acc;
        self.matrix.for_each_correction(|r, c, v| {
            let x = exitance[c].to_array();
            for k in 0..3 {
                acc[r][k] += f64::from(v[if grey { 0 } else { k }]) * f64::from(x[k]);
            }
        });
        for (r, acc) in self.acc.iter_mut().enumerate() {
            for (c, v) in self.matrix.sparse.row(r, ch) {
                let x = exitance[c].to_array();
                for k in 0..3 {
                    acc[k] += f64::from(v[if grey { 0 } else { k }]) * f64::from(x[k]);
                }
            }
        }
        for (y, a) in irradiance.iter_mut().zip(&self.acc) {
            *y = Rgb::new(a[0] as f32, a[1] as f32, a[2] as f32);
        }
        Ok(())
    }
}
