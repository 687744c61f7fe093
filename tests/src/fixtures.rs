//! Deterministic inputs shared by the cross-crate tests: a tiny PRNG, form-factor-like
//! matrices, and a complete sample `.rad` file.

use radiosity_bake::encode::{EncodeParams, ErrorWeights, SparseSelection, encode_dense_with};
use radiosity_core::{
    Bounces, DecodeMode, Format, Gather, GatherError, Patch, PatchOrder, RadFile, ReferenceGather,
    Rgb, TransferMatrix, check_gather_args,
};
use std::borrow::Cow;

/// The bake's deterministic generator, so tests need no `rand` and every run sees the same
/// inputs.
pub use radiosity_bake::rng::SplitMix64;

/// Every storable (format, channels) pair: what format-generic tests loop over.
pub const FORMAT_CASES: [(Format, usize); 9] = Format::CASES;

/// A dense `n × n × channels` matrix shaped like a transfer matrix: patches on a ring, entries
/// falling off as `1/(1 + d²)` with distance, zero diagonal, channels scaled by a colour, and a
/// few large near-field entries. Row-major, channels interleaved.
pub fn transfer_like_matrix(n: usize, channels: usize, seed: u64) -> Vec<f32> {
    let mut rng = SplitMix64(seed);
    let tint = [1.0f32, 0.6, 0.3];
    let mut m = vec![0f32; n * n * channels];
    for r in 0..n {
        for c in 0..n {
            if r == c {
                continue;
            }
            let d = (r as f32 - c as f32)
                .abs()
                .min(n as f32 - (r as f32 - c as f32).abs());
            let mut v = 0.2 / (1.0 + d * d) * (0.8 + 0.4 * rng.next_f32());
            if rng.next_u64().is_multiple_of(97) {
                v *= 20.0; // a near-field spike, the kind the sparse list is for
            }
            for k in 0..channels {
                m[(r * n + c) * channels + k] = v * tint[k];
            }
        }
    }
    m
}

/// Unit-area, valid patches for a matrix of `n`, alternating between two objects.
pub fn sample_patches(n: usize) -> Vec<Patch> {
    (0..n)
        .map(|i| Patch {
            centre: [i as f32, 0.5, -1.0],
            area: 0.25 + i as f32 * 0.01,
            normal: [0.0, 1.0, 0.0],
            object: (i % 2) as u32,
            reflectance: Rgb::new(0.7, 0.5, 0.3),
            emission: if i == 0 { Rgb::splat(10.0) } else { Rgb::ZERO },
        })
        .collect()
}

/// A complete, valid `.rad` file: `n` patches, `channels`, `format`, tiles of `max_tile`,
/// 2% sparse entries, for BC1 and BC4 a quarter of the blocks corrected (the bake's
/// error-driven encode), a reversed patch order, two objects and a report.
pub fn sample_file(n: usize, channels: usize, format: Format, max_tile: u32) -> RadFile<'static> {
    let dense = transfer_like_matrix(n, channels, 7);
    let params = EncodeParams {
        format,
        max_tile,
        sparse_fraction: 0.02,
        corrections: 0.25,
        ..EncodeParams::default()
    };
    let matrix = encode_dense_with(
        n,
        channels,
        &dense,
        &params,
        &ErrorWeights::uniform(),
        SparseSelection::ErrorDriven,
    )
    .expect("sample matrix encodes");
    RadFile {
        patch_order: PatchOrder::Spatial,
        compression_rmse: Some(0.0125),
        report: Some(Cow::Borrowed("{\"note\":\"sample\"}")),
        mesh: Some(sample_mesh(n)),
        probes: Some(sample_probes(n)),
        sky: Some(sample_sky(n, 2)),
        parts: Some(sample_parts(n, sample_mesh(n).samples.len())),
        bounce: Some(sample_bounce(n, sample_mesh(n).samples.len())),
        coverage: Some(Cow::Owned(sample_coverage(sample_mesh(n).triangles.len()))),
        ..RadFile::new(
            Cow::Owned(sample_patches(n)),
            Cow::Owned((0..n as u32).rev().collect()),
            matrix,
            vec![Cow::Borrowed("floor"), Cow::Borrowed("wall ünïcode")],
            Bounces::Finite(4),
        )
    }
}

/// Coverage for `t` triangles: every third at 0.5, the rest opaque.
pub fn sample_coverage(t: usize) -> Vec<f32> {
    (0..t).map(|i| if i % 3 == 1 { 0.5 } else { 1.0 }).collect()
}

