//! The gather, the corner pass and the probe pass on a device the host owns ([`HostGather`],
//! [`CornerPass`], [`ProbePass`]), on every adapter found except GL ones (as in `wgpu_gather.rs`, whose reasons apply).
//!
//! With no adapter these tests print why and pass, except when `CI=true`: CI installs the
//! software Vulkan driver (scripts/test.sh), so a missing adapter there is a failure.
//!
//! Tolerances.
//! - **The host gather** runs the same kernels over the same plan as the own-device
//!   [`WgpuGather`] (same limits, same column splits): its `y` must be the same bits.
//! - **The corner pass** sums each corner's row in the core's order
//!   ([`Mesh::corner_indirect`]); the only freedom left is a driver fusing a multiply and an
//!   add (WGSL allows it), which changes the rounding of each product by at most half an ulp
//!   of that product. A row of k terms then differs by at most γ_(k+1)·Σ|y·w| (the recursive
//!   summation bound over the products and the k adds), with a factor 2 of margin and
//!   k·`f32::MIN_POSITIVE` for subnormal products a GPU may flush. On lavapipe the values are
//!   bit-identical (asserted there: `is_mesa_software`).
//! - **The probe pass** sums each probe's row in 64 strided partial sums added by a tree, not
//!   in the core's order ([`Probes::gather`]): each coefficient is a sum of k products, whose
//!   error under any order of summation is at most γ_k·Σ|r·w| (Higham's bound for any
//!   summation tree), and the reflected radiosity `x − E + ρ∘y` itself takes three more
//!   roundings (γ_3·(|x| + |E| + |ρ∘y|) per term). Asserted with a factor 2 of margin.

mod gpu_support;

use gpu_support::gpu_adapters;
use radiosity_backend_wgpu::{
    Adapter, CornerBuffers, CornerPass, DecodePath, GpuError, GpuOptions, HostGather,
    HostGatherBuffers, PROBE_OUT_BYTES, ProbeBuffers, ProbePass, WgpuGather,
};
use radiosity_core::{
    CornerWeight, DecodedProbes, Gather, Mesh, MeshTriangle, Patch, ProbeFactors, ProbeWeight,
    Probes, Rgb, SH_COEFFICIENTS, TransferMatrix,
};
use radiosity_tests::fixtures::{FORMAT_CASES, SplitMix64, exitance, sample_file};
use std::borrow::Cow;
use std::sync::Mutex;

/// Devices are opened one test at a time: the crate's own devices are serialised by its
/// lifecycle lock, the tests' by this one (see the crate's `device` module for why).
static DEVICES: Mutex<()> = Mutex::new(());

/// A device of the host's own on `adapter`, with `limits`.
fn host_device(adapter: &Adapter, limits: wgpu::Limits) -> (wgpu::Device, wgpu::Queue) {
    pollster::block_on(
        adapter
            .wgpu_adapter()
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("host"),
                required_limits: limits,
                ..Default::default()
            }),
    )
    .unwrap_or_else(|e| panic!("{}: {e}", adapter.info))
}

fn buffer(device: &wgpu::Device, bytes: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: bytes,
        usage,
        mapped_at_creation: false,
    })
}

/// The host's `x` and `y` for `n` patches, as an engine would make them.
fn gather_buffers(device: &wgpu::Device, n: usize) -> (wgpu::Buffer, wgpu::Buffer) {
    use wgpu::BufferUsages as U;
    (
        buffer(device, 12 * n as u64, U::COPY_DST | U::COPY_SRC),
        buffer(
            device,
            12 * n as u64,
            U::STORAGE | U::COPY_SRC | U::COPY_DST,
        ),
    )
}

