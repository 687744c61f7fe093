//! Which rules a texture unit decodes BC1/BC4 palettes by, measured rather than assumed.
//!
//! D3D10 lets hardware round palette entries its own way, and the encoder chose every block
//! for [`DecodeMode::D3d10`]'s truncating arithmetic. A texture unit that decodes otherwise
//! moves entries by whole codes, each code a factor `e^(s/255)` (2.7% at the default log
//! range): an NVIDIA H100 (driver 580) interpolates BC4 with weights 0.140, 0.280, 0.440,
//! 0.560, 0.720, 0.860 instead of sevenths (up to 7.5 codes off) and BC1 up to 6 codes off,
//! which made its hardware path ten times less accurate than decoding in the shader. So the
//! hardware path is chosen only where a measurement shows a rule the CPU can reproduce.

use crate::GpuError;
use crate::adapter::Adapter;
use crate::device;
use crate::toolkit::upload_texture;
use radiosity_core::{Bc1Block, Bc4Block, DecodeMode};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// Blocks per row of a test texture.
const WIDE: usize = 64;

/// What the texture unit returned for every texel of `blocks` (`format` is BC1 or BC4 RGBA
/// unorm; 8 bytes a block, a multiple of [`WIDE`] blocks), block-row-major, on a device of
/// its own. Texel `i` of block `k` is at [`texel`]`(k, i)`.
pub fn read_bc_texels(
    adapter: &Adapter,
    format: wgpu::TextureFormat,
    blocks: &[u8],
) -> Result<Vec<[f32; 4]>, GpuError> {
    let info = &adapter.info;
    let inner = adapter.wgpu_adapter();
    // Bound first, so it drops last: the device is destroyed under the lock (`device`).
    let dev = device::open(
        inner,
        &wgpu::DeviceDescriptor {
            label: Some("bc texture unit check"),
            required_features: wgpu::Features::TEXTURE_COMPRESSION_BC,
            ..Default::default()
        },
    )
    .map_err(|e| GpuError::Device(format!("{info}: {e}")))?;
    let (device, queue) = (dev.device(), dev.queue());
    let rows = blocks.len() / 8 / WIDE;
    assert_eq!(rows * WIDE * 8, blocks.len(), "whole rows of blocks");
    let view = upload_texture(device, queue, format, (WIDE, rows), blocks);
    let (width, height) = ((WIDE * 4) as u32, (rows * 4) as u32);
    let bytes = u64::from(width * height) * 16;
    let buffer = |usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("texture unit texels"),
            size: bytes,
            usage,
            mapped_at_creation: false,
        })
    };
    let out = buffer(wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    let read = buffer(wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("texture unit check"),
        source: wgpu::ShaderSource::Wgsl(
            "@group(0) @binding(0) var tex: texture_2d<f32>;
@group(0) @binding(1) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    let d = textureDimensions(tex);
    if g.x < d.x && g.y < d.y {
        out[g.y * d.x + g.x] = textureLoad(tex, vec2<i32>(g.xy), 0);
    }
}"
            .into(),
        ),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("texture unit check"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("texture unit check"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: out.as_entire_binding(),
            },
        ],
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &read, 0, bytes);
    queue.submit([enc.finish()]);
    crate::device::map_read_and_wait(device, &read, &format!("{info}: texture unit check"))?;
    let view = read
        .get_mapped_range(..)
        .map_err(|e| GpuError::Device(format!("texture unit readback: {e}")))?;
    Ok(bytemuck::cast_slice::<u8, [f32; 4]>(&view).to_vec())
}

/// Where texel `i` (0–15) of block `k` lies in [`read_bc_texels`]'s answer.
pub fn texel(k: usize, i: usize) -> usize {
    let (bx, by) = (k % WIDE, k / WIDE);
    (by * 4 + i / 4) * WIDE * 4 + bx * 4 + i % 4
}

/// The code the gather's texture path reads from a texel value `t` (`shader::TEX_BIAS`):
/// `⌊255·t + 1/14⌋`.
pub(crate) fn code_of(t: f32) -> i32 {
    (t * 255.0 + 1.0 / 14.0).floor() as i32
}

/// The test blocks: 4096 BC4 blocks (every endpoint pair on a 16-step grid of both
/// orders, plus pairs one apart) and 4096 BC1 blocks (random endpoints, both modes), each
/// using every palette index.
fn test_blocks() -> (Vec<u8>, Vec<u8>) {
    let mut bc4 = Vec::with_capacity(4096 * 8);
    let mut idx = 0u64;
    for i in 0..16u64 {
        idx |= (i % 8) << (3 * i);
    }
    let mut pair = |r0: u8, r1: u8| {
        bc4.extend_from_slice(&[r0, r1]);
        bc4.extend_from_slice(&idx.to_le_bytes()[..6]);
    };
    for a in 0..64u8 {
        for b in 0..32u8 {
            pair(a * 4 + 1, b * 8 + 3);
        }
    }
    for r in 0..=255u8 {
        for (d, w) in [(1u8, 0u8), (0, 1)].iter().cycle().take(8) {
            pair(r.saturating_add(*d), r.saturating_add(*w));
        }
    }
    (bc4, random_bc1_blocks(4096))
}