/// Gather rows of two objects' parts in each of the first three patches (fewer for a smaller
/// file), each entry a mesh sample of `samples` with a count of 1 to 3.
pub fn sample_parts(n: usize, samples: usize) -> radiosity_core::PartRows<'static> {
    use radiosity_core::Part;
    let mut parts = Vec::new();
    let (mut at, mut counts) = (Vec::new(), Vec::new());
    for patch in 0..n.min(3) as u32 {
        for object in 0..2u32 {
            parts.push(Part {
                patch,
                object,
                scale: 1.0 / 64.0,
                start: at.len() as u32,
            });
            for s in (patch as usize + object as usize..samples).step_by(3) {
                at.push(s as u32);
                counts.push(1 + (s % 3) as u16);
            }
        }
    }
    radiosity_core::PartRows {
        parts: Cow::Owned(parts),
        samples: Cow::Owned(at),
        counts: Cow::Owned(counts),
        sky: Cow::Owned(vec![0.25; 9 * (2 * n.min(3))]),
    }
}

/// First-bounce rows for `n` patches: patch `i` meets every fourth mesh sample of `samples`
/// from `i % 4`, each with a weight of 1 to 4 units; the last patch none.
pub fn sample_bounce(n: usize, samples: usize) -> radiosity_core::BounceRows<'static> {
    let (mut starts, mut at, mut weights) = (vec![0u32], Vec::new(), Vec::new());
    for i in 0..n {
        if i + 1 < n {
            for s in (i % 4..samples).step_by(4) {
                at.push(s as u32);
                weights.push(radiosity_core::half::f32_to_f16(1.0 + (s % 4) as f32));
            }
        }
        starts.push(at.len() as u32);
    }
    radiosity_core::BounceRows {
        scale: Cow::Owned((0..n).map(|i| 1.0 / (256.0 + i as f32)).collect()),
        starts: Cow::Owned(starts),
        samples: Cow::Owned(at),
        weights: Cow::Owned(weights),
    }
}

/// Sky visibility for `n` patches and `m` probes: patch `i` sees a share `i/n` of its lobe,
/// the probes half the sphere.
pub fn sample_sky(n: usize, m: usize) -> radiosity_core::SkyVisibility<'static> {
    use radiosity_core::sky::Y0;
    use std::f32::consts::PI;
    let patches: Vec<[f32; 9]> = (0..n)
        .map(|i| {
            let mut t = [0.01 * i as f32 / n as f32; 9];
            t[0] = PI * Y0 * i as f32 / n as f32;
            t
        })
        .collect();
    let mut probe = [0.1; 9];
    probe[0] = 2.0 * PI * Y0;
    radiosity_core::SkyVisibility::new(&patches, &vec![probe; m])
}

/// Two valid probes for a file of `n ≥ 1` patches: the first weighs patches 0 and `n − 1`,
/// the second none.
pub fn sample_probes(n: usize) -> radiosity_core::Probes<'static> {
    use radiosity_core::{ProbeWeight, SH_COEFFICIENTS};
    let mut weights = vec![ProbeWeight::new(0, [0.25; SH_COEFFICIENTS])];
    if n > 1 {
        weights.push(ProbeWeight::new(n as u32 - 1, [-0.125; SH_COEFFICIENTS]));
    }
    radiosity_core::Probes {
        spacing: 0.25,
        positions: Cow::Owned(vec![[0.5, 0.5, 0.5], [0.25, 0.75, 0.5]]),
        rows: Cow::Owned(vec![0, weights.len() as u32, weights.len() as u32]),
        weights: Cow::Owned(weights),
        factors: None,
    }
}

