//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`. The choice
//! and the reason are printed on stderr; an unavailable backend is an error, never a silent
//! fallback (only `auto` chooses).

use anyhow::bail;
use radiosity_backend_cpu::CpuGather;
use radiosity_core::{DecodeMode, Gather, ReferenceGather, TransferMatrix};

/// A chosen gather with the backend kind (`cpu`, `reference`) for reports.
pub(crate) struct Chosen {
    pub(crate) gather: Box<dyn Gather>,
    pub(crate) kind: &'static str,
    pub(crate) detail: String,
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
    let cpu = |why: &str| {
        let g = CpuGather::new(matrix.clone());
        let detail = format!("{why}; SIMD path {}", g.path());
        Chosen {
            gather: Box::new(g),
            kind: "cpu",
            detail,
        }
    };
    let chosen = match requested.as_str() {
        "auto" => cpu("auto: this build has no GPU backend yet"),
        "cpu" => cpu(&format!("requested by {source}")),
        "reference" => Chosen {
            gather: Box::new(ReferenceGather::new(matrix, DecodeMode::D3d10)),
            kind: "reference",
            detail: format!("requested by {source}: the scalar oracle"),
        },
        "gpu" => bail!(
            "backend gpu (from {source}) is not available: this build has no GPU backend yet (issue #6); use auto or cpu"
        ),
        other => {
            bail!("unknown backend {other:?} (from {source}): use auto, cpu, gpu or reference")
        }
    };
    eprintln!("backend: {} ({})", chosen.gather.name(), chosen.detail);
    Ok(chosen)
}
