//! The rows of `radiosity bench`: each method a [`Gather`] with the numbering its vectors are
//! in and its cost per call. The encoded matrix on the CPU (and on the GPU where there is an
//! adapter) in every format, then the peers.

use crate::Progress;
use crate::peers::{Cost, FaerDense, JacobiBounces, LuSolve, gather_cost};
use crate::timing::ms;
use anyhow::Context;
use radiosity_backend_cpu::CpuGather;
use radiosity_bake::encode::{
    EncodeParams, ErrorWeights, SparseSelection, default_sparse_fraction, encode_dense_with,
};
use radiosity_bake::pipeline::Discretised;
use radiosity_core::{Format, Gather, Rgb};
use std::time::Instant;

/// Jacobi bounce iterations per frame for the classical-radiosity peer (`jacobi-8`).
const JACOBI_ITERATIONS: usize = 8;
/// One method measured: a gather, which numbering its vectors use, and its cost per call.
pub(super) struct Row {
    /// `cpu-bc1`, `faer-dense-f32`, … (the names of `docs/contract.md`).
    pub(super) method: String,
    pub(super) gather: Box<dyn Gather>,
    /// Vectors in the file's numbering (the encoded matrices) rather than the bake's.
    pub(super) file_order: bool,
    pub(super) cost: Cost,
    /// One-off preparation (encoding, factorisation), ms.
    pub(super) setup_ms: f64,
    /// GPU rows: median GPU time of the kernels alone (timestamps), ms.
    pub(super) kernel_ms: Option<f64>,
    pub(super) note: String,
}