/// A small valid mesh for a file of `n ≥ 1` patches: a unit quad in z = 0 (two triangles of
/// object 0), every corner interpolating patch 0 and, where it exists, patch `n − 1`; one
/// direct-light sample per patch.
pub fn sample_mesh(n: usize) -> radiosity_core::Mesh<'static> {
    use radiosity_core::{CornerWeight, Mesh, MeshTriangle, PatchSample};
    let tri = |vertices| MeshTriangle {
        vertices,
        object: 0,
        reflectance: Rgb::new(0.7, 0.5, 0.3),
        emission: Rgb::ZERO,
    };
    let last = (n - 1) as u32;
    let mut corner_rows = vec![0u32];
    let mut corner_weights = Vec::new();
    for c in 0..6 {
        if c % 2 == 0 || last == 0 {
            corner_weights.push(CornerWeight {
                patch: 0,
                weight: 1.0,
            });
        } else {
            corner_weights.push(CornerWeight {
                patch: 0,
                weight: 0.25,
            });
            corner_weights.push(CornerWeight {
                patch: last,
                weight: 0.75,
            });
        }
        corner_rows.push(corner_weights.len() as u32);
    }
    Mesh {
        positions: Cow::Owned(vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]),
        triangles: Cow::Owned(vec![tri([0, 1, 2]), tri([0, 2, 3])]),
        corner_rows: Cow::Owned(corner_rows),
        corner_weights: Cow::Owned(corner_weights),
        sample_rows: Cow::Owned((0..=n as u32).collect()),
        samples: Cow::Owned(
            (0..n)
                .map(|i| PatchSample {
                    position: [i as f32 / n as f32, 0.5, 0.0],
                    normal: [0.0, 0.0, 1.0],
                    area: 1.0 / n as f32,
                })
                .collect(),
        ),
    }
}

/// The shipped Cornell box (McGuire's CornellBox-Original) simplified to about `patches`
/// patches, with ray-cast form factors and all bounces (LU): its core patches and the dense RGB
/// transfer matrix (`n·n·3`, natural order). For order tests and benches that need a real M
/// before any reordering or encoding.
pub fn cornell_transfer(patches: usize) -> (Vec<Patch>, Vec<f32>) {
    use radiosity_bake::transfer::{BounceSpec, transfer_matrix};
    let (core, f) = cornell_form_factors(patches);
    let reflectance: Vec<[f64; 3]> = core
        .iter()
        .map(|p| p.reflectance.to_array().map(f64::from))
        .collect();
    let (m, _) =
        transfer_matrix(&f, &reflectance, 3, BounceSpec::Infinite).expect("transfer converges");
    (core, m)
}

/// The patches and ray-cast form factors of [`cornell_transfer`], before any transfer: for
/// tests that compute `M` under reflectances of their own.
pub fn cornell_form_factors(patches: usize) -> (Vec<Patch>, radiosity_bake::transfer::Dense) {
    use radiosity_bake::form_factor::{FormFactorParams, form_factors};
    use radiosity_bake::scene::Scene;
    use radiosity_bake::simplify::{VoxelParams, simplify};
    use radiosity_bake::transfer::Dense;
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/cornell-box/CornellBox-Original.obj");
    let scene = Scene::load_obj(&path).expect("Cornell box loads");
    let simplified = simplify(&scene, &VoxelParams::with_patches(patches)).expect("simplifies");
    let occluders = scene.occluders();
    let ff = form_factors(
        &simplified,
        Some(&occluders),
        &FormFactorParams::default(),
        None,
    );
    let f = Dense::new(ff.n, ff.matrix.iter().map(|v| f64::from(*v)).collect());
    (simplified.to_core(), f)
}

/// A reproducible exitance vector with channels of different magnitudes (r up to 10, g up to
/// 1, b up to 0.1), so a backend that mixes channels up shows it.
pub fn exitance(n: usize, seed: u64) -> Vec<Rgb> {
    let mut rng = SplitMix64(seed);
    (0..n)
        .map(|_| Rgb::new(rng.next_f32() * 10.0, rng.next_f32(), rng.next_f32() * 0.1))
        .collect()
}

/// Asserts that `backend`, gathering from `matrix`, refuses wrong lengths and non-finite
/// exitance (NaN, infinity) with exactly the errors of the reference gather and of
/// [`check_gather_args`]. `matrix` needs at least 8 patches.
pub fn assert_argument_errors_match_reference(
    backend: &mut dyn Gather,
    matrix: &TransferMatrix<'static>,
) {
    let n = matrix.layout.n();
    let mut reference = ReferenceGather::new(matrix.clone(), DecodeMode::D3d10);
    let good = exitance(n, 3);
    let mut nan = good.clone();
    nan[4].g = f32::NAN;
    let mut inf = good.clone();
    inf[7].b = f32::INFINITY;
    let inputs: [(&[Rgb], usize); 5] = [
        (&good[..n - 1], n),
        (&good, n + 1),
        (&good, 0),
        (&nan, n),
        (&inf, n),
    ];
    for (x, len) in inputs {
        let mut y1 = vec![Rgb::ZERO; len];
        let mut y2 = vec![Rgb::ZERO; len];
        let e1 = reference.gather(x, &mut y1).unwrap_err();
        let e2 = backend.gather(x, &mut y2).unwrap_err();
        assert_eq!(e1, e2);
        assert_eq!(check_gather_args(n, x, &y2), Err(e2.clone()));
        assert!(matches!(
            e2,
            GatherError::Length { .. } | GatherError::NonFinite { .. }
        ));
    }
}

