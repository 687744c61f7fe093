//! The simplified-scene patch as stored in a `.rad` file.

use crate::Rgb;
use bytemuck::{Pod, Zeroable};

/// One patch of the simplified scene, in the numbering of the transfer matrix.
///
/// `#[repr(C)]`, 56 bytes, [`Pod`]: the `.rad` PATCHES section is a plain `[Patch]`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Patch {
    /// Area-weighted centre, in scene units.
    pub centre: [f32; 3],
    /// Area in scene units squared; strictly positive.
    pub area: f32,
    /// Unit normal of the front (counter-clockwise) side.
    pub normal: [f32; 3],
    /// Index of the OBJ object the patch came from (into the `.rad` object names).
    pub object: u32,
    /// Diffuse reflectance ρ per channel, each in `[0, 1)`.
    pub reflectance: Rgb,
    /// Emitted exitance E = π·L (W/m²), where L is the MTL `Ke` radiance.
    pub emission: Rgb,
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{align_of, offset_of, size_of};

    #[test]
    fn layout_is_stable() {
        assert_eq!(size_of::<Patch>(), 56);
        assert_eq!(align_of::<Patch>(), 4);
        assert_eq!(offset_of!(Patch, centre), 0);
        assert_eq!(offset_of!(Patch, area), 12);
        assert_eq!(offset_of!(Patch, normal), 16);
        assert_eq!(offset_of!(Patch, object), 28);
        assert_eq!(offset_of!(Patch, reflectance), 32);
        assert_eq!(offset_of!(Patch, emission), 44);
    }
}
