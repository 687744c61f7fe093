//! GPU gather for radiosity transfer matrices: `y = M · x` in WGSL compute shaders, on any
//! adapter wgpu finds (Vulkan, GL, Metal, DX12; hardware GPUs and Mesa's software drivers).
//!
//! [`WgpuGather`] implements [`radiosity_core::Gather`] for every format and channel count,
//! including the exact sparse list, on one of two decode paths ([`DecodePath`]):
//!
//! - **software** decoding: the blocks sit in storage buffers and the shader decodes them
//!   (BC1/BC4 palettes under a chosen [`DecodeMode`], u8 codes, f16 bits, f32). It runs on
//!   every adapter and, under [`DecodeMode::D3d10`], decodes exactly what the CPU backends do;
//! - **hardware** BC decoding: BC1/BC4 blocks sit in `Bc1RgbaUnorm`/`Bc4RUnorm` textures and the
//!   texture unit decodes them (`textureLoad`), where the adapter has
//!   `TEXTURE_COMPRESSION_BC`. The palette rounding is then the driver's: on Mesa
//!   (llvmpipe/lavapipe) it is exactly [`DecodeMode::Mesa`] ([`WgpuGather::decode_model`]).
//!
//! Either way the result differs from [`radiosity_core::ReferenceGather`] under the same decode
//! rules only by f32 summation order.
//!
//! # How it runs
//!
//! - At construction the matrix is cut into **bands** that respect the device's limits
//!   (`max_storage_buffer_binding_size`, `max_buffer_size`, `max_texture_dimension_2d`,
//!   `max_compute_workgroups_per_dimension`): block rows inside one tile row, and for textures
//!   also block columns. Each band's blocks are uploaded once into their own buffer or
//!   textures; the per-tile log tables (256 floats per tile and channel, the same
//!   `LogScale::table()` the CPU uses) go up once too.
//! - Each frame: one upload of `x`, one dispatch per band (a workgroup of 64 invocations per
//!   block row: each decodes whole blocks and keeps four RGB sums; a tree reduction in workgroup
//!   memory adds them), one dispatch per sparse band adding the column groups' partial sums
//!   and the CSR corrections, one copy and **one readback** of `y`. All buffers persist.
//!
//! # Example
//!
//! ```
//! use radiosity_backend_wgpu::{GpuOptions, WgpuGather};
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
//! match WgpuGather::new(&matrix, &GpuOptions::default()) {
//!     Ok(mut gather) => {
//!         let x = vec![Rgb::new(1.0, 2.0, 0.0); 4];
//!         let mut y = vec![Rgb::ZERO; 4];
//!         gather.gather(&x, &mut y).unwrap();
//!         assert_eq!(y[0], Rgb::new(2.0, 4.0, 0.0));
//!         println!("gathered on {} ({})", gather.adapter(), gather.path());
//!     }
//!     // No adapter on this machine: the error says why.
//!     Err(e) => println!("{e}"),
//! }
//! ```
//!
//! # On the engine's own device
//!
//! An engine that already has a `wgpu::Device` keeps the frame there: [`HostGather`] reads
//! `x` from the engine's buffer and writes `y` into another, [`CornerPass`] turns `y` into
//! per-corner light of the file's mesh in a vertex buffer; both only record into the engine's
//! encoder (no submission, no readback, no wait). Layouts and usages: [`HostGatherBuffers`],
//! [`CornerBuffers`].
//!
//! ```
//! use radiosity_backend_wgpu::{GpuOptions, HostGather, HostGatherBuffers, adapters};
//! use radiosity_core::{
//!     BlockCorrections, Format, LogScale, MatrixLayout, Rgb, SparseRows, TransferMatrix,
//! };
//! use std::borrow::Cow;
//!
//! let matrix = TransferMatrix {
//!     layout: MatrixLayout::new(4, 1, Format::U8, 8192).unwrap(),
//!     scales: Cow::Owned(vec![LogScale::new(0.5, 6.9)]),
//!     blocks: Cow::Owned(vec![255; 16]),
//!     sparse: SparseRows::empty(4),
//!     corrections: BlockCorrections::empty(4),
//! };
//! let Some(adapter) = adapters().into_iter().next() else {
//!     return println!("no adapter on this machine");
//! };
//! // The engine's device, queue and buffers (n RGB f32 each).
//! let (device, queue) = pollster::block_on(
//!     adapter.wgpu_adapter().request_device(&wgpu::DeviceDescriptor::default()),
//! )
//! .unwrap();
//! let buffer = |usage| {
//!     device.create_buffer(&wgpu::BufferDescriptor {
//!         label: None,
//!         size: 4 * 12,
//!         usage,
//!         mapped_at_creation: false,
//!     })
//! };
//! use wgpu::BufferUsages as U;
//! let x = buffer(U::COPY_DST | U::COPY_SRC);
//! let y = buffer(U::STORAGE | U::COPY_SRC);
//! // Once: the matrix goes up, the bind groups are made.
//! let options = GpuOptions::default();
//! let gather =
//!     HostGather::new(&device, &queue, &matrix, &options, HostGatherBuffers { x: &x, y: &y })
//!         .unwrap();
//! // Every frame: the engine writes x, records the gather among its own passes, submits.
//! queue.write_buffer(&x, 0, bytemuck::cast_slice(&[Rgb::new(1.0, 2.0, 0.0); 4]));
//! let mut encoder = device.create_command_encoder(&Default::default());
//! gather.record(&mut encoder);
//! // ... the engine's passes read y here (a CornerPass, its shading) ...
//! queue.submit([encoder.finish()]);
//! ```

