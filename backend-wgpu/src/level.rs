//! A level file's systems (`.rad` version 3) lit on the GPU: [`HostLevel`] records a frame into
//! the host's encoder on the host's device, [`WgpuLevel`] runs it on a device of its own and
//! reads the light back. One device for every system: each system's gather
//! ([`HostGather`]) between buffers of its own, and the light between systems through the
//! coupling on the device too (`shaders/level.wgsl`), so a frame is one submission.

use crate::adapter::{Adapter, choose_adapter};
use crate::device::{self, SerialDevice};
use crate::gather::{HostGather, HostGatherBuffers};
use crate::shader::WORKGROUP;
use crate::toolkit::{
    READ, UNIFORM, WRITE, buffer_ty, check_host_buffer, entire, in_error_scopes, layout_entry,
    pipeline, sized, storage, storage_binding_limit, workgroup_grid,
};
use crate::{GpuError, GpuOptions};
use bytemuck::{Pod, Zeroable};
use radiosity_core::container::LevelSystems;
use radiosity_core::systems::Coupling;
use radiosity_core::{RadFile, Rgb};
use std::ops::Range;
use wgpu::util::DeviceExt;

const LEVEL: &str = include_str!("shaders/level.wgsl");

/// The kernels' uniform (`struct System` in `level.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SystemUniform {
    start: u32,
    count: u32,
    row: u32,
    _pad: u32,
}

const _: () = assert!(size_of::<SystemUniform>() == 16);

/// The host's buffers a [`HostLevel`] reads and writes, bound once at construction: each `n`
/// RGB triples of f32 (12 bytes each) from offset 0, in the level's patch numbering.
#[derive(Clone, Copy, Debug)]
pub struct HostLevelBuffers<'a> {
    /// The first exitance `x` (W/m²: `E + ρ∘H_d` per patch). Needs
    /// [`wgpu::BufferUsages::STORAGE`].
    pub first: &'a wgpu::Buffer,
    /// The gathered irradiance after the frame (the light from the other systems plus the
    /// system's own transfer). Needs [`wgpu::BufferUsages::STORAGE`]; add `COPY_SRC` to read
    /// it back, bind it to a [`crate::CornerPass`] to light the mesh.
    pub gathered: &'a wgpu::Buffer,
}

/// One system: its gather between its own `x` and `y`, and its bind group for the coupling
/// and update kernels.
#[derive(Debug)]
struct System {
    gather: HostGather,
    bind_group: wgpu::BindGroup,
    grid: (u32, u32),
    count: usize,
}

/// The systems of `file`, or why it is no level the GPU can light: not a level file, or
/// its systems not loaded.
fn loaded_systems<'f, 'a>(file: &'f RadFile<'a>) -> Result<&'f LevelSystems<'a>, GpuError> {
    let sys = file
        .systems
        .as_ref()
        .ok_or_else(|| GpuError::Unsupported("not a level file (no systems)".into()))?;
    if !sys.is_loaded() {
        return Err(GpuError::Unsupported(
            "the level's systems are not loaded".into(),
        ));
    }
    Ok(sys)
}

/// Checks the host's `buffers` (`bytes` each, with `STORAGE`) and that the coupling's
/// columns and the per-patch light each fit one storage binding of `device`.
fn check_level_buffers(
    device: &wgpu::Device,
    sys: &LevelSystems<'_>,
    buffers: HostLevelBuffers<'_>,
    bytes: u64,
) -> Result<(), GpuError> {
    for (what, buffer) in [("first", buffers.first), ("gathered", buffers.gathered)] {
        check_host_buffer(
            "the level",
            what,
            buffer,
            bytes,
            wgpu::BufferUsages::STORAGE,
        )?;
    }
    let most = storage_binding_limit(&device.limits());
    for (what, b) in [
        ("coupling columns", 4 * sys.coupling.cols.len() as u64),
        ("per-patch light", bytes),
    ] {
        if b > most {
            return Err(GpuError::Unsupported(format!(
                "the level's {what} take {b} bytes, more than one storage binding ({most} bytes)"
            )));
        }
    }
    Ok(())
}

