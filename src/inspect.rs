//! `radiosity inspect`.
use std::path::Path;

pub(crate) fn run(_file: &Path, _json: bool) -> anyhow::Result<()> {
    anyhow::bail!("inspect is not implemented yet")
}
