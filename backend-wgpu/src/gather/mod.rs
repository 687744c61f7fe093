//! [`WgpuGather`]: the device, the persistent buffers and textures, the per-frame dispatches.
//!
//! Building runs in steps that each take the device, queue and plan they need: `setup.rs`
//! plans the cut of the matrix within the device's limits and makes the shared buffers and
//! the pipelines, `bind.rs` uploads each dispatch's share of the matrix and makes its bind
//! group. Each frame [`Frame::record_pass`] records the dispatches into a command encoder: the
//! own-device [`WgpuGather`] then copies `y` back, the host-device [`HostGather`] (`host.rs`)
//! leaves it in the host's buffer.

mod bind;
mod host;
mod setup;

pub use host::{HostGather, HostGatherBuffers};

#[cfg(test)]
pub(crate) use setup::workgroup_bytes;

use crate::adapter::{Adapter, AdapterInfo, choose_adapter};
use crate::device::{self, SerialDevice};
use crate::texture_unit;
use crate::{DecodePath, GpuError, GpuOptions};
use bind::Dispatch;
use radiosity_core::{DecodeMode, Gather, GatherError, Rgb, TransferMatrix, check_gather_args};
use setup::{Buffers, FramePlan, Pipelines, Readback, Timer};
use std::sync::{Arc, Mutex, mpsc};

/// The wgpu compute gather. Build once per matrix ([`WgpuGather::new`] uploads everything);
/// every [`Gather::gather`] then uploads `x`, dispatches, and reads `y` back.
#[derive(Debug)]
pub struct WgpuGather {
    adapter: AdapterInfo,
    path: DecodePath,
    model: Option<DecodeMode>,
    n: usize,
    name: String,
    frame: Frame,
    readback: Readback,
    device_bytes: u64,
    errors: Arc<Mutex<Vec<String>>>,
    kernel_ms: Option<f64>,
    declined: bool,
    /// Last, so that every resource above is gone when it drops and the device is destroyed
    /// under the process-wide lock ([`crate::device`]).
    dev: SerialDevice,
}

impl WgpuGather {
    /// A gather over `matrix` on the adapter and path `options` choose. The matrix must be
    /// valid ([`TransferMatrix::validate`]; a parsed `.rad` file is).
    pub fn new(matrix: &TransferMatrix<'_>, options: &GpuOptions) -> Result<Self, GpuError> {
        let adapter = choose_adapter(&options.adapter).map_err(GpuError::NoAdapter)?;
        Self::on_adapter(matrix, &adapter, options)
    }

