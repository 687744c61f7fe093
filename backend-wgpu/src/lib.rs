//! GPU backend for the radiosity gather (wgpu compute).
//!
//! **Status:** the WGSL gather (software decode from storage buffers, hardware BC sampling where
//! the adapter has `TEXTURE_COMPRESSION_BC`) arrives with the GPU-backend issue. The core already
//! offers [`radiosity_core::DecodeMode::Mesa`], the bit-exact model of Mesa's BC decoder that the
//! GPU tests will compare against.
