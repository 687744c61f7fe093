//! The first steps of building a [`super::WgpuGather`], each taking what it needs explicitly:
//! the device's limits ([`plan_limits`]), the cut of the matrix into dispatches
//! ([`FramePlan::new`]), the persistent buffers ([`Buffers::new`]) and the two pipelines
//! ([`Pipelines::new`]). The bind groups of each dispatch are made in `bind.rs`.

use crate::plan::{self, Band, PlanLimits};
use crate::shader::{self, Source};
use crate::toolkit::{
    READ, UNIFORM, WRITE, buffer_ty, layout_entry, pipeline, storage, storage_binding_limit,
};
use crate::{DecodePath, GpuError, GpuOptions};
use radiosity_core::{DecodeMode, MatrixLayout, SparseRows, TransferMatrix};

/// Workgroups one gather dispatch should have, when the matrix has columns enough: a large
/// GPU keeps tens of workgroups of 64 invocations resident on each of its 100–150
/// multiprocessors, and memory latency is hidden only when they are all busy. Measured on an
/// H100 at 16384 patches (512 block-row groups per band): BC1 kernels take 0.399, 0.377 and
/// 0.400 ms in 1, 4 and 8 splits; BC4 1.03, 0.85 and 1.03 ms.
const TARGET_WORKGROUPS: usize = 2048;

/// Fewest block columns one invocation walks in a column split: below this the reduction at
/// the end of each workgroup outweighs its share of blocks.
const MIN_COLUMNS_PER_INVOCATION: usize = 4;

/// Column splits per band: enough for [`TARGET_WORKGROUPS`] with `row_workgroups` block-row
/// groups, as long as each invocation keeps [`MIN_COLUMNS_PER_INVOCATION`] block columns.
fn column_splits(row_workgroups: usize, cols: usize, max: u32) -> usize {
    let most = (cols / (64 * MIN_COLUMNS_PER_INVOCATION)).max(1);
    TARGET_WORKGROUPS
        .div_ceil(row_workgroups.max(1))
        .clamp(1, most)
        .min(max as usize)
}

/// `v` as a `u32` for a uniform, or why the matrix is too large for one.
pub(super) fn u32_of(v: usize, what: &str) -> Result<u32, GpuError> {
    u32::try_from(v).map_err(|_| GpuError::Unsupported(format!("{what} {v} does not fit 32 bits")))
}

/// The limits a plan respects: the device's, lowered by the caps of `options`.
pub(super) fn plan_limits(device: &wgpu::Device, options: &GpuOptions) -> PlanLimits {
    let dl = device.limits();
    let cap = |own: u64, opt: Option<u64>| opt.map_or(own, |o| o.min(own));
    PlanLimits {
        binding_bytes: cap(storage_binding_limit(&dl), options.max_binding_bytes),
        texture_side: cap(
            u64::from(dl.max_texture_dimension_2d),
            options.max_texture_side.map(u64::from),
        ) as u32,
        workgroups: dl.max_compute_workgroups_per_dimension,
    }
}

/// How the matrix is cut into the dispatches of a frame. Made before anything goes to the
/// device, so every limit the matrix exceeds is reported without device work.
#[derive(Debug)]
pub(super) struct FramePlan {
    /// Patches, as the uniforms carry it.
    pub(super) n: u32,
    /// Where the gather kernel reads blocks from.
    pub(super) source: Source,
    /// The gather dispatches' rectangles of blocks.
    pub(super) bands: Vec<Band>,
    /// Column splits per band, the same for every band so that every band writes every slab.
    pub(super) splits: usize,
    /// Block columns of one split (the widest band's).
    pub(super) split_cols: usize,
    /// Column groups of the texture bands (1 for buffers): the stride between a band's slabs.
    pub(super) texture_groups: usize,
    /// Slabs of partial sums: `texture_groups × splits`.
    pub(super) groups: usize,
    /// Floats of decode tables per tile row (one buffer each; a band stays in one tile row).
    pub(super) row_tables: usize,
    /// The finish dispatches: `(first row, rows)` of the sparse part.
    pub(super) sparse_bands: Vec<(usize, usize)>,
}