    /// A gather on a given adapter (from [`crate::adapters`]); `options.adapter` is ignored.
    pub fn on_adapter(
        matrix: &TransferMatrix<'_>,
        adapter: &Adapter,
        options: &GpuOptions,
    ) -> Result<Self, GpuError> {
        let l = matrix.layout;
        let format = l.format();
        let info = adapter.info.clone();
        // The texture unit's decode rules, measured once per adapter (`texture_unit`), where its
        // path is asked for or could be chosen.
        let hardware_possible = format.is_block_compressed() && info.bc;
        let texture_model = match options.path {
            DecodePath::HardwareBc if hardware_possible => {
                texture_unit::texture_decode_model(adapter)?
            }
            // A software rasteriser's texture unit is software too, and slower than decoding
            // in the shader (lavapipe, n = 1913 BC1: 100 ms against 39 ms): not measured.
            DecodePath::Auto if hardware_possible && info.is_hardware() => {
                texture_unit::texture_decode_model(adapter).unwrap_or(None)
            }
            _ => None,
        };
        let path = match options.path {
            // Only a texture unit that decodes exactly as the CPU does (D3D10's or Mesa's
            // rules, measured): one that rounds otherwise moves entries by whole codes.
            DecodePath::Auto if texture_model.is_some() => DecodePath::HardwareBc,
            DecodePath::Auto => DecodePath::Software,
            DecodePath::HardwareBc if !format.is_block_compressed() => {
                return Err(GpuError::Unsupported(format!(
                    "hardware decoding needs a bc1 or bc4 matrix, this one is {format}"
                )));
            }
            DecodePath::HardwareBc if !info.bc => {
                return Err(GpuError::Unsupported(format!(
                    "{info} has no TEXTURE_COMPRESSION_BC"
                )));
            }
            p => p,
        };
        let model = match path {
            DecodePath::HardwareBc => texture_model,
            _ => Some(options.software_mode),
        };
        // `auto` passed over a hardware texture unit because its measured rounding matched no CPU rules.
        let declined = options.path == DecodePath::Auto
            && hardware_possible
            && info.is_hardware()
            && texture_model.is_none();
        let mut features = if path == DecodePath::HardwareBc {
            wgpu::Features::TEXTURE_COMPRESSION_BC
        } else {
            wgpu::Features::empty()
        };
        // GPU timestamps for `kernel_ms`, where the adapter has them.
        features |= adapter.inner.features() & wgpu::Features::TIMESTAMP_QUERY;
        // Bound first, so it drops last: on an error below, every resource is gone before the
        // device is destroyed under the lock.
        let dev = device::open(
            &adapter.inner,
            &wgpu::DeviceDescriptor {
                label: Some("radiosity gather"),
                required_features: features,
                required_limits: adapter.inner.limits(),
                ..Default::default()
            },
        )
        .map_err(|e| GpuError::Device(format!("{info}: {e}")))?;
        let device = dev.device();
        let errors = Arc::new(Mutex::new(Vec::new()));
        {
            let errors = errors.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                if let Ok(mut list) = errors.lock() {
                    list.push(e.to_string());
                }
            }));
        }
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let built = Self::build(matrix, dev.clone(), info, path, model, options, errors)
            .map(|g| WgpuGather { declined, ..g });
        let oom = pollster::block_on(oom.pop());
        let validation = pollster::block_on(validation.pop());
        if let Some(e) = oom.or(validation) {
            return Err(GpuError::Device(e.to_string()));
        }
        // One gather of zeros: drivers that compile kernels at their first dispatch (lavapipe
        // does, 0.1–1 s each) do it now, so frame timings measure frames.
        let mut built = built?;
        let zeros = vec![Rgb::ZERO; built.n];
        let mut y = zeros.clone();
        built
            .gather(&zeros, &mut y)
            .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(built)
    }

    /// Builds the gather on `dev`: the frame's dispatches ([`Frame::build`]) and the readback.
    fn build(
        matrix: &TransferMatrix<'_>,
        dev: SerialDevice,
        adapter: AdapterInfo,
        path: DecodePath,
        model: Option<DecodeMode>,
        options: &GpuOptions,
        errors: Arc<Mutex<Vec<String>>>,
    ) -> Result<Self, GpuError> {
        let (device, queue) = (dev.device(), dev.queue());
        let frame = Frame::build(
            matrix,
            device,
            queue,
            path,
            options,
            adapter.is_hardware(),
            None,
        )?;
        let readback = Readback::new(device, queue, frame.buffers.y_bytes);
        let l = matrix.layout;
        Ok(WgpuGather {
            name: format!("gpu-{}", l.format().name()),
            adapter,
            path,
            model,
            n: l.n(),
            // The readback holds one more copy of `y`.
            device_bytes: frame.device_bytes + frame.buffers.y_bytes,
            frame,
            readback,
            errors,
            kernel_ms: None,
            declined: false,
            dev,
        })
    }

    /// The adapter it runs on.
    pub fn adapter(&self) -> &AdapterInfo {
        &self.adapter
    }

    /// The decode path that runs ([`DecodePath::Software`] or [`DecodePath::HardwareBc`],
    /// never `Auto`).
    pub fn path(&self) -> DecodePath {
        self.path
    }

    /// The CPU decode rules that reproduce this gather's decoded entries bit for bit, when
    /// known: the software path's mode; on the hardware path the rules the texture unit was
    /// measured to match ([`crate::texture_unit::texture_decode_model`]: D3D10's on a decoder that
    /// interpolates without rounding, Mesa's on llvmpipe/lavapipe), and `None` on drivers
    /// that match neither (D3D10 allows each palette entry to be off by one code; an NVIDIA
    /// H100 is off by up to 7).
    pub fn decode_model(&self) -> Option<DecodeMode> {
        self.model
    }

    /// Why the path is what it is, where that is not obvious: under [`DecodePath::Auto`] on a
    /// GPU whose texture unit decodes BC1/BC4 by rules no CPU decoder reproduces (the measurement
    /// of [`crate::texture_unit::texture_decode_model`] matched none, as on an NVIDIA H100), the shader
    /// decodes instead and this says so. `None` otherwise.
    pub fn path_note(&self) -> Option<&'static str> {
        self.declined.then_some(
            "its texture unit decodes BC off the CPU's rules (measured), so the shader decodes",
        )
    }

    /// GPU time of the last [`Gather::gather`]'s compute pass (every gather and finish
    /// dispatch, without the upload of `x` and the readback of `y`), in milliseconds, from
    /// timestamps written by the device; `None` where the adapter has no
    /// `TIMESTAMP_QUERY` or before the first gather. What a renderer that keeps `y` on the
    /// GPU would pay per frame.
    pub fn kernel_ms(&self) -> Option<f64> {
        self.kernel_ms
    }

    /// Dispatches per frame (bands plus sparse bands): more than two means the matrix was cut
    /// to respect the device's limits.
    pub fn dispatches(&self) -> usize {
        self.frame.dispatches()
    }

    /// Bytes held on the device: blocks, tables, sparse part, `x`, `y` and scratch.
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }

    fn take_errors(&self) -> Result<(), GatherError> {
        let mut list = self
            .errors
            .lock()
            .map_err(|_| GatherError::Backend("error log poisoned".into()))?;
        if list.is_empty() {
            Ok(())
        } else {
            let all = list.join("; ");
            list.clear();
            Err(GatherError::Backend(format!(
                "{}: {all}",
                self.adapter.name
            )))
        }
    }
}