/// Submits `encoder` after recording a copy of `src`'s first `len` triples, then waits and
/// returns them (the test's readback; the host path itself never waits).
fn submit_and_read(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mut encoder: wgpu::CommandEncoder,
    src: &wgpu::Buffer,
    len: usize,
) -> Vec<Rgb> {
    let bytes = (12 * len).max(4) as u64;
    let read = buffer(
        device,
        bytes,
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    encoder.copy_buffer_to_buffer(src, 0, &read, 0, 12 * len as u64);
    queue.submit([encoder.finish()]);
    read.map_async(wgpu::MapMode::Read, .., |r| r.expect("maps"));
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("device polls");
    let view = read.get_mapped_range(..).expect("mapped");
    bytemuck::cast_slice::<u8, Rgb>(&view[..12 * len]).to_vec()
}

fn encoder(device: &wgpu::Device) -> wgpu::CommandEncoder {
    device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
}

/// One frame of a [`HostGather`] over `m` on the host's device: `x` written through the
/// queue, the gather recorded, `y` read back.
fn host_frame(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    m: &TransferMatrix<'_>,
    options: &GpuOptions,
    x: &[Rgb],
) -> (Vec<Rgb>, HostGather) {
    let n = m.layout.n();
    let (xb, yb) = gather_buffers(device, n);
    let g = HostGather::new(
        device,
        queue,
        m,
        options,
        HostGatherBuffers { x: &xb, y: &yb },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    queue.write_buffer(&xb, 0, bytemuck::cast_slice(x));
    let mut e = encoder(device);
    g.record(&mut e);
    (submit_and_read(device, queue, e, &yb, n), g)
}

fn bits(v: &[Rgb]) -> Vec<[u32; 3]> {
    v.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
}

#[test]
fn host_gather_equals_the_own_device_gather_bit_for_bit() {
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        for (format, channels) in FORMAT_CASES {
            for (n, max_tile) in [(1, 8), (37, 16), (130, 8192)] {
                let m = sample_file(n, channels, format, max_tile).matrix;
                let options = GpuOptions {
                    path: DecodePath::Software,
                    ..GpuOptions::default()
                };
                let x = exitance(n, n as u64);
                let mut want = vec![Rgb::ZERO; n];
                let mut own = WgpuGather::on_adapter(&m, &adapter, &options).unwrap();
                own.gather(&x, &mut want).unwrap();
                let (got, g) = host_frame(&device, &queue, &m, &options, &x);
                assert_eq!(g.patches(), n);
                assert_eq!(g.path(), DecodePath::Software);
                assert_eq!(g.dispatches(), own.dispatches());
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "{format} ×{channels} n={n} tile={max_tile} on {}",
                    adapter.info
                );
            }
        }
    }
}

/// A device with a storage binding of 4 KiB: the host gather cuts the matrix into bands (as
/// the own-device gather does under the same cap) and gives the same bits.
#[test]
fn host_gather_adapts_to_small_device_limits() {
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let cap = 4096;
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: cap,
            ..adapter.wgpu_adapter().limits()
        };
        let (device, queue) = host_device(&adapter, limits);
        let m = sample_file(130, 3, radiosity_core::Format::Bc1, 8192).matrix;
        let options = GpuOptions {
            path: DecodePath::Software,
            max_binding_bytes: Some(cap),
            ..GpuOptions::default()
        };
        let x = exitance(130, 9);
        let mut want = vec![Rgb::ZERO; 130];
        let mut own = WgpuGather::on_adapter(&m, &adapter, &options).unwrap();
        own.gather(&x, &mut want).unwrap();
        let host_options = GpuOptions {
            max_binding_bytes: None,
            ..options
        };
        let (got, g) = host_frame(&device, &queue, &m, &host_options, &x);
        assert!(g.dispatches() > 2, "{} dispatches", g.dispatches());
        assert_eq!(g.dispatches(), own.dispatches());
        assert_eq!(bits(&got), bits(&want), "{}", adapter.info);
    }
}

