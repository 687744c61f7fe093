//! Core formats ↔ wgpu texture formats.

use radiosity_core::Format;

/// The texture format whose texels are this format's blocks, for the formats the texture unit
/// decodes (BC1, BC4); `None` for the others.
pub(crate) fn texture_format(format: Format) -> Option<wgpu::TextureFormat> {
    match format {
        // Linear, not sRGB: the texels are log codes, not colours.
        Format::Bc1 => Some(wgpu::TextureFormat::Bc1RgbaUnorm),
        Format::Bc4 => Some(wgpu::TextureFormat::Bc4RUnorm),
        Format::U8 | Format::F16 | Format::F32 => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bc_formats_have_8_byte_blocks() {
        for f in [Format::Bc1, Format::Bc4] {
            let t = texture_format(f).unwrap();
            assert_eq!(t.block_dimensions(), (4, 4));
            assert_eq!(t.block_copy_size(None), Some(f.block_bytes() as u32));
            assert!(!t.is_srgb());
        }
        assert_eq!(texture_format(Format::U8), None);
    }
}
