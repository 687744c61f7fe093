//! [`CornerPass`]: the per-corner indirect irradiance of a `.rad`'s full-detail mesh from a
//! gather's `y`, on the GPU, into a vertex-attribute buffer the host draws with.

use crate::GpuError;
use crate::shader::WORKGROUP;
use crate::toolkit::{
    READ, UNIFORM, WRITE, buffer_ty, check_host_buffer, check_pass_limits, entire, in_error_scopes,
    layout_entry, pipeline, record_dispatch, sized, storage, storage_binding_limit, workgroup_grid,
};
use bytemuck::{Pod, Zeroable};
use radiosity_core::Mesh;
use wgpu::util::DeviceExt;

const CORNER: &str = include_str!("shaders/corner.wgsl");

/// The kernel's uniform (`struct Corners` in `corner.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct CornerUniform {
    count: u32,
    row: u32,
    _pad: [u32; 2],
}

const _: () = assert!(size_of::<CornerUniform>() == 16);

/// The host's buffers a [`CornerPass`] reads and writes, bound once at construction.
#[derive(Clone, Copy, Debug)]
pub struct CornerBuffers<'a> {
    /// Per-patch irradiance (a [`crate::HostGather`]'s `y`): `n` RGB f32 triples from offset
    /// 0, `n` the mesh's patch count. Needs [`wgpu::BufferUsages::STORAGE`].
    pub y: &'a wgpu::Buffer,
    /// The output: one RGB f32 triple per corner (12 bytes, tightly packed from offset 0),
    /// triangle-major: triple `3·t + c` is corner `c` of triangle `t`, whose vertex is
    /// `mesh.triangles[t].vertices[c]`. Needs [`wgpu::BufferUsages::STORAGE`]; to draw with
    /// it, add `VERTEX` and bind it as a vertex buffer of stride 12 with one
    /// `Float32x3` attribute, drawing `3·triangles` unindexed vertices.
    pub out: &'a wgpu::Buffer,
}

/// The GPU twin of [`Mesh::corner_indirect`]: one compute dispatch, one invocation per
/// corner, each summing its weight row in stored order from zero (the core's order), so the
/// values equal the core's up to the driver's contraction of a multiply and an add into one
/// fused operation (WGSL allows it): bit for bit where the driver does not fuse.
#[derive(Debug)]
pub struct CornerPass {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// Workgroups along x and y.
    grid: (u32, u32),
    corners: usize,
    device_bytes: u64,
}

impl CornerPass {
    /// The pass for `mesh` (a parsed `.rad`'s) on the host's `device`, between `buffers`.
    /// Uploads the corner rows and weights once. A mesh whose rows
    /// do not match its triangles or name a patch past its patch count, a buffer of the wrong
    /// size or usage, or a device short of a limit is an `Err`, never a panic of wgpu.
    pub fn new(
        device: &wgpu::Device,
        mesh: &Mesh<'_>,
        buffers: CornerBuffers<'_>,
    ) -> Result<Self, GpuError> {
        let patches = mesh.sample_rows.len().saturating_sub(1);
        let corners = mesh.corner_count();
        let unsupported = |s: String| Err(GpuError::Unsupported(s));
        if mesh.corner_rows.len() != corners + 1
            || mesh.corner_rows.last().map(|&r| r as usize) != Some(mesh.corner_weights.len())
        {
            return unsupported(format!(
                "the mesh has {} corner row starts for {corners} corners and {} weights",
                mesh.corner_rows.len(),
                mesh.corner_weights.len()
            ));
        }
        if let Some(e) = mesh
            .corner_weights
            .iter()
            .find(|e| e.patch as usize >= patches)
        {
            return unsupported(format!(
                "a corner weight names patch {} of {patches}",
                e.patch
            ));
        }
        check_pass_limits(device, "the corner pass", 4)?;
        let dl = device.limits();
        let y_bytes = 12 * patches as u64;
        let out_bytes = 12 * corners as u64;
        check_host_buffer(
            "the corner pass",
            "y",
            buffers.y,
            y_bytes,
            wgpu::BufferUsages::STORAGE,
        )?;
        check_host_buffer(
            "the corner pass",
            "out",
            buffers.out,
            out_bytes,
            wgpu::BufferUsages::STORAGE,
        )?;
        let most = storage_binding_limit(&dl);
        let rows_bytes = 4 * mesh.corner_rows.len() as u64;
        let weight_bytes = 8 * mesh.corner_weights.len() as u64;
        for (what, bytes) in [
            ("per-corner output", out_bytes),
            ("corner weights", weight_bytes),
            ("corner rows", rows_bytes),
            ("per-patch irradiance", y_bytes),
        ] {
            if bytes > most {
                return unsupported(format!(
                    "the mesh's {what} take {bytes} bytes, more than one storage binding ({most} bytes)"
                ));
            }
        }
        let (gx, gy) = workgroup_grid(&dl, corners.div_ceil(WORKGROUP as usize), || {
            format!("{corners} corners")
        })?;
        let built = in_error_scopes(device, || {
            Self::build(device, mesh, buffers, (gx, gy), y_bytes, out_bytes)
        })?;
        Ok(CornerPass {
            device_bytes: rows_bytes + weight_bytes,
            ..built
        })
    }