/// What a frame records on either path: the pipelines, each dispatch's bind group, and the
/// buffers they share.
#[derive(Debug)]
pub(crate) struct Frame {
    pipelines: Pipelines,
    bands: Vec<Dispatch>,
    finishes: Vec<Dispatch>,
    buffers: Buffers,
    /// Bytes held on the device: blocks, tables, sparse part, `x`, the own `y` and scratch.
    device_bytes: u64,
}

impl Frame {
    /// Builds a frame over `matrix` on `device` in steps that each take what they need: the
    /// plan (how the matrix is cut within the device's limits), the buffers every dispatch
    /// shares, the two pipelines, then each dispatch's share of the matrix and its bind
    /// group. `hardware` says whether the device is a hardware GPU (column splits); `host_y`
    /// is the host's `y`, bound instead of a buffer of the frame's own.
    fn build(
        matrix: &TransferMatrix<'_>,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        path: DecodePath,
        options: &GpuOptions,
        hardware: bool,
        host_y: Option<&wgpu::Buffer>,
    ) -> Result<Self, GpuError> {
        let l = matrix.layout;
        assert_eq!(
            matrix.blocks.len() as u64,
            l.block_bytes(),
            "block data does not match the layout"
        );
        assert_eq!(matrix.scales.len(), l.scale_count(), "scale count");
        // The block corrections ride along in the sparse list (16 entries each at most): the
        // finish pass then adds them without bindings of their own.
        let merged;
        let sparse = if matrix.corrections.is_empty() {
            &matrix.sparse
        } else {
            merged = matrix.sparse_with_corrections();
            &merged
        };
        setup::check_compute_limits(&device.limits(), l.channels())?;
        let lim = setup::plan_limits(device, options);
        let plan = FramePlan::new(&l, sparse, &lim, path, options, hardware)?;
        let buffers = Buffers::new(device, matrix, &plan, host_y);
        let pipelines = Pipelines::new(device, &l, plan.source, options.software_mode);
        let (bands, band_bytes) = bind::band_dispatches(
            device,
            queue,
            matrix,
            &plan,
            &buffers,
            &pipelines.gather_layout,
        )?;
        let (finishes, sparse_bytes) = bind::finish_dispatches(
            device,
            sparse,
            l.channels(),
            &plan,
            &buffers,
            &pipelines.finish_layout,
        );
        Ok(Frame {
            device_bytes: buffers.bytes + band_bytes + sparse_bytes,
            pipelines,
            bands,
            finishes,
            buffers,
        })
    }

