//! [`ProbePass`]: a `.rad`'s light probes' radiance SH for a frame, `P·(B − E)`, on the host's
//! device from a [`crate::HostGather`]'s `x` and `y`, into a buffer the host's shaders read.

use crate::GpuError;
use crate::gather::{
    READ, UNIFORM, WRITE, buffer_ty, check_host_buffer, check_pass_limits, entire, in_error_scopes,
    layout_entry, pipeline, record_dispatch, sized, storage, storage_binding_limit, workgroup_grid,
};
use bytemuck::{Pod, Zeroable};
use radiosity_core::{Patch, ProbeWeight, Probes, Rgb, SH_COEFFICIENTS};
use wgpu::util::DeviceExt;

const PROBES: &str = include_str!("shaders/probes.wgsl");

/// The kernel's uniform (`struct ProbeCfg` in `probes.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ProbeUniform {
    count: u32,
    row: u32,
    _pad: [u32; 2],
}

const _: () = assert!(size_of::<ProbeUniform>() == 16);
const _: () = assert!(size_of::<ProbeWeight>() == 24);

/// Bytes of one probe's output: nine RGB f32 coefficients.
pub const PROBE_OUT_BYTES: u64 = (SH_COEFFICIENTS * 12) as u64;

/// The host's buffers a [`ProbePass`] reads and writes, bound once at construction.
#[derive(Clone, Copy, Debug)]
pub struct ProbeBuffers<'a> {
    /// The frame's first exitance `x` (a [`crate::HostGather`]'s): `n` RGB f32 triples from
    /// offset 0. Needs [`wgpu::BufferUsages::STORAGE`].
    pub x: &'a wgpu::Buffer,
    /// The frame's gathered irradiance `y = M·x`, laid out as `x`. Needs `STORAGE`.
    pub y: &'a wgpu::Buffer,
    /// The output: per probe, nine RGB f32 SH coefficients of reflected radiance
    /// ([`PROBE_OUT_BYTES`] bytes, in the order of [`radiosity_core::sh_basis`]), probe-major
    /// and tightly packed from offset 0, the layout of `[[Rgb; 9]]`. Needs `STORAGE`; the
    /// host's shaders turn a coefficient set into irradiance for a normal as
    /// [`radiosity_core::sh_irradiance`] does.
    pub out: &'a wgpu::Buffer,
}

/// The GPU twin of [`Probes::gather`] on the reflected radiosity `B − E = x − E + ρ∘y`: one
/// dispatch of one workgroup per probe. It reads the frame's `x` and `y`, so it is recorded
/// after [`crate::HostGather::record`] into the same encoder (or a later one). The values
/// equal the core's up to f32 summation order (each workgroup adds its 64 partial sums by a
/// tree).
#[derive(Debug)]
pub struct ProbePass {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    table: wgpu::Buffer,
    reflectance: Vec<Rgb>,
    grid: (u32, u32),
    probes: usize,
    device_bytes: u64,
}

/// Per patch: emission, then reflectance (`probes.wgsl`'s `table`).
fn table_of(emission: impl Iterator<Item = Rgb>, reflectance: &[Rgb]) -> Vec<f32> {
    emission
        .zip(reflectance)
        .flat_map(|(e, r)| [e.r, e.g, e.b, r.r, r.g, r.b])
        .collect()
}

impl ProbePass {
    /// The pass for `probes` over a file's `patches` (valid, as a parsed `.rad`'s are) on the
    /// host's `device`, between `buffers`. Uploads the weights and the patches' emission and
    /// reflectance once ([`ProbePass::set_emission`] changes the emission). Probes naming a
    /// patch past `patches`, a buffer of the wrong size or usage, or a device short of a
    /// limit is an `Err`, never a panic of wgpu.
    pub fn new(
        device: &wgpu::Device,
        probes: &Probes<'_>,
        patches: &[Patch],
        buffers: ProbeBuffers<'_>,
    ) -> Result<Self, GpuError> {
        let unsupported = |s: String| Err(GpuError::Unsupported(s));
        if let Err(e) = probes.validate(patches.len()) {
            return unsupported(format!("the probes do not fit the patches: {e}"));
        }
        check_pass_limits(device, "the probe pass", 6)?;
        let dl = device.limits();
        let patch_bytes = 12 * patches.len() as u64;
        let out_bytes = PROBE_OUT_BYTES * probes.len() as u64;
        for (what, buffer, bytes) in [
            ("x", buffers.x, patch_bytes),
            ("y", buffers.y, patch_bytes),
            ("out", buffers.out, out_bytes),
        ] {
            check_host_buffer(
                "the probe pass",
                what,
                buffer,
                bytes,
                wgpu::BufferUsages::STORAGE,
            )?;
        }
        let most = storage_binding_limit(&dl);
        let rows_bytes = 4 * probes.rows.len() as u64;
        let weight_bytes = 24 * probes.weights.len() as u64;
        let table_bytes = 2 * patch_bytes;
        for (what, bytes) in [
            ("probe output", out_bytes),
            ("probe weights", weight_bytes),
            ("probe rows", rows_bytes),
            ("per-patch emission and reflectance", table_bytes),
        ] {
            if bytes > most {
                return unsupported(format!(
                    "the {what} take {bytes} bytes, more than one storage binding ({most} bytes)"
                ));
            }
        }
        let grid = workgroup_grid(&dl, probes.len(), || format!("{} probes", probes.len()))?;
        let built = in_error_scopes(device, || {
            Self::build(
                device,
                probes,
                patches,
                buffers,
                grid,
                patch_bytes,
                out_bytes,
            )
        })?;
        Ok(ProbePass {
            device_bytes: rows_bytes + weight_bytes + table_bytes,
            ..built
        })
    }