/// A device of WebGPU's downlevel limits has 4 storage buffers per stage: the gather says
/// so. A device without BC compression refuses the hardware path by name.
#[test]
fn host_gather_names_what_the_device_lacks() {
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let m = sample_file(37, 3, radiosity_core::Format::Bc1, 16).matrix;
        let (device, queue) = host_device(&adapter, wgpu::Limits::downlevel_defaults());
        let (x, y) = gather_buffers(&device, 37);
        let buffers = HostGatherBuffers { x: &x, y: &y };
        match HostGather::new(&device, &queue, &m, &GpuOptions::default(), buffers) {
            Err(GpuError::Unsupported(why)) => assert_eq!(
                why,
                "the device's max_storage_buffers_per_shader_stage is 4, the gather needs 6"
            ),
            other => panic!("{other:?}"),
        }
        // Devices are made without optional features here.
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        let (x, y) = gather_buffers(&device, 37);
        let options = GpuOptions {
            path: DecodePath::HardwareBc,
            ..GpuOptions::default()
        };
        let buffers = HostGatherBuffers { x: &x, y: &y };
        match HostGather::new(&device, &queue, &m, &options, buffers) {
            Err(GpuError::Unsupported(why)) => {
                assert!(why.contains("TEXTURE_COMPRESSION_BC"), "{why}")
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn wrong_host_buffers_are_errors_not_panics() {
    use wgpu::BufferUsages as U;
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        let file = sample_file(37, 3, radiosity_core::Format::Bc1, 16);
        let m = &file.matrix;
        let (x, y) = gather_buffers(&device, 37);
        let short = buffer(&device, 12 * 36, U::STORAGE | U::COPY_SRC);
        let no_copy = buffer(&device, 12 * 37, U::STORAGE);
        let no_storage = buffer(&device, 12 * 37, U::COPY_SRC | U::VERTEX);
        let o = GpuOptions::default();
        let cases = [
            (
                &short,
                &y,
                "the host's x buffer has 432 bytes, the gather needs 444",
            ),
            (
                &no_copy,
                &y,
                "the host's x buffer lacks usage BufferUsages(COPY_SRC)",
            ),
            (
                &x,
                &short,
                "the host's y buffer has 432 bytes, the gather needs 444",
            ),
            (
                &x,
                &no_storage,
                "the host's y buffer lacks usage BufferUsages(STORAGE)",
            ),
        ];
        for (xb, yb, want) in cases {
            match HostGather::new(&device, &queue, m, &o, HostGatherBuffers { x: xb, y: yb }) {
                Err(GpuError::Unsupported(why)) => assert!(why.starts_with(want), "{why}"),
                other => panic!("{want}: {other:?}"),
            }
        }
        let mesh = file.mesh.as_ref().unwrap();
        let out = buffer(&device, 12 * 6, U::STORAGE | U::VERTEX);
        let small_out = buffer(&device, 12 * 5, U::STORAGE | U::VERTEX);
        let cases = [
            (
                &y,
                &small_out,
                "the host's out buffer has 60 bytes, the corner pass needs 72",
            ),
            (
                &no_storage,
                &out,
                "the host's y buffer lacks usage BufferUsages(STORAGE)",
            ),
            (
                &x,
                &out,
                "the host's y buffer lacks usage BufferUsages(STORAGE)",
            ),
        ];
        for (yb, ob, want) in cases {
            match CornerPass::new(&device, mesh, CornerBuffers { y: yb, out: ob }) {
                Err(GpuError::Unsupported(why)) => assert!(why.starts_with(want), "{why}"),
                other => panic!("{want}: {other:?}"),
            }
        }
        let mut bad = mesh.clone();
        bad.corner_weights.to_mut()[0].patch = 37;
        match CornerPass::new(&device, &bad, CornerBuffers { y: &y, out: &out }) {
            Err(GpuError::Unsupported(why)) => {
                assert_eq!(why, "a corner weight names patch 37 of 37")
            }
            other => panic!("{other:?}"),
        }
    }
}

/// A mesh over `patches` patches of `triangles` triangles whose corner rows hold 0 to 9
/// weights on random patches (weights of a row summing to about 1).
fn random_mesh(patches: usize, triangles: usize, seed: u64) -> Mesh<'static> {
    let mut rng = SplitMix64(seed);
    let mut rows = vec![0u32];
    let mut weights = Vec::new();
    for _ in 0..3 * triangles {
        let k = (rng.next_f32() * 10.0) as usize;
        for _ in 0..k {
            weights.push(CornerWeight {
                patch: ((rng.next_f32() * patches as f32) as u32).min(patches as u32 - 1),
                weight: rng.next_f32() / k as f32,
            });
        }
        rows.push(weights.len() as u32);
    }
    Mesh {
        positions: Cow::Owned(vec![[0.0; 3]; 3]),
        triangles: Cow::Owned(vec![
            MeshTriangle {
                vertices: [0, 1, 2],
                ..MeshTriangle::default()
            };
            triangles
        ]),
        corner_rows: Cow::Owned(rows),
        corner_weights: Cow::Owned(weights),
        sample_rows: Cow::Owned(vec![0; patches + 1]),
        samples: Cow::Owned(Vec::new()),
    }
}

/// The GPU corner values against the core's, under the bound of the module docs; bit for
/// bit on Mesa's software driver.
fn assert_corners_match(adapter: &Adapter, mesh: &Mesh<'_>, y: &[Rgb], got: &[Rgb]) {
    let mut want = vec![Rgb::ZERO; mesh.corner_count()];
    mesh.corner_indirect(y, &mut want).unwrap();
    assert_eq!(got.len(), want.len());
    for (r, (g, w)) in got.iter().zip(&want).enumerate() {
        let row = mesh.corner(r / 3, r % 3);
        let k = row.len() as f32;
        for ch in 0..3 {
            let abs: f32 = row
                .iter()
                .map(|e| (y[e.patch as usize].to_array()[ch] * e.weight).abs())
                .sum();
            let tol = 2.0 * (k + 1.0) * f32::EPSILON * abs + k * f32::MIN_POSITIVE;
            let (g, w) = (g.to_array()[ch], w.to_array()[ch]);
            if adapter.info.is_mesa_software() {
                assert_eq!(
                    g.to_bits(),
                    w.to_bits(),
                    "corner {r} ch {ch}: {g} against {w}"
                );
            }
            assert!(
                (g - w).abs() <= tol,
                "corner {r} ch {ch} on {}: gpu {g} core {w} tolerance {tol:e}",
                adapter.info
            );
        }
    }
}

#[test]
fn corner_pass_equals_the_cores_corner_indirect() {
    use wgpu::BufferUsages as U;
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        // 5000 triangles: 15 000 corners, 235 workgroups, rows from empty to 9 weights.
        for (patches, triangles) in [(1, 1), (300, 5000)] {
            let mesh = random_mesh(patches, triangles, patches as u64);
            let y = exitance(patches, 4);
            let yb = buffer(&device, 12 * patches as u64, U::STORAGE | U::COPY_DST);
            queue.write_buffer(&yb, 0, bytemuck::cast_slice(&y));
            let corners = mesh.corner_count();
            let out = buffer(
                &device,
                12 * corners as u64,
                U::STORAGE | U::COPY_SRC | U::VERTEX,
            );
            let pass = CornerPass::new(&device, &mesh, CornerBuffers { y: &yb, out: &out })
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(pass.corners(), corners);
            let mut e = encoder(&device);
            pass.record(&mut e);
            let got = submit_and_read(&device, &queue, e, &out, corners);
            assert_corners_match(&adapter, &mesh, &y, &got);
        }
    }
}

