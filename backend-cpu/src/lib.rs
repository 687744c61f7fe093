//! CPU backend for the radiosity gather.
//!
//! **Status:** the SIMD (`wide`) + `rayon` gather arrives with the CPU-runtime issue. Until then
//! this crate offers nothing of its own: use [`radiosity_core::ReferenceGather`], the scalar
//! oracle every backend is tested against.
