//! The engine's GPU side: its buffers, the radiosity passes bound to them once, the targets,
//! and one frame recorded into one encoder and read back.

use super::Result;
use super::pipelines::{Pipelines, SceneUniform, mesh_vertices};
use glam::{Mat3, Mat4, Vec3};
use radiosity_backend_wgpu::{
    CornerBuffers, CornerPass, GpuOptions, HostGather, HostGatherBuffers, HostLevel,
    HostLevelBuffers,
};
use radiosity_core::{Mesh, RadFile, Rgb};
use wgpu::BufferUsages as U;

/// Side of each shadow cube face, in texels.
const SHADOW_SIDE: u32 = 1024;

/// Shadow bias as a share of the distance to the light: a face's texel spans 2/SHADOW_SIDE of
/// the distance, and a surface seen at a grazing angle changes its distance by a few texels'
/// worth within one texel.
const SHADOW_BIAS: f32 = 8.0 / SHADOW_SIDE as f32;

fn buffer(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(4),
        usage,
        mapped_at_creation: false,
    })
}

/// The six cube faces' view matrices for a light at `eye`, in the Vulkan (and wgpu) cube
/// map convention: face k's screen right and up are the directions of the sampling rule's
/// `sc` and `−tc` for that major axis, so a fragment drawn into it is read back by
/// `textureSample(cube, dir)` with `dir` from the light.
fn cube_views(eye: Vec3) -> [Mat4; 6] {
    let faces = [
        (Vec3::X, Vec3::NEG_Z, Vec3::Y),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::X, Vec3::NEG_Z),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
    ];
    faces.map(|(forward, right, up)| {
        // Rows right, up, −forward: view space looks along −z as perspective_rh expects.
        Mat4::from_mat3(Mat3::from_cols(right, up, -forward).transpose())
            * Mat4::from_translation(-eye)
    })
}

/// The render targets: the shadow cube (distance to the light) with its depth buffer, the
/// image with its depth buffer, and the buffer the image is read back through.
struct Targets {
    face_views: Vec<wgpu::TextureView>,
    cube_view: wgpu::TextureView,
    cube_depth_view: wgpu::TextureView,
    image: wgpu::Texture,
    image_view: wgpu::TextureView,
    image_depth_view: wgpu::TextureView,
    readback: wgpu::Buffer,
    /// Bytes of a row of the image in `readback`.
    row_bytes: u32,
    width: u32,
    height: u32,
}

impl Targets {
    fn new(device: &wgpu::Device, (w, h): (u32, u32)) -> Self {
        let texture = |label: &str, (w, h, layers): (u32, u32, u32), format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: layers,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        use wgpu::TextureUsages as T;
        let s = SHADOW_SIDE;
        let cube = texture(
            "shadow cube",
            (s, s, 6),
            wgpu::TextureFormat::R32Float,
            T::RENDER_ATTACHMENT | T::TEXTURE_BINDING,
        );
        let cube_depth = texture(
            "shadow depth",
            (s, s, 1),
            wgpu::TextureFormat::Depth32Float,
            T::RENDER_ATTACHMENT,
        );
        let image = texture(
            "image",
            (w, h, 1),
            wgpu::TextureFormat::Rgba32Float,
            T::RENDER_ATTACHMENT | T::COPY_SRC,
        );
        let image_depth = texture(
            "image depth",
            (w, h, 1),
            wgpu::TextureFormat::Depth32Float,
            T::RENDER_ATTACHMENT,
        );
        let face_views: Vec<wgpu::TextureView> = (0..6)
            .map(|f| {
                cube.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: f,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let cube_view = cube.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::Cube),
            ..Default::default()
        });
        let row_bytes = (16 * w).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let readback = buffer(
            device,
            "readback",
            u64::from(row_bytes) * u64::from(h),
            U::MAP_READ | U::COPY_DST,
        );
        Targets {
            face_views,
            cube_view,
            cube_depth_view: cube_depth.create_view(&Default::default()),
            image_view: image.create_view(&Default::default()),
            image_depth_view: image_depth.create_view(&Default::default()),
            image,
            readback,
            row_bytes,
            width: w,
            height: h,
        }
    }
}

/// Level frames a draw records: each picture within 0.01% of its light's steady state (the
/// light after a jump is 2% / 0.1% / 0.008% off it after frames 1 / 2 / 3 on a city,
/// `docs/decisions/systems.md`).
const LEVEL_FRAMES_PER_DRAW: usize = 4;

