//! The last step of building a [`super::WgpuGather`]: each dispatch's uniform, its share of
//! the matrix on the device (a band's blocks, a sparse band's rows) and its bind group.

use super::setup::{Buffers, FramePlan, u32_of};
use crate::shader::{self, Source};
use crate::toolkit::{storage, upload_texture};
use crate::{GpuError, conv};
use bytemuck::{Pod, Zeroable};
use radiosity_core::{SparseRows, TransferMatrix};
use wgpu::util::DeviceExt;

/// The gather kernel's per-band uniform (`struct Band` in `gather.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct BandUniform {
    row0: u32,
    col0: u32,
    cols: u32,
    rows: u32,
    tile_blocks: u32,
    group: u32,
    n: u32,
    split: u32,
    group_stride: u32,
    _pad: [u32; 3],
}

/// The finish kernel's per-band uniform (`struct Finish` in `finish.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct FinishUniform {
    row0: u32,
    rows: u32,
    groups: u32,
    n: u32,
}

// The uniform structs must match the WGSL structs field for field.
const _: () = assert!(size_of::<BandUniform>() == 48 && size_of::<FinishUniform>() == 16);

/// One dispatch: its bind group and workgroup counts (x: block-row groups or finish rows;
/// y: column splits).
#[derive(Debug)]
pub(super) struct Dispatch {
    pub(super) bind_group: wgpu::BindGroup,
    pub(super) workgroups: u32,
    pub(super) splits: u32,
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// One gather dispatch per band of `plan`: uploads the band's blocks (a storage buffer, or
/// one BC texture per plane on the texture source) and binds them with the band's uniform,
/// its tile row's decode tables, `x` and the partial sums, following `layout`. Returns the
/// dispatches and the bytes of blocks uploaded.
pub(super) fn band_dispatches(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    matrix: &TransferMatrix<'_>,
    plan: &FramePlan,
    buffers: &Buffers,
    layout: &wgpu::BindGroupLayout,
) -> Result<(Vec<Dispatch>, u64), GpuError> {
    let l = &matrix.layout;
    let tile_blocks = u32_of(l.tile_size() / 4, "tile side")?;
    let mut dispatches = Vec::with_capacity(plan.bands.len());
    let mut uploaded = 0u64;
    let mut bytes = Vec::new();
    for band in &plan.bands {
        let uniform = BandUniform {
            row0: u32_of(band.row0, "block row")?,
            col0: u32_of(band.col0, "block column")?,
            cols: u32_of(band.cols, "block columns")?,
            rows: u32_of(band.rows, "block rows")?,
            tile_blocks,
            group: band.group as u32,
            n: plan.n,
            split: u32_of(plan.split_cols, "block columns per split")?,
            group_stride: plan.texture_groups as u32,
            _pad: [0; 3],
        };
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("band"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let mut keep_buffers = Vec::new();
        let mut views = Vec::new();
        match plan.source {
            Source::Buffer => {
                bytes.clear();
                for p in 0..l.planes() {
                    crate::plan::copy_plane(l, &matrix.blocks, p, band, &mut bytes);
                }
                uploaded += bytes.len() as u64;
                keep_buffers.push(storage(
                    device,
                    "blocks",
                    &bytes,
                    wgpu::BufferUsages::empty(),
                ));
            }
            Source::Texture => {
                let tf = conv::texture_format(l.format()).expect("hardware path has a BC format");
                for p in 0..l.planes() {
                    bytes.clear();
                    crate::plan::copy_plane(l, &matrix.blocks, p, band, &mut bytes);
                    uploaded += bytes.len() as u64;
                    views.push(upload_texture(
                        device,
                        queue,
                        tf,
                        (band.cols, band.rows),
                        &bytes,
                    ));
                }
            }
        }
        let mut entries = vec![
            entry(0, &ubuf),
            entry(1, &buffers.tables[band.row0 / (l.tile_size() / 4)]),
            entry(2, &buffers.x),
            entry(3, &buffers.partial),
        ];
        for b in &keep_buffers {
            entries.push(entry(4, b));
        }
        for (p, v) in views.iter().enumerate() {
            entries.push(wgpu::BindGroupEntry {
                binding: 4 + p as u32,
                resource: wgpu::BindingResource::TextureView(v),
            });
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("band"),
            layout,
            entries: &entries,
        });
        dispatches.push(Dispatch {
            bind_group,
            workgroups: band.rows.div_ceil(shader::ROWS) as u32,
            splits: plan.splits as u32,
        });
    }
    Ok((dispatches, uploaded))
}

/// One finish dispatch per sparse band of `plan`: uploads the band's rows of `sp` (the
/// matrix's sparse part with its block corrections merged in) and binds them with the band's
/// uniform, the partial sums, `x` and `y`, following `layout`. Returns the dispatches and the
/// bytes uploaded.
pub(super) fn finish_dispatches(
    device: &wgpu::Device,
    sp: &SparseRows<'_>,
    channels: usize,
    plan: &FramePlan,
    buffers: &Buffers,
    layout: &wgpu::BindGroupLayout,
) -> (Vec<Dispatch>, u64) {
    let mut finishes = Vec::with_capacity(plan.sparse_bands.len());
    let mut uploaded = 0u64;
    for &(row0, rows) in &plan.sparse_bands {
        let (a, b) = (sp.row_ptr[row0], sp.row_ptr[row0 + rows]);
        let ptr: Vec<u32> = sp.row_ptr[row0..=row0 + rows]
            .iter()
            .map(|p| p - a)
            .collect();
        let (a, b) = (a as usize, b as usize);
        let ptr = storage(
            device,
            "sparse rows",
            bytemuck::cast_slice(&ptr),
            wgpu::BufferUsages::empty(),
        );
        let cols = storage(
            device,
            "sparse columns",
            bytemuck::cast_slice(&sp.cols[a..b]),
            wgpu::BufferUsages::empty(),
        );
        let vals = storage(
            device,
            "sparse values",
            bytemuck::cast_slice(&sp.values[a * channels..b * channels]),
            wgpu::BufferUsages::empty(),
        );
        uploaded += ptr.size() + cols.size() + vals.size();
        let uniform = FinishUniform {
            row0: row0 as u32,
            rows: rows as u32,
            groups: plan.groups as u32,
            n: plan.n,
        };
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("finish"),
            contents: bytemuck::bytes_of(&uniform),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("finish"),
            layout,
            entries: &[
                entry(0, &ubuf),
                entry(1, &buffers.partial),
                entry(2, &buffers.x),
                entry(3, &ptr),
                entry(4, &cols),
                entry(5, &vals),
                // The host's `y` may be larger than the gather's share of it.
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &buffers.y,
                        offset: 0,
                        size: wgpu::BufferSize::new(buffers.y_bytes),
                    }),
                },
            ],
        });
        finishes.push(Dispatch {
            bind_group,
            workgroups: rows.div_ceil(64) as u32,
            splits: 1,
        });
    }
    (finishes, uploaded)
}
