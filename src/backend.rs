//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`
//! (`radiosity_backend_wgpu::choose`, which the C ABI shares). The choice, the reason and (for
//! the GPU) the adapter and decode path are printed on stderr; an unavailable backend is an
//! error that says why, never a silent fallback (only `auto` chooses).

use anyhow::bail;
use radiosity_backend_wgpu::{Backend, Chosen};
use radiosity_core::TransferMatrix;

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
    let Some(backend) = Backend::from_name(&requested) else {
        bail!("unknown backend {requested:?} (from {source}): use auto, cpu, gpu or reference");
    };
    let chosen = radiosity_backend_wgpu::choose(backend, matrix, &format!("requested by {source}"))
        .map_err(|e| anyhow::anyhow!("backend gpu (from {source}) is not available: {}", e.0))?;
    eprintln!("backend: {} ({})", chosen.gather.name(), chosen.detail);
    Ok(chosen)
}