impl FramePlan {
    /// The plan for a matrix of layout `l` whose sparse part (with the block corrections
    /// merged in) is `sparse`, on decode `path`, within `lim`. `hardware` says whether the
    /// adapter is a hardware GPU (a software rasteriser gets no column splits by default).
    pub(super) fn new(
        l: &MatrixLayout,
        sparse: &SparseRows<'_>,
        lim: &PlanLimits,
        path: DecodePath,
        options: &GpuOptions,
        hardware: bool,
    ) -> Result<Self, GpuError> {
        let unsupported = GpuError::Unsupported;
        let n = u32_of(l.n(), "patch count")?;
        u32_of(3 * l.padded(), "exitance length")?;
        let row_tables = l.tiles_per_side() * l.scale_count() / l.tile_count().max(1) * 256;
        if (row_tables * 4) as u64 > lim.binding_bytes {
            return Err(unsupported(format!(
                "the decode tables of one tile row take {} bytes, more than one storage binding ({} bytes)",
                row_tables * 4,
                lim.binding_bytes
            )));
        }
        let source = if path == DecodePath::HardwareBc {
            Source::Texture
        } else {
            Source::Buffer
        };
        let (bands, texture_groups) = match source {
            Source::Buffer => (plan::buffer_bands(l, lim).map_err(unsupported)?, 1),
            Source::Texture => plan::texture_bands(l, lim).map_err(unsupported)?,
        };
        let band_wgs = bands
            .iter()
            .map(|b| b.rows.div_ceil(shader::ROWS))
            .max()
            .unwrap_or(1);
        let band_cols = bands.iter().map(|b| b.cols).min().unwrap_or(1);
        let splits = match options.column_splits {
            Some(s) => (s.max(1) as usize)
                .min(band_cols)
                .min(lim.workgroups as usize),
            // A software rasteriser runs workgroups a few at a time on the CPU's cores, where
            // splits only add reductions (lavapipe, n = 2048 BC1: 10.6 ms whole, 20.4 ms in 3).
            None if !hardware => 1,
            None => column_splits(band_wgs, band_cols, lim.workgroups),
        };
        let split_cols = bands
            .iter()
            .map(|b| b.cols.div_ceil(splits))
            .max()
            .unwrap_or(1);
        let groups = texture_groups * splits;
        let plan = FramePlan {
            n,
            source,
            bands,
            splits,
            split_cols,
            texture_groups,
            groups,
            row_tables,
            sparse_bands: Vec::new(),
        };
        let partial_bytes = plan.partial_bytes();
        if partial_bytes > lim.binding_bytes {
            return Err(unsupported(format!(
                "{groups} column groups of partial sums take {partial_bytes} bytes, more than one storage binding"
            )));
        }
        let sparse_bands = plan::sparse_bands(sparse, l.channels(), lim).map_err(unsupported)?;
        Ok(FramePlan {
            sparse_bands,
            ..plan
        })
    }

    /// Bytes of the partial sums: one RGB slab of `n` rows per column group.
    pub(super) fn partial_bytes(&self) -> u64 {
        (self.groups * self.n as usize * 3 * 4) as u64
    }
}

/// GPU timestamps around the frame's compute pass, where the adapter has them.
#[derive(Debug)]
pub(super) struct Timer {
    pub(super) queries: wgpu::QuerySet,
    pub(super) resolve: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    pub(super) period: f64,
}

impl Timer {
    /// The pass's timestamp writes: query 0 at its start, 1 at its end.
    pub(super) fn writes(&self) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }
}

/// Storage buffers the finish kernel binds (the most of the gather's kernels: partial sums,
/// `x`, the sparse rows' three arrays, `y`).
pub(crate) const STORAGE_BINDINGS: u32 = 6;

