//! The geometry the form factors and the checks share: the occlusion BVH over the full-detail
//! triangles ([`bvh`]), convex polygons ([`polygon`]), the exact point-to-polygon form-factor
//! kernel ([`point_polygon`]) and adaptive triangle quadrature ([`quadrature`]).

pub mod bvh;
pub mod point_polygon;
pub mod polygon;
pub mod quadrature;

pub use bvh::{Hit, Occluders};
