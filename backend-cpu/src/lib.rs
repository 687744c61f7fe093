//! Fast CPU gather for radiosity transfer matrices: `y = M · x` straight from the stored blocks.
//!
//! [`CpuGather`] implements [`radiosity_core::Gather`] for every format (BC1, BC4, u8, f16, f32;
//! one or three channels) including the exact sparse list. It gives the same answer as
//! [`radiosity_core::ReferenceGather`] under [`DecodeMode::D3d10`](radiosity_core::DecodeMode)
//! up to f32 summation order: the decoded entries are bit-identical (same palette rules, same
//! per-tile `LogScale::table()`), only the accumulation differs (f32, eight lanes, then the
//! sparse corrections row by row).
//!
//! # How it runs
//!
//! - Each block row of the matrix owns four output rows, so rayon splits the output into
//!   four-row chunks and threads never share an output. The serial path is the same body over
//!   `chunks_mut` instead of `par_chunks_mut` ([`CpuGather::set_parallel`]).
//! - Per block: decode the palette once (BC1: 4 entries × 3 channels, BC4: 8 entries through
//!   the tile's 256-entry table, built once in [`CpuGather::new`]; tiles of at least 65536
//!   blocks also get BC1 palette tables, 256 KiB indexed by each channel's endpoint pair, so a
//!   BC1 block costs three 16-byte loads before its expansion), expand the 16 texels through
//!   the 2- or 3-bit indices, then two `f32x8` fused multiply-adds per channel (two block rows
//!   per register) against the exitance, which is re-laid out once per gather into one `f32x8`
//!   per column block and channel (a buffer reused across gathers).
//!
//! # SIMD dispatch: at run time, not by a build setting
//!
//! `wide` picks its instructions when it is compiled: a plain `x86_64` build only has SSE2.
//! The block-row body is generic over a small `Isa` trait (palette expansion, f16 conversion,
//! multiply-add) and compiled twice: the baseline (`wide` as built) and, inside
//! `#[target_feature(enable = "avx2,fma,f16c")]`, an `std::arch` implementation (`vpsrlvd` to
//! put the indices in place, `vpermilps`/`vpermps` to expand palettes, `vgatherdps` for the BC4
//! palette, `vcvtph2ps`, `vfmadd`). Dedicated bodies:
//!
//! - `avx512.rs` (AVX-512F): BC1, BC4 and u8 with one whole 4×4 block per `zmm` register. BC1
//!   turns the endpoints of 16 blocks at a time into palette-table keys in vector registers, a
//!   run of 128 blocks ahead of their use; BC4 and u8 turn log codes into values without the
//!   256-entry table through the core's product form of the quantiser,
//!   `LogScale::decode(q) = high[(255 − q) >> 4] · low[(255 − q) & 15]` (two 16-entry tables in
//!   two registers, two `vpermps` and one multiply for 16 codes: the same rounding as the
//!   table). f16 and f32 run the AVX2 body on this path.
//! - `avx2.rs` (AVX2): BC1 as the `zmm` body in two halves (keys of eight blocks per register,
//!   the exitance in 16-byte form), BC4 through the same product form. u8 keeps the generic
//!   body.
//!
//! Every path decodes bit-identical entries. [`CpuGather::new`] takes the fastest path
//! `is_x86_feature_detected!` allows ([`SimdPath::detect`]); [`CpuGather::path`] names the path
//! that runs. A plain x86-64 binary with these bodies runs on any x86-64 CPU. Why runtime
//! dispatch and these bodies, with the timings per format and path and what was tried:
//! `docs/decisions/cpu-gather-bodies.md`.
//!
//! # Example
//!
//! ```
//! use radiosity_backend_cpu::CpuGather;
//! use radiosity_core::{
//!     BlockCorrections, Format, Gather, LogScale, MatrixLayout, Rgb, SparseRows, TransferMatrix,
//! };
//! use std::borrow::Cow;
//!
//! // A 4×4 grey u8 matrix whose every entry is code 255 (= v_max = 0.5).
//! let layout = MatrixLayout::new(4, 1, Format::U8, 8192).unwrap();
//! let matrix = TransferMatrix {
//!     layout,
//!     scales: Cow::Owned(vec![LogScale::new(0.5, 6.9)]),
//!     blocks: Cow::Owned(vec![255; 16]),
//!     sparse: SparseRows::empty(4),
//!     corrections: BlockCorrections::empty(4),
//! };
//! let mut gather = CpuGather::new(matrix);
//! let x = vec![Rgb::new(1.0, 2.0, 0.0); 4];
//! let mut y = vec![Rgb::ZERO; 4];
//! gather.gather(&x, &mut y).unwrap();
//! assert_eq!(y[0], Rgb::new(2.0, 4.0, 0.0));
//! println!("gathered on the {} path", gather.path());
//! ```

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
mod block_row;
mod decode;

