//! The wgpu gather against the reference gather, for every format and channel count, both
//! decode paths, single and several bands, on every adapter found except GL ones, which get
//! one smoke test (`gl_adapter_smoke`): Mesa's GL compiler takes 2–30 s per kernel variant on
//! this project's 2-core machines where lavapipe (Vulkan) takes 0.1–1 s, and the kernels are
//! the same WGSL. A machine with GL adapters only runs the whole suite on them.
//!
//! With no adapter these tests print why and pass, except when `CI=true`: CI installs the
//! software Vulkan driver (scripts/test.sh), so a missing adapter there is a failure.
//!
//! Tolerances.
//! - **Decoding** is exact wherever the decode rules are known ([`WgpuGather::decode_model`]:
//!   the software path's mode, or [`DecodeMode::Mesa`] for the texture unit of Mesa's
//!   drivers): `exact_columns` gathers unit vectors with the sparse list removed and demands
//!   every decoded entry bit for bit. On other drivers' texture units D3D10 allows each palette
//!   entry to be off by one code in each interpolation (two for BC4's narrower steps, as the
//!   core measured for Mesa against D3D10), which moves a value by at most a factor
//!   `e^(2·s/255)`, so those entries get that relative slack on top of the summation bound.
//! - **Summation** is f32 on the GPU: each invocation sums its blocks' products, a tree of 64
//!   adds them, the column groups and then each sparse correction are added in turn. Every
//!   output is therefore a sum of at most k = n + (sparse entries in the row) + 8 rounded
//!   terms, and the recursive-summation bound |Δ| ≤ γ_k·Σ|terms| (γ_k ≈ k·ε) applies; as in
//!   the CPU test the terms are block and sparse products counted separately
//!   (S = Σ_j (|b_ij| + |s_ij|)·|x_j|) and a factor C = 2 covers the reference's final f64 →
//!   f32 rounding and the product roundings. GPUs may flush subnormal products to zero, so
//!   k·`f32::MIN_POSITIVE` is added.

mod gpu_support;

use gpu_support::gpu_adapters;
use radiosity_backend_wgpu::{
    Adapter, AdapterChoice, DecodePath, GpuError, GpuOptions, WgpuGather, adapters,
};
use radiosity_core::{
    DecodeMode, Format, Gather, ReferenceGather, Rgb, SparseRows, TransferMatrix,
};
use radiosity_tests::fixtures::{FORMAT_CASES, exitance, sample_file};

/// Safety factor over the recursive-summation bound (module docs).
const C: f32 = 2.0;

/// Per row and channel: (Σ_j |b_ij|·|x_j|, Σ_j |s_ij|·|x_j|), blocks and sparse apart.
fn abs_sums(m: &TransferMatrix<'_>, mode: DecodeMode, x: &[Rgb]) -> Vec<[(f32, f32); 3]> {
    let l = m.layout;
    let (n, ch) = (l.n(), l.channels());
    let mut blocks_only = m.clone();
    blocks_only.sparse = SparseRows::empty(n);
    let b = blocks_only.decode_dense(mode);
    let with_sparse = m.decode_dense(mode);
    (0..n)
        .map(|r| {
            let mut s = [(0f64, 0f64); 3];
            for c in 0..n {
                let xc = x[c].to_array();
                for k in 0..3 {
                    let i = (r * n + c) * ch + if ch == 1 { 0 } else { k };
                    let sparse = f64::from(with_sparse[i]) - f64::from(b[i]);
                    let xa = f64::from(xc[k]).abs();
                    s[k].0 += f64::from(b[i]).abs() * xa;
                    s[k].1 += sparse.abs() * xa;
                }
            }
            s.map(|(a, b)| (a as f32, b as f32))
        })
        .collect()
}

/// The largest log range of the matrix's scales (0 for float formats).
fn max_shift(m: &TransferMatrix<'_>) -> f32 {
    m.scales.iter().map(|s| s.shift).fold(0.0, f32::max)
}

