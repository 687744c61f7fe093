//! Builds only if `radiosity-core` compiles without `std` (`default-features = false`).
//! CI builds this crate on its own (`cargo build -p no-std-check`) so that feature unification
//! with the rest of the workspace cannot switch `std` back on, and for `wasm32-unknown-unknown`
//! when that target is installed.
#![no_std]

pub use radiosity_core::*;
