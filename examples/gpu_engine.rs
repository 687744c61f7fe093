//! A small wgpu "engine" that keeps the whole frame on its own GPU: it draws a baked `.rad`'s
//! full-detail mesh with a render pipeline, lit by a point light that moves over the frames
//! and by the baked indirect light, all on one device and one queue.
//!
//! ```text
//! cargo run --release -- demo --out out          # bakes out/demo.rad
//! cargo run --release --example gpu_engine -- out/demo.rad --camera CAMERA.json --frames 8 --out frames
//! ```
//!
//! Every frame:
//!
//! 1. **CPU**: the point light's direct irradiance per patch, averaged over the patch's
//!    samples with one shadow ray each through a BVH over the file's mesh (as `radiosity
//!    render` does), and the first exitance `x = E + ρ∘H_d`, written into a GPU buffer.
//! 2. **GPU, one encoder**: the gather `y = M·x` ([`HostGather`], on the engine's device, into
//!    the engine's buffer), the corner pass ([`CornerPass`]: per-corner indirect irradiance
//!    into a vertex buffer), a cube shadow map of the light (six faces, distance to the light),
//!    and the main pass: per pixel, the light's inverse-square cosine law shadowed by the cube
//!    map, plus the corners' indirect light interpolated across each triangle; radiance
//!    `(E + ρ∘H)/π` into a float texture.
//! 3. The texture is read back and written as `DIR/frame-NNN.png` with `radiosity render`'s
//!    exposure and tone map (99th percentile of luminance to 0.8, extended Reinhard with
//!    white 4, sRGB); `DIR/lights-NNN.json` is the frame's light as a lights file, so that
//!    `radiosity render BAKED.rad --lights DIR/lights-NNN.json --camera CAMERA.json --aa 1`
//!    draws the same frame by ray casting.
//!
//! The camera file is `radiosity render`'s (`position`, `look_at`, optional `up`, `fov_deg`,
//! `width`, `height`). The light orbits the centre of the mesh's bounds, a fifth of the way
//! down from the top, at a third of the horizontal half-extent.

use glam::{DVec3, Mat3, Mat4, Vec3};
use radiosity_backend_wgpu::{
    CornerBuffers, CornerPass, GpuOptions, HostGather, HostGatherBuffers, adapters,
};
use radiosity_bake::geometry::Occluders;
use radiosity_core::{Light, Mesh, RadFile, Rgb, first_exitance};
use std::error::Error;
use std::path::{Path, PathBuf};
use wgpu::util::DeviceExt;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// Side of each shadow cube face, in texels.
const SHADOW_SIDE: u32 = 1024;

/// Shadow bias as a share of the distance to the light: a face's texel spans 2/SHADOW_SIDE of
/// the distance, and a surface seen at a grazing angle changes its distance by a few texels'
/// worth within one texel.
const SHADOW_BIAS: f32 = 8.0 / SHADOW_SIDE as f32;

/// What the command line asks for.
pub(crate) struct Options {
    pub(crate) rad: PathBuf,
    pub(crate) camera: PathBuf,
    pub(crate) frames: u32,
    pub(crate) out: PathBuf,
}

impl Options {
    /// `BAKED.rad --camera CAMERA.json [--frames N] --out DIR`.
    pub(crate) fn parse(args: &[String]) -> Result<Self> {
        let usage = "usage: gpu_engine BAKED.rad --camera CAMERA.json [--frames N] --out DIR";
        let (mut rad, mut camera, mut frames, mut out) = (None, None, 8, None);
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let mut value = || {
                it.next()
                    .ok_or_else(|| format!("{a} needs a value; {usage}"))
            };
            match a.as_str() {
                "--camera" => camera = Some(PathBuf::from(value()?)),
                "--out" => out = Some(PathBuf::from(value()?)),
                "--frames" => {
                    let v = value()?;
                    frames = v
                        .parse()
                        .ok()
                        .filter(|f| (1..=10_000).contains(f))
                        .ok_or_else(|| format!("--frames must be 1 to 10000, not {v:?}"))?;
                }
                s if s.starts_with("--") => {
                    return Err(format!("unknown option {s}; {usage}").into());
                }
                s if rad.is_none() => rad = Some(PathBuf::from(s)),
                s => return Err(format!("unexpected argument {s:?}; {usage}").into()),
            }
        }
        Ok(Options {
            rad: rad.ok_or(usage)?,
            camera: camera.ok_or(usage)?,
            frames,
            out: out.ok_or(usage)?,
        })
    }
}

