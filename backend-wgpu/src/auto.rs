//! The GPU half of the `auto` backend choice, shared by the CLI and the C ABI: the wgpu gather
//! on a **hardware** adapter when there is one and it can hold the matrix. A software
//! rasteriser such as llvmpipe is slower than the CPU backend on the same cores, so `auto`
//! never picks one; the caller falls back to the CPU gather with the reason given.

use crate::{GpuOptions, WgpuGather, adapters};
use radiosity_core::TransferMatrix;

/// The gather `auto` runs on the GPU: built on the first hardware adapter, else `Err` with
/// the reason to use the CPU instead, a sentence starting `auto: ` (no adapter, only software
/// rasterisers and which, or why the hardware GPU cannot run the matrix).
pub fn auto_gather(
    matrix: &TransferMatrix<'_>,
    options: &GpuOptions,
) -> Result<WgpuGather, String> {
    let all = adapters();
    match all.iter().find(|a| a.info.is_hardware()) {
        Some(adapter) => WgpuGather::on_adapter(matrix, adapter, options)
            .map_err(|e| format!("auto: the GPU cannot run it ({e})")),
        None if all.is_empty() => Err("auto: no GPU adapter".to_owned()),
        None => {
            let names: Vec<String> = all
                .iter()
                .map(|a| format!("{} via {}", a.info.name, a.info.backend))
                .collect();
            Err(format!(
                "auto: no hardware GPU, only software rasterisers ({}; --backend gpu uses them)",
                names.join(", ")
            ))
        }
    }
}

/// The level `auto` lights on the GPU ([`crate::WgpuLevel`]): on the first hardware adapter,
/// else `Err` with the reason to use the CPU instead, as [`auto_gather`] says it.
pub fn auto_level(
    file: &radiosity_core::RadFile<'_>,
    options: &GpuOptions,
) -> Result<crate::WgpuLevel, String> {
    let all = adapters();
    match all.iter().find(|a| a.info.is_hardware()) {
        Some(adapter) => crate::WgpuLevel::on_adapter(file, adapter, options)
            .map_err(|e| format!("auto: the GPU cannot run the level ({e})")),
        None if all.is_empty() => Err("auto: no GPU adapter".to_owned()),
        None => Err(
            "auto: no hardware GPU, only software rasterisers (--backend gpu uses them)".to_owned(),
        ),
    }
}