/// The whole frame on the host's device, as an engine records it: `x` uploaded, the gather and
/// the corner pass in one encoder, one submission. The corners equal the core's corner light
/// of the `y` the same frame wrote.
#[test]
fn gather_then_corner_pass_in_one_encoder() {
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        let n = 70;
        let file = sample_file(n, 3, radiosity_core::Format::Bc1, 32);
        let mesh = file.mesh.as_ref().unwrap();
        let (xb, yb) = gather_buffers(&device, n);
        let out = buffer(
            &device,
            12 * mesh.corner_count() as u64,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        );
        let options = GpuOptions::default();
        let buffers = HostGatherBuffers { x: &xb, y: &yb };
        let gather = HostGather::new(&device, &queue, &file.matrix, &options, buffers).unwrap();
        let corners = CornerPass::new(&device, mesh, CornerBuffers { y: &yb, out: &out }).unwrap();
        let x = exitance(n, 11);
        queue.write_buffer(&xb, 0, bytemuck::cast_slice(&x));
        let mut e = encoder(&device);
        gather.record(&mut e);
        corners.record(&mut e);
        let got = submit_and_read(&device, &queue, e, &out, mesh.corner_count());
        let y = submit_and_read(&device, &queue, encoder(&device), &yb, n);
        // y is the gather's: the own-device gather's bits.
        let mut want = vec![Rgb::ZERO; n];
        let mut own = WgpuGather::on_adapter(&file.matrix, &adapter, &options).unwrap();
        own.gather(&x, &mut want).unwrap();
        assert_eq!(bits(&y), bits(&want));
        assert!(y.iter().any(|v| v.to_array()[0] > 0.0));
        assert_corners_match(&adapter, mesh, &y, &got);
    }
}

