//! Backend choice at run time: `--backend`, else `RADIOSITY_BACKEND`, else `auto`
//! ([`radiosity_perf::backend`]). The choice, the reason and (for the GPU) the adapter and
//! decode path are printed on stderr; an unavailable backend is an error that says why.

use radiosity_backend_wgpu::Chosen;
use radiosity_core::{RadFile, Rgb, TransferMatrix};
pub(crate) use radiosity_perf::backend::{ChosenLevel, refuse_level};
use radiosity_perf::backend::{Request, choose_level as level_on};

/// The level `file` on the backend of `flag` (else the environment's, else `auto`), with
/// `edits` (level patch, new reflectance) in the systems' gathers; prints the choice.
pub(crate) fn choose_level(
    flag: Option<&str>,
    file: &RadFile<'_>,
    edits: &[(u32, Rgb)],
) -> anyhow::Result<ChosenLevel> {
    let chosen = level_on(&Request::from_env(flag)?, file, edits)?;
    eprintln!("backend: {}", chosen.summary());
    Ok(chosen)
}

/// The gather of `matrix` on the backend of `flag` (else the environment's, else `auto`);
/// prints the choice.
pub(crate) fn choose(
    flag: Option<&str>,
    matrix: TransferMatrix<'static>,
) -> anyhow::Result<Chosen> {
    let chosen = radiosity_perf::backend::choose(&Request::from_env(flag)?, matrix)?;
    eprintln!("backend: {} ({})", chosen.gather.name(), chosen.detail);
    Ok(chosen)
}
