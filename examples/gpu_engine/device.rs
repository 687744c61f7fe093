//! The engine's device: the first adapter that renders to the float targets, preferring one
//! that is not GL.

use super::{Result, renders_float};
use radiosity_backend_wgpu::adapters;

/// The engine's device and queue, and the adapter as the log names it: the first adapter
/// that renders to the float targets (the shadow cube's R32Float, the image's Rgba32Float),
/// preferring one that is not GL (Mesa's GL compiles slowly, and cannot render to R32Float).
pub(crate) fn open() -> Result<(wgpu::Device, wgpu::Queue, String)> {
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
    Ok((device, queue, adapter.info.to_string()))
}