/// `count` BC1 blocks of seeded random endpoints (both modes), each row of texels using
/// indices 0, 1, 2, 3 in turn.
pub fn random_bc1_blocks(count: usize) -> Vec<u8> {
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut bc1 = Vec::with_capacity(count * 8);
    for _ in 0..count {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        bc1.extend_from_slice(&(seed as u32).to_le_bytes());
        bc1.extend_from_slice(&0xe4e4_e4e4u32.to_le_bytes());
    }
    bc1
}

/// The decode rules under which the gather's texture path (codes read as [`code_of`]) gives
/// exactly the entries the CPU decodes, or `None` when neither D3D10's nor Mesa's does.
fn measure(adapter: &Adapter) -> Result<Option<DecodeMode>, GpuError> {
    let (bc4, bc1) = test_blocks();
    let t4 = read_bc_texels(adapter, wgpu::TextureFormat::Bc4RUnorm, &bc4)?;
    let t1 = read_bc_texels(adapter, wgpu::TextureFormat::Bc1RgbaUnorm, &bc1)?;
    let fits = |mode: DecodeMode| {
        let bc4_ok = bc4.chunks_exact(8).enumerate().all(|(k, b)| {
            let want = Bc4Block(b.try_into().expect("8 bytes")).decode(mode);
            (0..16).all(|i| code_of(t4[texel(k, i)][0]) == i32::from(want[i]))
        });
        let bc1_ok = bc1.chunks_exact(8).enumerate().all(|(k, b)| {
            let want = Bc1Block(b.try_into().expect("8 bytes")).decode(mode);
            (0..16).all(|i| (0..3).all(|c| code_of(t1[texel(k, i)][c]) == i32::from(want[i][c])))
        });
        bc4_ok && bc1_ok
    };
    Ok([DecodeMode::D3d10, DecodeMode::Mesa]
        .into_iter()
        .find(|&m| fits(m)))
}

/// The rules under which `adapter`'s texture unit, read as the gather's texture path reads
/// it, decodes BC1 and BC4 exactly as the CPU does: [`DecodeMode::D3d10`],
/// [`DecodeMode::Mesa`], or `None` for neither. Measured on 4096 blocks of each format the
/// first time an adapter is asked about (a few milliseconds on a GPU), then remembered for
/// the process. An error when the adapter cannot open a device with BC textures.
pub fn texture_decode_model(adapter: &Adapter) -> Result<Option<DecodeMode>, GpuError> {
    static SEEN: OnceLock<Mutex<HashMap<String, Option<DecodeMode>>>> = OnceLock::new();
    let key = adapter.info.to_string();
    let seen = SEEN.get_or_init(Default::default);
    if let Some(m) = seen.lock().ok().and_then(|s| s.get(&key).copied()) {
        return Ok(m);
    }
    let m = measure(adapter)?;
    if let Ok(mut s) = seen.lock() {
        s.insert(key, m);
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The test BC4 blocks cover both palette modes and every index; its BC1 blocks both
    /// modes.
    #[test]
    fn test_blocks_cover_both_modes() {
        let (bc4, bc1) = test_blocks();
        assert_eq!((bc4.len(), bc1.len()), (4096 * 8, 4096 * 8));
        let modes4: Vec<bool> = bc4
            .chunks_exact(8)
            .map(|b| Bc4Block(b.try_into().unwrap()).is_eight_value())
            .collect();
        assert!(modes4.contains(&true) && modes4.contains(&false));
        let b = Bc4Block(bc4[..8].try_into().unwrap());
        let mut seen: Vec<u8> = (0..16).map(|i| b.index(i)).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 8);
        let modes1: Vec<bool> = bc1
            .chunks_exact(8)
            .map(|b| Bc1Block(b.try_into().unwrap()).is_four_colour())
            .collect();
        assert!(modes1.contains(&true) && modes1.contains(&false));
    }

    /// `code_of` gives back whole codes and D3D10's truncated fractions.
    #[test]
    fn code_of_recovers_truncated_fractions() {
        for c in 0..=255 {
            assert_eq!(code_of(c as f32 / 255.0), c);
            for (num, den) in [(1, 3), (2, 3), (1, 2), (1, 7), (6, 7), (1, 5), (4, 5)] {
                if c < 255 {
                    let t = (c as f32 + num as f32 / den as f32) / 255.0;
                    assert_eq!(code_of(t), c, "{c} + {num}/{den}");
                }
            }
        }
    }
}