/// `count` probes over `n` patches, each row a random ascending subset (empty to all of
/// them, so rows both shorter and longer than a workgroup), weights of either sign.
fn random_probes(n: usize, count: usize, seed: u64) -> Probes<'static> {
    let mut rng = SplitMix64(seed);
    let (mut rows, mut weights, mut positions) = (vec![0u32], Vec::new(), Vec::new());
    for p in 0..count {
        let keep = rng.next_f64();
        for patch in 0..n as u32 {
            if rng.next_f64() < keep {
                let sh = [0; SH_COEFFICIENTS].map(|_| (rng.next_f64() - 0.4) as f32);
                weights.push(ProbeWeight::new(patch, sh));
            }
        }
        rows.push(weights.len() as u32);
        positions.push([p as f32, 0.5, 0.5]);
    }
    Probes {
        spacing: 1.0,
        positions: Cow::Owned(positions),
        rows: Cow::Owned(rows),
        weights: Cow::Owned(weights),
        factors: None,
    }
}

fn abs(v: Rgb) -> Rgb {
    Rgb::from_array(v.to_array().map(f32::abs))
}

/// The pass's coefficient `c` of probe `p`, channel `ch`, within `tol` of the core's.
fn assert_coefficient(
    got: &[Rgb],
    want: &[[Rgb; SH_COEFFICIENTS]],
    (p, c, ch): (usize, usize, usize),
    tol: f32,
) {
    let (g, w) = (
        got[SH_COEFFICIENTS * p + c].channel(ch),
        want[p][c].channel(ch),
    );
    assert!(
        (g - w).abs() <= tol,
        "probe {p} coefficient {c} channel {ch}: gpu {g} core {w} tolerance {tol:e}"
    );
}

/// The core's probe SH from `x` and `y` (`Probes::gather` on `x − E + ρ∘y`) against the
/// pass's `got`, within the bound of the module docs.
fn assert_probes_match(probes: &Probes<'_>, patches: &[Patch], x: &[Rgb], y: &[Rgb], got: &[Rgb]) {
    let reflected: Vec<Rgb> = (0..patches.len())
        .map(|j| x[j] + patches[j].emission * -1.0 + patches[j].reflectance * y[j])
        .collect();
    let scale: Vec<Rgb> = (0..patches.len())
        .map(|j| abs(x[j]) + abs(patches[j].emission) + abs(patches[j].reflectance * y[j]))
        .collect();
    let mut want = vec![[Rgb::ZERO; SH_COEFFICIENTS]; probes.len()];
    probes.gather(&reflected, &mut want);
    assert_eq!(got.len(), SH_COEFFICIENTS * probes.len());
    let gamma = |k: usize| k as f32 * f32::EPSILON / 2.0 / (1.0 - k as f32 * f32::EPSILON / 2.0);
    for p in 0..probes.len() {
        let row = probes.weights_of(p);
        for c in 0..SH_COEFFICIENTS {
            for ch in 0..3 {
                let abs: f32 = row
                    .iter()
                    .map(|w| (scale[w.patch as usize].channel(ch) * w.sh()[c]).abs())
                    .sum();
                // A shader may flush a binary16 subnormal weight (under 2⁻¹⁴) to zero.
                let flushed: f32 = row
                    .iter()
                    .filter(|w| w.sh()[c].abs() < 2f32.powi(-14))
                    .map(|w| (scale[w.patch as usize].channel(ch) * w.sh()[c]).abs())
                    .sum();
                let tol = 2.0 * (gamma(row.len()) + gamma(3)) * abs
                    + flushed
                    + row.len() as f32 * f32::MIN_POSITIVE;
                assert_coefficient(got, &want, (p, c, ch), tol);
            }
        }
    }
}

/// A host gather and a probe pass between fresh host buffers, as an engine sets them up.
struct ProbeFrame {
    xb: wgpu::Buffer,
    yb: wgpu::Buffer,
    out: wgpu::Buffer,
    gather: HostGather,
    pass: ProbePass,
}

impl ProbeFrame {
    /// One frame from first exitance `x`: the gather, then the probe pass, in one encoder;
    /// the probes' SH and the gather's `y`. The SH are not all zero.
    fn run(&self, device: &wgpu::Device, queue: &wgpu::Queue, x: &[Rgb]) -> (Vec<Rgb>, Vec<Rgb>) {
        queue.write_buffer(&self.xb, 0, bytemuck::cast_slice(x));
        let mut e = encoder(device);
        self.gather.record(&mut e);
        self.pass.record(&mut e);
        let count = SH_COEFFICIENTS * self.pass.probes();
        let got = submit_and_read(device, queue, e, &self.out, count);
        let y = submit_and_read(device, queue, encoder(device), &self.yb, x.len());
        assert!(got.iter().any(|v| v.r != 0.0));
        (got, y)
    }
}

