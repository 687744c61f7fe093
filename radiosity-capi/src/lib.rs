//! `radiosity-capi`: the C ABI of the radiosity runtime, for engines written in C or C++ (and
//! plugin hosts such as Godot's GDExtension or Unreal). The header
//! `radiosity-capi/include/radiosity.h` is generated from this crate by cbindgen and committed.
//!
//! A host opens a `.rad` ([`rad_scene_open`], [`rad_scene_from_bytes`]), reads its patches and
//! object names, computes first exitance from its own direct light ([`rad_first_exitance`]),
//! gathers `y = M · x` on a backend ([`rad_gather_new`], [`rad_gather_run`]) and carries `y`
//! to the corners of the full-detail mesh ([`rad_scene_corner_indirect`]); a moving object
//! takes its light from the scene's probes ([`rad_scene_probes_frame`],
//! [`rad_probe_irradiance`]).
//!
//! # Rules
//!
//! - **Errors**: every function that can fail returns an `int32_t` status, [`RAD_OK`] (0) on
//!   success, one of the `RAD_ERR_*` codes otherwise, and sets [`rad_last_error`]: this
//!   thread's last failure, a NUL-terminated message valid until this thread's next call into
//!   the library. Functions that return a count or a pointer return 0 or NULL on failure and set
//!   the message too. Nothing unwinds across the boundary: a panic inside is caught and returned
//!   as [`RAD_ERR_PANIC`].
//! - **Checks**: every pointer is checked for NULL and alignment, every length against the
//!   scene (`n` is the patch count, `corners` three times the triangle count). Input and output
//!   arrays may overlap (the input is copied first).
//! - **Ownership**: a `RadScene` and a `RadGather` are owned by the caller and freed with
//!   [`rad_scene_free`] and [`rad_gather_free`] (NULL is a no-op). Pointers a scene returns
//!   (patches, triangles, vertices, object names) are owned by the scene and live as long as it.
//!   A scene must outlive every gather made from it. Bytes given to [`rad_scene_from_bytes`]
//!   are copied.
//! - **Threads**: a scene is read-only once made, so one scene may be read from many threads
//!   at once. A gather is used by one thread at a time (it keeps scratch buffers); make one
//!   gather per thread to gather in parallel.

mod bake;
mod error;
mod gather;
mod probes;
mod runtime;
mod scene;

pub use bake::{RadProgress, rad_bake};
pub use error::rad_last_error;
pub use gather::{
    RadGather, rad_gather_backend, rad_gather_frame, rad_gather_free, rad_gather_name,
    rad_gather_new, rad_gather_run, rad_gather_set_priority, rad_gather_system_range,
    rad_gather_systems, rad_gather_update_within,
};
pub use probes::{
    RadProbeVisible, rad_probe_irradiance, rad_scene_probe_count, rad_scene_probe_positions,
    rad_scene_probes_frame,
};
pub use runtime::{
    RAD_LIGHT_DIRECTIONAL, RAD_LIGHT_POINT, RAD_LIGHT_SKY, RAD_LIGHT_SPOT, RAD_POINT_INSIDE,
    RAD_POINT_OK, RAD_POINT_OUTSIDE, RadLight, rad_scene_direct, rad_scene_point_irradiance,
};
pub use scene::{
    RadScene, rad_first_exitance, rad_scene_corner_indirect, rad_scene_free, rad_scene_from_bytes,
    rad_scene_object_count, rad_scene_object_name, rad_scene_open, rad_scene_patch_count,
    rad_scene_patches, rad_scene_triangle_count, rad_scene_triangles, rad_scene_vertex_count,
    rad_scene_vertices,
};

use bytemuck::{Pod, Zeroable};
use std::ffi::{CStr, c_char};

/// Success.
pub const RAD_OK: i32 = 0;
/// A required pointer is NULL or not aligned for its type.
pub const RAD_ERR_POINTER: i32 = 1;
/// A length does not match the scene (patch count, three corners per triangle).
pub const RAD_ERR_LENGTH: i32 = 2;
/// A value is refused: a negative or non-finite exitance or light, an unknown light kind, bad
/// bake options, a scene that cannot be loaded or baked, a string that is not UTF-8.
pub const RAD_ERR_VALUE: i32 = 3;
/// The file could not be read.
pub const RAD_ERR_IO: i32 = 4;
/// The bytes are not a valid `.rad` file.
pub const RAD_ERR_FORMAT: i32 = 5;
/// The scene has no full-detail mesh (the bake did not store one) or it has no triangles.
pub const RAD_ERR_NO_MESH: i32 = 6;
/// The backend name is not one of "auto", "cpu", "gpu", "reference".
pub const RAD_ERR_BACKEND: i32 = 7;
/// The backend cannot run here (no GPU adapter, or the GPU cannot hold the matrix).
pub const RAD_ERR_UNAVAILABLE: i32 = 8;
/// The gather failed while running (a lost device, an allocation refused).
pub const RAD_ERR_GATHER: i32 = 9;
/// An internal error (a caught panic); the message says where.
pub const RAD_ERR_PANIC: i32 = 10;
/// The scene has no light probes (baked with `--probes none`), or none of them is in sight of
/// the point asked about.
pub const RAD_ERR_NO_PROBES: i32 = 11;
/// The bake was cancelled from its progress callback; nothing was written.
pub const RAD_ERR_CANCELLED: i32 = 12;