/// Each system's dispatch grid for the coupling and update kernels: a workgroup per
/// [`WORKGROUP`] patches, within the device's per-dimension limit.
fn system_grids(
    device: &wgpu::Device,
    sys: &LevelSystems<'_>,
) -> Result<Vec<(u32, u32)>, GpuError> {
    let dl = device.limits();
    (0..sys.count())
        .map(|s| {
            let count = sys.range(s).len();
            workgroup_grid(&dl, count.div_ceil(WORKGROUP as usize), || {
                format!("system {s}'s {count} patches")
            })
        })
        .collect()
}

/// One system's gather and the buffers of its own `x` and `y` it runs between.
struct SystemGather {
    gather: HostGather,
    x: wgpu::Buffer,
    y: wgpu::Buffer,
}

/// Every system's gather, with the bytes they and their `x` and `y` hold on the device. A
/// matrix the device cannot take is an `Err` naming the system.
fn system_gathers(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    file: &RadFile<'_>,
    sys: &LevelSystems<'_>,
    options: &GpuOptions,
) -> Result<(Vec<SystemGather>, u64), GpuError> {
    let mut gathers = Vec::with_capacity(sys.count());
    let mut device_bytes = 0;
    for s in 0..sys.count() {
        let one = sys
            .system(file, s)
            .map_err(|e| GpuError::Unsupported(format!("system {s}: {e}")))?;
        let m = 12 * sys.range(s).len() as u64;
        let make = |label: &str, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: m.max(4),
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let x = make("system x", wgpu::BufferUsages::COPY_SRC);
        let y = make("system y", wgpu::BufferUsages::empty());
        let gather = HostGather::new(
            device,
            queue,
            &one.matrix,
            options,
            HostGatherBuffers { x: &x, y: &y },
        )
        .map_err(|e| match e {
            GpuError::Unsupported(why) => GpuError::Unsupported(format!("system {s}: {why}")),
            other => other,
        })?;
        device_bytes += gather.device_bytes() + 2 * m;
        gathers.push(SystemGather { gather, x, y });
    }
    Ok((gathers, device_bytes))
}

/// What every system's bind group shares: the layout of the coupling and update kernels,
/// the coupling, the reflectances and the level's exitance.
struct SharedBindings {
    layout: wgpu::BindGroupLayout,
    row_ptr: wgpu::Buffer,
    cols: wgpu::Buffer,
    vals: wgpu::Buffer,
    rho: wgpu::Buffer,
    exitance: wgpu::Buffer,
}