    fn dispatches(&self) -> usize {
        self.bands.len() + self.finishes.len()
    }

    /// Records the frame's compute pass into `encoder`: every gather dispatch, then every
    /// finish dispatch, between the pass's timestamps where `timer` is given. The pass reads
    /// `x` and writes `y`; it uploads and reads back nothing.
    fn record_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gather"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipelines.gather);
        for d in &self.bands {
            pass.set_bind_group(0, &d.bind_group, &[]);
            pass.dispatch_workgroups(d.workgroups, d.splits, 1);
        }
        pass.set_pipeline(&self.pipelines.finish);
        for d in &self.finishes {
            pass.set_bind_group(0, &d.bind_group, &[]);
            pass.dispatch_workgroups(d.workgroups, d.splits, 1);
        }
    }
}

impl WgpuGather {
    /// Byte offset of the two timestamps in the readback buffer, after `y`.
    fn stamps_at(&self) -> u64 {
        self.frame.buffers.y_bytes.next_multiple_of(8)
    }

    /// Records the copies of `y` and the resolved timestamps into the readback buffer.
    fn record_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let (b, r) = (&self.frame.buffers, &self.readback);
        encoder.copy_buffer_to_buffer(&b.y, 0, &r.buffer, 0, b.y_bytes);
        if let Some(t) = &r.timer {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &r.buffer, self.stamps_at(), 16);
        }
    }

    /// Waits for the submitted frame, then copies `y` into `irradiance` and the pass's GPU
    /// time into `kernel_ms`.
    fn read_back(&mut self, irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        let (tx, rx) = mpsc::channel();
        self.readback
            .buffer
            .map_async(wgpu::MapMode::Read, .., move |r| {
                let _ = tx.send(r);
            });
        self.dev
            .device()
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GatherError::Backend(format!("{}: {e}", self.adapter.name)))?;
        let mapped = rx
            .recv()
            .map_err(|_| GatherError::Backend("readback callback never ran".into()))?;
        self.take_errors()?;
        mapped.map_err(|e| GatherError::Backend(format!("readback failed: {e}")))?;
        let stamps_at = self.stamps_at() as usize;
        {
            let r = &self.readback;
            let view = r
                .buffer
                .get_mapped_range(..)
                .map_err(|e| GatherError::Backend(format!("readback failed: {e}")))?;
            let y: &mut [f32] = bytemuck::cast_slice_mut(irradiance);
            y.copy_from_slice(bytemuck::cast_slice(
                &view[..self.frame.buffers.y_bytes as usize],
            ));
            if let Some(t) = &r.timer {
                let stamp = |i: usize| {
                    let at = stamps_at + 8 * i;
                    u64::from_le_bytes(view[at..at + 8].try_into().unwrap())
                };
                let ticks = stamp(1).wrapping_sub(stamp(0));
                self.kernel_ms = Some(ticks as f64 * t.period * 1e-6);
            }
        }
        self.readback.buffer.unmap();
        Ok(())
    }
}

impl Gather for WgpuGather {
    fn name(&self) -> &str {
        &self.name
    }

    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        check_gather_args(self.n, exitance, irradiance)?;
        self.dev
            .queue()
            .write_buffer(&self.frame.buffers.x, 0, bytemuck::cast_slice(exitance));
        let mut encoder =
            self.dev
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("gather"),
                });
        let stamps = self.readback.timer.as_ref().map(Timer::writes);
        self.frame.record_pass(&mut encoder, stamps);
        self.record_readback(&mut encoder);
        self.dev.queue().submit([encoder.finish()]);
        self.read_back(irradiance)
    }
}
