//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`
//! (`radiosity_backend_wgpu::choose`, which the C ABI shares). The choice, the reason and (for
//! the GPU) the adapter and decode path are printed on stderr; an unavailable backend is an
//! error that says why, never a silent fallback (only `auto` chooses).

use anyhow::bail;
use radiosity_backend_wgpu::{Backend, Chosen};
use radiosity_core::{Gather, RadFile, TransferMatrix};
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
            "{what} does not take a level file ({} systems, no one-matrix transfer); light it with `radiosity solve LEVEL.rad`",
            sys.count()
        );
    }
    Ok(())
}

/// A level lit by one gather a system, with the backend it runs on and the gather's name.
pub(crate) type ChosenLevel = (Level<Box<dyn Gather>>, &'static str, String);

/// A level file's systems, each with the requested backend's gather (on the GPU each system
/// on a device of its own; `auto` decides for the first system and the others follow), ready
/// to light (`solve`); the light between systems crosses on the CPU.
pub(crate) fn choose_level(flag: Option<&str>, file: &RadFile<'_>) -> anyhow::Result<ChosenLevel> {
    let (mut backend, requested, source) = requested(flag)?;
    let mut first: Option<(String, &'static str, String)> = None;
    let level = Level::new(file, |s, one| {
        let why = format!("requested by {source}");
        let chosen = radiosity_backend_wgpu::choose(backend, one.matrix.clone().into_owned(), &why)
            .map_err(|e| {
                anyhow::anyhow!(
                    "backend {requested} (from {source}) is not available for system {s} of the level: {}",
                    e.0
                )
            })?;
        if s == 0 {
            backend = Backend::from_name(chosen.kind).unwrap_or(Backend::Cpu);
            first = Some((
                chosen.detail.clone(),
                chosen.kind,
                format!("{}-systems", chosen.gather.name()),
            ));
        }
        Ok::<_, anyhow::Error>(chosen.gather)
    })
    .map_err(|e| match e {
        radiosity_runtime::systems::LevelError::Gather(_, e) => e,
        other => anyhow::anyhow!("{other}"),
    })?;
    let (detail, kind, name) = first.unwrap_or_default();
    eprintln!(
        "backend: {kind} ({} systems of a level; {detail})",
        level.count()
    );
    Ok((level, kind, name))
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
