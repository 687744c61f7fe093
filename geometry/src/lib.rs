//! `radiosity-geometry`: the geometry the bake, the runtime and the path tracer share.
//!
//! - [`bvh`]: the occlusion BVH over full-detail triangles ([`Occluders`]): shadow segments,
//!   first hits from a surface, burial, emitters drawn on a surface covering it.
//! - [`polygon`]: convex polygons and their distances.
//! - [`point_polygon`]: the exact irradiance kernel from a point to a polygon (Lambert's
//!   contour integral).
//! - [`quadrature`]: adaptive triangle quadrature.
//! - [`rng`]: the deterministic random streams (`SplitMix64`, scrambled Sobol' points).
//!
//! Light (obvhs and glam only): an engine that lights a baked file depends on this crate, not
//! on the bake.
#![deny(missing_docs)]

pub mod aabb;
pub mod bvh;
pub mod point_polygon;
pub mod polygon;
pub mod quadrature;
pub mod rng;

pub use bvh::{Hit, Occluders};
