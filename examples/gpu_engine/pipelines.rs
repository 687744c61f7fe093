//! The render pipelines of `gpu_engine.wgsl`: the shadow cube's (distance to the light) and
//! the main pass's (direct light shadowed by the cube, plus the corners' indirect light).

use wgpu::util::DeviceExt;

/// `struct Scene` of `gpu_engine.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct SceneUniform {
    pub(crate) view_proj: [[f32; 4]; 4],
    pub(crate) light: [f32; 4],
    pub(crate) intensity: [f32; 4],
    pub(crate) shadow: [f32; 4],
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

/// The mesh as vertex buffer 0, one vertex per corner. Returns the buffer and its vertices.
pub(crate) fn mesh_vertices(
    device: &wgpu::Device,
    mesh: &radiosity_core::Mesh<'_>,
) -> (wgpu::Buffer, u32) {
    let vertices: Vec<Vertex> = (0..mesh.triangles.len())
        .flat_map(|t| {
            let tri = mesh.triangles[t];
            let [a, b, c] = mesh.corners(t).map(glam::Vec3::from);
            let normal = (b - a).cross(c - a).normalize_or_zero();
            [a, b, c].map(|p| Vertex {
                position: p.to_array(),
                normal: normal.to_array(),
                reflectance: tri.reflectance.to_array(),
                emission: tri.emission.to_array(),
            })
        })
        .collect();
    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("mesh"),
        contents: bytemuck::cast_slice(&vertices),
        usage: wgpu::BufferUsages::VERTEX,
    });
    (buffer, vertices.len() as u32)
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

/// The two pipelines and their bind group layouts.
pub(crate) struct Pipelines {
    /// One face's [`SceneUniform`].
    pub(crate) shadow_layout: wgpu::BindGroupLayout,
    /// The camera's [`SceneUniform`], the shadow cube and its sampler.
    pub(crate) main_layout: wgpu::BindGroupLayout,
    pub(crate) shadow: wgpu::RenderPipeline,
    pub(crate) main: wgpu::RenderPipeline,
}

impl Pipelines {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
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
        let corner_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Float32x3];
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
        let shadow = render_pipeline(
            device,
            &module,
            ("shadow", "shadow_vs", "shadow_fs"),
            &shadow_layout,
            std::slice::from_ref(&mesh_layout),
            wgpu::TextureFormat::R32Float,
        );
        let main = render_pipeline(
            device,
            &module,
            ("main", "main_vs", "main_fs"),
            &main_layout,
            &[mesh_layout.clone(), indirect_layout],
            wgpu::TextureFormat::Rgba32Float,
        );
        Pipelines {
            shadow_layout,
            main_layout,
            shadow,
            main,
        }
    }
}

/// A pipeline `label` of the vertex and fragment entry points `vs`, `fs` drawing into
/// `format` with a Depth32Float depth buffer.
fn render_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    (label, vs, fs): (&str, &str, &str),
    layout: &wgpu::BindGroupLayout,
    buffers: &[wgpu::VertexBufferLayout<'_>],
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        vertex: wgpu::VertexState {
            module,
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
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    })
}
