//! `radiosity-bake`: from an OBJ or glTF scene to a compressed transfer matrix.
//!
//! The stages in pipeline order (the user-facing contract is `docs/contract.md`):
//!
//! 1. [`scene`]: OBJ + MTL and glTF 2.0 loading ([`scene::Scene::load_with`], by extension):
//!    objects, reflectance, emission, textures, errors that name the file and line or item.
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
//! 7. [`bounce`]: the multi-bounce transfer matrix `M = Σ (F^C)^b · F` and F's closure.
//! 8. [`order`]: patch reordering before compression, with estimated errors.
//! 9. [`encode`]: BC1/BC4, u8-log, f16 and f32 encoders from a dense matrix to a
//!    [`radiosity_core::TransferMatrix`].
//! 10. [`pipeline`]: the whole bake ([`pipeline::bake`]) with its report.
//!
//! Beside the pipeline: [`check`] (rows of F against hemisphere rays, object-to-object view
//! factors) and [`rng`] (the deterministic random streams).
#![deny(missing_docs)]

pub mod bounce;
pub mod check;
pub mod effects;
pub mod encode;
pub mod error;
pub mod form_factor;
pub(crate) mod hemisphere;
pub mod host;
pub mod limits;
pub mod order;
pub mod pipeline;
pub mod probes;
pub mod scene;
pub mod simplify;

pub use error::BakeError;

// The geometry stage and the random streams live in `radiosity-geometry`, which the runtime
// shares without the bake's heavy dependencies; the bake's stages name them as before.
pub use radiosity_geometry as geometry;
pub use radiosity_geometry::rng;
