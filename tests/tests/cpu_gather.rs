//! The SIMD CPU gather against the reference gather (D3D10 decoding), for every format,
//! channel count, tile size and SIMD path this CPU has, serial and parallel.
//!
//! Tolerance. The decoded entries are bit-identical (same palette rules, same tables), so the
//! only difference is summation: the reference accumulates in f64 in a fixed order (error below
//! f32 resolution once rounded), the CPU gather in f32 — one rounding per product, eight-lane
//! partial sums over the ≤ n/4 column blocks, a 4-term lane reduction, then each sparse
//! correction in turn. Every partial sum is a sum of at most k = n + 8 rounded terms, so the
//! classical bound for recursive summation gives |Δ| ≤ γ_k · Σ|terms| with γ_k ≈ k·ε. The terms
//! are the block products and the sparse corrections *separately* (a correction may cancel
//! most of its block value, so Σ|m_ij x_j| over the combined matrix could undercount): we take
//! S = Σ_j (|b_ij| + |s_ij|)·|x_j| with `b` the blocks alone (`decode_dense` of the matrix with
//! the sparse list emptied) and `s` the sparse values, and allow |Δ| ≤ C·(n + 8)·ε·S with
//! C = 2 (one more for the final f64 → f32 rounding of the reference and the product rounding),
//! plus `f32::MIN_POSITIVE` for rows whose sum is exactly zero.

use radiosity_backend_cpu::{CpuGather, SimdPath};
use radiosity_core::{
    DecodeMode, Format, Gather, GatherError, ReferenceGather, Rgb, SparseRows, TransferMatrix,
};
use radiosity_tests::fixtures::{exitance, sample_file};

/// Safety factor over the recursive-summation bound (see the module docs).
const C: f32 = 2.0;

/// Every storable (format, channels) pair.
const CASES: [(Format, usize); 9] = radiosity_tests::fixtures::FORMAT_CASES;

fn paths() -> Vec<SimdPath> {
    SimdPath::ALL
        .into_iter()
        .filter(|p| p.is_available())
        .collect()
}

/// Per row and channel, Σ_j (|b_ij| + |s_ij|)·|x_j| (see the module docs).
fn abs_sums(m: &TransferMatrix<'_>, x: &[Rgb]) -> Vec<[f32; 3]> {
    let l = m.layout;
    let (n, ch) = (l.n(), l.channels());
    let mut blocks_only = m.clone();
    blocks_only.sparse = SparseRows::empty(n);
    let b = blocks_only.decode_dense(DecodeMode::D3d10);
    let with_sparse = m.decode_dense(DecodeMode::D3d10);
    (0..n)
        .map(|r| {
            let mut s = [0f64; 3];
            for c in 0..n {
                let xc = x[c].to_array();
                for k in 0..3 {
                    let i = (r * n + c) * ch + if ch == 1 { 0 } else { k };
                    let sparse = f64::from(with_sparse[i]) - f64::from(b[i]);
                    s[k] += (f64::from(b[i]).abs() + sparse.abs()) * f64::from(xc[k]).abs();
                }
            }
            s.map(|v| v as f32)
        })
        .collect()
}

/// The one test body: every path, serial and parallel, against the reference.
fn check_against_reference(n: usize, format: Format, channels: usize, max_tile: u32) {
    let file = sample_file(n, channels, format, max_tile);
    let m = file.matrix;
    let x = exitance(n, n as u64 + max_tile as u64);
    let mut want = vec![Rgb::ZERO; n];
    ReferenceGather::new(m.clone(), DecodeMode::D3d10)
        .gather(&x, &mut want)
        .unwrap();
    let sums = abs_sums(&m, &x);
    for path in paths() {
        for parallel in [false, true] {
            let mut g = CpuGather::with_path(m.clone(), path).unwrap();
            g.set_parallel(parallel);
            assert_eq!(g.patches(), n);
            assert_eq!(g.name(), format!("cpu-{}", format.name()));
            let mut got = vec![Rgb::splat(f32::NAN); n];
            g.gather(&x, &mut got).unwrap();
            for r in 0..n {
                let (w, gv) = (want[r].to_array(), got[r].to_array());
                for k in 0..3 {
                    let tol = C * (n as f32 + 8.0) * f32::EPSILON * sums[r][k] + f32::MIN_POSITIVE;
                    let diff = (w[k] - gv[k]).abs();
                    assert!(
                        diff <= tol,
                        "{format} ×{channels} n={n} tile={max_tile} path={} parallel={parallel} \
                         row {r} ch {k}: reference {} cpu {} diff {diff:e} tolerance {tol:e}",
                        g.path(),
                        w[k],
                        gv[k]
                    );
                }
            }
        }
    }
}