/// `radiosity render`'s pinhole camera, from its camera file.
pub(crate) struct Camera {
    pub(crate) position: Vec3,
    pub(crate) look_at: Vec3,
    pub(crate) up: Vec3,
    pub(crate) fov_deg: f32,
    pub(crate) width: u32,
    pub(crate) height: u32,
}

impl Camera {
    fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read camera file {}: {e}", path.display()))?;
        let v: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| format!("bad camera file {}: {e}", path.display()))?;
        let vec = |k: &str, default: Option<Vec3>| -> Result<Vec3> {
            match v.get(k) {
                None => default.ok_or_else(|| format!("camera file needs {k}").into()),
                Some(a) => {
                    let a: [f32; 3] = serde_json::from_value(a.clone())
                        .map_err(|e| format!("camera {k}: {e}"))?;
                    Ok(Vec3::from(a))
                }
            }
        };
        let num = |k: &str, default: f64| v.get(k).and_then(|x| x.as_f64()).unwrap_or(default);
        let cam = Camera {
            position: vec("position", None)?,
            look_at: vec("look_at", None)?,
            up: vec("up", Some(Vec3::Y))?,
            fov_deg: num("fov_deg", 40.0) as f32,
            width: num("width", 512.0) as u32,
            height: num("height", 512.0) as u32,
        };
        let view = cam.look_at - cam.position;
        let valid = view.length() > 0.0
            && view.normalize().cross(cam.up.normalize()).length() >= 1e-6
            && cam.fov_deg > 0.0
            && cam.fov_deg < 180.0
            && (1..=8192).contains(&cam.width)
            && (1..=8192).contains(&cam.height);
        if !valid {
            return Err(format!("bad camera file {}", path.display()).into());
        }
        Ok(cam)
    }

    /// View-projection with `Camera::ray`'s conventions (vertical field of view, up made
    /// perpendicular to the view, pixel rows from the top) and depth in [0, 1].
    fn view_proj(&self, near: f32, far: f32) -> Mat4 {
        let aspect = self.width as f32 / self.height as f32;
        glam::camera::rh::proj::directx::perspective(self.fov_deg.to_radians(), aspect, near, far)
            * glam::camera::rh::view::look_at_mat4(self.position, self.look_at, self.up)
    }
}

/// The light of frame `f` of `frames`.
pub(crate) fn light_at(lo: Vec3, hi: Vec3, f: u32, frames: u32) -> Light {
    let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let a = std::f32::consts::TAU * f as f32 / frames as f32;
    let position = Vec3::new(
        c.x + h.x / 3.0 * a.cos(),
        c.y + 0.6 * h.y,
        c.z + h.z / 3.0 * a.sin(),
    );
    // About 1 W/m² at the scale of the scene: the exposure is automatic anyway.
    Light::Point {
        position,
        intensity: Rgb::splat(h.length_squared()),
    }
}

/// The per-patch direct irradiance of `light`: the area-weighted mean over each patch's
/// samples, one shadow ray each (`radiosity render`'s runtime, for one light).
fn direct_per_patch(mesh: &Mesh<'_>, occ: &Occluders, light: &Light, n: usize) -> Vec<Rgb> {
    (0..n)
        .map(|p| {
            let (mut acc, mut area) = (Rgb::ZERO, 0.0f32);
            for s in mesh.samples_of(p) {
                let (pos, nrm) = (Vec3::from(s.position), Vec3::from(s.normal));
                if let Some((e, ray)) = light.irradiance_at(pos, nrm) {
                    let a = pos.as_dvec3();
                    let b = a + ray.direction.as_dvec3() * f64::from(ray.distance);
                    if occ.segment_visible(a, b) {
                        acc += e * s.area;
                    }
                }
                area += s.area;
            }
            if area > 0.0 { acc * (1.0 / area) } else { acc }
        })
        .collect()
}

/// `struct Scene` of `gpu_engine.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SceneUniform {
    view_proj: [[f32; 4]; 4],
    light: [f32; 4],
    intensity: [f32; 4],
    shadow: [f32; 4],
}

/// One corner of vertex buffer 0 of `gpu_engine.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    reflectance: [f32; 3],
    emission: [f32; 3],
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

