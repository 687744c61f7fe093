//! What a pass checks before it builds on a device: the device's limits, the host's buffers,
//! and errors caught while building.

use crate::GpuError;
use crate::shader::WORKGROUP;

/// Bytes one storage binding may have on a device of limits `dl`.
pub(crate) fn storage_binding_limit(dl: &wgpu::Limits) -> u64 {
    dl.max_storage_buffer_binding_size.min(dl.max_buffer_size)
}

/// Refuses a device short of what a host-device pass of one 64-wide workgroup, `storage`
/// storage buffers and one uniform needs, naming the limit.
pub(crate) fn check_pass_limits(
    device: &wgpu::Device,
    pass: &str,
    storage: u32,
) -> Result<(), GpuError> {
    let dl = device.limits();
    let needs = [
        (
            "max_compute_workgroup_size_x",
            dl.max_compute_workgroup_size_x,
            WORKGROUP,
        ),
        (
            "max_compute_invocations_per_workgroup",
            dl.max_compute_invocations_per_workgroup,
            WORKGROUP,
        ),
        (
            "max_storage_buffers_per_shader_stage",
            dl.max_storage_buffers_per_shader_stage,
            storage,
        ),
        (
            "max_uniform_buffers_per_shader_stage",
            dl.max_uniform_buffers_per_shader_stage,
            1,
        ),
    ];
    for (name, has, need) in needs {
        if has < need {
            return Err(GpuError::Unsupported(format!(
                "the device's {name} is {has}, {pass} needs {need}"
            )));
        }
    }
    Ok(())
}

/// Checks one of the host's buffers before `pass` (named in the message) binds it: at least
/// `bytes` long, with `usage`.
pub(crate) fn check_host_buffer(
    pass: &str,
    what: &str,
    buffer: &wgpu::Buffer,
    bytes: u64,
    usage: wgpu::BufferUsages,
) -> Result<(), GpuError> {
    if buffer.size() < bytes {
        return Err(GpuError::Unsupported(format!(
            "the host's {what} buffer has {} bytes, {pass} needs {bytes}",
            buffer.size()
        )));
    }
    if !buffer.usage().contains(usage) {
        return Err(GpuError::Unsupported(format!(
            "the host's {what} buffer lacks usage {usage:?} (it has {:?})",
            buffer.usage()
        )));
    }
    Ok(())
}

/// Runs `build` inside validation and out-of-memory error scopes, so a failed build is an
/// `Err` and never reaches the device's error handler.
pub(crate) fn in_error_scopes<T>(
    device: &wgpu::Device,
    build: impl FnOnce() -> T,
) -> Result<T, GpuError> {
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let oom = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let built = build();
    let oom = pollster::block_on(oom.pop());
    let validation = pollster::block_on(validation.pop());
    match oom.or(validation) {
        Some(e) => Err(GpuError::Device(e.to_string())),
        None => Ok(built),
    }
}
