//! [`ProbePass`]: a `.rad`'s light probes' radiance SH for a frame, `P·(B − E)`, on the host's
//! device from a [`crate::HostGather`]'s `x` and `y`, into a buffer the host's shaders read.

use crate::GpuError;
use crate::toolkit::{
    READ, UNIFORM, WRITE, buffer_ty, check_host_buffer, check_pass_limits, entire, in_error_scopes,
    layout_entry, pipeline, record_dispatch, sized, storage, storage_binding_limit, workgroup_grid,
};
use bytemuck::{Pod, Zeroable};
use radiosity_core::{Patch, ProbeWeight, Probes, Rgb, SH_COEFFICIENTS};
use wgpu::util::DeviceExt;

const PROBES: &str = include_str!("shaders/probes.wgsl");
const FACTORS: &str = include_str!("shaders/probe_factors.wgsl");

/// The kernel's uniform (`struct ProbeCfg` in `probes.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ProbeUniform {
    count: u32,
    row: u32,
    _pad: [u32; 2],
}

const _: () = assert!(size_of::<ProbeUniform>() == 16);

/// The factored kernels' uniform (`struct FactorCfg` in `probe_factors.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct FactorUniform {
    count: u32,
    row: u32,
    rank: u32,
    patches: u32,
    mode_row: u32,
    _pad: [u32; 3],
}

const _: () = assert!(size_of::<FactorUniform>() == 32);
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
/// dispatch of one workgroup per probe (factored probes: one workgroup per mode, then one
/// invocation per probe and SH coefficient, `probe_factors.wgsl`). It reads the frame's `x` and `y`, so it is recorded
/// after [`crate::HostGather::record`] into the same encoder (or a later one). The values
/// equal the core's up to f32 summation order (each workgroup adds its 64 partial sums by a
/// tree).
#[derive(Debug)]
pub struct ProbePass {
    pipeline: wgpu::ComputePipeline,
    /// For factored probes, the `modes` kernel and its grid, dispatched before `pipeline`.
    modes: Option<(wgpu::ComputePipeline, (u32, u32))>,
    bind_group: wgpu::BindGroup,
    table: wgpu::Buffer,
    reflectance: Vec<Rgb>,
    grid: (u32, u32),
    probes: usize,
    device_bytes: u64,
}

/// binary16 bits as the bytes of whole words (a zero half after an odd count).
fn halves_as_words(h: &[u16]) -> Vec<u8> {
    let mut bytes = bytemuck::cast_slice::<u16, u8>(h).to_vec();
    bytes.resize(4 * h.len().div_ceil(2), 0);
    bytes
}

/// Per patch: emission, then reflectance (`probes.wgsl`'s `table`).
fn table_of(emission: impl Iterator<Item = Rgb>, reflectance: &[Rgb]) -> Vec<f32> {
    emission
        .zip(reflectance)
        .flat_map(|(e, r)| [e.r, e.g, e.b, r.r, r.g, r.b])
        .collect()
}

/// The pass's bind group layout: the uniform, five read-only buffers (rows or basis, weights
/// or coefficients, `x`, `y`, the patch table), the output and, for factored probes, the modes.
fn bind_group_layout(device: &wgpu::Device, factored: bool) -> wgpu::BindGroupLayout {
    let mut entries = vec![layout_entry(0, buffer_ty(UNIFORM))];
    entries.extend((1..=5).map(|b| layout_entry(b, buffer_ty(READ))));
    entries.push(layout_entry(6, buffer_ty(WRITE)));
    if factored {
        entries.push(layout_entry(7, buffer_ty(WRITE)));
    }
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("probes"),
        entries: &entries,
    })
}

/// The kernels of the pass and what only they read: the plain kernel with the probes' rows
/// and weights, or the factored kernels with the basis and coefficients and the modes'
/// buffer.
struct Kernels {
    pipeline: wgpu::ComputePipeline,
    /// For factored probes, the `modes` kernel, its grid and the modes it writes.
    modes: Option<(wgpu::ComputePipeline, (u32, u32), wgpu::Buffer)>,
    /// The bytes of the kernel's uniform.
    uniform: Vec<u8>,
    /// Binding 1: the probes' rows, or the factors' basis.
    rows: wgpu::Buffer,
    /// Binding 2: the probes' weights, or the factors' coefficients.
    weights: wgpu::Buffer,
}

