//! Writing the runtime's linear-light images ([`LinearImage`]) as PNG files, atomically, and
//! the `--exposure` check. Shared by `render`, `demo`, `pathtrace` and `report`.

pub(crate) use radiosity_runtime::image::LinearImage;
use std::path::Path;

/// Writes the tone-mapped image as PNG, atomically (a temporary file renamed into place),
/// so that a failure never leaves a partial file.
pub(crate) fn save_png(img: &LinearImage, path: &Path, exposure: f32) -> anyhow::Result<()> {
    save_png_atomic(&srgb8(img, exposure), path)
}

/// The tone-mapped image as an 8-bit sRGB `image` buffer.
pub(crate) fn srgb8(img: &LinearImage, exposure: f32) -> image::RgbImage {
    image::RgbImage::from_raw(img.width, img.height, img.to_srgb8(exposure))
        .expect("three bytes a pixel")
}

/// Refuses an `--exposure` that is not a finite positive number.
pub(crate) fn check_exposure(exposure: Option<f32>) -> anyhow::Result<()> {
    match exposure {
        Some(e) if !(e.is_finite() && e > 0.0) => {
            anyhow::bail!("--exposure must be a finite number above 0, not {e}")
        }
        _ => Ok(()),
    }
}

/// Writes an 8-bit image as PNG, atomically ([`crate::output::write_atomic`]).
pub(crate) fn save_png_atomic(img: &image::RgbImage, path: &Path) -> anyhow::Result<()> {
    crate::output::write_atomic(path, |w| {
        img.write_to(w, image::ImageFormat::Png)?;
        Ok(())
    })
}