/// The indirect light's pass: one matrix's gather, or a level's frames (every system's
/// gather and the light between systems, on the engine's device).
enum Indirect {
    One(HostGather),
    Level(HostLevel),
}

impl Indirect {
    /// The pass for `file` between the engine's `x` and `y`: its level's frames when it has
    /// systems, its matrix's gather otherwise.
    fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        file: &RadFile<'_>,
        x_buf: &wgpu::Buffer,
        y_buf: &wgpu::Buffer,
    ) -> Result<Self> {
        Ok(if file.systems.is_some() {
            Indirect::Level(HostLevel::new(
                device,
                queue,
                file,
                &GpuOptions::default(),
                HostLevelBuffers {
                    first: x_buf,
                    gathered: y_buf,
                },
            )?)
        } else {
            Indirect::One(HostGather::new(
                device,
                queue,
                &file.matrix,
                &GpuOptions::default(),
                HostGatherBuffers { x: x_buf, y: y_buf },
            )?)
        })
    }

    fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        match self {
            Indirect::One(g) => g.record(encoder),
            Indirect::Level(l) => (0..LEVEL_FRAMES_PER_DRAW).for_each(|_| l.record(encoder)),
        }
    }
}

/// The scene's uniforms and the bind groups that hold them: one per cube face for the
/// shadow pass, the camera's with the shadow cube and its sampler for the main pass.
struct SceneBindings {
    face_uniforms: Vec<wgpu::Buffer>,
    main_uniform: wgpu::Buffer,
    face_groups: Vec<wgpu::BindGroup>,
    main_group: wgpu::BindGroup,
}

impl SceneBindings {
    fn new(device: &wgpu::Device, pipelines: &Pipelines, targets: &Targets) -> Self {
        let uniform = |label| {
            buffer(
                device,
                label,
                size_of::<SceneUniform>() as u64,
                U::UNIFORM | U::COPY_DST,
            )
        };
        let face_uniforms: Vec<wgpu::Buffer> = (0..6).map(|_| uniform("face")).collect();
        let main_uniform = uniform("camera");
        let face_groups = face_uniforms
            .iter()
            .map(|u| {
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("face"),
                    layout: &pipelines.shadow_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: u.as_entire_binding(),
                    }],
                })
            })
            .collect();
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor::default());
        let main_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("main"),
            layout: &pipelines.main_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: main_uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&targets.cube_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
            ],
        });
        SceneBindings {
            face_uniforms,
            main_uniform,
            face_groups,
            main_group,
        }
    }
}

/// Everything a frame draws with, made once.
pub(crate) struct Renderer {
    x_buf: wgpu::Buffer,
    /// `y`, kept with the passes that write and read it.
    _y_buf: wgpu::Buffer,
    indirect: wgpu::Buffer,
    gather: Indirect,
    corner_pass: CornerPass,
    vertex_buf: wgpu::Buffer,
    vertex_count: u32,
    pipelines: Pipelines,
    targets: Targets,
    face_uniforms: Vec<wgpu::Buffer>,
    main_uniform: wgpu::Buffer,
    face_groups: Vec<wgpu::BindGroup>,
    main_group: wgpu::BindGroup,
}

