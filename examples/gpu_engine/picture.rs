//! The frame's outputs: `radiosity render`'s tone map, PNGs and lights files written
//! atomically.

use super::Result;
use glam::Vec3;
use radiosity_core::Rgb;
use std::path::{Path, PathBuf};

/// Exposure, tone map and sRGB of `radiosity render` (its `picture` module).
pub(crate) fn tone_map(pixels: &[Vec3], width: u32, height: u32) -> image::RgbImage {
    let luminance = |c: Vec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
    let mut lum: Vec<f32> = pixels
        .iter()
        .map(|p| luminance(*p))
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    let exposure = if lum.is_empty() {
        1.0
    } else {
        let k = ((lum.len() - 1) as f64 * 0.99) as usize;
        let (_, p99, _) = lum.select_nth_unstable_by(k, f32::total_cmp);
        0.8 / *p99
    };
    let srgb = |x: f32| {
        if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        }
    };
    let mut img = image::RgbImage::new(width, height);
    for (px, v) in img.pixels_mut().zip(pixels) {
        let v = *v * exposure;
        *px = image::Rgb([v.x, v.y, v.z].map(|x| {
            let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
            let t = x * (1.0 + x / 16.0) / (1.0 + x);
            (srgb(t.min(1.0)) * 255.0 + 0.5) as u8
        }));
    }
    img
}

/// Writes `bytes` to `path` through a temporary file renamed into place.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes)
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("cannot write {}: {e}", path.display()).into()
        })
}

/// Writes frame `f`'s picture as `DIR/frame-NNN.png` and its light as `DIR/lights-NNN.json`
/// (a lights file of one point light). Returns the PNG's path.
pub(crate) fn write_frame(
    out: &Path,
    f: u32,
    pixels: &[Vec3],
    (w, h): (u32, u32),
    position: Vec3,
    intensity: Rgb,
) -> Result<PathBuf> {
    let png = out.join(format!("frame-{f:03}.png"));
    let mut encoded = Vec::new();
    tone_map(pixels, w, h).write_to(
        &mut std::io::Cursor::new(&mut encoded),
        image::ImageFormat::Png,
    )?;
    write_atomic(&png, &encoded)?;
    let [px, py, pz] = position.to_array();
    let lights = format!(
        "{{\"lights\":[{{\"type\":\"point\",\"position\":[{px:?},{py:?},{pz:?}],\"intensity\":[{:?},{:?},{:?}]}}]}}\n",
        intensity.r, intensity.g, intensity.b
    );
    write_atomic(&out.join(format!("lights-{f:03}.json")), lights.as_bytes())?;
    Ok(png)
}
