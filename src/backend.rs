//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`. The choice,
//! the reason and (for the GPU) the adapter and decode path are printed on stderr; an
//! unavailable backend is an error that says why, never a silent fallback (only `auto` chooses).
//!
//! - `auto`: the wgpu gather on a **hardware** GPU adapter when there is one and it can hold
//!   the matrix, else the SIMD CPU gather (a software rasteriser such as llvmpipe is slower
//!   than the CPU backend on the same cores, so `auto` never picks one); the GPU half is
//!   `radiosity_backend_wgpu::auto_gather`, which the C ABI shares.
//! - `gpu`: the wgpu gather on the best adapter, software rasterisers included; no adapter is
//!   an error.
//! - `cpu`, `reference`: the SIMD CPU gather, the scalar oracle.

use anyhow::bail;
use radiosity_backend_cpu::CpuGather;
use radiosity_backend_wgpu::{GpuOptions, WgpuGather, auto_gather};
use radiosity_core::{DecodeMode, Gather, ReferenceGather, TransferMatrix};

/// A chosen gather with the backend kind (`cpu`, `gpu`, `reference`) for reports.
pub(crate) struct Chosen {
    pub(crate) gather: Box<dyn Gather>,
    pub(crate) kind: &'static str,
    pub(crate) detail: String,
}

fn gpu_detail(g: &WgpuGather, why: &str) -> String {
    let note = g.path_note().map_or(String::new(), |n| format!(": {n}"));
    format!(
        "{why}; adapter {}, {} decode{note}",
        g.adapter(),
        g.path().name()
    )
}

pub(crate) fn choose(
    flag: Option<&str>,
    matrix: TransferMatrix<'static>,
) -> anyhow::Result<Chosen> {
    let env = std::env::var("RADIOSITY_BACKEND").ok();
    let (requested, source) = match (flag, env.as_deref()) {
        (Some(f), _) => (f.to_owned(), "--backend"),
        (None, Some(e)) if !e.is_empty() => (e.to_owned(), "RADIOSITY_BACKEND"),
        _ => ("auto".to_owned(), "default"),
    };
    let cpu = |matrix: TransferMatrix<'static>, why: &str| {
        let g = CpuGather::new(matrix);
        let detail = format!("{why}; SIMD path {}", g.path());
        Chosen {
            gather: Box::new(g),
            kind: "cpu",
            detail,
        }
    };
    let chosen = match requested.as_str() {
        "auto" => match auto_gather(&matrix, &GpuOptions::default()) {
            Ok(g) => {
                let detail = gpu_detail(&g, "auto: a hardware GPU is present");
                Chosen {
                    gather: Box::new(g),
                    kind: "gpu",
                    detail,
                }
            }
            Err(why) => cpu(matrix, &why),
        },
        "cpu" => cpu(matrix, &format!("requested by {source}")),
        "reference" => Chosen {
            gather: Box::new(ReferenceGather::new(matrix, DecodeMode::D3d10)),
            kind: "reference",
            detail: format!("requested by {source}: the scalar oracle"),
        },
        "gpu" => match WgpuGather::new(&matrix, &GpuOptions::default()) {
            Ok(g) => {
                let detail = gpu_detail(&g, &format!("requested by {source}"));
                Chosen {
                    gather: Box::new(g),
                    kind: "gpu",
                    detail,
                }
            }
            Err(e) => bail!("backend gpu (from {source}) is not available: {e}"),
        },
        other => {
            bail!("unknown backend {other:?} (from {source}): use auto, cpu, gpu or reference")
        }
    };
    eprintln!("backend: {} ({})", chosen.gather.name(), chosen.detail);
    Ok(chosen)
}