impl SharedBindings {
    /// Uploads the coupling `c` and the reflectances `rho`, and makes the level's exitance
    /// (`bytes`, zero) and the kernels' bind group layout.
    fn new(device: &wgpu::Device, c: &Coupling<'_>, rho: &[Rgb], bytes: u64) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("level"),
            entries: &[
                layout_entry(0, buffer_ty(UNIFORM)),
                layout_entry(1, buffer_ty(READ)),
                layout_entry(2, buffer_ty(READ)),
                layout_entry(3, buffer_ty(READ)),
                layout_entry(4, buffer_ty(READ)),
                layout_entry(5, buffer_ty(READ)),
                layout_entry(6, buffer_ty(WRITE)),
                layout_entry(7, buffer_ty(WRITE)),
                layout_entry(8, buffer_ty(WRITE)),
                layout_entry(9, buffer_ty(READ)),
            ],
        });
        let none = wgpu::BufferUsages::empty();
        SharedBindings {
            layout,
            row_ptr: storage(
                device,
                "coupling rows",
                bytemuck::cast_slice(&c.row_ptr),
                none,
            ),
            cols: storage(
                device,
                "coupling columns",
                bytemuck::cast_slice(&c.cols),
                none,
            ),
            vals: storage(
                device,
                "coupling values",
                bytemuck::cast_slice(&c.values),
                none,
            ),
            rho: storage(device, "reflectance", bytemuck::cast_slice(rho), none),
            exitance: storage(
                device,
                "level exitance",
                &vec![0u8; bytes as usize],
                wgpu::BufferUsages::COPY_DST,
            ),
        }
    }

    /// The system of patches `r` running `one`, its kernels bound to the shared buffers, the
    /// host's `buffers` (`bytes` each) and its own `x` and `y`, dispatched over `grid`.
    fn system(
        &self,
        device: &wgpu::Device,
        one: SystemGather,
        r: Range<usize>,
        grid: (u32, u32),
        buffers: HostLevelBuffers<'_>,
        bytes: u64,
    ) -> System {
        let m = 12 * r.len() as u64;
        let uniform = SystemUniform {
            start: r.start as u32,
            count: r.len() as u32,
            row: grid.0 * WORKGROUP,
            _pad: 0,
        };
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("level system"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("level system"),
            layout: &self.layout,
            entries: &[
                entire(0, &ubuf),
                entire(1, &self.row_ptr),
                entire(2, &self.cols),
                entire(3, &self.vals),
                sized(4, buffers.first, bytes),
                entire(5, &self.rho),
                entire(6, &self.exitance),
                sized(7, buffers.gathered, bytes),
                sized(8, &one.x, m),
                sized(9, &one.y, m),
            ],
        });
        System {
            gather: one.gather,
            bind_group,
            grid,
            count: r.len(),
        }
    }
}

/// A level's frame on the host's device: every system updated once, in order (block
/// Gauss–Seidel, as [`radiosity_core::systems::Systems::frame`]): the light the other systems
/// send it through the coupling from their latest exitance, its own transfer, its new
/// exitance. The level's exitance stays on the device from frame to frame, so the light
/// converges over frames; [`HostLevel::reset`] darkens it.
#[derive(Debug)]
pub struct HostLevel {
    couple: wgpu::ComputePipeline,
    update: wgpu::ComputePipeline,
    systems: Vec<System>,
    exitance: wgpu::Buffer,
    n: usize,
    device_bytes: u64,
}

impl HostLevel {
    /// The level of `file` (a parsed level `.rad`, every system loaded) on the host's
    /// `device` and `queue`, between `buffers`. Uploads every system's matrix, the coupling
    /// and the reflectances once. A file that is not a level, a buffer of the wrong size or
    /// usage, or a device short of a limit is an `Err`, never a panic of wgpu.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        file: &RadFile<'_>,
        options: &GpuOptions,
        buffers: HostLevelBuffers<'_>,
    ) -> Result<Self, GpuError> {
        let sys = loaded_systems(file)?;
        let n = file.n();
        let bytes = 12 * n as u64;
        check_level_buffers(device, sys, buffers, bytes)?;
        let grids = system_grids(device, sys)?;
        let (gathers, gather_bytes) = system_gathers(device, queue, file, sys, options)?;
        let c = &sys.coupling;
        let device_bytes =
            4 * (c.row_ptr.len() + 2 * c.cols.len()) as u64 + 2 * bytes + gather_bytes;
        let rho: Vec<Rgb> = file.patches.iter().map(|p| p.reflectance).collect();
        let built = in_error_scopes(device, || {
            let shared = SharedBindings::new(device, c, &rho, bytes);
            let couple = pipeline(device, "level couple", LEVEL, "couple", &shared.layout);
            let update = pipeline(device, "level update", LEVEL, "update", &shared.layout);
            let systems: Vec<System> = gathers
                .into_iter()
                .zip(&grids)
                .enumerate()
                .map(|(s, (gather, &grid))| {
                    shared.system(device, gather, sys.range(s), grid, buffers, bytes)
                })
                .collect();
            (couple, update, systems, shared.exitance)
        })?;
        let (couple, update, systems, exitance) = built;
        Ok(HostLevel {
            couple,
            update,
            systems,
            exitance,
            n,
            device_bytes,
        })
    }

    /// Records one frame into `encoder`: for each system in order, the coupling kernel, its
    /// gather, the update kernel. Reads the host's `first`, writes its `gathered`.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        for s in &self.systems {
            if s.count == 0 {
                continue;
            }
            self.dispatch(encoder, "level couple", &self.couple, s);
            s.gather.record(encoder);
            self.dispatch(encoder, "level update", &self.update, s);
        }
    }

    fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        s: &System,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &s.bind_group, &[]);
        pass.dispatch_workgroups(s.grid.0, s.grid.1, 1);
    }

    /// Darkens the level: the exitance every system reads from the others goes to zero (the
    /// state before the first frame).
    pub fn reset(&self, queue: &wgpu::Queue) {
        queue.write_buffer(&self.exitance, 0, &vec![0u8; 12 * self.n]);
    }

    /// Systems.
    pub fn systems(&self) -> usize {
        self.systems.len()
    }

    /// Patches of the level.
    pub fn patches(&self) -> usize {
        self.n
    }

    /// Bytes the level holds on the device: the systems' matrices and buffers, the coupling,
    /// the exitance.
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }
}

