//! `radiosity-core`: the `no_std` heart of precomputed-transfer radiosity.
//!
//! A baked scene is a transfer matrix `M` (`docs/contract.md`): irradiance at patch `i` caused by unit
//! first exitance at patch `j`, through any number of bounces. Every frame the runtime computes
//! first exitance `x`, then gathers `y = M · x`. This crate owns what every other crate agrees
//! on, and nothing that needs an operating system:
//!
//! - [`Rgb`] and [`Patch`], plain-old-data (`#[repr(C)]`, [`bytemuck::Pod`]);
//! - BC1 and BC4 blocks and the **reference software decoder** ([`decode_bc1_block`],
//!   [`decode_bc4_block`], whole surfaces, and the [`DecodeMode::Mesa`] model of Mesa's GPU
//!   decoder);
//! - the log quantiser [`LogScale`], one per tile and channel;
//! - the matrix layout ([`MatrixLayout`]: tiles, 4×4 blocks, planes) and the exact
//!   [`SparseRows`] of large entries, together a [`TransferMatrix`];
//! - the `.rad` container ([`RadFile::to_bytes`], [`RadFile::parse`]): checksummed sections,
//!   strict validation, zero-copy where aligned, never a panic whatever the bytes;
//! - the [`Gather`] trait and the scalar [`ReferenceGather`] every backend is tested against;
//! - analytic [`Light`]s and the frame arithmetic around the gather.
//!
//! Without the default `std` feature the crate is `no_std` + `alloc` (float maths from libm).
//!
//! # Example
//!
//! Store a 2-patch matrix exactly (f32), write and parse the file, gather one frame:
//!
//! ```
//! use radiosity_core::*;
//! use std::borrow::Cow;
//!
//! // M = [[0, 0.5], [0.25, 0]], one grey channel, stored as f32 in one 4×4 block.
//! let layout = MatrixLayout::new(2, 1, Format::F32, DEFAULT_MAX_TILE).unwrap();
//! let mut block = [0f32; 16];
//! block[1] = 0.5; // row 0, column 1
//! block[4] = 0.25; // row 1, column 0
//! let patch = Patch { area: 1.0, normal: [0.0, 0.0, 1.0], ..Patch::default() };
//! let file = RadFile {
//!     patches: Cow::Owned(vec![patch; 2]),
//!     order: Cow::Owned(vec![0, 1]),
//!     matrix: TransferMatrix {
//!         layout,
//!         scales: Cow::Owned(vec![]),
//!         blocks: Cow::Owned(bytemuck::cast_slice(&block).to_vec()),
//!         sparse: SparseRows::empty(2),
//!         corrections: BlockCorrections::empty(2),
//!     },
//!     objects: vec![Cow::Borrowed("box")],
//!     bounces: Bounces::Infinite,
//!     patch_order: PatchOrder::Natural,
//!     compression_rmse: None,
//!     lighting_error: None,
//!     report: None,
//!     mesh: None,
//!     probes: None,
//!     sky: None,
//!     parts: None,
//!     bounce: None,
//!     coverage: None,
//!     systems: None,
//! };
//! let bytes = file.to_bytes().unwrap();
//! let parsed = RadFile::parse(&bytes).unwrap();
//!
//! let mut gather = ReferenceGather::new(parsed.matrix, DecodeMode::D3d10);
//! let x = [Rgb::new(4.0, 2.0, 0.0), Rgb::ZERO];
//! let mut y = [Rgb::ZERO; 2];
//! gather.gather(&x, &mut y).unwrap();
//! assert_eq!(y, [Rgb::ZERO, Rgb::new(1.0, 0.5, 0.0)]); // a grey matrix carries colour
//! ```
#![no_std]
#![deny(missing_docs)]

extern crate alloc;
#[cfg(feature = "std")]
extern crate std;

mod bc;
mod bc1;
mod bc4;
pub mod bounce;
mod checksum;
mod color;
pub mod container;
pub mod corrections;
mod edit;
mod error;
mod gather;
pub mod half;
mod layout;
mod light;
mod math;
pub mod mesh;
pub mod parts;
mod patch;
mod pod_bytes;
pub mod probes;
mod quantise;
pub mod sky;
mod sparse;
pub mod systems;
mod transfer;

pub use bc::{DecodeMode, SurfaceError};
pub use bc1::{
    Bc1Block, decode_bc1_block, decode_bc1_block_with, decode_bc1_surface, decode_bc1_surface_into,
    expand_565,
};
pub use bc4::{
    Bc4Block, decode_bc4_block, decode_bc4_block_with, decode_bc4_surface, decode_bc4_surface_into,
};
pub use bounce::{BounceRows, first_bounce};
pub use checksum::{Crc32, crc32};
pub use color::Rgb;
pub use container::{Bounces, PatchOrder, RadFile};
pub use corrections::BlockCorrections;
pub use edit::{EditError, EditedGather, ReflectanceEdit};
pub use error::{RadError, SectionKind};
pub use gather::{Gather, GatherError, ReferenceGather, check_gather_args};
pub use layout::{DEFAULT_MAX_TILE, Format, LayoutError, MatrixLayout, Tile};
pub use light::{
    Light, LightError, ShadowRay, finish_frame, first_exitance, sky_radiance_of, sky_sh_of,
};
pub use mesh::{CornerLengthError, CornerWeight, Mesh, MeshCounts, MeshTriangle, PatchSample};
pub use parts::{Part, PartRows};
pub use patch::Patch;
pub use probes::{
    DecodedProbes, ProbeFactors, ProbeModes, ProbeWeight, Probes, SH_COEFFICIENTS, sh_irradiance,
};
pub use quantise::{DEFAULT_SHIFT, LogScale};
pub use sky::{EnvMap, SkySh, SkyVisibility, sky_irradiance, uniform_sky_sh};
pub use sparse::SparseRows;
pub use transfer::{BlockDecoder, BlockValues, TransferMatrix};

// Re-exported so users of the public types need not name a matching glam/bytemuck version.
pub use bytemuck;
pub use glam;