fn probe_frame(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    matrix: &TransferMatrix<'_>,
    probes: &Probes<'_>,
    patches: &[Patch],
) -> ProbeFrame {
    use wgpu::BufferUsages as U;
    let (n, count) = (patches.len() as u64, probes.len() as u64);
    let xb = buffer(device, 12 * n, U::COPY_DST | U::COPY_SRC | U::STORAGE);
    let yb = buffer(device, 12 * n, U::STORAGE | U::COPY_SRC);
    let out = buffer(device, PROBE_OUT_BYTES * count, U::STORAGE | U::COPY_SRC);
    let buffers = HostGatherBuffers { x: &xb, y: &yb };
    let gather = HostGather::new(device, queue, matrix, &GpuOptions::default(), buffers).unwrap();
    let pass_buffers = ProbeBuffers {
        x: &xb,
        y: &yb,
        out: &out,
    };
    let pass =
        ProbePass::new(device, probes, patches, pass_buffers).unwrap_or_else(|e| panic!("{e}"));
    ProbeFrame {
        xb,
        yb,
        out,
        gather,
        pass,
    }
}

/// The whole frame with probes, as an engine records it: the gather, then the probe pass
/// reading that frame's `x` and `y`, in one encoder; then the emission changed at run time.
#[test]
fn gather_then_probe_pass_in_one_encoder() {
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        // 300 patches: rows up to 300 weights (about five a thread); 3 probes and 600, the
        // latter one workgroup each.
        for (n, count) in [(70, 3), (300, 600)] {
            let file = sample_file(n, 3, radiosity_core::Format::Bc1, 32);
            let mut patches = file.patches.to_vec();
            for (j, p) in patches.iter_mut().enumerate() {
                if j % 7 == 0 {
                    p.emission = Rgb::new(3.0, 2.0, 1.0);
                }
            }
            let probes = random_probes(n, count, n as u64);
            let frame = probe_frame(&device, &queue, &file.matrix, &probes, &patches);
            let (out, pass) = (&frame.out, &frame.pass);
            assert_eq!(pass.probes(), count);
            let x = exitance(n, 5);
            let (got, y) = frame.run(&device, &queue, &x);
            assert_probes_match(&probes, &patches, &x, &y, &got);
            // The emitters turned off: the pass now subtracts nothing.
            for p in &mut patches {
                p.emission = Rgb::ZERO;
            }
            let emission = vec![Rgb::ZERO; n];
            pass.set_emission(&queue, &emission).unwrap();
            let mut e = encoder(&device);
            pass.record(&mut e);
            let got = submit_and_read(&device, &queue, e, out, SH_COEFFICIENTS * count);
            assert_probes_match(&probes, &patches, &x, &y, &got);
            assert!(pass.set_emission(&queue, &emission[1..]).is_err());
        }
    }
}

/// `count` probes over `n` patches as random factors of rank `k`, no factor under 10⁻³ in
/// size (so no shader flushes a binary16 subnormal).
fn random_factored_probes(n: usize, count: usize, k: usize, seed: u64) -> Probes<'static> {
    let mut rng = SplitMix64(seed);
    let mut half = || {
        let v = (rng.next_f64() - 0.4) as f32;
        radiosity_core::half::f32_to_f16(if v.abs() < 1e-3 { 1e-3 } else { v })
    };
    let basis: Vec<u16> = (0..k * n).map(|_| half()).collect();
    let coefficients: Vec<u16> = (0..SH_COEFFICIENTS * count * k).map(|_| half()).collect();
    Probes {
        spacing: 1.0,
        positions: Cow::Owned((0..count).map(|p| [p as f32, 0.5, 0.5]).collect()),
        rows: Cow::Owned(vec![0; count + 1]),
        weights: Cow::Owned(Vec::new()),
        factors: Some(ProbeFactors {
            rank: k as u32,
            basis: Cow::Owned(basis),
            coefficients: Cow::Owned(coefficients),
        }),
    }
}

