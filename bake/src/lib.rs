//! `radiosity-bake`: from an OBJ or glTF scene to a compressed transfer matrix.
//!
//! The modules below are declared in layers, bottom-up: each imports only modules declared
//! before it (`scripts/layers.py` checks it, and that ARCHITECTURE.md's table lists them in
//! this order). The pipeline runs them in the same order but for two pairs: the order
//! stage measures its candidates with the encoder, and the systems' choice is made before the
//! discretisation that needs it. The user-facing contract is `docs/contract.md`.
//!
//! - Beneath the stages: [`error`], [`hooks`] (progress and cancellation), [`geometry`] and
//!   [`rng`] (the `radiosity-geometry` crate), [`scene`] (OBJ + MTL and glTF loading),
//!   [`patch`] (the patch model and per-patch helpers: points, hemisphere directions, seeds,
//!   identity), [`effect_plan`] (the effect plan: which effects a scene calls for, each with its
//!   reason).
//! - The discretisation: [`simplify`] (scene → patches), [`form_factor`] (the burial survey
//!   and F, dense or as sparse rows), `exposure` (buried surface taken out of the patches),
//!   `closure` (whether light leaves the scene, and F corrected to match),
//!   [`shadow_points`], `dark_patches`, `part_rows`, `bounce_rows`, [`systems`] (a level's cut), and
//!   [`discretise`] which runs them.
//! - The matrix: [`transfer`] (`M = Σ (F^C)^b F`), [`encode`] (BC1/BC4, u8-log, f16, f32),
//!   [`order`] (patch renumbering before compression, with estimated errors).
//! - The outputs: [`report`] (the `bake --json` object), [`passes`] (probes, sky visibility:
//!   outputs over a finished transfer behind one interface), [`pipeline`] (the whole bake, one
//!   matrix or a level).
//! - On top: [`limits`] (what a machine can bake), [`host`] (flags, loading, a bake to a file
//!   with progress), [`plan`] (planned, sharded and re-used bakes), [`check`] (rows of F against
//!   hemisphere rays, object-to-object view factors).
#![deny(missing_docs)]

// One declaration a group, so that rustfmt keeps the layer order.

// Beneath the stages.
pub mod error;

pub mod hooks;

pub use radiosity_geometry as geometry;

pub use radiosity_geometry::rng;

/// The scene and its readers: the `radiosity-scene` crate, which the path tracer shares
/// without the bake.
pub use radiosity_scene as scene;

pub mod patch;

pub mod effect_plan;

// The discretisation.
pub mod simplify;

pub mod form_factor;

/// The surface other objects bury, taken out of the patches.
pub(crate) mod exposure;

/// Whether light leaves the scene, and F corrected to match.
pub(crate) mod closure;

/// Direct-light points where shadows fall.
pub mod shadow_points;

/// Patches that see nothing: dropped when buried whole, checked by hemisphere rays.
pub(crate) mod dark_patches;

/// Each object's own gather row in the patches it shares.
pub(crate) mod part_rows;

/// Each patch's first bounce gathered where its rays land (cast as part rows are).
pub(crate) mod bounce_rows;

pub mod systems;

pub mod discretise;

// The matrix.
pub mod transfer;

pub mod encode;

pub mod order;

// The outputs.
pub mod report;

pub mod passes;

pub mod pipeline;

// On top.
pub mod limits;

pub mod host;

pub mod plan;

pub mod check;

pub use error::BakeError;
