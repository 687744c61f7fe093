//! [`EditedHostGather`]: the frame of a scene whose reflectance was edited at run time
//! ([`radiosity_core::ReflectanceEdit`]) on the host's device: two [`HostGather`] passes of
//! the baked matrix and, between them, the `k × k` correction as one small dispatch.

use crate::shader::WORKGROUP;
use crate::toolkit::{
    READ, UNIFORM, WRITE, buffer_ty, check_pass_limits, entire, in_error_scopes, layout_entry,
    pipeline, record_dispatch, sized, storage, storage_binding_limit, workgroup_grid,
};
use crate::{GpuError, GpuOptions, HostGather, HostGatherBuffers};
use bytemuck::{Pod, Zeroable};
use radiosity_core::{ReflectanceEdit, TransferMatrix};
use wgpu::util::DeviceExt;

const EDIT: &str = include_str!("shaders/edit.wgsl");

/// The kernel's uniform (`struct EditCfg` in `edit.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct EditUniform {
    k: u32,
    row: u32,
    _pad: [u32; 2],
}

/// [`radiosity_core::EditedGather`] on the host's device: [`EditedHostGather::record`] records
/// the gather of the host's `x` (the first exitance under the new reflectance) into the host's
/// `y`, a copy of `x` plus the correction `K·y_S` on the edited patches, and the gather of that
/// into `y` again, which then holds the edited scene's gathered irradiance. Nothing is
/// submitted or waited for. Give it an edit prepared under the gather's decode rules
/// ([`HostGather::decode_model`], `DecodeMode::D3d10` by default).
#[derive(Debug)]
pub struct EditedHostGather {
    gather: HostGather,
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// x̃, the corrected exitance.
    corrected: wgpu::Buffer,
    grid: (u32, u32),
    k: usize,
    device_bytes: u64,
}

impl EditedHostGather {
    /// The edited gather over `matrix` between the host's `buffers` (as [`HostGather::new`],
    /// whose errors it returns), applying `edit` (prepared against `matrix`). Uploads the
    /// correction matrices once (`12·k²` bytes). An edit of another matrix, or one whose
    /// matrices exceed a storage binding, is an `Err`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        matrix: &TransferMatrix<'_>,
        options: &GpuOptions,
        edit: &ReflectanceEdit,
        buffers: HostGatherBuffers<'_>,
    ) -> Result<Self, GpuError> {
        let n = matrix.layout.n();
        if edit.matrix_patches() != n {
            return Err(GpuError::Unsupported(format!(
                "the edit was prepared for {} patches, the matrix has {n}",
                edit.matrix_patches()
            )));
        }
        let gather = HostGather::new(device, queue, matrix, options, buffers)?;
        check_pass_limits(device, "the edit pass", 4)?;
        let dl = device.limits();
        let k = edit.len();
        let kmat_bytes = 12 * (k * k) as u64;
        let most = storage_binding_limit(&dl);
        if kmat_bytes > most {
            return Err(GpuError::Unsupported(format!(
                "the correction of {k} edited patches takes {kmat_bytes} bytes, more than one storage binding ({most} bytes)"
            )));
        }
        let grid = workgroup_grid(&dl, k.div_ceil(WORKGROUP as usize), || {
            format!("{k} edited patches")
        })?;
        let y_bytes = 12 * n as u64;
        let (pipeline, bind_group, corrected) = in_error_scopes(device, || {
            let mut entries = vec![layout_entry(0, buffer_ty(UNIFORM))];
            entries.extend((1..=3).map(|b| layout_entry(b, buffer_ty(READ))));
            entries.push(layout_entry(4, buffer_ty(WRITE)));
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("edit"),
                entries: &entries,
            });
            let pipeline = pipeline(device, "edit", EDIT, "edit", &layout);
            let uniform = EditUniform {
                k: k as u32,
                row: grid.0 * WORKGROUP,
                _pad: [0; 2],
            };
            let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("edit"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let patches = storage(
                device,
                "edited patches",
                bytemuck::cast_slice(edit.patches()),
                wgpu::BufferUsages::empty(),
            );
            let kmat: Vec<f32> = edit.correction_matrices().concat();
            let kmat = storage(
                device,
                "edit correction",
                bytemuck::cast_slice(&kmat),
                wgpu::BufferUsages::empty(),
            );
            let corrected = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("edited exitance"),
                size: y_bytes.max(4),
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("edit"),
                layout: &layout,
                entries: &[
                    entire(0, &ubuf),
                    entire(1, &patches),
                    entire(2, &kmat),
                    sized(3, buffers.y, y_bytes),
                    entire(4, &corrected),
                ],
            });
            (pipeline, bind_group, corrected)
        })?;
        Ok(EditedHostGather {
            gather,
            pipeline,
            bind_group,
            corrected,
            grid,
            k,
            device_bytes: kmat_bytes + 4 * k as u64 + y_bytes,
        })
    }

    /// Records the edited frame into `encoder` (see the type). With no patch edited, the plain
    /// gather.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        self.gather.record(encoder);
        if self.k == 0 {
            return;
        }
        let x = self.gather.host_x();
        encoder.copy_buffer_to_buffer(x, 0, &self.corrected, 0, 12 * self.gather.patches() as u64);
        record_dispatch(
            encoder,
            "edit",
            &self.pipeline,
            &self.bind_group,
            self.grid,
            None,
        );
        self.gather.record_from(encoder, &self.corrected, None);
    }

    /// Patches edited.
    pub fn edited(&self) -> usize {
        self.k
    }

    /// The gather both passes run.
    pub fn gather(&self) -> &HostGather {
        &self.gather
    }

    /// Bytes the edit adds on the device (the correction, the patch list, x̃), beyond the
    /// gather's own ([`HostGather::device_bytes`]).
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }
}
