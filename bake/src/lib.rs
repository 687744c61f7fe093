//! `radiosity-bake`: from an OBJ or glTF scene to a compressed transfer matrix.
//!
//! The stages in pipeline order (the user-facing contract is `docs/contract.md`):
//!
//! 1. [`scene`] (the `radiosity-scene` crate): OBJ + MTL and glTF 2.0 loading
//!    ([`scene::Scene::load_with`], by extension): objects, reflectance, emission, textures,
//!    errors that name the file and line or item.
//! 2. [`simplify`]: the paper's voxel simplification into patches ([`simplify::simplify`]),
//!    with per-vertex interpolation weights and the runtime mesh.
//! 3. [`geometry`] (the `radiosity-geometry` crate): the occlusion BVH over the full-detail triangles, polygons, the exact
//!    point-to-polygon kernel and adaptive quadrature.
//! 4. [`form_factor`]: the n × n form-factor matrix ([`form_factor::form_factors`]): exact,
//!    clustered and flat-site pairs with ray-sampled visibility.
//! 5. `hemisphere`: cosine-weighted hemisphere rays from patches, shared by the bake's
//!    burial, escape and dark-patch checks and by [`check::row_check`].
//! 6. [`effects`]: which effects a scene needs (colour, occlusion, emission), each with a
//!    reason.
//! 7. `closure`: burial (surface other objects bury, taken out of the patches), whether light
//!    leaves the scene (F's row sums, then hemisphere rays) and the matching correction of F.
//! 8. `dark`: patches whose row of F is zero, dropped when buried whole, checked by
//!    hemisphere rays ([`pipeline::check_dark`]).
//! 9. [`transfer`]: the multi-bounce transfer matrix `M = Σ (F^C)^b · F`, and the closure's
//!    scaling and capping of F's rows.
//! 10. [`order`]: patch reordering before compression, with estimated errors.
//! 11. [`encode`]: BC1/BC4, u8-log, f16 and f32 encoders from a dense matrix to a
//!     [`radiosity_core::TransferMatrix`].
//! 12. [`pipeline`]: the whole bake ([`pipeline::bake`]) with its report.
//! 13. [`probes`]: light probes placed and weighed over the baked file (a bake parameter).
//!
//! Beside the pipeline: [`host`] (the bake flags, loading with the command line's checks, and
//! a whole bake to a file with progress and cancellation), [`limits`] (what a machine can
//! bake), [`check`] (rows of F against hemisphere rays, object-to-object view factors) and
//! [`rng`] (the deterministic random streams, from `radiosity-geometry`).
#![deny(missing_docs)]

// The stages in pipeline order, one a group so that rustfmt keeps the order.
// The scene and its readers live in `radiosity-scene`, which the path tracer shares without
// the bake; the bake's stages name it as before.
pub use radiosity_scene as scene;

pub mod simplify;

// The geometry stage and the random streams live in `radiosity-geometry`, which the runtime
// shares without the bake's heavy dependencies; the bake's stages name them as before.
pub use radiosity_geometry as geometry;

pub mod form_factor;

pub(crate) mod hemisphere;

pub mod effects;

pub(crate) mod closure;
/// F during the discretisation, dense or as sparse rows.
pub(crate) mod exchange;

pub(crate) mod dark;
/// Each object's own gather row in the patches it shares.
pub(crate) mod part_rows;
/// Direct-light points where shadows fall.
pub mod shadow_points;

pub mod transfer;

pub mod order;

pub mod encode;

pub mod pipeline;

pub mod probes;

pub mod sky;

pub mod systems;

pub mod plan;

// Beside the pipeline.
pub mod check;
pub mod error;
pub mod host;
pub mod limits;
pub use radiosity_geometry::rng;

pub use error::BakeError;