/// A `cpu-<format>` row per format (BC1 only with three channels) and, on the best adapter
/// when there is one, the `gpu-…` rows of the same matrix. `on_default` sees the matrix in the
/// bake's default format for `channels` (BC1, or BC4 for one channel). What it skips is a
/// note of `progress`.
pub(super) fn encoded_rows(
    n: usize,
    channels: usize,
    m_file: Vec<f32>,
    weights: &ErrorWeights,
    progress: &Progress<'_>,
    on_default: &mut dyn FnMut(&radiosity_core::TransferMatrix<'_>),
) -> anyhow::Result<Vec<Row>> {
    let default = if channels == 1 {
        Format::Bc4
    } else {
        Format::Bc1
    };
    let mut rows: Vec<Row> = Vec::new();
    let gpu = radiosity_backend_wgpu::adapters().into_iter().next();
    if gpu.is_none() {
        (progress.note)("note: no GPU adapter: gpu-… rows skipped");
    }
    for format in Format::ALL {
        if format == Format::Bc1 && channels == 1 {
            (progress.note)(
                "note: cpu-bc1 skipped: the scene is grey and BC1 cannot hold one channel",
            );
            continue;
        }
        (progress.stage)(&format!("encode {}", format.name()));
        let t = Instant::now();
        let encode = EncodeParams {
            sparse_fraction: default_sparse_fraction(format, channels),
            ..EncodeParams::for_format(format)
        };
        let matrix = encode_dense_with(
            n,
            channels,
            &m_file,
            &encode,
            weights,
            SparseSelection::ErrorDriven,
        )
        .with_context(|| format!("cannot encode in {}", format.name()))?;
        let setup_ms = ms(t.elapsed());
        let cost = gather_cost(&matrix);
        let sparse = matrix.sparse.nnz();
        if let Some(adapter) = &gpu {
            gpu_rows(adapter, &matrix, cost, setup_ms, &mut rows)?;
        }
        if format == default {
            on_default(&matrix);
        }
        let gather = CpuGather::new(matrix);
        let note = format!("SIMD path {}, {sparse} sparse entries", gather.path());
        rows.push(Row {
            method: format!("cpu-{}", format.name()),
            gather: Box::new(gather),
            file_order: true,
            cost,
            setup_ms,
            kernel_ms: None,
            note,
        });
    }
    Ok(rows)
}

/// The peers in the bake's numbering: faer's dense mat-vec of `m` (dropped once copied),
/// Jacobi bounces with F, and the LU solve per frame (`lu`, factorised in `lu_setup` ms).
pub(super) fn peer_rows(
    sys: &Discretised,
    m: Vec<f32>,
    lu: LuSolve,
    lu_setup: f64,
    rows: &mut Vec<Row>,
) {
    let (n, channels) = (sys.len(), sys.channels);
    let t = Instant::now();
    let faer = FaerDense::new(n, channels, &m);
    drop(m);
    rows.push(Row {
        method: "faer-dense-f32".into(),
        cost: faer.cost(),
        gather: Box::new(faer),
        file_order: false,
        setup_ms: ms(t.elapsed()),
        kernel_ms: None,
        note: format!("faer matmul, the same M unquantised, {channels} channel matrices"),
    });
    let t = Instant::now();
    let jacobi = JacobiBounces::new(&sys.f, &sys.reflectance, JACOBI_ITERATIONS);
    rows.push(Row {
        method: format!("jacobi-{JACOBI_ITERATIONS}"),
        cost: jacobi.cost(),
        gather: Box::new(jacobi),
        file_order: false,
        setup_ms: ms(t.elapsed()),
        kernel_ms: None,
        note: format!(
            "{JACOBI_ITERATIONS} bounce iterations with F (f32, faer): its error is the bounces it leaves out"
        ),
    });
    rows.push(Row {
        method: "lu-per-frame".into(),
        cost: lu.cost(),
        gather: Box::new(lu),
        file_order: false,
        setup_ms: lu_setup,
        kernel_ms: None,
        note: "F·x and triangular solves (f64); the factorisation of I − F^C is made once and reused: it depends only on geometry and reflectance".into(),
    });
}

/// The `gpu-<format>` row on `adapter` (its default decode path) and, for a BC matrix on an
/// adapter with BC textures, the other path too (`gpu-<format>-software` decoding in the
/// shader, or `gpu-<format>-hardware` decoding in the texture unit), timed side by side. The
/// roofline of these rows is the CPU's: right for a software rasteriser (llvmpipe), only a
/// reference for a real GPU.
fn gpu_rows(
    adapter: &radiosity_backend_wgpu::Adapter,
    matrix: &radiosity_core::TransferMatrix<'_>,
    cost: Cost,
    setup_ms: f64,
    rows: &mut Vec<Row>,
) -> anyhow::Result<()> {
    use radiosity_backend_wgpu::{DecodePath, GpuOptions, WgpuGather};
    let format = matrix.layout.format();
    let mut push = |path: DecodePath, suffix: &str| -> anyhow::Result<DecodePath> {
        let t = Instant::now();
        let options = GpuOptions {
            path,
            ..GpuOptions::default()
        };
        let mut gather = WgpuGather::on_adapter(matrix, adapter, &options)
            .with_context(|| format!("cannot build the GPU gather on {}", adapter.info))?;
        let chosen = gather.path();
        let mut note = format!(
            "{}, {} decode, {} dispatches, {:.1} MB on the device",
            gather.adapter(),
            chosen,
            gather.dispatches(),
            gather.device_bytes() as f64 / 1e6
        );
        // The kernels alone (GPU timestamps): what a frame costs when y stays on the GPU.
        let x = vec![Rgb::splat(1.0); gather.patches()];
        let mut y = x.clone();
        let mut kernel = Vec::new();
        for _ in 0..21 {
            gather.gather(&x, &mut y)?;
            kernel.extend(gather.kernel_ms());
        }
        kernel.sort_by(f64::total_cmp);
        let kernel_ms = kernel.get(kernel.len() / 2).copied();
        if let Some(k) = kernel_ms {
            note += &format!(
                "; kernels {k:.3} ms (GPU timestamps, median of 21), {:.1} GB/s",
                cost.bytes as f64 / (k * 1e-3) / 1e9
            );
        }
        rows.push(Row {
            method: format!("gpu-{}{suffix}", format.name()),
            gather: Box::new(gather),
            file_order: true,
            cost,
            setup_ms: setup_ms + ms(t.elapsed()),
            kernel_ms,
            note,
        });
        Ok(chosen)
    };
    // The other decode path of a BC matrix, where the adapter has both.
    match push(DecodePath::Auto, "")? {
        DecodePath::HardwareBc => {
            push(DecodePath::Software, "-software")?;
        }
        _ if format.is_block_compressed() && adapter.info.bc => {
            push(DecodePath::HardwareBc, "-hardware")?;
        }
        _ => {}
    }
    Ok(())
}