/// A level lit on a GPU device of its own: each [`WgpuLevel::frame`] uploads the first
/// exitance, records a [`HostLevel`] frame, and reads the gathered light back.
#[derive(Debug)]
pub struct WgpuLevel {
    level: HostLevel,
    first: wgpu::Buffer,
    gathered: wgpu::Buffer,
    readback: wgpu::Buffer,
    out: Vec<Rgb>,
    reflectance: Vec<Rgb>,
    exitance: Vec<Rgb>,
    change: f32,
    name: String,
    /// Last, so that every resource above is gone when it drops ([`crate::device`]).
    dev: SerialDevice,
}

impl WgpuLevel {
    /// The level of `file` on the adapter `options` choose, on a device of its own.
    pub fn new(file: &RadFile<'_>, options: &GpuOptions) -> Result<Self, GpuError> {
        let adapter = choose_adapter(&options.adapter).map_err(GpuError::NoAdapter)?;
        Self::on_adapter(file, &adapter, options)
    }

    /// The level of `file` on a given adapter (from [`crate::adapters`]); `options.adapter`
    /// is ignored.
    pub fn on_adapter(
        file: &RadFile<'_>,
        adapter: &Adapter,
        options: &GpuOptions,
    ) -> Result<Self, GpuError> {
        let info = adapter.info.clone();
        let dev = device::open(
            &adapter.inner,
            &wgpu::DeviceDescriptor {
                label: Some("radiosity level"),
                required_limits: adapter.inner.limits(),
                ..Default::default()
            },
        )
        .map_err(|e| GpuError::Device(format!("{info}: {e}")))?;
        let (device, queue) = (dev.device(), dev.queue());
        let n = file.n();
        let bytes = (12 * n as u64).max(4);
        let make = |label: &str, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let first = make("level first", U::STORAGE | U::COPY_DST);
        let gathered = make("level gathered", U::STORAGE | U::COPY_SRC);
        let readback = make("level readback", U::MAP_READ | U::COPY_DST);
        let level = HostLevel::new(
            device,
            queue,
            file,
            options,
            HostLevelBuffers {
                first: &first,
                gathered: &gathered,
            },
        )?;
        Ok(WgpuLevel {
            name: format!("gpu-{}-systems", file.matrix.layout.format()),
            level,
            first,
            gathered,
            readback,
            out: vec![Rgb::ZERO; n],
            reflectance: file.patches.iter().map(|p| p.reflectance).collect(),
            exitance: vec![Rgb::ZERO; n],
            change: f32::INFINITY,
            dev,
        })
    }