/// One gather on `adapter` with `options` against the reference under the gather's decode
/// model (D3D10 with the palette slack when the model is unknown).
fn check(adapter: &Adapter, m: &TransferMatrix<'_>, options: &GpuOptions, seed: u64) -> WgpuGather {
    let l = m.layout;
    let n = l.n();
    let mut g = WgpuGather::on_adapter(m, adapter, options)
        .unwrap_or_else(|e| panic!("{}: {e}", adapter.info));
    assert_eq!(g.patches(), n);
    assert_eq!(g.name(), format!("gpu-{}", l.format().name()));
    let mode = g.decode_model().unwrap_or(DecodeMode::D3d10);
    // Palette slack only where the texture unit's rounding is not modelled (module docs).
    let slack = if g.decode_model().is_none() {
        (2.0 * max_shift(m) / 255.0).exp() - 1.0
    } else {
        0.0
    };
    let x = exitance(n, seed);
    let mut want = vec![Rgb::ZERO; n];
    ReferenceGather::new(m.clone(), mode)
        .gather(&x, &mut want)
        .unwrap();
    let sums = abs_sums(m, mode, &x);
    let mut got = vec![Rgb::splat(f32::NAN); n];
    g.gather(&x, &mut got).unwrap();
    for r in 0..n {
        let k_terms = n as f32 + 8.0 + (m.sparse.row_ptr[r + 1] - m.sparse.row_ptr[r]) as f32;
        let (w, gv) = (want[r].to_array(), got[r].to_array());
        for k in 0..3 {
            let (b, s) = sums[r][k];
            let tol =
                C * k_terms * f32::EPSILON * (b + s) + slack * b + k_terms * f32::MIN_POSITIVE;
            let diff = (w[k] - gv[k]).abs();
            assert!(
                diff <= tol,
                "{} ×{} n={n} tile={} on {} path={} model={:?} row {r} ch {k}: reference {} gpu {} diff {diff:e} tolerance {tol:e}",
                l.format(),
                l.channels(),
                l.max_tile(),
                adapter.info,
                g.path(),
                g.decode_model(),
                w[k],
                gv[k]
            );
        }
    }
    g
}

/// The paths to test for a format on an adapter: software always, hardware for BC formats
/// where the adapter decodes BC.
fn paths(adapter: &Adapter, format: Format) -> Vec<DecodePath> {
    let mut p = vec![DecodePath::Software];
    if format.is_block_compressed() && adapter.info.bc {
        p.push(DecodePath::HardwareBc);
    }
    p
}

#[test]
fn every_format_and_path_matches_the_reference() {
    for adapter in gpu_adapters() {
        for (format, channels) in FORMAT_CASES {
            for (n, max_tile) in [(1, 8), (5, 8), (37, 16), (70, 32), (130, 8192)] {
                let m = sample_file(n, channels, format, max_tile).matrix;
                for path in paths(&adapter, format) {
                    let options = GpuOptions {
                        path,
                        ..GpuOptions::default()
                    };
                    let g = check(&adapter, &m, &options, n as u64);
                    assert_eq!(g.path(), path);
                }
            }
        }
    }
}

/// The software path under Mesa's palette rules equals the reference in Mesa mode (and so the
/// hardware path on Mesa): the mode reaches the shader.
#[test]
fn software_mesa_mode_matches_the_mesa_reference() {
    for adapter in gpu_adapters() {
        for (format, channels) in [(Format::Bc1, 3), (Format::Bc4, 1)] {
            let m = sample_file(37, channels, format, 16).matrix;
            let options = GpuOptions {
                path: DecodePath::Software,
                software_mode: DecodeMode::Mesa,
                ..GpuOptions::default()
            };
            let g = check(&adapter, &m, &options, 5);
            assert_eq!(g.decode_model(), Some(DecodeMode::Mesa));
        }
    }
}