/// One frame of `file` on the reference gather, given each patch's direct irradiance
/// (`direct`, W/m²): the gathered `y`, the irradiance `H` and the radiosity `B` per patch.
pub struct ReferenceFrame {
    /// `M·x`, the indirect irradiance.
    pub y: Vec<Rgb>,
    /// `direct + y`.
    pub h: Vec<Rgb>,
    /// `E + ρ·H`.
    pub b: Vec<Rgb>,
}

/// [`ReferenceFrame`] of `file` under `direct`.
pub fn reference_frame(file: &RadFile<'_>, direct: &[Rgb]) -> ReferenceFrame {
    let n = file.n();
    let mut x = vec![Rgb::ZERO; n];
    radiosity_core::first_exitance(&file.patches, direct, &mut x);
    let mut y = vec![Rgb::ZERO; n];
    ReferenceGather::new(file.matrix.clone(), DecodeMode::D3d10)
        .gather(&x, &mut y)
        .expect("the reference gather takes the file's own sizes");
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    radiosity_core::finish_frame(&file.patches, direct, &y, &mut h, &mut b);
    ReferenceFrame { y, h, b }
}

/// A level file cut into systems of `sizes` patches (each a one-system file of those patches
/// with its own BC1 matrix, in the level's order), a few coupling entries from every patch
/// to the next system's first patches, the level's patches [`sample_patches`].
pub fn sample_level(sizes: &[usize]) -> RadFile<'static> {
    use radiosity_core::container::LevelSystems;
    use radiosity_core::systems::Coupling;
    let n: usize = sizes.iter().sum();
    let patches = sample_patches(n);
    let objects = vec![Cow::Borrowed("floor"), Cow::Borrowed("wall ünïcode")];
    let mut files = Vec::new();
    let mut ranges = Vec::new();
    let mut start = 0;
    for (s, &m) in sizes.iter().enumerate() {
        let dense = transfer_like_matrix(m, 3, 11 + s as u64);
        let matrix = encode_dense_with(
            m,
            3,
            &dense,
            &EncodeParams::default(),
            &ErrorWeights::uniform(),
            SparseSelection::ErrorDriven,
        )
        .expect("system matrix encodes");
        files.push(RadFile {
            patch_order: PatchOrder::Spatial,
            compression_rmse: Some(0.01),
            ..RadFile::new(
                Cow::Owned(patches[start..start + m].to_vec()),
                Cow::Owned((0..m as u32).collect()),
                matrix,
                objects.clone(),
                Bounces::Infinite,
            )
        });
        ranges.push(start..start + m);
        start += m;
    }
    let (mut row_ptr, mut cols, mut values) = (vec![0u32], Vec::new(), Vec::new());
    for (s, r) in ranges.iter().enumerate() {
        let next = &ranges[(s + 1) % ranges.len()];
        for i in r.clone() {
            if next != r {
                for j in next.start..next.end.min(next.start + 3) {
                    cols.push(j as u32);
                    values.push(0.01 + 0.001 * (i % 7) as f32);
                }
            }
            row_ptr.push(cols.len() as u32);
        }
    }
    // Columns increase within a row only where the next system lies after this one; the
    // contract does not ask for sorted columns.
    let coupling = Coupling {
        row_ptr: row_ptr.into(),
        cols: cols.into(),
        values: values.into(),
    };
    let systems = LevelSystems::from_files(&files, coupling).expect("systems serialise");
    RadFile {
        patch_order: PatchOrder::Spatial,
        compression_rmse: Some(0.01),
        report: Some(Cow::Borrowed("{\"note\":\"level\"}")),
        mesh: Some(sample_mesh(n)),
        systems: Some(systems),
        ..RadFile::new(
            Cow::Owned(patches),
            Cow::Owned((0..n as u32).rev().collect()),
            TransferMatrix::none(
                radiosity_core::MatrixLayout::none(
                    3,
                    Format::Bc1,
                    radiosity_core::DEFAULT_MAX_TILE,
                )
                .expect("a BC1 layout"),
            ),
            objects,
            Bounces::Infinite,
        )
    }
}