    /// One frame for the first exitance `first` (`n` values, finite): every system updated
    /// once on the device; the gathered light read back ([`Self::gathered`]). Returns the
    /// frame's change of the exitance, `Σ |ΔB|` over patches and channels.
    pub fn frame(&mut self, first: &[Rgb]) -> Result<f32, GpuError> {
        if first.len() != self.out.len() {
            return Err(GpuError::Unsupported(format!(
                "{} first exitances for a level of {} patches",
                first.len(),
                self.out.len()
            )));
        }
        let (device, queue) = (self.dev.device(), self.dev.queue());
        queue.write_buffer(&self.first, 0, bytemuck::cast_slice(first));
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("level frame"),
        });
        self.level.record(&mut encoder);
        encoder.copy_buffer_to_buffer(&self.gathered, 0, &self.readback, 0, self.gathered.size());
        queue.submit([encoder.finish()]);
        device::map_read_and_wait(device, &self.readback, "the level's frame")?;
        let read = self
            .readback
            .get_mapped_range(..)
            .map(|view| {
                let n = self.out.len();
                let out: &mut [f32] = bytemuck::cast_slice_mut(&mut self.out);
                out.copy_from_slice(bytemuck::cast_slice(&view[..12 * n]));
            })
            .map_err(|e| GpuError::Device(format!("the level's readback failed: {e}")));
        // Unmapped whatever the read gave, so the next frame can copy into it.
        self.readback.unmap();
        read?;
        let mut change = 0.0;
        for ((b, &x), (&g, &rho)) in self
            .exitance
            .iter_mut()
            .zip(first)
            .zip(self.out.iter().zip(&self.reflectance))
        {
            let new = x + rho * g;
            let d = new - *b;
            change += d.r.abs() + d.g.abs() + d.b.abs();
            *b = new;
        }
        Ok(change)
    }

    /// Frames until the relative change of the exitance in a frame (`Σ|ΔB| / Σ|B|`) is at
    /// most `tolerance`, or `max_frames` (as `radiosity_runtime::systems::Level::steady`).
    /// Returns the frames taken; [`Self::change`] is the last one's relative change.
    pub fn steady(
        &mut self,
        first: &[Rgb],
        tolerance: f32,
        max_frames: usize,
    ) -> Result<usize, GpuError> {
        let mut frames = 0;
        while frames < max_frames {
            let change = self.frame(first)?;
            frames += 1;
            let total: f32 = self
                .exitance
                .iter()
                .map(|b| b.r.abs() + b.g.abs() + b.b.abs())
                .sum();
            self.change = radiosity_core::systems::relative_change(change, total);
            if !self.change.is_finite() {
                return Err(GpuError::Device(
                    "the level's light is not finite".to_owned(),
                ));
            }
            if self.change <= tolerance {
                break;
            }
        }
        Ok(frames)
    }

    /// The gathered irradiance after the last frame, per patch.
    pub fn gathered(&self) -> &[Rgb] {
        &self.out
    }

    /// The relative change of the exitance in the last [`Self::steady`] frame.
    pub fn change(&self) -> f32 {
        self.change
    }

    /// Systems.
    pub fn count(&self) -> usize {
        self.level.systems()
    }

    /// `gpu-<format>-systems`.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Darkens the level ([`HostLevel::reset`]).
    pub fn reset(&mut self) {
        self.level.reset(self.dev.queue());
        self.exitance.fill(Rgb::ZERO);
        self.change = f32::INFINITY;
    }
}

/// A GPU level is a gather as the runtime's CPU level is: `gather(x, y)` lights it to the
/// steady state (a relative change of 1e-4, at most 100 frames) from the light it holds.
impl radiosity_core::Gather for WgpuLevel {
    fn name(&self) -> &str {
        &self.name
    }

    fn patches(&self) -> usize {
        self.out.len()
    }

    fn gather(
        &mut self,
        exitance: &[Rgb],
        irradiance: &mut [Rgb],
    ) -> Result<(), radiosity_core::GatherError> {
        radiosity_core::check_gather_args(self.out.len(), exitance, irradiance)?;
        self.steady(exitance, 1e-4, 100)
            .map_err(|e| radiosity_core::GatherError::Backend(e.to_string()))?;
        irradiance.copy_from_slice(&self.out);
        Ok(())
    }
}
