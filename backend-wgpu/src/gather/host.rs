//! [`HostGather`]: the gather on a device and queue the host owns, recording its passes into
//! the host's command encoder between the host's buffers.

use super::Frame;
use crate::toolkit::{check_host_buffer, in_error_scopes, storage_binding_limit};
use crate::{DecodePath, GpuError, GpuOptions};
use radiosity_core::{DecodeMode, TransferMatrix};

/// The host's buffers a [`HostGather`] reads and writes, bound once at construction.
///
/// Both hold `n` RGB triples of f32 (12 bytes each, the layout of [`radiosity_core::Rgb`]),
/// tightly packed from offset 0, in the file's patch numbering; bytes past `12·n` are neither
/// read nor written.
#[derive(Clone, Copy, Debug)]
pub struct HostGatherBuffers<'a> {
    /// The first exitance `x` (W/m²). Needs [`wgpu::BufferUsages::COPY_SRC`]: each frame
    /// starts with a copy of it into the gather's own `x`, which is padded to whole blocks.
    pub x: &'a wgpu::Buffer,
    /// The gathered irradiance `y = M·x` (W/m²), written by the frame's last dispatches.
    /// Needs [`wgpu::BufferUsages::STORAGE`]; add `COPY_SRC` to read it back, and bind it to a
    /// [`crate::CornerPass`] to light a mesh.
    pub y: &'a wgpu::Buffer,
}

/// The gather on the host's own `wgpu::Device` and `wgpu::Queue`: built once (the matrix is
/// uploaded through the host's queue), then each frame [`HostGather::record`] records a copy
/// and one compute pass into the host's encoder. Nothing is submitted, mapped or waited for:
/// the host submits the encoder with the rest of its frame, and wgpu orders the pass after
/// whatever wrote `x` earlier in the same submission.
///
/// The device may have wgpu's default limits or smaller ones: the matrix is cut into bands
/// within them (as on the own-device path), and a device that cannot run the kernels at all
/// is refused with the limit that is short. Without `TEXTURE_COMPRESSION_BC` the blocks are
/// decoded in the shader.
#[derive(Debug)]
pub struct HostGather {
    frame: Frame,
    /// The host's `x`.
    x: wgpu::Buffer,
    path: DecodePath,
    model: Option<DecodeMode>,
    n: usize,
}

impl HostGather {
    /// A gather over `matrix` (valid, as a parsed `.rad`'s is) on the host's `device` and
    /// `queue`, between the host's `buffers`. `options.adapter` is ignored. Under
    /// [`DecodePath::Auto`] the shader decodes (exactly, under `options.software_mode`): the
    /// texture unit's rounding is measured only on a device of the gather's own
    /// ([`crate::WgpuGather`]). [`DecodePath::HardwareBc`] needs a BC1/BC4 matrix and the
    /// device's `TEXTURE_COMPRESSION_BC`.
    ///
    /// A wrong size or usage of a buffer, a missing feature or a short limit is an `Err`
    /// before anything reaches the device; so is any validation or out-of-memory error of
    /// the build (caught in error scopes, not passed to the device's error handler).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        matrix: &TransferMatrix<'_>,
        options: &GpuOptions,
        buffers: HostGatherBuffers<'_>,
    ) -> Result<Self, GpuError> {
        let l = matrix.layout;
        let format = l.format();
        let path = match options.path {
            DecodePath::Auto | DecodePath::Software => DecodePath::Software,
            DecodePath::HardwareBc if !format.is_block_compressed() => {
                return Err(GpuError::Unsupported(format!(
                    "hardware decoding needs a bc1 or bc4 matrix, this one is {format}"
                )));
            }
            DecodePath::HardwareBc
                if !device
                    .features()
                    .contains(wgpu::Features::TEXTURE_COMPRESSION_BC) =>
            {
                return Err(GpuError::Unsupported(
                    "the device was created without TEXTURE_COMPRESSION_BC".into(),
                ));
            }
            DecodePath::HardwareBc => DecodePath::HardwareBc,
        };
        let model = (path == DecodePath::Software).then_some(options.software_mode);
        let bytes = (12 * l.n()) as u64;
        check_host_buffer(
            "the gather",
            "x",
            buffers.x,
            bytes,
            wgpu::BufferUsages::COPY_SRC,
        )?;
        check_host_buffer(
            "the gather",
            "y",
            buffers.y,
            bytes,
            wgpu::BufferUsages::STORAGE,
        )?;
        let most = storage_binding_limit(&device.limits());
        if bytes > most {
            return Err(GpuError::Unsupported(format!(
                "y of {} patches takes {bytes} bytes, more than one storage binding ({most} bytes)",
                l.n()
            )));
        }
        let hardware = device.adapter_info().device_type != wgpu::DeviceType::Cpu;
        let frame = in_error_scopes(device, || {
            Frame::build(
                matrix,
                device,
                queue,
                path,
                options,
                hardware,
                Some(buffers.y),
            )
        })??;
        Ok(HostGather {
            frame,
            x: buffers.x.clone(),
            path,
            model,
            n: l.n(),
        })
    }

    /// Records the frame into `encoder`: the copy of the host's `x` into the gather's padded
    /// `x`, then one compute pass of every gather and finish dispatch, which writes the
    /// host's `y`. The CPU cost is a few wgpu calls per dispatch ([`HostGather::dispatches`]).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        self.record_timed(encoder, None);
    }

    /// [`HostGather::record`] with the compute pass between the host's `timestamps` (the
    /// device needs `TIMESTAMP_QUERY`); the copy of `x` is outside them.
    pub fn record_timed(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        self.record_from(encoder, &self.x, timestamps);
    }

    /// [`HostGather::record_timed`] from `x` instead of the host's `x` bound at construction
    /// (the caller checked it holds `12·n` bytes and has `COPY_SRC`): the second gather of an
    /// edited frame ([`crate::EditedHostGather`]).
    pub(crate) fn record_from(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        x: &wgpu::Buffer,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let b = &self.frame.buffers;
        encoder.copy_buffer_to_buffer(x, 0, &b.x, 0, b.y_bytes);
        self.frame.record_pass(encoder, timestamps);
    }

    /// The host's `x`, bound at construction.
    pub(crate) fn host_x(&self) -> &wgpu::Buffer {
        &self.x
    }

    /// Patches: the length of `x` and `y` in RGB triples.
    pub fn patches(&self) -> usize {
        self.n
    }

    /// The decode path that runs ([`DecodePath::Software`] or [`DecodePath::HardwareBc`]).
    pub fn path(&self) -> DecodePath {
        self.path
    }

    /// The CPU decode rules that reproduce the decoded entries bit for bit: the software
    /// path's mode; `None` on the hardware path (its texture unit is not measured here).
    pub fn decode_model(&self) -> Option<DecodeMode> {
        self.model
    }

    /// Dispatches per frame (bands plus sparse bands).
    pub fn dispatches(&self) -> usize {
        self.frame.dispatches()
    }

    /// Bytes the gather holds on the device besides the host's buffers.
    pub fn device_bytes(&self) -> u64 {
        self.frame.device_bytes
    }
}