/// Workgroup memory of the gather kernel: the reduction's 256 `vec3<f32>` (16-byte stride)
/// and one 256-entry decode table per stored channel.
pub(crate) fn workgroup_bytes(channels: usize) -> u32 {
    256 * 16 + 256 * 4 * channels as u32
}

/// Checks that a device runs the gather's kernels at all: compute workgroups of 64
/// invocations, [`STORAGE_BINDINGS`] storage buffers and a uniform per stage, and the
/// workgroup memory of [`workgroup_bytes`]. The error names the limit that is short (a
/// downlevel device, such as WebGL2's, has no compute at all).
pub(crate) fn check_compute_limits(dl: &wgpu::Limits, channels: usize) -> Result<(), GpuError> {
    let needs = [
        (
            "max_compute_workgroup_size_x",
            dl.max_compute_workgroup_size_x,
            shader::WORKGROUP,
        ),
        (
            "max_compute_invocations_per_workgroup",
            dl.max_compute_invocations_per_workgroup,
            shader::WORKGROUP,
        ),
        (
            "max_storage_buffers_per_shader_stage",
            dl.max_storage_buffers_per_shader_stage,
            STORAGE_BINDINGS,
        ),
        (
            "max_uniform_buffers_per_shader_stage",
            dl.max_uniform_buffers_per_shader_stage,
            1,
        ),
        (
            "max_compute_workgroup_storage_size",
            dl.max_compute_workgroup_storage_size,
            workgroup_bytes(channels),
        ),
    ];
    for (name, has, needs) in needs {
        if has < needs {
            return Err(GpuError::Unsupported(format!(
                "the device's {name} is {has}, the gather needs {needs}"
            )));
        }
    }
    Ok(())
}

/// Where a gather's `y` comes back to the CPU: the own-device path only.
#[derive(Debug)]
pub(super) struct Readback {
    /// `y`, then (with timestamps) the pass's two u64 timestamps at an 8-aligned offset.
    pub(super) buffer: wgpu::Buffer,
    pub(super) timer: Option<Timer>,
}

impl Readback {
    /// A readback buffer for `y_bytes` of `y` and (where `device` has `TIMESTAMP_QUERY`) the
    /// timestamp queries.
    pub(super) fn new(device: &wgpu::Device, queue: &wgpu::Queue, y_bytes: u64) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("y readback"),
            size: y_bytes.next_multiple_of(8) + 16,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let timer = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Timer {
                queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("gather timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamps"),
                    size: 16,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                period: f64::from(queue.get_timestamp_period()),
            });
        Readback { buffer, timer }
    }
}

/// The buffers every dispatch of a frame shares.
#[derive(Debug)]
pub(super) struct Buffers {
    /// Decode tables, one buffer per tile row.
    pub(super) tables: Vec<wgpu::Buffer>,
    /// The exitance, RGB f32 over the padded patches, zero past `n`.
    pub(super) x: wgpu::Buffer,
    /// The irradiance, RGB f32 over the patches: the gather's own, or the host's (of which
    /// the first `12·n` bytes are bound).
    pub(super) y: wgpu::Buffer,
    /// Bytes of `y` that are bound and written: `12·n`.
    pub(super) y_bytes: u64,
    /// The column groups' partial sums.
    pub(super) partial: wgpu::Buffer,
    /// Bytes they hold on the device (the host's `y` not counted).
    pub(super) bytes: u64,
}

