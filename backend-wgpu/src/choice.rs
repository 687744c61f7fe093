//! The backend chosen at run time by name, shared by the command line (`--backend`,
//! `RADIOSITY_BACKEND`) and the C ABI (`rad_gather_new`): `auto`, `cpu`, `gpu`, `reference`.
//!
//! - `auto`: the wgpu gather on a **hardware** GPU adapter when there is one and it can hold
//!   the matrix ([`auto_gather`]), else the SIMD CPU gather (a software rasteriser such as
//!   llvmpipe is slower than the CPU backend on the same cores, so `auto` never picks one).
//! - `gpu`: the wgpu gather on the best adapter, software rasterisers included; no usable
//!   adapter is an error, never a silent fallback.
//! - `cpu`, `reference`: the SIMD CPU gather, the scalar oracle.

use crate::{GpuOptions, WgpuGather, auto_gather};
use radiosity_backend_cpu::CpuGather;
use radiosity_core::{DecodeMode, Gather, ReferenceGather, TransferMatrix};

/// A backend by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// A hardware GPU that can hold the matrix, else the CPU.
    Auto,
    /// The SIMD CPU gather.
    Cpu,
    /// The wgpu gather on the best adapter.
    Gpu,
    /// The scalar oracle.
    Reference,
}

impl Backend {
    /// The backend named `name` (`auto`, `cpu`, `gpu`, `reference`), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "auto" => Self::Auto,
            "cpu" => Self::Cpu,
            "gpu" => Self::Gpu,
            "reference" => Self::Reference,
            _ => return None,
        })
    }
}

/// A chosen gather: the gather, the kind that runs (`cpu`, `gpu` or `reference`; `auto`
/// resolves to one of the first two) and why, with the adapter and decode path for the GPU.
pub struct Chosen {
    /// The gather.
    pub gather: Box<dyn Gather>,
    /// `cpu`, `gpu` or `reference`.
    pub kind: &'static str,
    /// Why this one, and on what.
    pub detail: String,
}

/// Why `gpu` cannot run here.
#[derive(Debug, thiserror::Error)]
#[error("backend gpu is not available: {0}")]
pub struct Unavailable(pub String);

fn gpu_detail(g: &WgpuGather, why: &str) -> String {
    let note = g.path_note().map_or(String::new(), |n| format!(": {n}"));
    format!(
        "{why}; adapter {}, {} decode{note}",
        g.adapter(),
        g.path().name()
    )
}

/// Builds the gather of `backend` over `matrix`; `why` says who asked (`requested by
/// --backend`).
pub fn choose(
    backend: Backend,
    matrix: TransferMatrix<'static>,
    why: &str,
) -> Result<Chosen, Unavailable> {
    let cpu = |matrix: TransferMatrix<'static>, why: &str| {
        let g = CpuGather::new(matrix);
        let detail = format!("{why}; SIMD path {}", g.path());
        Chosen {
            gather: Box::new(g),
            kind: "cpu",
            detail,
        }
    };
    let gpu = |g: WgpuGather, why: &str| {
        let detail = gpu_detail(&g, why);
        Chosen {
            gather: Box::new(g),
            kind: "gpu",
            detail,
        }
    };
    Ok(match backend {
        Backend::Auto => match auto_gather(&matrix, &GpuOptions::default()) {
            Ok(g) => gpu(g, "auto: a hardware GPU is present"),
            Err(reason) => cpu(matrix, &reason),
        },
        Backend::Cpu => cpu(matrix, why),
        Backend::Reference => Chosen {
            gather: Box::new(ReferenceGather::new(matrix, DecodeMode::D3d10)),
            kind: "reference",
            detail: format!("{why}: the scalar oracle"),
        },
        Backend::Gpu => match WgpuGather::new(&matrix, &GpuOptions::default()) {
            Ok(g) => gpu(g, why),
            Err(e) => return Err(Unavailable(e.to_string())),
        },
    })
}