/// Unit exitance on one column with the sparse list removed: the gather returns that column
/// of the decoded matrix, which must be bit-identical to the CPU decode under the model
/// (every product is `v · 1`, every other term an exact zero).
#[test]
fn exact_columns_where_the_decode_is_modelled() {
    for adapter in gpu_adapters() {
        for (format, channels) in FORMAT_CASES {
            let n = 45;
            let mut m = sample_file(n, channels, format, 16).matrix;
            m.sparse = SparseRows::empty(n);
            for path in paths(&adapter, format) {
                let options = GpuOptions {
                    path,
                    ..GpuOptions::default()
                };
                let mut g = WgpuGather::on_adapter(&m, &adapter, &options).unwrap();
                let Some(mode) = g.decode_model() else {
                    continue; // an unmodelled texture unit: covered with slack above
                };
                let dense = m.decode_dense(mode);
                // Every position in a block, several tiles, the last (partial) block column.
                for col in [0, 1, 2, 3, 17, 30, 44] {
                    let mut x = vec![Rgb::ZERO; n];
                    x[col] = Rgb::splat(1.0);
                    let mut y = vec![Rgb::splat(f32::NAN); n];
                    g.gather(&x, &mut y).unwrap();
                    for r in 0..n {
                        for k in 0..3 {
                            let want =
                                dense[(r * n + col) * channels + if channels == 1 { 0 } else { k }];
                            assert_eq!(
                                y[r].channel(k).to_bits(),
                                want.to_bits(),
                                "{format} ×{channels} {path} on {}: entry ({r}, {col}) channel {k}: gpu {} cpu {want} ({mode:?})",
                                adapter.info,
                                y[r].channel(k)
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Tight limits force several bands, texture column groups and sparse bands on a small
/// matrix (and small tiles several tile rows and columns); the answer must not change.
#[test]
fn several_bands_under_small_limits() {
    for adapter in gpu_adapters() {
        for (format, channels) in [(Format::Bc1, 3), (Format::Bc4, 3), (Format::F16, 1)] {
            let m = sample_file(203, channels, format, 64).matrix;
            for path in paths(&adapter, format) {
                let options = GpuOptions {
                    path,
                    // One tile row's tables (BC1: 4 tiles × 3 channels × 1 KiB) fit, while
                    // BC4 RGB (1224 bytes a block row) and f16 (1632) bands are cut inside
                    // tile rows of 16 block rows.
                    max_binding_bytes: Some(16384),
                    max_texture_side: Some(40),
                    // Three column splits on top (each its own slab of partial sums, and
                    // several texture column groups per split on the hardware path).
                    column_splits: Some(3),
                    ..GpuOptions::default()
                };
                let g = check(&adapter, &m, &options, 11);
                assert!(
                    g.dispatches() > 4,
                    "{format} {path}: {} dispatches, expected a cut matrix",
                    g.dispatches()
                );
            }
        }
    }
}

/// GL adapters (llvmpipe through EGL here) run the same kernels: the two cheapest to compile
/// there, and the texture unit's BC4. A hardware GL adapter whose device cannot be opened is
/// skipped with a note: NVIDIA's GL driver through EGL in a headless container (an H100,
/// driver 580) lists an adapter whose device is lost at creation, which no code of ours can
/// change; software GL, what CI has, must work.
#[test]
fn gl_adapter_smoke() {
    for adapter in adapters().into_iter().filter(|a| a.info.backend == "gl") {
        if adapter.info.is_hardware() {
            let m = sample_file(8, 1, Format::F32, 32).matrix;
            if let Err(e @ GpuError::Device(_)) =
                WgpuGather::on_adapter(&m, &adapter, &GpuOptions::default())
            {
                eprintln!("skipping {}: {e}", adapter.info);
                continue;
            }
        }
        for (format, channels, path) in [
            (Format::F32, 1, DecodePath::Software),
            (Format::F16, 3, DecodePath::Software),
            (Format::Bc4, 1, DecodePath::HardwareBc),
        ] {
            if path == DecodePath::HardwareBc && !adapter.info.bc {
                continue;
            }
            let m = sample_file(70, channels, format, 32).matrix;
            let options = GpuOptions {
                path,
                ..GpuOptions::default()
            };
            check(&adapter, &m, &options, 3);
        }
    }
}

#[test]
fn repeated_gathers_are_deterministic_and_follow_x() {
    for adapter in gpu_adapters() {
        let n = 37;
        let m = sample_file(n, 3, Format::Bc1, 16).matrix;
        let mut g = WgpuGather::on_adapter(&m, &adapter, &GpuOptions::default()).unwrap();
        let mut outs = Vec::new();
        for seed in [1, 2, 1] {
            let mut y = vec![Rgb::ZERO; n];
            g.gather(&exitance(n, seed), &mut y).unwrap();
            outs.push(y);
        }
        assert_eq!(outs[0], outs[2], "same input, same output");
        assert_ne!(outs[0], outs[1], "a new x is uploaded every frame");
    }
}

/// Several devices at once, each in its own thread (as cargo runs tests).
#[test]
fn several_devices_at_once() {
    for adapter in gpu_adapters() {
        std::thread::scope(|s| {
            for t in 0..4u64 {
                let adapter = &adapter;
                s.spawn(move || {
                    let m = sample_file(29 + t as usize, 1, Format::Bc4, 16).matrix;
                    for _ in 0..3 {
                        check(adapter, &m, &GpuOptions::default(), t);
                    }
                });
            }
        });
    }
}

#[test]
fn bad_arguments_give_the_reference_errors() {
    let Some(adapter) = gpu_adapters().into_iter().next() else {
        return;
    };
    let m = sample_file(9, 3, Format::Bc4, 8).matrix;
    let mut gpu = WgpuGather::on_adapter(&m, &adapter, &GpuOptions::default()).unwrap();
    radiosity_tests::fixtures::assert_argument_errors_match_reference(&mut gpu, &m);
}

/// Impossible requests are errors that say why, never a silent fallback.
#[test]
fn impossible_requests_are_errors() {
    let m = sample_file(8, 1, Format::U8, 8).matrix;
    let none = GpuOptions {
        adapter: AdapterChoice::Name("no such adapter here".into()),
        ..GpuOptions::default()
    };
    match WgpuGather::new(&m, &none) {
        Err(GpuError::NoAdapter(why)) => assert!(why.contains("no adapter matching"), "{why}"),
        other => panic!("expected NoAdapter, got {other:?}"),
    }
    let Some(adapter) = gpu_adapters().into_iter().next() else {
        return;
    };
    let hw = GpuOptions {
        path: DecodePath::HardwareBc,
        ..GpuOptions::default()
    };
    match WgpuGather::on_adapter(&m, &adapter, &hw) {
        Err(GpuError::Unsupported(why)) => assert!(why.contains("bc1 or bc4"), "{why}"),
        other => panic!("expected Unsupported, got {other:?}"),
    }
    // A texture side below one block cannot hold anything.
    let bc4 = sample_file(8, 1, Format::Bc4, 8).matrix;
    if adapter.info.bc {
        let tiny = GpuOptions {
            path: DecodePath::HardwareBc,
            max_texture_side: Some(2),
            ..GpuOptions::default()
        };
        assert!(matches!(
            WgpuGather::on_adapter(&bc4, &adapter, &tiny),
            Err(GpuError::Unsupported(_))
        ));
    }
}

/// The texture-unit check names Mesa's rules on Mesa's software drivers (known bit for bit),
/// and the hardware path reports whatever the check found as its decode model; `auto` takes
/// the hardware path only on a GPU whose texture unit matched a model.
#[test]
fn texture_unit_check_decides_the_hardware_path() {
    use radiosity_backend_wgpu::texture_unit::texture_decode_model;
    for adapter in gpu_adapters().into_iter().filter(|a| a.info.bc) {
        let found = texture_decode_model(&adapter).unwrap();
        if adapter.info.is_mesa_software() {
            assert_eq!(found, Some(DecodeMode::Mesa), "{}", adapter.info);
        }
        let m = sample_file(40, 3, Format::Bc1, 32).matrix;
        let hw = GpuOptions {
            path: DecodePath::HardwareBc,
            ..GpuOptions::default()
        };
        let g = WgpuGather::on_adapter(&m, &adapter, &hw).unwrap();
        assert_eq!(g.decode_model(), found, "{}", adapter.info);
        let auto = WgpuGather::on_adapter(&m, &adapter, &GpuOptions::default()).unwrap();
        let want = if adapter.info.is_hardware() && found.is_some() {
            DecodePath::HardwareBc
        } else {
            DecodePath::Software
        };
        assert_eq!(auto.path(), want, "{}", adapter.info);
        // The choice is explained exactly when a GPU's texture unit was passed over.
        assert_eq!(
            auto.path_note().is_some(),
            adapter.info.is_hardware() && found.is_none(),
            "{}",
            adapter.info
        );
        assert_eq!(g.path_note(), None, "an explicit path needs no note");
    }
}