impl Buffers {
    /// Uploads the decode tables of `matrix` and creates `x`, the partial sums and, unless
    /// the host lends its own (`host_y`), `y`.
    pub(super) fn new(
        device: &wgpu::Device,
        matrix: &TransferMatrix<'_>,
        plan: &FramePlan,
        host_y: Option<&wgpu::Buffer>,
    ) -> Self {
        let l = &matrix.layout;
        let row_tables = plan.row_tables;
        let tables: Vec<f32> = matrix.scales.iter().flat_map(|s| s.table()).collect();
        let tables: Vec<wgpu::Buffer> = (0..l.tiles_per_side())
            .map(|ty| {
                let part = if row_tables == 0 {
                    &[][..]
                } else {
                    &tables[ty * row_tables..(ty + 1) * row_tables]
                };
                storage(
                    device,
                    "tables",
                    bytemuck::cast_slice(part),
                    wgpu::BufferUsages::empty(),
                )
            })
            .collect();
        let table_bytes = tables.iter().map(wgpu::Buffer::size).sum::<u64>();
        let x_bytes = (3 * l.padded() * 4) as u64;
        let y_bytes = (3 * l.n() * 4) as u64;
        let mk = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                // An empty binding is invalid: at least one float.
                size: size.max(4),
                usage,
                mapped_at_creation: false,
            })
        };
        let x = mk(
            "x",
            x_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let (y, own_y) = match host_y {
            Some(y) => (y.clone(), 0),
            None => (
                mk(
                    "y",
                    y_bytes,
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                ),
                y_bytes,
            ),
        };
        let partial_bytes = plan.partial_bytes();
        let partial = mk("partial sums", partial_bytes, wgpu::BufferUsages::STORAGE);
        Buffers {
            tables,
            x,
            y,
            y_bytes,
            partial,
            bytes: table_bytes + x_bytes + own_y + partial_bytes,
        }
    }
}

/// The gather and finish pipelines and the layouts their bind groups follow.
#[derive(Debug)]
pub(super) struct Pipelines {
    pub(super) gather: wgpu::ComputePipeline,
    pub(super) gather_layout: wgpu::BindGroupLayout,
    pub(super) finish: wgpu::ComputePipeline,
    pub(super) finish_layout: wgpu::BindGroupLayout,
}

impl Pipelines {
    /// The kernels for a matrix of layout `l` reading blocks from `source`; `software_mode`
    /// is the palette rounding of the buffer source.
    pub(super) fn new(
        device: &wgpu::Device,
        l: &MatrixLayout,
        source: Source,
        software_mode: DecodeMode,
    ) -> Self {
        let (format, channels) = (l.format(), l.channels());
        let mut gather_entries = vec![
            layout_entry(0, buffer_ty(UNIFORM)),
            layout_entry(1, buffer_ty(READ)),
            layout_entry(2, buffer_ty(READ)),
            layout_entry(3, buffer_ty(WRITE)),
        ];
        match source {
            Source::Buffer => gather_entries.push(layout_entry(4, buffer_ty(READ))),
            Source::Texture => {
                for p in 0..l.planes() {
                    gather_entries.push(layout_entry(
                        4 + p as u32,
                        wgpu::BindingType::Texture {
                            sample_type: wgpu::TextureSampleType::Float { filterable: false },
                            view_dimension: wgpu::TextureViewDimension::D2,
                            multisampled: false,
                        },
                    ));
                }
            }
        }
        let gather_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gather"),
            entries: &gather_entries,
        });
        let mode = match source {
            Source::Buffer => software_mode,
            // Unused by the texture kernels: the texture unit builds the palettes.
            Source::Texture => DecodeMode::D3d10,
        };
        let gather = pipeline(
            device,
            "gather",
            &shader::gather(format, channels, source, mode),
            "gather",
            &gather_layout,
        );
        // Finish: partial sums plus the sparse corrections, per sparse band.
        let finish_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("finish"),
            entries: &[
                layout_entry(0, buffer_ty(UNIFORM)),
                layout_entry(1, buffer_ty(READ)),
                layout_entry(2, buffer_ty(READ)),
                layout_entry(3, buffer_ty(READ)),
                layout_entry(4, buffer_ty(READ)),
                layout_entry(5, buffer_ty(READ)),
                layout_entry(6, buffer_ty(WRITE)),
            ],
        });
        let finish = pipeline(
            device,
            "finish",
            &shader::finish(channels),
            "finish",
            &finish_layout,
        );
        Pipelines {
            gather,
            gather_layout,
            finish,
            finish_layout,
        }
    }
}