/// A linear RGB triple of floats: exitance and irradiance in W/m², reflectance unitless.
/// The layout of the core's `Rgb`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RadRgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

/// One patch of the simplified scene, in the matrix numbering (the index `x` and `y` use).
/// The layout of the core's `Patch` (56 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RadPatch {
    /// Area-weighted centre, in scene units.
    pub centre: [f32; 3],
    /// Area in scene units squared; strictly positive.
    pub area: f32,
    /// Unit normal of the front (counter-clockwise) side.
    pub normal: [f32; 3],
    /// Object index (see rad_scene_object_name).
    pub object: u32,
    /// Diffuse reflectance per channel, each in [0, 1).
    pub reflectance: RadRgb,
    /// Emitted exitance E = pi * L (W/m^2).
    pub emission: RadRgb,
}

/// One triangle of the full-detail mesh. The layout of the core's `MeshTriangle` (40 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RadTriangle {
    /// Vertex indices (into rad_scene_vertices), counter-clockwise seen from the front; corner
    /// c of the triangle is vertices[c].
    pub vertices: [u32; 3],
    /// Object index (see rad_scene_object_name).
    pub object: u32,
    /// Mean diffuse reflectance over the triangle.
    pub reflectance: RadRgb,
    /// Emitted exitance E = pi * L (W/m^2).
    pub emission: RadRgb,
}

const VERSION: &CStr =
    match CStr::from_bytes_with_nul(concat!(env!("CARGO_PKG_VERSION"), "\0").as_bytes()) {
        Ok(v) => v,
        Err(_) => panic!("the version has no NUL inside"),
    };

/// The library's version, e.g. "0.1.0"; a static string.
#[unsafe(no_mangle)]
pub extern "C" fn rad_version() -> *const c_char {
    VERSION.as_ptr()
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{align_of, offset_of, size_of};
    use radiosity_core::{MeshTriangle, Patch, Rgb};

    #[test]
    fn rgb_has_the_core_layout() {
        assert_eq!(size_of::<RadRgb>(), size_of::<Rgb>());
        assert_eq!(align_of::<RadRgb>(), align_of::<Rgb>());
        assert_eq!(offset_of!(RadRgb, r), offset_of!(Rgb, r));
        assert_eq!(offset_of!(RadRgb, g), offset_of!(Rgb, g));
        assert_eq!(offset_of!(RadRgb, b), offset_of!(Rgb, b));
    }

    #[test]
    fn patch_has_the_core_layout() {
        assert_eq!(size_of::<RadPatch>(), size_of::<Patch>());
        assert_eq!(align_of::<RadPatch>(), align_of::<Patch>());
        assert_eq!(offset_of!(RadPatch, centre), offset_of!(Patch, centre));
        assert_eq!(offset_of!(RadPatch, area), offset_of!(Patch, area));
        assert_eq!(offset_of!(RadPatch, normal), offset_of!(Patch, normal));
        assert_eq!(offset_of!(RadPatch, object), offset_of!(Patch, object));
        assert_eq!(
            offset_of!(RadPatch, reflectance),
            offset_of!(Patch, reflectance)
        );
        assert_eq!(offset_of!(RadPatch, emission), offset_of!(Patch, emission));
        // The same bytes read as the same values.
        let p = Patch {
            centre: [1.0, 2.0, 3.0],
            area: 4.0,
            normal: [0.0, 1.0, 0.0],
            object: 7,
            reflectance: Rgb::new(0.1, 0.2, 0.3),
            emission: Rgb::new(5.0, 6.0, 7.0),
        };
        let r: RadPatch = bytemuck::cast(p);
        assert_eq!(r.centre, p.centre);
        assert_eq!(r.object, 7);
        assert_eq!(
            r.emission,
            RadRgb {
                r: 5.0,
                g: 6.0,
                b: 7.0
            }
        );
    }

    #[test]
    fn triangle_has_the_core_layout() {
        assert_eq!(size_of::<RadTriangle>(), size_of::<MeshTriangle>());
        assert_eq!(align_of::<RadTriangle>(), align_of::<MeshTriangle>());
        assert_eq!(
            offset_of!(RadTriangle, vertices),
            offset_of!(MeshTriangle, vertices)
        );
        assert_eq!(
            offset_of!(RadTriangle, object),
            offset_of!(MeshTriangle, object)
        );
        assert_eq!(
            offset_of!(RadTriangle, reflectance),
            offset_of!(MeshTriangle, reflectance)
        );
        assert_eq!(
            offset_of!(RadTriangle, emission),
            offset_of!(MeshTriangle, emission)
        );
    }

    #[test]
    fn version_is_the_crate_version() {
        // SAFETY: rad_version returns a pointer to a static NUL-terminated string.
        let v = unsafe { CStr::from_ptr(rad_version()) };
        assert_eq!(v.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
    }
}
