//! [`WgpuGather`]: the device, the persistent buffers and textures, the per-frame dispatches.

use crate::adapter::{Adapter, AdapterInfo, choose_adapter};
use crate::device::{self, SerialDevice};
use crate::plan::{self, PlanLimits};
use crate::probe;
use crate::shader::{self, Source};
use crate::{DecodePath, GpuError, GpuOptions, conv};
use bytemuck::{Pod, Zeroable};
use radiosity_core::{DecodeMode, Gather, GatherError, Rgb, TransferMatrix, check_gather_args};
use std::sync::{Arc, Mutex, mpsc};
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

/// One dispatch: its bind group and workgroup counts (x: block-row groups or finish rows;
/// y: column splits).
#[derive(Debug)]
struct Dispatch {
    bind_group: wgpu::BindGroup,
    workgroups: u32,
    splits: u32,
}

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

/// GPU timestamps around the frame's compute pass, where the adapter has them.
#[derive(Debug)]
struct Timer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
}

/// The wgpu compute gather. Build once per matrix ([`WgpuGather::new`] uploads everything);
/// every [`Gather::gather`] then uploads `x`, dispatches, and reads `y` back.
#[derive(Debug)]
pub struct WgpuGather {
    adapter: AdapterInfo,
    path: DecodePath,
    model: Option<DecodeMode>,
    n: usize,
    name: String,
    gather_pipeline: wgpu::ComputePipeline,
    finish_pipeline: wgpu::ComputePipeline,
    bands: Vec<Dispatch>,
    finishes: Vec<Dispatch>,
    x: wgpu::Buffer,
    y: wgpu::Buffer,
    readback: wgpu::Buffer,
    device_bytes: u64,
    errors: Arc<Mutex<Vec<String>>>,
    timer: Option<Timer>,
    kernel_ms: Option<f64>,
    declined: bool,
    /// Last, so that every resource above is gone when it drops and the device is destroyed
    /// under the process-wide lock ([`crate::device`]).
    dev: SerialDevice,
}

/// A storage buffer of at least 4 bytes (an empty binding is invalid) with `data` in it.
fn storage(
    device: &wgpu::Device,
    label: &str,
    data: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    let padded;
    let contents = if data.len() < 4 {
        padded = [0u8; 4];
        &padded[..]
    } else {
        data
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE | usage,
    })
}

fn layout_entry(binding: u32, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty,
        count: None,
    }
}

fn buffer_ty(ty: wgpu::BufferBindingType) -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty,
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

const UNIFORM: wgpu::BufferBindingType = wgpu::BufferBindingType::Uniform;
const READ: wgpu::BufferBindingType = wgpu::BufferBindingType::Storage { read_only: true };
const WRITE: wgpu::BufferBindingType = wgpu::BufferBindingType::Storage { read_only: false };

