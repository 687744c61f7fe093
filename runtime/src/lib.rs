//! `radiosity-runtime`: everything an engine does with a baked `.rad` file every frame, without
//! the bake's dependencies (core, geometry, rayon and serde only).
//!
//! - [`BakedScene`] ([`scene`]): a parsed file with the ray caster over its full-detail mesh;
//!   per-patch direct light from point, spot and directional lights with shadow rays at the
//!   file's direct-light points; a whole [`Frame`] around any [`radiosity_core::Gather`].
//! - [`points`]: the total irradiance at any point and normal (a final gather over the frame's
//!   patches, a second gather near surfaces, the emitters' exact direct light; inside and
//!   outside detected).
//! - [`probes`]: the light probes' frame `P·(B − E)` and the irradiance they give a point or a
//!   moving object.
//! - [`render`]: the per-pixel shading lookup (the patches' kernel weights at a hit), primary
//!   visibility and shading of a camera's image; [`camera`] and [`image`] for it.
//! - [`objects`]: per-object area-weighted irradiance and radiosity ([`ObjectShares`]: patches
//!   shared by several objects' parts).
//! - [`daylight`]: a clear day's sun and sky for a sun position, for frames of a moving sun.
//! - [`lights`], [`materials`], [`points::parse`]: the lights, materials and points files of
//!   `docs/contract.md`, parsed and validated.
//!
//! Errors are [`Error`]: which input is wrong and why, in one line.
#![deny(missing_docs)]

/// Returns an [`Error::Invalid`] with a formatted message.
macro_rules! invalid {
    ($($t:tt)*) => { return Err($crate::Error::Invalid(format!($($t)*))) };
}
/// Returns an [`Error::Overflow`] with a formatted message.
macro_rules! overflow {
    ($($t:tt)*) => { return Err($crate::Error::Overflow(format!($($t)*))) };
}

pub mod camera;
pub mod daylight;
pub mod image;
pub mod lights;
pub mod materials;
pub mod objects;
pub mod points;
pub mod probes;
pub mod render;
pub mod scene;
pub mod systems;

pub use objects::{ObjectLight, ObjectShares, SharedPatch};
pub use scene::{BakedScene, Frame};

/// What went wrong at run time.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file has no mesh section, which the named capability needs.
    #[error("this .rad file has no mesh section ({0} needs one); bake it again with this version")]
    NoMesh(String),
    /// An input (a lights, points, materials or camera file, a value, a length) is refused.
    #[error("{0}")]
    Invalid(String),
    /// The frame's light overflows f32 (emission or light intensities too large).
    #[error("{0}")]
    Overflow(String),
    /// The gather failed.
    #[error(transparent)]
    Gather(#[from] radiosity_core::GatherError),
}

/// A runtime result.
pub type Result<T> = std::result::Result<T, Error>;
