//! The runtime's input files (`docs/contract.md`): read from disk here, parsed and validated
//! by `radiosity_runtime`. Each error names the file.

use anyhow::Context;
use radiosity_core::Light;
use radiosity_runtime::camera::Camera;
use radiosity_runtime::materials::MaterialEdit;
use radiosity_runtime::points::Point;
use std::path::Path;

/// Reads `path` as text, saying which kind of file could not be read.
fn read(path: &Path, kind: &str) -> anyhow::Result<String> {
    std::fs::read_to_string(path)
        .with_context(|| format!("cannot read {kind} file {}", path.display()))
}

/// Reads, parses and validates a lights file (an environment image's path relative to it).
pub(crate) fn lights(path: &Path) -> anyhow::Result<Vec<Light>> {
    let text = read(path, "lights")?;
    let base = path.parent().unwrap_or(Path::new(""));
    radiosity_runtime::lights::parse_in(&text, base)
        .with_context(|| format!("bad lights file {}", path.display()))
}

/// Reads and parses a points file.
pub(crate) fn points(path: &Path) -> anyhow::Result<Vec<Point>> {
    let text = read(path, "points")?;
    radiosity_runtime::points::parse(&text)
        .with_context(|| format!("bad points file {}", path.display()))
}

/// Reads and parses a materials file.
pub(crate) fn materials(path: &Path) -> anyhow::Result<Vec<MaterialEdit>> {
    let text = read(path, "materials")?;
    radiosity_runtime::materials::parse(&text)
        .with_context(|| format!("bad materials file {}", path.display()))
}

/// Reads, parses and validates a camera file, with a note naming the fields it leaves out
/// and the defaults they took (`None` when it gives them all), for the caller to print once it
/// succeeds.
pub(crate) fn camera(path: &Path) -> anyhow::Result<(Camera, Option<String>)> {
    let text = read(path, "camera")?;
    let cam =
        Camera::parse(&text).with_context(|| format!("bad camera file {}", path.display()))?;
    let note = Camera::defaults_note(&text).map(|d| format!("camera file {}: {d}", path.display()));
    Ok((cam, note))
}