#[test]
fn every_format_matches_the_reference() {
    for (format, channels) in CASES {
        for (n, max_tile) in [
            (1, 8),
            (1, 8192),
            (5, 8),
            (37, 8),
            (37, 16),
            (37, 8192),
            (64, 16),
            (70, 32),
        ] {
            check_against_reference(n, format, channels, max_tile);
        }
    }
}

#[test]
fn larger_matrix_several_tiles() {
    for (format, channels) in [(Format::Bc1, 3), (Format::Bc4, 1), (Format::U8, 3)] {
        check_against_reference(203, format, channels, 64);
    }
}

/// A tile of ≥ 65536 blocks: BC1 goes through the per-tile palette tables instead of
/// per-block palettes. n = 1030: one 1032² tile, partial last block row and column (258 block
/// columns: on the AVX-512 path two runs of 128 blocks and a run of 2, which has no full
/// group of 16); n = 1097: 275 block columns, a last run of 19 (one group of 16 keyed in
/// vector registers, 3 keyed one by one, an odd block after the pairs; on the AVX2 path two
/// groups of 8 and 3 one by one).
///
/// With `max_tile` 1024, n = 1030 has a 1024² tile with tables beside 6-wide tiles without:
/// both kinds in one block row.
#[test]
fn large_tile_bc1_palette_tables() {
    check_against_reference(1030, Format::Bc1, 3, 8192);
    check_against_reference(1097, Format::Bc1, 3, 8192);
    check_against_reference(1030, Format::Bc1, 3, 1024);
}

#[test]
fn bad_arguments_give_the_reference_errors() {
    let m = sample_file(9, 3, Format::Bc4, 8).matrix;
    radiosity_tests::fixtures::assert_argument_errors_match_reference(
        &mut CpuGather::new(m.clone()),
        &m,
    );
}

#[test]
fn repeated_gathers_reuse_buffers() {
    let n = 37;
    let m = sample_file(n, 3, Format::Bc1, 16).matrix;
    let mut g = CpuGather::new(m);
    let ptr = g.scratch_ptr();
    let mut y = vec![Rgb::ZERO; n];
    let mut first = None;
    for seed in [1, 2, 1] {
        g.gather(&exitance(n, seed), &mut y).unwrap();
        assert_eq!(g.scratch_ptr(), ptr, "the exitance buffer was reallocated");
        if seed == 1 {
            match &first {
                None => first = Some(y.clone()),
                Some(f) => assert_eq!(f, &y, "same input, same output"),
            }
        }
    }
}

#[test]
fn unavailable_path_is_an_error_not_a_fallback() {
    let m = sample_file(4, 1, Format::U8, 8).matrix;
    let r = CpuGather::with_path(m, SimdPath::Avx2Fma);
    match r {
        Ok(g) => assert_eq!(g.path(), "avx2+fma"),
        Err(e) => assert!(matches!(e, GatherError::Backend(_)), "{e}"),
    }
    let m = sample_file(4, 3, Format::Bc1, 8).matrix;
    match CpuGather::with_path(m, SimdPath::Avx512) {
        Ok(g) => assert_eq!(g.path(), "avx512"),
        Err(e) => assert!(e.to_string().contains("AVX-512F"), "{e}"),
    }
}
