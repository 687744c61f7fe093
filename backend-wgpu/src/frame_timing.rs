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
    let passes = Passes::new(device, queue, matrix, mesh, probes)?;
    let stamps = Stamps::new(device, queue);
    let mut samples = Samples::default();
    for _ in 0..frames.max(1) {
        time_frame(device, queue, &passes, &stamps, &info, &mut samples)?;
    }
    Ok(HostFrameTimes {
        adapter: info,
        path: passes.gather.path(),
        dispatches: passes.gather.dispatches(),
        corners: passes.corners.corners(),
        probes: passes.probes_written(),
        record_ms: median(&mut samples.record).unwrap_or(0.0),
        gather_ms: median(&mut samples.gather_ms),
        corners_ms: median(&mut samples.corners_ms),
        probes_ms: median(&mut samples.probes_ms),
    })
}

/// A buffer of at least 4 bytes (an empty binding is invalid).
fn buffer(
    device: &wgpu::Device,
    label: &str,
    bytes: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(4),
        usage,
        mapped_at_creation: false,
    })
}

/// The passes a frame records and the buffers they run between: `x` (1 on every patch),
/// `y`, the corners and the probes' SH.
struct Passes {
    gather: HostGather,
    corners: CornerPass,
    probes: Option<ProbePass>,
    // Bound by the passes' bind groups; kept for as long as the passes.
    _buffers: [wgpu::Buffer; 4],
}

impl Passes {
    /// A [`HostGather`] of `matrix`, a [`CornerPass`] of `mesh` and, given `probes` (with the
    /// file's patches), a [`ProbePass`], between buffers of their own; `x` is written.
    fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        matrix: &TransferMatrix<'_>,
        mesh: &Mesh<'_>,
        probes: Option<(&Probes<'_>, &[Patch])>,
    ) -> Result<Self, GpuError> {
        use wgpu::BufferUsages as U;
        let n = matrix.layout.n();
        let x = buffer(
            device,
            "x",
            12 * n as u64,
            U::COPY_DST | U::COPY_SRC | U::STORAGE,
        );
        let y = buffer(device, "y", 12 * n as u64, U::STORAGE);
        let out = buffer(
            device,
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
            device,
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
        Ok(Passes {
            gather,
            corners,
            probes: probe_pass,
            _buffers: [x, y, out, sh],
        })
    }

    /// Probes the probe pass writes (0 without probes).
    fn probes_written(&self) -> usize {
        self.probes.as_ref().map_or(0, ProbePass::probes)
    }
}

/// The frame's six timestamps (two per pass) where the device has `TIMESTAMP_QUERY`, and
/// the buffers they are resolved into and read back from.
struct Stamps {
    queries: Option<wgpu::QuerySet>,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Milliseconds per tick.
    period: f64,
}

impl Stamps {
    fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Self {
        use wgpu::BufferUsages as U;
        let timed = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let queries = timed.then(|| {
            device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("frame timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 6,
            })
        });
        Stamps {
            queries,
            resolve: buffer(device, "timestamps", 48, U::QUERY_RESOLVE | U::COPY_SRC),
            readback: buffer(device, "timestamps readback", 48, U::MAP_READ | U::COPY_DST),
            period: f64::from(queue.get_timestamp_period()) * 1e-6,
        }
    }

    /// The timestamp writes of the pass whose stamps are `begin` and `begin + 1`.
    fn writes(&self, begin: u32) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.queries
            .as_ref()
            .map(|q| wgpu::ComputePassTimestampWrites {
                query_set: q,
                beginning_of_pass_write_index: Some(begin),
                end_of_pass_write_index: Some(begin + 1),
            })
    }
}

/// Each frame's figures, in milliseconds.
#[derive(Default)]
struct Samples {
    record: Vec<f64>,
    gather_ms: Vec<f64>,
    corners_ms: Vec<f64>,
    probes_ms: Vec<f64>,
}

/// Records, submits and waits for one frame of `passes`, adding its figures to `samples`:
/// the recording's CPU time always, each pass's GPU time where `stamps` has queries.
fn time_frame(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    passes: &Passes,
    stamps: &Stamps,
    info: &AdapterInfo,
    samples: &mut Samples,
) -> Result<(), GpuError> {
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("frame"),
    });
    let t = Instant::now();
    passes.gather.record_timed(&mut encoder, stamps.writes(0));
    passes.corners.record_timed(&mut encoder, stamps.writes(2));
    if let Some(p) = &passes.probes {
        p.record_timed(&mut encoder, stamps.writes(4));
    }
    samples.record.push(t.elapsed().as_secs_f64() * 1e3);
    let Some(q) = &stamps.queries else {
        queue.submit([encoder.finish()]);
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Device(format!("{info}: {e}")))?;
        return Ok(());
    };
    encoder.resolve_query_set(q, 0..6, &stamps.resolve, 0);
    encoder.copy_buffer_to_buffer(&stamps.resolve, 0, &stamps.readback, 0, 48);
    queue.submit([encoder.finish()]);
    device::map_read_and_wait(device, &stamps.readback, &info.to_string())?;
    {
        let view = stamps
            .readback
            .get_mapped_range(..)
            .map_err(|e| GpuError::Device(format!("{info}: readback failed: {e}")))?;
        let stamp = |i: usize| u64::from_le_bytes(view[8 * i..8 * i + 8].try_into().unwrap());
        let ms = |begin: usize| stamp(begin + 1).wrapping_sub(stamp(begin)) as f64 * stamps.period;
        samples.gather_ms.push(ms(0));
        // An empty mesh records no corner pass: its stamps stay unwritten.
        if passes.corners.corners() > 0 {
            samples.corners_ms.push(ms(2));
        }
        if passes.probes_written() > 0 {
            samples.probes_ms.push(ms(4));
        }
    }
    stamps.readback.unmap();
    Ok(())
}

fn median(v: &mut [f64]) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied()
}

#[cfg(test)]
mod tests {
    use super::*;
    use radiosity_core::RadFile;

    /// The demo scene's frame on every adapter but GL ones (none: nothing to time, as the
    /// wgpu tests do outside CI): one row per pass with the mesh's corners and the file's
    /// probes, every GPU time that is reported finite and not negative.
    #[test]
    fn times_the_demo_frame_on_each_adapter() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/demo.rad");
        let bytes = std::fs::read(path).expect("assets/demo.rad");
        let file = RadFile::parse(&bytes).expect("the demo parses");
        let mesh = file.mesh.as_ref().expect("the demo has a mesh");
        let probes = file.probes.as_ref().map(|p| (p, &file.patches[..]));
        for adapter in crate::adapters().iter().filter(|a| a.info.backend != "gl") {
            let t = time_host_frame(adapter, &file.matrix, mesh, probes, 3)
                .unwrap_or_else(|e| panic!("{}: {e}", adapter.info));
            assert_eq!(t.corners, mesh.corner_count(), "{}", adapter.info);
            assert_eq!(
                t.probes,
                probes.map_or(0, |(p, _)| p.len()),
                "{}",
                adapter.info
            );
            assert_ne!(t.path, DecodePath::Auto);
            assert!(t.dispatches >= 1, "{}: no dispatch", adapter.info);
            assert!(t.record_ms.is_finite() && t.record_ms >= 0.0);
            for ms in [t.gather_ms, t.corners_ms, t.probes_ms]
                .into_iter()
                .flatten()
            {
                assert!(ms.is_finite() && ms >= 0.0, "{}: {ms} ms", adapter.info);
            }
        }
    }
}
