//! What a reflectance edit costs a frame at n = 4096 (BC1, the SIMD CPU gather): the plain
//! gather against `EditedGather` (two gathers and a k × k solve per channel) for edits of
//! k = 64, 256 and 1024 patches, and what preparing each edit costs (`ReflectanceEdit::new`:
//! the decode of the edited rows and k³ factorisations). The matrix is seeded
//! (`transfer_like_matrix(4096, 3, 11)`): costs do not depend on its values.
//!
//! Run: `cargo bench -p radiosity-benches --bench material_edit`.

use criterion::{Criterion, criterion_group, criterion_main};
use radiosity_backend_cpu::CpuGather;
use radiosity_bake::encode::{EncodeParams, encode_dense};
use radiosity_core::{DecodeMode, EditedGather, Format, Gather, ReflectanceEdit, Rgb};
use radiosity_perf::timing::{median, ms};
use radiosity_tests::fixtures::{exitance, sample_patches, transfer_like_matrix};
use std::time::Instant;

const N: usize = 4096;

fn bench(c: &mut Criterion) {
    let matrix = encode_dense(
        N,
        3,
        &transfer_like_matrix(N, 3, 11),
        &EncodeParams::for_format(Format::Bc1),
    )
    .unwrap();
    let patches = sample_patches(N);
    let x = exitance(N, 3);
    let mut y = vec![Rgb::ZERO; N];
    let mut plain = CpuGather::new(matrix.clone());
    let t_plain = median(31, || plain.gather(&x, &mut y).unwrap());
    eprintln!(
        "material_edit bench: plain cpu-bc1 gather {:.3} ms",
        ms(t_plain)
    );
    let mut g = c.benchmark_group("material_edit_4096");
    g.bench_function("plain", |b| b.iter(|| plain.gather(&x, &mut y).unwrap()));
    for k in [64usize, 256, 1024] {
        // Every (N / k)-th patch: rows spread over the matrix, as an object's patches are
        // after the paper's reordering.
        let edits: Vec<(u32, Rgb)> = (0..k)
            .map(|a| ((a * (N / k)) as u32, Rgb::new(0.2, 0.4, 0.6)))
            .collect();
        let t = Instant::now();
        let edit = ReflectanceEdit::new(&matrix, DecodeMode::D3d10, &patches, &edits).unwrap();
        let setup = ms(t.elapsed());
        let bytes = edit.bytes();
        let mut edited = EditedGather::new(CpuGather::new(matrix.clone()), edit).unwrap();
        let t_edit = median(31, || edited.gather(&x, &mut y).unwrap());
        eprintln!(
            "  k = {k}: edited gather {:.3} ms ({:.2}× the plain one), setup {setup:.0} ms, {:.2} MB held",
            ms(t_edit),
            t_edit.as_secs_f64() / t_plain.as_secs_f64(),
            bytes as f64 / 1e6
        );
        g.bench_function(format!("edited_{k}"), |b| {
            b.iter(|| edited.gather(&x, &mut y).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
