//! `radiosity-bake`: from an OBJ scene to a compressed transfer matrix.
//!
//! Pipeline (DESIGN.md): load → voxel simplification → form factors (BVH visibility) → effect
//! planning → multi-bounce transfer → encode. This crate grows one stage at a time; what is here
//! works and is tested:
//!
//! - [`encode`]: BC1/BC4 (texpresso), u8-log, f16 and f32 encoders from a dense matrix to a
//!   [`radiosity_core::TransferMatrix`], with the three-colour guard for BC1.
#![deny(missing_docs)]

pub mod encode;
