//! `radiosity view-factors` (being written for issue #3).
use std::path::Path;

pub(crate) fn run(_scene: &Path, _json: bool) -> anyhow::Result<()> {
    anyhow::bail!("view-factors is not implemented yet")
}