use radiosity_core::{Format, Gather, GatherError, Rgb, Tile, TransferMatrix, check_gather_args};
use rayon::prelude::*;
use wide::f32x8;

/// Which compiled copy of the gather body runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SimdPath {
    /// The body compiled for the build's own target features (plain x86-64: SSE2).
    Baseline,
    /// The body compiled with `avx2`, `fma` and `f16c` enabled (every AVX2 CPU has F16C);
    /// palette expansion, gathers and f16 conversion through `std::arch`; BC1 and BC4 through
    /// bodies of their own (`avx2.rs`).
    Avx2Fma,
    /// AVX-512F on top of the AVX2 set: BC1, BC4 and u8 through `zmm` bodies (one block per
    /// register; BC1 endpoint arithmetic of 16 blocks at a time; log codes to values by two
    /// in-register 16-entry tables); f16 and f32 run the AVX2 body.
    Avx512,
}

impl SimdPath {
    /// Every path, slowest first.
    pub const ALL: [SimdPath; 3] = [SimdPath::Baseline, SimdPath::Avx2Fma, SimdPath::Avx512];

    /// The fastest path this CPU supports.
    pub fn detect() -> SimdPath {
        if Self::Avx512.is_available() {
            SimdPath::Avx512
        } else if Self::Avx2Fma.is_available() {
            SimdPath::Avx2Fma
        } else {
            SimdPath::Baseline
        }
    }

    /// Whether this CPU can run the path.
    pub fn is_available(self) -> bool {
        match self {
            SimdPath::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx2Fma => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                    && std::arch::is_x86_feature_detected!("f16c")
            }
            #[cfg(target_arch = "x86_64")]
            SimdPath::Avx512 => {
                Self::Avx2Fma.is_available() && std::arch::is_x86_feature_detected!("avx512f")
            }
            #[cfg(not(target_arch = "x86_64"))]
            SimdPath::Avx2Fma | SimdPath::Avx512 => false,
        }
    }

    /// A short name for logs: `"avx2+fma"`, or the baseline's compile-time features
    /// (`"sse2"` on plain x86-64, `"avx512 (build)"` / `"avx2+fma (build)"` when the build
    /// targets a newer CPU, `"portable"` elsewhere).
    pub fn name(self) -> &'static str {
        match self {
            SimdPath::Avx2Fma => "avx2+fma",
            SimdPath::Avx512 => "avx512",
            SimdPath::Baseline => {
                if cfg!(target_feature = "avx512f") {
                    "avx512 (build)"
                } else if cfg!(all(target_feature = "avx2", target_feature = "fma")) {
                    "avx2+fma (build)"
                } else if cfg!(target_feature = "sse2") {
                    "sse2"
                } else {
                    "portable"
                }
            }
        }
    }
}

/// The SIMD + rayon CPU gather. Build once per matrix ([`CpuGather::new`] precomputes the
/// per-tile decode tables); every [`Gather::gather`] then reuses its buffers.
#[derive(Debug)]
pub struct CpuGather<'m> {
    matrix: TransferMatrix<'m>,
    /// One 256-entry decode table per tile and channel (empty for f16/f32).
    tables: Vec<[f32; 256]>,
    /// The tables' two 16-entry factors (`LogScale::factors`), for the `zmm` and `ymm` log
    /// bodies only.
    factors: Vec<([f32; 16], [f32; 16])>,
    /// BC1 only: each large tile's palettes decoded to values (`decode::Bc1Palettes`).
    bc1: Vec<Option<decode::Bc1Palettes>>,
    /// Every tile, in storage order.
    tiles: Vec<Tile>,
    /// F16 on the baseline path only: `decode::f16_table()`.
    f16: Vec<f32>,
    /// Exitance re-laid out per gather: `[column block][channel]`, each the block's four
    /// columns twice (two block rows per register).
    xs: Vec<f32x8>,
    /// The same for the `zmm` bodies and the AVX2 BC1 body (each column block's four values
    /// once); empty unless one of them runs.
    x4: Vec<block_row::X4>,
    /// The block corrections' scale tables ([`TransferMatrix::correction_tables`]).
    correction_tables: [[f32; 256]; 3],
    simd: SimdPath,
    parallel: bool,
    name: String,
}

