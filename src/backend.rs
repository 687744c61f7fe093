//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`
//! (`radiosity_backend_wgpu::choose`, which the C ABI shares). The choice, the reason and (for
//! the GPU) the adapter and decode path are printed on stderr; an unavailable backend is an
//! error that says why, never a silent fallback (only `auto` chooses).

use anyhow::bail;
use radiosity_backend_cpu::CpuGather;
use radiosity_backend_wgpu::{Backend, Chosen};
use radiosity_core::{RadFile, TransferMatrix};
use radiosity_runtime::systems::Level;

/// The backend asked for and where the request came from.
fn requested(flag: Option<&str>) -> anyhow::Result<(Backend, String, &'static str)> {
    let env = std::env::var("RADIOSITY_BACKEND").ok();
    let (requested, source) = match (flag, env.as_deref()) {
        (Some(f), _) => (f.to_owned(), "--backend"),
        (None, Some(e)) if !e.is_empty() => (e.to_owned(), "RADIOSITY_BACKEND"),
        _ => ("auto".to_owned(), "default"),
    };
    let Some(backend) = Backend::from_name(&requested) else {
        bail!("unknown backend {requested:?} (from {source}): use auto, cpu, gpu or reference");
    };
    Ok((backend, requested, source))
}

/// Refuses a level file (`.rad` version 3, its transfer split into systems) for a command
/// that lights one matrix only (`render`, a reflectance edit, `--export-dds`): one line that
/// says what does light it.
pub(crate) fn refuse_level(file: &RadFile<'_>, what: &str) -> anyhow::Result<()> {
    if let Some(sys) = &file.systems {
        bail!(
            "{what} does not take a level file ({} systems, no one-matrix transfer); light it with `radiosity solve LEVEL.rad --backend cpu`",
            sys.count()
        );
    }
    Ok(())
}

/// A level file's systems, each with the CPU backend's gather, ready to light (`solve`):
/// `auto` and `cpu` give it; `gpu` and `reference` cannot run a level and are refused.
pub(crate) fn choose_level(
    flag: Option<&str>,
    file: &RadFile<'_>,
) -> anyhow::Result<Level<CpuGather<'static>>> {
    let (backend, requested, source) = requested(flag)?;
    if !matches!(backend, Backend::Auto | Backend::Cpu) {
        bail!(
            "backend {requested} (from {source}) cannot light a level file (systems): use --backend cpu"
        );
    }
    let level = Level::new(file, |_, one| {
        Ok::<_, std::convert::Infallible>(CpuGather::new(one.matrix.clone().into_owned()))
    })
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    eprintln!(
        "backend: cpu ({} systems of a level, requested by {source})",
        level.count()
    );
    Ok(level)
}

pub(crate) fn choose(
    flag: Option<&str>,
    matrix: TransferMatrix<'static>,
) -> anyhow::Result<Chosen> {
    let (backend, _, source) = requested(flag)?;
    let chosen = radiosity_backend_wgpu::choose(backend, matrix, &format!("requested by {source}"))
        .map_err(|e| anyhow::anyhow!("backend gpu (from {source}) is not available: {}", e.0))?;
    eprintln!("backend: {} ({})", chosen.gather.name(), chosen.detail);
    Ok(chosen)
}
