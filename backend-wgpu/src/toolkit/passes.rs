//! Compute pipelines and their dispatches: building a pipeline, sizing a dispatch grid within
//! the device's limits, recording a one-dispatch pass.

use crate::GpuError;

/// A compute pipeline running `entry` of the WGSL `source` over bind groups of `layout`
/// (group 0, the only one), labelled `label`.
pub(crate) fn pipeline(
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

/// A dispatch grid `(x, y)` of at least `workgroups` workgroups within the device's
/// per-dimension limit, or an `Err` naming `what` needs them.
pub(crate) fn workgroup_grid(
    dl: &wgpu::Limits,
    workgroups: usize,
    what: impl FnOnce() -> String,
) -> Result<(u32, u32), GpuError> {
    let per_dim = dl.max_compute_workgroups_per_dimension.max(1);
    let too_many = |what: String| {
        GpuError::Unsupported(format!(
            "{what} need {workgroups} workgroups, more than {per_dim}²"
        ))
    };
    let Ok(count) = u32::try_from(workgroups) else {
        return Err(too_many(what()));
    };
    let gx = count.clamp(1, per_dim);
    let gy = count.div_ceil(gx).max(1);
    if gy > per_dim {
        return Err(too_many(what()));
    }
    Ok((gx, gy))
}

/// Records one compute pass of one dispatch of `pipeline` over `grid` workgroups, between
/// `timestamps` if given: the whole frame of a host-device pass (corners, probes).
pub(crate) fn record_dispatch(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    grid: (u32, u32),
    timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: timestamps,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[]);
    pass.dispatch_workgroups(grid.0, grid.1, 1);
}