impl Kernels {
    /// The kernels for `probes` over `patches`, bound through `layout`, dispatched over
    /// `grid` (and the modes over `mode_grid`, given for factored probes).
    fn new(
        device: &wgpu::Device,
        probes: &Probes<'_>,
        patches: &[Patch],
        layout: &wgpu::BindGroupLayout,
        (grid, mode_grid): ((u32, u32), Option<(u32, u32)>),
    ) -> Self {
        let read_only =
            |label: &str, bytes: &[u8]| storage(device, label, bytes, wgpu::BufferUsages::empty());
        let Some(f) = probes.factors.as_ref() else {
            return Kernels {
                pipeline: pipeline(device, "probes", PROBES, "probes", layout),
                modes: None,
                uniform: bytemuck::bytes_of(&ProbeUniform {
                    count: probes.len() as u32,
                    row: grid.0,
                    _pad: [0; 2],
                })
                .to_vec(),
                rows: read_only("probe rows", bytemuck::cast_slice(&probes.rows)),
                weights: read_only("probe weights", bytemuck::cast_slice(&probes.weights)),
            };
        };
        let mode_grid = mode_grid.expect("a grid for the modes of factored probes");
        let modes_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe modes"),
            size: 12 * u64::from(f.rank),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Kernels {
            pipeline: pipeline(device, "probe factors", FACTORS, "probes", layout),
            modes: Some((
                pipeline(device, "probe modes", FACTORS, "modes", layout),
                mode_grid,
                modes_buffer,
            )),
            uniform: bytemuck::bytes_of(&FactorUniform {
                count: probes.len() as u32,
                row: grid.0,
                rank: f.rank,
                patches: patches.len() as u32,
                mode_row: mode_grid.0,
                _pad: [0; 3],
            })
            .to_vec(),
            rows: read_only("probe basis", &halves_as_words(&f.basis)),
            weights: read_only("probe coefficients", &halves_as_words(&f.coefficients)),
        }
    }
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

        let storage_buffers = if probes.factors.is_some() { 7 } else { 6 };
        check_pass_limits(device, "the probe pass", storage_buffers)?;
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
        let (rows_bytes, weight_bytes) = match &probes.factors {
            // The basis and the coefficients, in words.
            Some(f) => (
                4 * f.basis.len().div_ceil(2) as u64,
                4 * f.coefficients.len().div_ceil(2) as u64,
            ),
            None => (
                4 * probes.rows.len() as u64,
                24 * probes.weights.len() as u64,
            ),
        };
        let table_bytes = 2 * patch_bytes;
        for (what, bytes) in [
            ("probe output", out_bytes),
            ("probe weights", weight_bytes),
            ("probe rows or basis", rows_bytes),
            ("per-patch emission and reflectance", table_bytes),
        ] {
            if bytes > most {
                return unsupported(format!(
                    "the {what} take {bytes} bytes, more than one storage binding ({most} bytes)"
                ));
            }
        }
        // Factored probes: one invocation per probe and SH coefficient, 64 a workgroup.
        let workgroups = match &probes.factors {
            Some(_) => (SH_COEFFICIENTS * probes.len()).div_ceil(64),
            None => probes.len(),
        };
        let grid = workgroup_grid(&dl, workgroups, || format!("{} probes", probes.len()))?;
        let mode_grid = match &probes.factors {
            Some(f) => Some(workgroup_grid(&dl, f.rank as usize, || {
                format!("{} probe modes", f.rank)
            })?),
            None => None,
        };
        let built = in_error_scopes(device, || {
            Self::build(
                device,
                probes,
                patches,
                buffers,
                (grid, mode_grid),
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
        (grid, mode_grid): ((u32, u32), Option<(u32, u32)>),
        patch_bytes: u64,
        out_bytes: u64,
    ) -> Self {
        let layout = bind_group_layout(device, probes.factors.is_some());
        let Kernels {
            pipeline,
            modes,
            uniform,
            rows,
            weights,
        } = Kernels::new(device, probes, patches, &layout, (grid, mode_grid));
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("probes"),
            contents: &uniform,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let reflectance: Vec<Rgb> = patches.iter().map(|p| p.reflectance).collect();
        let table = storage(
            device,
            "probe patch table",
            bytemuck::cast_slice(&table_of(patches.iter().map(|p| p.emission), &reflectance)),
            wgpu::BufferUsages::COPY_DST,
        );
        let mut bindings = vec![
            entire(0, &ubuf),
            entire(1, &rows),
            entire(2, &weights),
            sized(3, buffers.x, patch_bytes),
            sized(4, buffers.y, patch_bytes),
            entire(5, &table),
            sized(6, buffers.out, out_bytes),
        ];
        if let Some((_, _, m)) = &modes {
            bindings.push(entire(7, m));
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("probes"),
            layout: &layout,
            entries: &bindings,
        });
        ProbePass {
            pipeline,
            modes: modes.map(|(p, g, _)| (p, g)),
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

    /// Records the pass into `encoder`: one compute pass of one dispatch (two for factored
    /// probes: the modes, then the probes). Nothing is recorded for a file of no probes.
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
        if let Some((modes, mode_grid)) = &self.modes {
            // One pass of two dispatches: the second reads what the first wrote (WebGPU
            // orders storage writes between dispatches).
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("probes"),
                timestamp_writes: timestamps,
            });
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_pipeline(modes);
            pass.dispatch_workgroups(mode_grid.0, mode_grid.1, 1);
            pass.set_pipeline(&self.pipeline);
            pass.dispatch_workgroups(self.grid.0, self.grid.1, 1);
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

    /// Bytes the pass holds on the device (rows and weights, or basis and coefficients, and
    /// the per-patch table).
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }
}