mod adapter;
mod auto;
mod choice;
mod conv;
mod corner;
mod device;
mod edited_host;
mod frame_timing;
mod gather;
mod level;
mod light_probes;
mod plan;
mod shader;
pub mod texture_unit;
mod toolkit;

pub use adapter::{Adapter, AdapterChoice, AdapterInfo, DeviceKind, adapters, choose_adapter};
pub use auto::{auto_gather, auto_level};
pub use choice::{Backend, Chosen, Unavailable, choose};
pub use corner::{CornerBuffers, CornerPass};
pub use edited_host::EditedHostGather;
pub use frame_timing::{HostFrameTimes, time_host_frame};
pub use gather::{HostGather, HostGatherBuffers, WgpuGather};
pub use level::{HostLevel, HostLevelBuffers, WgpuLevel};
pub use light_probes::{PROBE_OUT_BYTES, ProbeBuffers, ProbePass};
pub use radiosity_core::DecodeMode;

use std::fmt;

/// How blocks are decoded on the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum DecodePath {
    /// Hardware BC decoding when the matrix is BC1/BC4 and the adapter is a GPU with
    /// `TEXTURE_COMPRESSION_BC`; software decoding otherwise, including on software
    /// rasterisers (llvmpipe/lavapipe), whose texture path is slower than the shader's decode
    /// and rounds palettes differently from the encoder.
    #[default]
    Auto,
    /// Decode in the shader from storage buffers (every format, every adapter).
    Software,
    /// Let the texture unit decode BC1/BC4 textures; an error for other formats or adapters
    /// without BC support.
    HardwareBc,
}

impl DecodePath {
    /// `"auto"`, `"software"` or `"hardware-bc"`.
    pub fn name(self) -> &'static str {
        match self {
            DecodePath::Auto => "auto",
            DecodePath::Software => "software",
            DecodePath::HardwareBc => "hardware-bc",
        }
    }
}

impl fmt::Display for DecodePath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a [`WgpuGather`] runs on and how. `Default` is the best adapter, the best path,
/// D3D10 palettes in software and the device's own limits.
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Which adapter (hardware first by default).
    pub adapter: AdapterChoice,
    /// Software or hardware block decoding.
    pub path: DecodePath,
    /// Palette rounding of the software path: [`DecodeMode::D3d10`] (default) decodes exactly
    /// what the bake's encoder and the CPU backends assume; [`DecodeMode::Mesa`] what Mesa's
    /// texture unit gives. No effect on the hardware path, where the driver rounds.
    pub software_mode: DecodeMode,
    /// Caps the storage binding size below the device's limit (tests use it to force several
    /// bands on small matrices); `None` uses the device's.
    pub max_binding_bytes: Option<u64>,
    /// Caps the texture side below the device's `max_texture_dimension_2d`; `None` uses the
    /// device's.
    pub max_texture_side: Option<u32>,
    /// Column splits per band (workgroups along y, each over a range of block columns, their
    /// partial sums added by the finish kernel); `None` chooses enough for a large GPU to be
    /// busy. Tests force several on small matrices.
    pub column_splits: Option<u32>,
}

/// Why a GPU gather could not be built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GpuError {
    /// No adapter matches the choice; says which exist (or that none does).
    NoAdapter(String),
    /// The adapter or the matrix cannot take the requested path, or the matrix exceeds a limit.
    Unsupported(String),
    /// The device refused something (creation, an allocation, a shader).
    Device(String),
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(why) => write!(f, "no GPU adapter: {why}"),
            GpuError::Unsupported(why) => write!(f, "GPU gather not possible: {why}"),
            GpuError::Device(why) => write!(f, "GPU device error: {why}"),
        }
    }
}

impl std::error::Error for GpuError {}