fn pipeline(
    device: &wgpu::Device,
    label: &str,
    source: &str,
    entry: &str,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
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
        // The texture unit's decode rules, measured once per adapter (`probe`), where its
        // path is asked for or could be chosen.
        let hardware_possible = format.is_block_compressed() && info.bc;
        let texture_model = match options.path {
            DecodePath::HardwareBc if hardware_possible => probe::texture_decode_model(adapter)?,
            // A software rasteriser's texture unit is software too, and slower than decoding
            // in the shader (lavapipe, n = 1913 BC1: 100 ms against 39 ms): not probed.
            DecodePath::Auto if hardware_possible && info.is_hardware() => {
                probe::texture_decode_model(adapter).unwrap_or(None)
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
        // `auto` passed over a hardware texture unit because its probe matched no CPU rules.
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

    fn build(
        matrix: &TransferMatrix<'_>,
        dev: SerialDevice,
        adapter: AdapterInfo,
        path: DecodePath,
        model: Option<DecodeMode>,
        options: &GpuOptions,
        errors: Arc<Mutex<Vec<String>>>,
    ) -> Result<Self, GpuError> {
        let l = matrix.layout;
        let (n, format, channels) = (l.n(), l.format(), l.channels());
        assert_eq!(
            matrix.blocks.len() as u64,
            l.block_bytes(),
            "block data does not match the layout"
        );
        assert_eq!(matrix.scales.len(), l.scale_count(), "scale count");
        let unsupported = GpuError::Unsupported;
        let (device, queue) = (dev.device(), dev.queue());
        let dl = device.limits();
        let cap = |own: u64, opt: Option<u64>| opt.map_or(own, |o| o.min(own));
        let lim = PlanLimits {
            binding_bytes: cap(
                dl.max_storage_buffer_binding_size.min(dl.max_buffer_size),
                options.max_binding_bytes,
            ),
            texture_side: cap(
                u64::from(dl.max_texture_dimension_2d),
                options.max_texture_side.map(u64::from),
            ) as u32,
            workgroups: dl.max_compute_workgroups_per_dimension,
        };
        let u32_of = |v: usize, what: &str| {
            u32::try_from(v).map_err(|_| unsupported(format!("{what} {v} does not fit 32 bits")))
        };
        let n32 = u32_of(n, "patch count")?;
        u32_of(3 * l.padded(), "exitance length")?;

        // Decode tables, one buffer per tile row (a band stays in one tile row); x, y, readback.
        let tps = l.tiles_per_side();
        let row_tables = tps * l.scale_count() / l.tile_count().max(1) * 256;
        let tables: Vec<f32> = matrix.scales.iter().flat_map(|s| s.table()).collect();
        if (row_tables * 4) as u64 > lim.binding_bytes {
            return Err(unsupported(format!(
                "the decode tables of one tile row take {} bytes, more than one storage binding ({} bytes)",
                row_tables * 4,
                lim.binding_bytes
            )));
        }
        let tables: Vec<wgpu::Buffer> = (0..tps)
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
        let y_bytes = (3 * n * 4) as u64;
        let mk = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let x = mk(
            "x",
            x_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let y = mk(
            "y",
            y_bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        // y, then (with timestamps) the pass's two u64 timestamps at an 8-aligned offset.
        let readback = mk(
            "y readback",
            y_bytes.next_multiple_of(8) + 16,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let timer = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Timer {
                queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("gather timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2,
                }),
                resolve: mk(
                    "timestamps",
                    16,
                    wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                ),
                period: f64::from(queue.get_timestamp_period()),
            });
        let mut device_bytes = table_bytes + x_bytes + 2 * y_bytes;

        // Bands and their sources.
        let source = if path == DecodePath::HardwareBc {
            Source::Texture
        } else {
            Source::Buffer
        };
        let (bands, groups) = match source {
            Source::Buffer => (plan::buffer_bands(&l, &lim).map_err(unsupported)?, 1),
            Source::Texture => plan::texture_bands(&l, &lim).map_err(unsupported)?,
        };
        // Column splits, the same for every band so that every band writes every slab.
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
            None if !adapter.is_hardware() => 1,
            None => column_splits(band_wgs, band_cols, lim.workgroups),
        };
        let split_cols = bands
            .iter()
            .map(|b| b.cols.div_ceil(splits))
            .max()
            .unwrap_or(1);
        let (texture_groups, groups) = (groups, groups * splits);
        let partial_bytes = (groups * n * 3 * 4) as u64;
        if partial_bytes > lim.binding_bytes {
            return Err(unsupported(format!(
                "{groups} column groups of partial sums take {partial_bytes} bytes, more than one storage binding"
            )));
        }
        let partial = mk("partial sums", partial_bytes, wgpu::BufferUsages::STORAGE);
        device_bytes += partial_bytes;

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
            Source::Buffer => options.software_mode,
            // Unused by the texture kernels: the texture unit builds the palettes.
            Source::Texture => DecodeMode::D3d10,
        };
        let gather_pipeline = pipeline(
            device,
            "gather",
            &shader::gather(format, channels, source, mode),
            "gather",
            &gather_layout,
        );

        let tile_blocks = u32_of(l.tile_size() / 4, "tile side")?;
        let mut dispatches = Vec::with_capacity(bands.len());
        let mut bytes = Vec::new();
        for band in &bands {
            let uniform = BandUniform {
                row0: u32_of(band.row0, "block row")?,
                col0: u32_of(band.col0, "block column")?,
                cols: u32_of(band.cols, "block columns")?,
                rows: u32_of(band.rows, "block rows")?,
                tile_blocks,
                group: band.group as u32,
                n: n32,
                split: u32_of(split_cols, "block columns per split")?,
                group_stride: texture_groups as u32,
                _pad: [0; 3],
            };
            let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("band"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let mut keep_buffers = Vec::new();
            let mut views = Vec::new();
            match source {
                Source::Buffer => {
                    bytes.clear();
                    for p in 0..l.planes() {
                        plan::copy_plane(&l, &matrix.blocks, p, band, &mut bytes);
                    }
                    device_bytes += bytes.len() as u64;
                    keep_buffers.push(storage(
                        device,
                        "blocks",
                        &bytes,
                        wgpu::BufferUsages::empty(),
                    ));
                }
                Source::Texture => {
                    let tf = conv::texture_format(format).expect("hardware path has a BC format");
                    for p in 0..l.planes() {
                        bytes.clear();
                        plan::copy_plane(&l, &matrix.blocks, p, band, &mut bytes);
                        device_bytes += bytes.len() as u64;
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
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: ubuf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: tables[band.row0 / (l.tile_size() / 4)].as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: x.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: partial.as_entire_binding(),
                },
            ];
            for b in &keep_buffers {
                entries.push(wgpu::BindGroupEntry {
                    binding: 4,
                    resource: b.as_entire_binding(),
                });
            }
            for (p, v) in views.iter().enumerate() {
                entries.push(wgpu::BindGroupEntry {
                    binding: 4 + p as u32,
                    resource: wgpu::BindingResource::TextureView(v),
                });
            }
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("band"),
                layout: &gather_layout,
                entries: &entries,
            });
            dispatches.push(Dispatch {
                bind_group,
                workgroups: band.rows.div_ceil(shader::ROWS) as u32,
                splits: splits as u32,
            });
        }

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
        let finish_pipeline = pipeline(
            device,
            "finish",
            &shader::finish(channels),
            "finish",
            &finish_layout,
        );
        // The block corrections ride along in the sparse list (16 entries each at most): the
        // finish pass then adds them without bindings of their own.
        let merged;
        let sp = if matrix.corrections.is_empty() {
            &matrix.sparse
        } else {
            merged = matrix.sparse_with_corrections();
            &merged
        };
        let mut finishes = Vec::new();
        for (row0, rows) in plan::sparse_bands(sp, channels, &lim).map_err(unsupported)? {
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
            device_bytes += ptr.size() + cols.size() + vals.size();
            let uniform = FinishUniform {
                row0: row0 as u32,
                rows: rows as u32,
                groups: groups as u32,
                n: n32,
            };
            let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("finish"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("finish"),
                layout: &finish_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: ubuf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: partial.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: x.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: ptr.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: cols.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: vals.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 6,
                        resource: y.as_entire_binding(),
                    },
                ],
            });
            finishes.push(Dispatch {
                bind_group,
                workgroups: rows.div_ceil(64) as u32,
                splits: 1,
            });
        }

        Ok(WgpuGather {
            name: format!("gpu-{}", format.name()),
            adapter,
            path,
            model,
            n,
            gather_pipeline,
            finish_pipeline,
            bands: dispatches,
            finishes,
            x,
            y,
            readback,
            device_bytes,
            errors,
            timer,
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
    /// known: the software path's mode; on the hardware path the rules a probe of the texture
    /// unit matched ([`crate::probe::texture_decode_model`]: D3D10's on a decoder that
    /// interpolates without rounding, Mesa's on llvmpipe/lavapipe), and `None` on drivers
    /// that match neither (D3D10 allows each palette entry to be off by one code; an NVIDIA
    /// H100 is off by up to 7).
    pub fn decode_model(&self) -> Option<DecodeMode> {
        self.model
    }

    /// Why the path is what it is, where that is not obvious: under [`DecodePath::Auto`] on a
    /// GPU whose texture unit decodes BC1/BC4 by rules no CPU decoder reproduces (the probe of
    /// [`crate::probe::texture_decode_model`] matched none, as on an NVIDIA H100), the shader
    /// decodes instead and this says so. `None` otherwise.
    pub fn path_note(&self) -> Option<&'static str> {
        self.declined.then_some(
            "its texture unit decodes BC off the CPU's rules (probed), so the shader decodes",
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
        self.bands.len() + self.finishes.len()
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

/// A `cols·4 × rows·4` BC texture holding `data` (`rows` rows of `cols` blocks), and its view.
pub(crate) fn upload_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    format: wgpu::TextureFormat,
    (cols, rows): (usize, usize),
    data: &[u8],
) -> wgpu::TextureView {
    let size = wgpu::Extent3d {
        width: (cols * 4) as u32,
        height: (rows * 4) as u32,
        depth_or_array_layers: 1,
    };
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("blocks"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        data,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some((cols * 8) as u32),
            rows_per_image: Some(rows as u32),
        },
        size,
    );
    texture.create_view(&wgpu::TextureViewDescriptor::default())
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
            .write_buffer(&self.x, 0, bytemuck::cast_slice(exitance));
        let mut encoder =
            self.dev
                .device()
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("gather"),
                });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("gather"),
                timestamp_writes: self
                    .timer
                    .as_ref()
                    .map(|t| wgpu::ComputePassTimestampWrites {
                        query_set: &t.queries,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }),
            });
            pass.set_pipeline(&self.gather_pipeline);
            for d in &self.bands {
                pass.set_bind_group(0, &d.bind_group, &[]);
                pass.dispatch_workgroups(d.workgroups, d.splits, 1);
            }
            pass.set_pipeline(&self.finish_pipeline);
            for d in &self.finishes {
                pass.set_bind_group(0, &d.bind_group, &[]);
                pass.dispatch_workgroups(d.workgroups, d.splits, 1);
            }
        }
        encoder.copy_buffer_to_buffer(&self.y, 0, &self.readback, 0, self.y.size());
        let stamps_at = self.y.size().next_multiple_of(8);
        if let Some(t) = &self.timer {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolve, 0);
            encoder.copy_buffer_to_buffer(&t.resolve, 0, &self.readback, stamps_at, 16);
        }
        self.dev.queue().submit([encoder.finish()]);
        let (tx, rx) = mpsc::channel();
        self.readback.map_async(wgpu::MapMode::Read, .., move |r| {
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
        {
            let view = self
                .readback
                .get_mapped_range(..)
                .map_err(|e| GatherError::Backend(format!("readback failed: {e}")))?;
            let y: &mut [f32] = bytemuck::cast_slice_mut(irradiance);
            y.copy_from_slice(bytemuck::cast_slice(&view[..self.y.size() as usize]));
            if let Some(t) = &self.timer {
                let at = stamps_at as usize;
                let stamp = |i: usize| {
                    u64::from_le_bytes(view[at + 8 * i..at + 8 * i + 8].try_into().unwrap())
                };
                let ticks = stamp(1).wrapping_sub(stamp(0));
                self.kernel_ms = Some(ticks as f64 * t.period * 1e-6);
            }
        }
        self.readback.unmap();
        Ok(())
    }
}

// The uniform structs must match the WGSL structs field for field.
const _: () = assert!(size_of::<BandUniform>() == 48 && size_of::<FinishUniform>() == 16);
