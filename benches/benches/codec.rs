//! Codec throughput: the reference BC decoders, the encoders, and the reference gather.
//! Deterministic inputs (SplitMix64, fixed seeds); run with `cargo bench -p radiosity-benches --bench codec`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use radiosity_bake::encode::{
    Bc1Fit, EncodeParams, encode_bc1_block, encode_bc4_block, encode_dense,
};
use radiosity_core::{
    DecodeMode, Format, Gather, ReferenceGather, Rgb, decode_bc1_block, decode_bc4_block,
};
use radiosity_tests::fixtures::{SplitMix64, transfer_like_matrix};
use std::hint::black_box;

fn random_blocks(count: usize) -> Vec<[u8; 8]> {
    let mut rng = SplitMix64(42);
    (0..count).map(|_| rng.next_bytes()).collect()
}

fn decode(c: &mut Criterion) {
    let blocks = random_blocks(1 << 14);
    let mut g = c.benchmark_group("decode");
    g.throughput(Throughput::Elements(blocks.len() as u64));
    g.bench_function("bc1_reference", |b| {
        b.iter(|| {
            blocks
                .iter()
                .map(|x| decode_bc1_block(black_box(x))[5][1] as u32)
                .sum::<u32>()
        })
    });
    g.bench_function("bc4_reference", |b| {
        b.iter(|| {
            blocks
                .iter()
                .map(|x| decode_bc4_block(black_box(x))[5] as u32)
                .sum::<u32>()
        })
    });
    g.finish();
}

fn encode(c: &mut Criterion) {
    let mut rng = SplitMix64(7);
    let codes: Vec<[[u8; 3]; 16]> = (0..1024)
        .map(|_| {
            let base = (rng.next_u64() % 200) as u8;
            core::array::from_fn(|_| {
                let v = base + (rng.next_u64() % 40) as u8;
                [v, v.saturating_sub(3), v / 2]
            })
        })
        .collect();
    let mut g = c.benchmark_group("encode_block");
    g.throughput(Throughput::Elements(codes.len() as u64));
    g.bench_function("bc1_cluster_fit", |b| {
        b.iter(|| {
            codes
                .iter()
                .map(|c| encode_bc1_block(black_box(c), 0xffff, Bc1Fit::Cluster).0[0] as u32)
                .sum::<u32>()
        })
    });
    g.bench_function("bc1_range_fit", |b| {
        b.iter(|| {
            codes
                .iter()
                .map(|c| encode_bc1_block(black_box(c), 0xffff, Bc1Fit::Range).0[0] as u32)
                .sum::<u32>()
        })
    });
    g.bench_function("bc4_best_of_three", |b| {
        b.iter(|| {
            codes
                .iter()
                .map(|c| {
                    encode_bc4_block(black_box(&core::array::from_fn(|i| c[i][0])), 0xffff)[0]
                        as u32
                })
                .sum::<u32>()
        })
    });
    g.finish();
}

fn reference_gather(c: &mut Criterion) {
    let n = 512;
    let dense = transfer_like_matrix(n, 3, 1);
    let mut g = c.benchmark_group("reference_gather_512");
    g.throughput(Throughput::Elements((n * n) as u64));
    for format in [Format::Bc1, Format::Bc4, Format::U8, Format::F32] {
        let m = encode_dense(n, 3, &dense, &EncodeParams::for_format(format)).unwrap();
        let mut gather = ReferenceGather::new(m, DecodeMode::D3d10);
        let x = vec![Rgb::ONE; n];
        let mut y = vec![Rgb::ZERO; n];
        g.bench_function(format.name(), |b| {
            b.iter(|| gather.gather(black_box(&x), &mut y).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, decode, encode, reference_gather);
criterion_main!(benches);