impl Renderer {
    /// The engine's buffers, the radiosity passes bound to them, the mesh, the pipelines and
    /// an image of `size` pixels.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        file: &RadFile<'_>,
        mesh: &Mesh<'_>,
        size: (u32, u32),
    ) -> Result<Self> {
        let n = file.n();
        let corners = mesh.corner_count();
        let x_buf = buffer(
            device,
            "x",
            12 * n as u64,
            U::COPY_DST | U::COPY_SRC | U::STORAGE,
        );
        let y_buf = buffer(device, "y", 12 * n as u64, U::STORAGE);
        let indirect = buffer(
            device,
            "indirect",
            12 * corners as u64,
            U::STORAGE | U::VERTEX,
        );
        let gather = Indirect::new(device, queue, file, &x_buf, &y_buf)?;
        let corner_pass = CornerPass::new(
            device,
            mesh,
            CornerBuffers {
                y: &y_buf,
                out: &indirect,
            },
        )?;
        let (vertex_buf, vertex_count) = mesh_vertices(device, mesh);
        let pipelines = Pipelines::new(device);
        let targets = Targets::new(device, size);
        let SceneBindings {
            face_uniforms,
            main_uniform,
            face_groups,
            main_group,
        } = SceneBindings::new(device, &pipelines, &targets);
        Ok(Renderer {
            x_buf,
            _y_buf: y_buf,
            indirect,
            gather,
            corner_pass,
            vertex_buf,
            vertex_count,
            pipelines,
            targets,
            face_uniforms,
            main_uniform,
            face_groups,
            main_group,
        })
    }

    /// Writes the frame's first exitance `x`.
    pub(crate) fn write_x(&self, queue: &wgpu::Queue, x: &[Rgb]) {
        queue.write_buffer(&self.x_buf, 0, bytemuck::cast_slice(x));
    }

    /// Writes the point light at `position` of `intensity`, as the cube faces see it and as
    /// the camera's `view_proj` does, with depth in `[near, far]`.
    pub(crate) fn write_light(
        &self,
        queue: &wgpu::Queue,
        (position, intensity): (Vec3, Rgb),
        view_proj: Mat4,
        (near, far): (f32, f32),
    ) {
        let scene = |view_proj: Mat4| SceneUniform {
            view_proj: view_proj.to_cols_array_2d(),
            light: position.extend(1.0).to_array(),
            intensity: [intensity.r, intensity.g, intensity.b, 0.0],
            shadow: [SHADOW_BIAS, 0.0, 0.0, 0.0],
        };
        let face_proj = glam::camera::rh::proj::directx::perspective(
            std::f32::consts::FRAC_PI_2,
            1.0,
            near,
            far,
        );
        for (u, v) in self.face_uniforms.iter().zip(cube_views(position)) {
            queue.write_buffer(u, 0, bytemuck::bytes_of(&scene(face_proj * v)));
        }
        queue.write_buffer(&self.main_uniform, 0, bytemuck::bytes_of(&scene(view_proj)));
    }

    /// Gather, corner pass, shadow cube and image in one encoder and one submission, then
    /// the image read back: radiance RGB per pixel, rows from the top.
    pub(crate) fn draw(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<Vec<Vec3>> {
        let mut encoder = device.create_command_encoder(&Default::default());
        self.gather.record(&mut encoder);
        self.corner_pass.record(&mut encoder);
        self.record_shadow(&mut encoder);
        self.record_main(&mut encoder);
        let t = &self.targets;
        let (w, h) = (t.width, t.height);
        encoder.copy_texture_to_buffer(
            t.image.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &t.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(t.row_bytes),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        queue.submit([encoder.finish()]);
        t.readback.map_async(wgpu::MapMode::Read, .., |r| {
            if let Err(e) = r {
                eprintln!("readback failed: {e}");
            }
        });
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let pixels: Vec<Vec3> = {
            let view = t.readback.get_mapped_range(..)?;
            (0..h as usize)
                .flat_map(|row| {
                    let line = &view[row * t.row_bytes as usize..][..16 * w as usize];
                    bytemuck::cast_slice::<u8, [f32; 4]>(line)
                        .iter()
                        .map(|p| Vec3::new(p[0], p[1], p[2]))
                        .collect::<Vec<_>>()
                })
                .collect()
        };
        t.readback.unmap();
        Ok(pixels)
    }

    /// The six faces of the shadow cube.
    fn record_shadow(&self, encoder: &mut wgpu::CommandEncoder) {
        let t = &self.targets;
        for (view, group) in t.face_views.iter().zip(&self.face_groups) {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        // Nothing drawn: lit from any distance.
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: f64::from(f32::MAX),
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &t.cube_depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipelines.shadow);
            pass.set_bind_group(0, group, &[]);
            pass.set_vertex_buffer(0, self.vertex_buf.slice(..));
            pass.draw(0..self.vertex_count, 0..1);
        }
    }

    /// The image: direct light shadowed by the cube plus the corners' indirect light.
    fn record_main(&self, encoder: &mut wgpu::CommandEncoder) {
        let t = &self.targets;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("main"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &t.image_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &t.image_depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipelines.main);
        pass.set_bind_group(0, &self.main_group, &[]);
        pass.set_vertex_buffer(0, self.vertex_buf.slice(..));
        pass.set_vertex_buffer(1, self.indirect.slice(..));
        pass.draw(0..self.vertex_count, 0..1);
    }
}
