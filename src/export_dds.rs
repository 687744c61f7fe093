//! `inspect --export-dds DIR`: every tile plane of the matrix as a standard DDS texture.
//!
//! BC1/BC4 planes are written as they are stored (`BC1_UNORM`, `BC4_UNORM`); u8, f16 and f32
//! planes are rearranged from 4×4 blocks into rows (`R8_UNORM`, `R16_FLOAT`, `R32_FLOAT`).
//! `tiles.json` beside them gives each file's place in the matrix and its log scale, so codes
//! can be turned back into values: `v = v_max · exp(shift · (q/255 − 1))`, 0 for q = 0.

use anyhow::Context;
use ddsfile::{AlphaMode, D3D10ResourceDimension, Dds, DxgiFormat, NewDxgiParams};
use radiosity_core::{Format, RadFile};
use serde_json::json;
use std::path::Path;

pub(crate) fn export(file: &RadFile<'_>, dir: &Path) -> anyhow::Result<usize> {
    crate::backend::refuse_level(file, "--export-dds")?;
    crate::output::create_dir(dir)?;
    let m = &file.matrix;
    let l = &m.layout;
    let bb = l.format().block_bytes();
    let (dxgi, texel_bytes) = match l.format() {
        Format::Bc1 => (DxgiFormat::BC1_UNorm, 0),
        Format::Bc4 => (DxgiFormat::BC4_UNorm, 0),
        Format::U8 => (DxgiFormat::R8_UNorm, 1),
        Format::F16 => (DxgiFormat::R16_Float, 2),
        Format::F32 => (DxgiFormat::R32_Float, 4),
    };
    let plane_names: &[&str] = match (l.format(), l.channels()) {
        (Format::Bc1, _) => &["rgb"],
        (_, 1) => &["grey"],
        _ => &["r", "g", "b"],
    };
    let mut index = Vec::new();
    for tile in l.tiles() {
        let (ty, tx) = (tile.row0 / l.tile_size(), tile.col0 / l.tile_size());
        let plane_bytes = tile.blocks_high() * tile.blocks_wide() * bb;
        for (plane, name) in plane_names.iter().enumerate() {
            let start = l.block_offset(&tile, plane, 0, 0);
            let src = &m.blocks[start..start + plane_bytes];
            let mut dds = Dds::new_dxgi(NewDxgiParams {
                height: tile.rows as u32,
                width: tile.cols as u32,
                depth: None,
                format: dxgi,
                mipmap_levels: None,
                array_layers: None,
                caps2: None,
                is_cubemap: false,
                resource_dimension: D3D10ResourceDimension::Texture2D,
                alpha_mode: AlphaMode::Unknown,
            })
            .context("cannot create a DDS header")?;
            if texel_bytes == 0 {
                dds.data.copy_from_slice(src);
            } else {
                // Blocks of 16 texels (row-major inside) → rows of the tile.
                for (b, block) in src.chunks_exact(bb).enumerate() {
                    let (br, bc) = (b / tile.blocks_wide(), b % tile.blocks_wide());
                    for i in 0..16 {
                        let (r, c) = (br * 4 + i / 4, bc * 4 + i % 4);
                        let at = (r * tile.cols + c) * texel_bytes;
                        dds.data[at..at + texel_bytes]
                            .copy_from_slice(&block[i * texel_bytes..(i + 1) * texel_bytes]);
                    }
                }
            }
            let fname = format!("tile_{ty:03}_{tx:03}_{name}.dds");
            let path = dir.join(&fname);
            crate::output::write_atomic(&path, |w| Ok(dds.write(w)?))?;
            let scale = l.format().is_log().then(|| {
                let channel = if l.format() == Format::Bc1 {
                    None
                } else {
                    Some(plane)
                };
                let scales: Vec<_> = (0..l.channels())
                    .filter(|c| channel.is_none_or(|p| p == *c))
                    .map(|c| m.scales[l.scale_index(tile.index, c)])
                    .map(|s| json!({"v_max": s.v_max, "shift": s.shift}))
                    .collect();
                scales
            });
            index.push(json!({
                "file": fname, "row0": tile.row0, "col0": tile.col0, "rows": tile.rows, "cols": tile.cols,
                "format": l.format().name(), "scales": scale,
            }));
        }
    }
    let n = index.len();
    let meta = json!({ "patches": file.n(), "tile_size": l.tile_size(), "tiles": index,
        "note": "rows/cols beyond `patches` are padding; sparse entries and block corrections are not in the textures" });
    crate::output::write_bytes(
        &dir.join("tiles.json"),
        serde_json::to_string_pretty(&meta)?.as_bytes(),
    )?;
    Ok(n)
}