impl<'m> CpuGather<'m> {
    /// A gather over `matrix` on the fastest path this CPU has, parallel over block rows.
    ///
    /// The matrix must be valid ([`TransferMatrix::validate`]; a parsed `.rad` file is).
    pub fn new(matrix: TransferMatrix<'m>) -> Self {
        Self::build(matrix, SimdPath::detect())
    }

    /// A gather on a chosen path; an error saying why when this CPU cannot run it.
    pub fn with_path(matrix: TransferMatrix<'m>, simd: SimdPath) -> Result<Self, GatherError> {
        if !simd.is_available() {
            return Err(GatherError::Backend(format!(
                "the {} path needs a CPU with {}",
                simd.name(),
                if simd == SimdPath::Avx512 {
                    "AVX-512F, AVX2, FMA and F16C"
                } else {
                    "AVX2, FMA and F16C"
                }
            )));
        }
        Ok(Self::build(matrix, simd))
    }

    fn build(matrix: TransferMatrix<'m>, simd: SimdPath) -> Self {
        let l = matrix.layout;
        assert_eq!(
            matrix.blocks.len() as u64,
            l.block_bytes(),
            "block data does not match the layout"
        );
        assert_eq!(matrix.scales.len(), l.scale_count(), "scale count");
        let tables: Vec<[f32; 256]> = matrix.scales.iter().map(|s| s.table()).collect();
        let factors = if uses_x4(l.format(), simd) {
            matrix.scales.iter().map(|s| s.factors()).collect()
        } else {
            Vec::new()
        };
        let tiles: Vec<Tile> = l.tiles().collect();
        let bc1 = if l.format() == Format::Bc1 {
            tiles
                .par_iter()
                .map(|t| {
                    let tab = |c: usize| &tables[l.scale_index(t.index, c)];
                    (t.blocks_high() * t.blocks_wide() >= decode::BC1_TABLE_MIN_BLOCKS)
                        .then(|| decode::Bc1Palettes::new([tab(0), tab(1), tab(2)]))
                })
                .collect()
        } else {
            Vec::new()
        };
        let f16 = if l.format() == Format::F16 && simd == SimdPath::Baseline {
            decode::f16_table()
        } else {
            Vec::new()
        };
        let x4 = if uses_x4(l.format(), simd) {
            vec![block_row::X4::ZERO; l.padded() / 4 * 3]
        } else {
            Vec::new()
        };
        let xs = if x4.is_empty() {
            vec![f32x8::ZERO; l.padded() / 4 * 3]
        } else {
            Vec::new()
        };
        let name = format!("cpu-{}", l.format().name());
        let correction_tables = matrix.correction_tables();
        Self {
            matrix,
            tables,
            factors,
            bc1,
            tiles,
            f16,
            xs,
            x4,
            correction_tables,
            simd,
            parallel: true,
            name,
        }
    }

    /// The body that runs, for logs and benches (`"avx512"`, `"avx2+fma"`, `"sse2"`, …): on
    /// the AVX-512 path, formats without a `zmm` body name the AVX2 body they run.
    pub fn path(&self) -> &'static str {
        if self.simd == SimdPath::Avx512 && !uses_zmm(self.matrix.layout.format(), self.simd) {
            SimdPath::Avx2Fma.name()
        } else {
            self.simd.name()
        }
    }

    /// The SIMD path in use.
    pub fn simd(&self) -> SimdPath {
        self.simd
    }

    /// Runs over rayon's pool (`true`, the default) or on the calling thread.
    pub fn set_parallel(&mut self, parallel: bool) {
        self.parallel = parallel;
    }

    /// The matrix gathered from.
    pub fn matrix(&self) -> &TransferMatrix<'m> {
        &self.matrix
    }

    /// Address of the reusable exitance buffer: the same across gathers, since gathers never
    /// reallocate (the tests check this).
    pub fn scratch_ptr(&self) -> *const u8 {
        if self.x4.is_empty() {
            self.xs.as_ptr().cast()
        } else {
            self.x4.as_ptr().cast()
        }
    }
}

