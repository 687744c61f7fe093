//! The CPU cost of one frame on the host-device path at n = 4096 (BC1): the bind groups are
//! built once ([`HostGather::new`], [`CornerPass::new`]), then each frame only records the
//! gather (a copy and one compute pass of its dispatches) and the corner pass into the host's
//! encoder. Measured: `record` alone, and `record` of both into a fresh encoder and its
//! `finish` (what a host adds to its frame). Nothing is submitted: the cost is the CPU's.
//!
//! It needs a wgpu adapter (lavapipe will do); without one it prints why and measures
//! nothing.
//!
//! Run: `cargo bench -p radiosity-benches --bench host_record`.

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use radiosity_backend_wgpu::{
    CornerBuffers, CornerPass, GpuOptions, HostGather, HostGatherBuffers, adapters,
};
use radiosity_bake::encode::{EncodeParams, encode_dense};
use radiosity_core::{CornerWeight, Format, Mesh, MeshTriangle};
use radiosity_tests::fixtures::transfer_like_matrix;
use std::borrow::Cow;

const N: usize = 4096;

/// Two triangles per patch, each corner interpolating four patches.
fn mesh(n: usize) -> Mesh<'static> {
    let corners = 6 * n;
    let weights: Vec<CornerWeight> = (0..corners)
        .flat_map(|c| {
            (0..4).map(move |k| CornerWeight {
                patch: ((c / 6 + k) % n) as u32,
                weight: 0.25,
            })
        })
        .collect();
    Mesh {
        positions: Cow::Owned(vec![[0.0; 3]; 3]),
        triangles: Cow::Owned(vec![
            MeshTriangle {
                vertices: [0, 1, 2],
                ..MeshTriangle::default()
            };
            2 * n
        ]),
        corner_rows: Cow::Owned((0..=corners as u32).map(|c| 4 * c).collect()),
        corner_weights: Cow::Owned(weights),
        sample_rows: Cow::Owned(vec![0; n + 1]),
        samples: Cow::Owned(Vec::new()),
    }
}

fn bench(c: &mut Criterion) {
    let list = adapters();
    let Some(adapter) = list
        .iter()
        .find(|a| a.info.backend != "gl")
        .or(list.first())
    else {
        eprintln!(
            "host_record bench: no GPU adapter (install mesa-vulkan-drivers libvulkan1): skipped"
        );
        return;
    };
    let matrix = encode_dense(
        N,
        3,
        &transfer_like_matrix(N, 3, 11),
        &EncodeParams::for_format(Format::Bc1),
    )
    .unwrap();
    let (device, queue) = pollster::block_on(adapter.wgpu_adapter().request_device(
        &wgpu::DeviceDescriptor {
            label: Some("host"),
            required_limits: adapter.wgpu_adapter().limits(),
            ..Default::default()
        },
    ))
    .unwrap();
    let buffer = |bytes: usize, usage| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: bytes as u64,
            usage,
            mapped_at_creation: false,
        })
    };
    use wgpu::BufferUsages as U;
    let mesh = mesh(N);
    let x = buffer(12 * N, U::COPY_DST | U::COPY_SRC);
    let y = buffer(12 * N, U::STORAGE);
    let out = buffer(12 * mesh.corner_count(), U::STORAGE | U::VERTEX);
    let gather = HostGather::new(
        &device,
        &queue,
        &matrix,
        &GpuOptions::default(),
        HostGatherBuffers { x: &x, y: &y },
    )
    .unwrap();
    let corners = CornerPass::new(&device, &mesh, CornerBuffers { y: &y, out: &out }).unwrap();
    eprintln!(
        "host_record bench on {}: n = {N} bc1, {} dispatches, {} corners",
        adapter.info,
        gather.dispatches(),
        corners.corners()
    );
    let encoder = || device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
    let mut g = c.benchmark_group("host_record_4096");
    g.bench_function("gather_record", |b| {
        b.iter_batched_ref(encoder, |e| gather.record(e), BatchSize::SmallInput)
    });
    g.bench_function("gather_and_corners_record", |b| {
        b.iter_batched_ref(
            encoder,
            |e| {
                gather.record(e);
                corners.record(e);
            },
            BatchSize::SmallInput,
        )
    });
    g.bench_function("encoder_record_finish", |b| {
        b.iter(|| {
            let mut e = encoder();
            gather.record(&mut e);
            corners.record(&mut e);
            e.finish()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
