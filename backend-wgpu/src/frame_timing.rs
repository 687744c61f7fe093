//! [`time_host_frame`]: what one frame of the host-device path costs on an adapter — the CPU
//! time to record the gather, the corner pass and the probe pass, and the GPU time of each
//! pass from timestamps. `radiosity bench` reports it on every adapter it finds.

use crate::adapter::{Adapter, AdapterInfo};
use crate::device;
use crate::{
    CornerBuffers, CornerPass, DecodePath, GpuError, GpuOptions, HostGather, HostGatherBuffers,
    PROBE_OUT_BYTES, ProbeBuffers, ProbePass,
};
use radiosity_core::{Mesh, Patch, Probes, Rgb, TransferMatrix};
use std::time::Instant;

/// One frame of [`HostGather`], [`CornerPass`] and (given probes) [`ProbePass`] on one
/// adapter, medians over the frames.
#[derive(Clone, Debug)]
pub struct HostFrameTimes {
    pub adapter: AdapterInfo,
    /// The gather's decode path.
    pub path: DecodePath,
    /// The gather's dispatches per frame.
    pub dispatches: usize,
    /// Corners the corner pass writes.
    pub corners: usize,
    /// Probes the probe pass writes (0 without probes).
    pub probes: usize,
    /// CPU time to record the passes (with their timestamp writes) into an encoder, ms.
    pub record_ms: f64,
    /// GPU time of the gather's compute pass, ms; `None` without `TIMESTAMP_QUERY`.
    pub gather_ms: Option<f64>,
    /// GPU time of the corner pass, ms; `None` without `TIMESTAMP_QUERY`.
    pub corners_ms: Option<f64>,
    /// GPU time of the probe pass, ms; `None` without probes or `TIMESTAMP_QUERY`.
    pub probes_ms: Option<f64>,
}

/// Opens a device on `adapter` (its own limits, with `TIMESTAMP_QUERY` where it has it), builds
/// a [`HostGather`] of `matrix`, a [`CornerPass`] of `mesh` and, given `probes` (with the
/// file's patches), a [`ProbePass`] between buffers of its own, and runs `frames` frames (at
/// least one), each submitted and waited for, with `x` = 1 on every patch. Errors are the
/// passes' own ([`HostGather::new`], [`CornerPass::new`], [`ProbePass::new`]) or the device's.
pub fn time_host_frame(
    adapter: &Adapter,
    matrix: &TransferMatrix<'_>,
    mesh: &Mesh<'_>,
    probes: Option<(&Probes<'_>, &[Patch])>,
    frames: usize,
) -> Result<HostFrameTimes, GpuError> {
    let info = adapter.info.clone();
    let inner = adapter.wgpu_adapter();
    let features = inner.features() & wgpu::Features::TIMESTAMP_QUERY;
    // Bound first, so it drops last (see the `device` module).
    let dev = device::open(
        inner,
        &wgpu::DeviceDescriptor {
            label: Some("radiosity frame timing"),
            required_features: features,
            required_limits: inner.limits(),
            ..Default::default()
        },
    )
    .map_err(|e| GpuError::Device(format!("{info}: {e}")))?;
    let (device, queue) = (dev.device(), dev.queue());
    let n = matrix.layout.n();
    let buffer = |label, bytes: u64, usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(4),
            usage,
            mapped_at_creation: false,
        })
    };
    use wgpu::BufferUsages as U;
    let x = buffer("x", 12 * n as u64, U::COPY_DST | U::COPY_SRC | U::STORAGE);
    let y = buffer("y", 12 * n as u64, U::STORAGE);
    let out = buffer(
        "corners",
        12 * mesh.corner_count() as u64,
        U::STORAGE | U::VERTEX,
    );
    let gather = HostGather::new(
        device,
        queue,
        matrix,
        &GpuOptions::default(),
        HostGatherBuffers { x: &x, y: &y },
    )?;
    let corners = CornerPass::new(device, mesh, CornerBuffers { y: &y, out: &out })?;
    let sh = buffer(
        "probe sh",
        PROBE_OUT_BYTES * probes.map_or(0, |(p, _)| p.len()) as u64,
        U::STORAGE,
    );
    let probe_pass = probes
        .map(|(p, patches)| {
            let buffers = ProbeBuffers {
                x: &x,
                y: &y,
                out: &sh,
            };
            ProbePass::new(device, p, patches, buffers)
        })
        .transpose()?;
    queue.write_buffer(&x, 0, bytemuck::cast_slice(&vec![Rgb::splat(1.0); n]));

    let timed = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
    let queries = timed.then(|| {
        device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("frame timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 6,
        })
    });
    let resolve = buffer("timestamps", 48, U::QUERY_RESOLVE | U::COPY_SRC);
    let readback = buffer("timestamps readback", 48, U::MAP_READ | U::COPY_DST);
    let period = f64::from(queue.get_timestamp_period()) * 1e-6; // ms per tick
    let writes = |begin: u32| {
        queries.as_ref().map(|q| wgpu::ComputePassTimestampWrites {
            query_set: q,
            beginning_of_pass_write_index: Some(begin),
            end_of_pass_write_index: Some(begin + 1),
        })
    };

    let (mut record, mut gather_ms, mut corners_ms) = (Vec::new(), Vec::new(), Vec::new());
    let mut probes_ms = Vec::new();
    let probes_written = probe_pass.as_ref().map_or(0, ProbePass::probes);
    for _ in 0..frames.max(1) {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("frame"),
        });
        let t = Instant::now();
        gather.record_timed(&mut encoder, writes(0));
        corners.record_timed(&mut encoder, writes(2));
        if let Some(p) = &probe_pass {
            p.record_timed(&mut encoder, writes(4));
        }
        record.push(t.elapsed().as_secs_f64() * 1e3);
        if let Some(q) = &queries {
            encoder.resolve_query_set(q, 0..6, &resolve, 0);
            encoder.copy_buffer_to_buffer(&resolve, 0, &readback, 0, 48);
        }
        queue.submit([encoder.finish()]);
        if queries.is_none() {
            device
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| GpuError::Device(format!("{info}: {e}")))?;
            continue;
        }
        device::map_read_and_wait(device, &readback, &info.to_string())?;
        {
            let view = readback
                .get_mapped_range(..)
                .map_err(|e| GpuError::Device(format!("{info}: readback failed: {e}")))?;
            let stamp = |i: usize| u64::from_le_bytes(view[8 * i..8 * i + 8].try_into().unwrap());
            gather_ms.push(stamp(1).wrapping_sub(stamp(0)) as f64 * period);
            // An empty mesh records no corner pass: its stamps stay unwritten.
            if corners.corners() > 0 {
                corners_ms.push(stamp(3).wrapping_sub(stamp(2)) as f64 * period);
            }
            if probes_written > 0 {
                probes_ms.push(stamp(5).wrapping_sub(stamp(4)) as f64 * period);
            }
        }
        readback.unmap();
    }
    Ok(HostFrameTimes {
        adapter: info,
        path: gather.path(),
        dispatches: gather.dispatches(),
        corners: corners.corners(),
        probes: probes_written,
        record_ms: median(&mut record).unwrap_or(0.0),
        gather_ms: median(&mut gather_ms),
        corners_ms: median(&mut corners_ms),
        probes_ms: median(&mut probes_ms),
    })
}

fn median(v: &mut [f64]) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}