/// Factored probes: the pass's two dispatches (modes, then probes) against the core's
/// `DecodedProbes::gather` on the same frame.
#[test]
fn factored_probes_pass_equals_the_cores_product() {
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        // Ranks under and over a workgroup's 64 invocations, an odd count of halves.
        for (n, count, k) in [(70, 3, 5), (301, 200, 100)] {
            let file = sample_file(n, 3, radiosity_core::Format::Bc1, 32);
            let mut patches = file.patches.to_vec();
            for (j, p) in patches.iter_mut().enumerate() {
                if j % 5 == 0 {
                    p.emission = Rgb::new(1.0, 2.0, 3.0);
                }
            }
            let probes = random_factored_probes(n, count, k, n as u64);
            probes.validate(n).unwrap();
            let frame = probe_frame(&device, &queue, &file.matrix, &probes, &patches);
            let x = exitance(n, 9);
            let (got, y) = frame.run(&device, &queue, &x);
            let reflected: Vec<Rgb> = (0..n)
                .map(|j| x[j] + patches[j].emission * -1.0 + patches[j].reflectance * y[j])
                .collect();
            let decoded = DecodedProbes::new(&probes);
            let mut want = vec![[Rgb::ZERO; SH_COEFFICIENTS]; count];
            decoded.gather(&reflected, &mut want);
            // Both sum the same f32 products in different orders: each mode's n terms, then
            // each coefficient's k. The bound: (γ_n + γ_k + γ_3)·Σ_q |C_q|·Σ_j |V_qj|·|r_j|
            // (|r_j| of each of its three terms), twice for the two orders.
            let gamma = |m: usize| m as f32 * f32::EPSILON / (1.0 - m as f32 * f32::EPSILON);
            let f = probes.factors.as_ref().unwrap();
            let h = radiosity_core::half::f16_to_f32;
            for ch in 0..3 {
                let mode_abs: Vec<f32> = (0..k)
                    .map(|q| {
                        (0..n)
                            .map(|j| {
                                let r = x[j].channel(ch).abs()
                                    + patches[j].emission.channel(ch).abs()
                                    + (patches[j].reflectance * y[j]).channel(ch).abs();
                                h(f.basis[q * n + j]).abs() * r
                            })
                            .sum()
                    })
                    .collect();
                for p in 0..count {
                    for c in 0..SH_COEFFICIENTS {
                        let row = &f.coefficients[(p * SH_COEFFICIENTS + c) * k..][..k];
                        let abs: f32 = row
                            .iter()
                            .zip(&mode_abs)
                            .map(|(&w, m)| h(w).abs() * m)
                            .sum();
                        let tol = 2.0 * (gamma(n) + gamma(k) + gamma(3)) * abs + 1e-30;
                        assert_coefficient(&got, &want, (p, c, ch), tol);
                    }
                }
            }
        }
    }
}

#[test]
fn wrong_probe_pass_input_is_an_error_not_a_panic() {
    use wgpu::BufferUsages as U;
    let _one = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
    for adapter in gpu_adapters() {
        let (device, _queue) = host_device(&adapter, adapter.wgpu_adapter().limits());
        let n = 10;
        let patches = sample_file(n, 3, radiosity_core::Format::F32, 32)
            .patches
            .to_vec();
        let probes = random_probes(n, 4, 1);
        let good = buffer(&device, 12 * n as u64, U::STORAGE);
        let out = buffer(&device, PROBE_OUT_BYTES * 4, U::STORAGE);
        let small = buffer(&device, PROBE_OUT_BYTES * 3, U::STORAGE);
        let unbound = buffer(&device, 12 * n as u64, U::COPY_SRC);
        for (what, buffers, needle) in [
            (
                "small out",
                ProbeBuffers {
                    x: &good,
                    y: &good,
                    out: &small,
                },
                "out buffer has",
            ),
            (
                "x usage",
                ProbeBuffers {
                    x: &unbound,
                    y: &good,
                    out: &out,
                },
                "lacks usage",
            ),
        ] {
            match ProbePass::new(&device, &probes, &patches, buffers) {
                Err(GpuError::Unsupported(m)) => assert!(m.contains(needle), "{what}: {m}"),
                other => panic!("{what}: {other:?}"),
            }
        }
        // Probes of more patches than the file has.
        let wide = random_probes(n + 5, 4, 2);
        let buffers = ProbeBuffers {
            x: &good,
            y: &good,
            out: &out,
        };
        match ProbePass::new(&device, &wide, &patches, buffers) {
            Err(GpuError::Unsupported(m)) => assert!(m.contains("do not fit"), "{m}"),
            other => panic!("{other:?}"),
        }
    }
}