impl Gather for CpuGather<'_> {
    fn name(&self) -> &str {
        &self.name
    }

    fn patches(&self) -> usize {
        self.matrix.layout.n()
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        let n = self.matrix.layout.n();
        check_gather_args(n, exitance, irradiance)?;
        let col =
            |j: usize, c: usize, k: usize| exitance.get(4 * j + c).map_or(0.0, |x| x.channel(k));
        for (j, xs) in self.xs.chunks_exact_mut(3).enumerate() {
            for (k, v) in xs.iter_mut().enumerate() {
                let q: [f32; 4] = core::array::from_fn(|c| col(j, c, k));
                *v = f32x8::from([q[0], q[1], q[2], q[3], q[0], q[1], q[2], q[3]]);
            }
        }
        for (j, xs) in self.x4.chunks_exact_mut(3).enumerate() {
            for (k, v) in xs.iter_mut().enumerate() {
                v.0 = core::array::from_fn(|c| col(j, c, k));
            }
        }
        let ctx = block_row::Ctx {
            matrix: &self.matrix,
            tables: &self.tables,
            factors: &self.factors,
            bc1: &self.bc1,
            tiles: &self.tiles,
            f16: &self.f16,
            xs: &self.xs,
            x4: &self.x4,
            exitance,
            corrections: &self.correction_tables,
        };
        let (simd, parallel) = (self.simd, self.parallel);
        let format = self.matrix.layout.format();
        #[cfg(target_arch = "x86_64")]
        if let Some(body) = x4_body(format, simd) {
            let x4 = &self.x4[..];
            // SAFETY: `x4_body` gives a `zmm` body only on `SimdPath::Avx512` and a `ymm` one
            // only on `SimdPath::Avx2Fma`, which `CpuGather` holds only after `is_available`
            // saw AVX-512F, AVX2, FMA and F16C, or AVX2, FMA and F16C.
            run(parallel, irradiance, |r, out| unsafe {
                body(&ctx, x4, r, out)
            });
            return Ok(());
        }
        match format {
            Format::Bc1 => run(parallel, irradiance, |r, out| {
                block_row::dispatch::<decode::Bc1>(&ctx, simd, r, out)
            }),
            Format::Bc4 => run(parallel, irradiance, |r, out| {
                block_row::dispatch::<decode::Bc4>(&ctx, simd, r, out)
            }),
            Format::U8 => run(parallel, irradiance, |r, out| {
                block_row::dispatch::<decode::U8>(&ctx, simd, r, out)
            }),
            Format::F16 => run(parallel, irradiance, |r, out| {
                block_row::dispatch::<decode::F16>(&ctx, simd, r, out)
            }),
            Format::F32 => run(parallel, irradiance, |r, out| {
                block_row::dispatch::<decode::F32>(&ctx, simd, r, out)
            }),
        }
        Ok(())
    }
}

/// The block-row body of its own that `format` runs on `simd`, if there is one: a `zmm` body
/// on the AVX-512 path (`avx512::body`), a `ymm` body on the AVX2 path (`avx2::body`). Both read
/// the exitance as [`block_row::X4`].
#[cfg(target_arch = "x86_64")]
fn x4_body(format: Format, simd: SimdPath) -> Option<block_row::RowBody> {
    match simd {
        SimdPath::Avx512 => avx512::body(format),
        SimdPath::Avx2Fma => avx2::body(format),
        SimdPath::Baseline => None,
    }
}

/// Whether `format` reads the exitance as [`block_row::X4`] and the tables' factors on `simd`
/// ([`x4_body`]).
fn uses_x4(format: Format, simd: SimdPath) -> bool {
    #[cfg(target_arch = "x86_64")]
    return x4_body(format, simd).is_some();
    #[cfg(not(target_arch = "x86_64"))]
    return {
        let _ = (format, simd);
        false
    };
}

/// Whether `format` runs a `zmm` body on `simd`.
fn uses_zmm(format: Format, simd: SimdPath) -> bool {
    #[cfg(target_arch = "x86_64")]
    return simd == SimdPath::Avx512 && avx512::body(format).is_some();
    #[cfg(not(target_arch = "x86_64"))]
    return {
        let _ = (format, simd);
        false
    };
}

/// Runs `body(block_row, its output rows)` over every block row, in parallel or not: the same
/// body either way.
fn run(parallel: bool, irradiance: &mut [Rgb], body: impl Fn(usize, &mut [Rgb]) + Sync) {
    if parallel {
        irradiance
            .par_chunks_mut(4)
            .enumerate()
            .for_each(|(r, out)| body(r, out));
    } else {
        irradiance
            .chunks_mut(4)
            .enumerate()
            .for_each(|(r, out)| body(r, out));
    }
}