    fn build(
        device: &wgpu::Device,
        mesh: &Mesh<'_>,
        buffers: CornerBuffers<'_>,
        grid: (u32, u32),
        y_bytes: u64,
        out_bytes: u64,
    ) -> Self {
        let corners = mesh.corner_count();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("corners"),
            entries: &[
                layout_entry(0, buffer_ty(UNIFORM)),
                layout_entry(1, buffer_ty(READ)),
                layout_entry(2, buffer_ty(READ)),
                layout_entry(3, buffer_ty(READ)),
                layout_entry(4, buffer_ty(WRITE)),
            ],
        });
        let pipeline = pipeline(device, "corners", CORNER, "corners", &layout);
        let uniform = CornerUniform {
            count: corners as u32,
            row: grid.0 * WORKGROUP,
            _pad: [0; 2],
        };
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("corners"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let rows = storage(
            device,
            "corner rows",
            bytemuck::cast_slice(&mesh.corner_rows),
            wgpu::BufferUsages::empty(),
        );
        let weights = storage(
            device,
            "corner weights",
            bytemuck::cast_slice(&mesh.corner_weights),
            wgpu::BufferUsages::empty(),
        );
        // Bindings of at least 4 bytes: an empty one is invalid (the pass then dispatches
        // nothing, see `record`).
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("corners"),
            layout: &layout,
            entries: &[
                entire(0, &ubuf),
                entire(1, &rows),
                entire(2, &weights),
                sized(3, buffers.y, y_bytes),
                sized(4, buffers.out, out_bytes),
            ],
        });
        CornerPass {
            pipeline,
            bind_group,
            grid,
            corners,
            device_bytes: 0,
        }
    }

    /// Records the pass into `encoder`: one compute pass of one dispatch, reading `y` and
    /// writing `out`. Recorded after a [`crate::HostGather::record`] into the same encoder
    /// (or a later one), it reads that frame's `y`. Nothing is recorded for a mesh of no
    /// triangles.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        self.record_timed(encoder, None);
    }

    /// [`CornerPass::record`] between the host's `timestamps` (the device needs
    /// `TIMESTAMP_QUERY`).
    pub fn record_timed(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        if self.corners == 0 {
            return;
        }
        record_dispatch(
            encoder,
            "corners",
            &self.pipeline,
            &self.bind_group,
            self.grid,
            timestamps,
        );
    }

    /// Corners written: three per triangle.
    pub fn corners(&self) -> usize {
        self.corners
    }

    /// Bytes the pass holds on the device (corner rows and weights).
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }
}