/// Exposure, tone map and sRGB of `radiosity render` (its `picture` module).
pub(crate) fn tone_map(pixels: &[Vec3], width: u32, height: u32) -> image::RgbImage {
    let luminance = |c: Vec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
    let mut lum: Vec<f32> = pixels
        .iter()
        .map(|p| luminance(*p))
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    let exposure = if lum.is_empty() {
        1.0
    } else {
        let k = ((lum.len() - 1) as f64 * 0.99) as usize;
        let (_, p99, _) = lum.select_nth_unstable_by(k, f32::total_cmp);
        0.8 / *p99
    };
    let srgb = |x: f32| {
        if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        }
    };
    let mut img = image::RgbImage::new(width, height);
    for (px, v) in img.pixels_mut().zip(pixels) {
        let v = *v * exposure;
        *px = image::Rgb([v.x, v.y, v.z].map(|x| {
            let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
            let t = x * (1.0 + x / 16.0) / (1.0 + x);
            (srgb(t.min(1.0)) * 255.0 + 0.5) as u8
        }));
    }
    img
}

/// Writes `bytes` to `path` through a temporary file renamed into place.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes)
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("cannot write {}: {e}", path.display()).into()
        })
}

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

fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Renders the frames and writes them (module docs). Returns the PNG paths.
pub(crate) fn run(options: &Options) -> Result<Vec<PathBuf>> {
    let bytes = std::fs::read(&options.rad)
        .map_err(|e| format!("cannot read {}: {e}", options.rad.display()))?;
    let file = RadFile::parse(&bytes).map_err(|e| format!("{}: {e}", options.rad.display()))?;
    let mesh = file
        .mesh
        .as_ref()
        .ok_or("this .rad file has no mesh section; bake it again with this version")?;
    let cam = Camera::load(&options.camera)?;
    std::fs::create_dir_all(&options.out)
        .map_err(|e| format!("cannot create {}: {e}", options.out.display()))?;
    let n = file.n();
    let tris: Vec<[DVec3; 3]> = (0..mesh.triangles.len())
        .map(|t| mesh.corners(t).map(|c| Vec3::from(c).as_dvec3()))
        .collect();
    let occ = Occluders::from_triangles(&tris);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in mesh.positions.iter() {
        lo = lo.min(Vec3::from(*p));
        hi = hi.max(Vec3::from(*p));
    }

    // The engine's device: the first adapter that renders to the float targets below (the
    // shadow cube's R32Float, the image's Rgba32Float), preferring one that is not GL (Mesa's
    // GL compiles slowly, and cannot render to R32Float).
    let list = adapters();
    let usable: Vec<_> = list
        .iter()
        .filter(|a| renders_float(a.wgpu_adapter()))
        .collect();
    let adapter = usable
        .iter()
        .find(|a| a.info.backend != "gl")
        .or(usable.first())
        .ok_or_else(|| {
            if list.is_empty() {
                "no GPU adapter (on Debian: apt-get install mesa-vulkan-drivers libvulkan1)"
                    .to_owned()
            } else {
                format!(
                    "no adapter renders to R32Float and Rgba32Float textures (found: {}); on Debian, Mesa's Vulkan driver does: apt-get install mesa-vulkan-drivers libvulkan1",
                    list.iter()
                        .map(|a| a.info.to_string())
                        .collect::<Vec<_>>()
                        .join("; ")
                )
            }
        })?;
    let (device, queue) = pollster::block_on(adapter.wgpu_adapter().request_device(
        &wgpu::DeviceDescriptor {
            label: Some("engine"),
            required_limits: adapter.wgpu_adapter().limits(),
            ..Default::default()
        },
    ))?;
    eprintln!(
        "{}: {n} patches, {} triangles on {}",
        options.rad.display(),
        mesh.triangles.len(),
        adapter.info
    );

    // The engine's buffers, and the radiosity passes bound to them once.
    use wgpu::BufferUsages as U;
    let corners = mesh.corner_count();
    let x_buf = buffer(&device, "x", 12 * n as u64, U::COPY_DST | U::COPY_SRC);
    let y_buf = buffer(&device, "y", 12 * n as u64, U::STORAGE);
    let indirect = buffer(
        &device,
        "indirect",
        12 * corners as u64,
        U::STORAGE | U::VERTEX,
    );
    let gather = HostGather::new(
        &device,
        &queue,
        &file.matrix,
        &GpuOptions::default(),
        HostGatherBuffers {
            x: &x_buf,
            y: &y_buf,
        },
    )?;
    let corner_pass = CornerPass::new(
        &device,
        mesh,
        CornerBuffers {
            y: &y_buf,
            out: &indirect,
        },
    )?;

    // The mesh, one vertex per corner.
    let vertices: Vec<Vertex> = (0..mesh.triangles.len())
        .flat_map(|t| {
            let tri = mesh.triangles[t];
            let [a, b, c] = mesh.corners(t).map(Vec3::from);
            let normal = (b - a).cross(c - a).normalize_or_zero();
            [a, b, c].map(|p| Vertex {
                position: p.to_array(),
                normal: normal.to_array(),
                reflectance: tri.reflectance.to_array(),
                emission: tri.emission.to_array(),
            })
        })
        .collect();
    let vertex_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("mesh"),
        contents: bytemuck::cast_slice(&vertices),
        usage: U::VERTEX,
    });

    // Pipelines.
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("gpu_engine"),
        source: wgpu::ShaderSource::Wgsl(include_str!("gpu_engine.wgsl").into()),
    });
    let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("shadow"),
        entries: &[uniform_entry(0)],
    });
    let main_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("main"),
        entries: &[
            uniform_entry(0),
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::Cube,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering),
                count: None,
            },
        ],
    });
    let corner_attributes =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Float32x3];
    let indirect_attributes = wgpu::vertex_attr_array![4 => Float32x3];
    let mesh_layout = wgpu::VertexBufferLayout {
        array_stride: size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &corner_attributes,
    };
    // The corner pass's output as it is laid out: RGB f32 per corner, stride 12.
    let indirect_layout = wgpu::VertexBufferLayout {
        array_stride: 12,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &indirect_attributes,
    };
    let pipeline = |label: &str,
                    layout: &wgpu::BindGroupLayout,
                    vs: &str,
                    fs: &str,
                    buffers: &[wgpu::VertexBufferLayout<'_>],
                    format: wgpu::TextureFormat| {
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &[Some(layout)],
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers: &buffers.iter().cloned().map(Some).collect::<Vec<_>>(),
            },
            // Both sides drawn: a back face hides what is behind it (and shades black).
            primitive: wgpu::PrimitiveState {
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &[Some(format.into())],
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let shadow_pipeline = pipeline(
        "shadow",
        &shadow_layout,
        "shadow_vs",
        "shadow_fs",
        std::slice::from_ref(&mesh_layout),
        wgpu::TextureFormat::R32Float,
    );
    let main_pipeline = pipeline(
        "main",
        &main_layout,
        "main_vs",
        "main_fs",
        &[mesh_layout.clone(), indirect_layout],
        wgpu::TextureFormat::Rgba32Float,
    );

    // Targets: the shadow cube (distance to the light) with its depth buffer, the image.
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
    let (w, h) = (cam.width, cam.height);
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
    let cube_depth_view = cube_depth.create_view(&Default::default());
    let image_view = image.create_view(&Default::default());
    let image_depth_view = image_depth.create_view(&Default::default());
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor::default());
    let uniform = |label| {
        buffer(
            &device,
            label,
            size_of::<SceneUniform>() as u64,
            U::UNIFORM | U::COPY_DST,
        )
    };
    let face_uniforms: Vec<wgpu::Buffer> = (0..6).map(|_| uniform("face")).collect();
    let main_uniform = uniform("camera");
    let face_groups: Vec<wgpu::BindGroup> = face_uniforms
        .iter()
        .map(|u| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("face"),
                layout: &shadow_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: u.as_entire_binding(),
                }],
            })
        })
        .collect();
    let main_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("main"),
        layout: &main_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: main_uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&cube_view),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
        ],
    });
    let row_bytes = (16 * w).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let readback = buffer(
        &device,
        "readback",
        u64::from(row_bytes) * u64::from(h),
        U::MAP_READ | U::COPY_DST,
    );

    // Depth range of both projections: the whole scene from anywhere inside its bounds.
    let extent = (hi - lo).length().max(1e-6);
    let far = 4.0 * extent + (cam.position - (lo + hi) * 0.5).length();
    let near = 1e-3 * extent;
    let mut x = vec![Rgb::ZERO; n];
    let mut written = Vec::new();
    for f in 0..options.frames {
        let light = light_at(lo, hi, f, options.frames);
        let Light::Point {
            position,
            intensity,
        } = light
        else {
            unreachable!("light_at makes point lights")
        };
        // 1. CPU: the light's direct irradiance per patch and the first exitance.
        let t = std::time::Instant::now();
        let direct = direct_per_patch(mesh, &occ, &light, n);
        first_exitance(&file.patches, &direct, &mut x);
        queue.write_buffer(&x_buf, 0, bytemuck::cast_slice(&x));
        let cpu_ms = t.elapsed().as_secs_f64() * 1e3;
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
        for (u, v) in face_uniforms.iter().zip(cube_views(position)) {
            queue.write_buffer(u, 0, bytemuck::bytes_of(&scene(face_proj * v)));
        }
        queue.write_buffer(
            &main_uniform,
            0,
            bytemuck::bytes_of(&scene(cam.view_proj(near, far))),
        );

        // 2. GPU: gather, corner pass, shadow cube, image; one encoder, one submission.
        let t = std::time::Instant::now();
        let mut encoder = device.create_command_encoder(&Default::default());
        gather.record(&mut encoder);
        corner_pass.record(&mut encoder);
        let vertex_count = 3 * mesh.triangles.len() as u32;
        for (view, group) in face_views.iter().zip(&face_groups) {
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
                    view: &cube_depth_view,
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
            pass.set_pipeline(&shadow_pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.set_vertex_buffer(0, vertex_buf.slice(..));
            pass.draw(0..vertex_count, 0..1);
        }
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("main"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &image_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &image_depth_view,
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
            pass.set_pipeline(&main_pipeline);
            pass.set_bind_group(0, &main_group, &[]);
            pass.set_vertex_buffer(0, vertex_buf.slice(..));
            pass.set_vertex_buffer(1, indirect.slice(..));
            pass.draw(0..vertex_count, 0..1);
        }
        encoder.copy_texture_to_buffer(
            image.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row_bytes),
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

        // 3. The picture: read back, tone mapped, written with the frame's lights file.
        readback.map_async(wgpu::MapMode::Read, .., |r| {
            if let Err(e) = r {
                eprintln!("readback failed: {e}");
            }
        });
        device.poll(wgpu::PollType::wait_indefinitely())?;
        let pixels: Vec<Vec3> = {
            let view = readback.get_mapped_range(..)?;
            (0..h as usize)
                .flat_map(|row| {
                    let line = &view[row * row_bytes as usize..][..16 * w as usize];
                    bytemuck::cast_slice::<u8, [f32; 4]>(line)
                        .iter()
                        .map(|p| Vec3::new(p[0], p[1], p[2]))
                        .collect::<Vec<_>>()
                })
                .collect()
        };
        readback.unmap();
        let gpu_ms = t.elapsed().as_secs_f64() * 1e3;
        let png = options.out.join(format!("frame-{f:03}.png"));
        let mut encoded = Vec::new();
        tone_map(&pixels, w, h).write_to(
            &mut std::io::Cursor::new(&mut encoded),
            image::ImageFormat::Png,
        )?;
        write_atomic(&png, &encoded)?;
        let [px, py, pz] = position.to_array();
        let lights = format!(
            "{{\"lights\":[{{\"type\":\"point\",\"position\":[{px:?},{py:?},{pz:?}],\"intensity\":[{:?},{:?},{:?}]}}]}}\n",
            intensity.r, intensity.g, intensity.b
        );
        write_atomic(
            &options.out.join(format!("lights-{f:03}.json")),
            lights.as_bytes(),
        )?;
        eprintln!(
            "frame {f}: light at [{px:.3}, {py:.3}, {pz:.3}], direct light {cpu_ms:.1} ms, GPU frame and readback {gpu_ms:.1} ms, wrote {}",
            png.display()
        );
        written.push(png);
    }
    Ok(written)
}

/// Whether `adapter` can render to the example's float targets (Mesa's GL adapter cannot).
pub(crate) fn renders_float(adapter: &wgpu::Adapter) -> bool {
    [
        wgpu::TextureFormat::R32Float,
        wgpu::TextureFormat::Rgba32Float,
    ]
    .iter()
    .all(|&f| {
        adapter
            .get_texture_format_features(f)
            .allowed_usages
            .contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
    })
}

#[allow(dead_code)] // the comparison test includes this file as a module and calls `run`
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Err(e) = Options::parse(&args).and_then(|o| run(&o)) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
