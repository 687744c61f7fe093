//! `radiosity-bake`: from an OBJ scene to a compressed transfer matrix.
//!
//! Pipeline (DESIGN.md): load → voxel simplification → form factors (BVH visibility) → effect
//! planning → multi-bounce transfer → encode. This crate grows one stage at a time; what is here
//! works and is tested:
//!
//! - [`encode`]: BC1/BC4 (texpresso), u8-log, f16 and f32 encoders from a dense matrix to a
//!   [`radiosity_core::TransferMatrix`], with the three-colour guard for BC1.
//! - [`scene`]: OBJ + MTL loading ([`scene::Scene::load_obj`]): objects, reflectance, emission,
//!   `map_Kd` textures, line-numbered errors.
//! - [`voxel`]: the paper's voxel simplification into patches ([`voxel::simplify`]) with
//!   per-vertex interpolation weights.
//! - [`bvh`]: the occlusion structure over the full-detail triangles (obvhs).
//! - [`form_factor`]: the n × n form-factor matrix ([`form_factor::form_factors`]) with an
//!   analytic point-to-polygon kernel, adaptive quadrature and ray-sampled visibility.
//! - [`view_factors`]: object-to-object view factors from the full-detail geometry.
//! - [`row_check`]: rows of F against hemisphere rays, an independent check of the form factors.
#![deny(missing_docs)]

pub mod effects;
pub mod encode;

pub mod bvh;
pub mod error;
pub mod form_factor;
pub mod kernel;
pub mod mesh;
mod obj;
pub mod order;
pub mod pipeline;
pub mod polygon;
pub mod quadrature;
pub mod rng;
pub mod row_check;
pub mod scene;
pub mod texture;
pub mod transfer;
pub mod view_factors;
pub mod voxel;

pub use error::BakeError;