    fn build(
        device: &wgpu::Device,
        probes: &Probes<'_>,
        patches: &[Patch],
        buffers: ProbeBuffers<'_>,
        grid: (u32, u32),
        patch_bytes: u64,
        out_bytes: u64,
    ) -> Self {
        let mut entries = vec![layout_entry(0, buffer_ty(UNIFORM))];
        entries.extend((1..=5).map(|b| layout_entry(b, buffer_ty(READ))));
        entries.push(layout_entry(6, buffer_ty(WRITE)));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("probes"),
            entries: &entries,
        });
        let pipeline = pipeline(device, "probes", PROBES, "probes", &layout);
        let uniform = ProbeUniform {
            count: probes.len() as u32,
            row: grid.0,
            _pad: [0; 2],
        };
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("probes"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let rows = storage(
            device,
            "probe rows",
            bytemuck::cast_slice(&probes.rows),
            wgpu::BufferUsages::empty(),
        );
        let weights = storage(
            device,
            "probe weights",
            bytemuck::cast_slice(&probes.weights),
            wgpu::BufferUsages::empty(),
        );
        let reflectance: Vec<Rgb> = patches.iter().map(|p| p.reflectance).collect();
        let table = storage(
            device,
            "probe patch table",
            bytemuck::cast_slice(&table_of(patches.iter().map(|p| p.emission), &reflectance)),
            wgpu::BufferUsages::COPY_DST,
        );
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("probes"),
            layout: &layout,
            entries: &[
                entire(0, &ubuf),
                entire(1, &rows),
                entire(2, &weights),
                sized(3, buffers.x, patch_bytes),
                sized(4, buffers.y, patch_bytes),
                entire(5, &table),
                sized(6, buffers.out, out_bytes),
            ],
        });
        ProbePass {
            pipeline,
            bind_group,
            table,
            reflectance,
            grid,
            probes: probes.len(),
            device_bytes: 0,
        }
    }

    /// Writes the patches' emission through the host's `queue`, for a frame whose emitters
    /// were scaled (as `x` was): the pass subtracts it from `x`. One entry per patch, finite;
    /// otherwise an `Err` and nothing is written.
    pub fn set_emission(&self, queue: &wgpu::Queue, emission: &[Rgb]) -> Result<(), GpuError> {
        if emission.len() != self.reflectance.len() {
            return Err(GpuError::Unsupported(format!(
                "{} emissions for {} patches",
                emission.len(),
                self.reflectance.len()
            )));
        }
        if let Some(i) = emission.iter().position(|e| !e.is_finite()) {
            return Err(GpuError::Unsupported(format!(
                "the emission of patch {i} is NaN or infinite"
            )));
        }
        let table = table_of(emission.iter().copied(), &self.reflectance);
        queue.write_buffer(&self.table, 0, bytemuck::cast_slice(&table));
        Ok(())
    }

    /// Records the pass into `encoder`: one compute pass of one dispatch. Nothing is
    /// recorded for a file of no probes.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        self.record_timed(encoder, None);
    }

    /// [`ProbePass::record`] between the host's `timestamps` (the device needs
    /// `TIMESTAMP_QUERY`).
    pub fn record_timed(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        if self.probes == 0 {
            return;
        }
        record_dispatch(
            encoder,
            "probes",
            &self.pipeline,
            &self.bind_group,
            self.grid,
            timestamps,
        );
    }

    /// Probes written.
    pub fn probes(&self) -> usize {
        self.probes
    }

    /// Bytes the pass holds on the device (rows, weights and the per-patch table).
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }
}
