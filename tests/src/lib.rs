//! Shared helpers for the cross-crate tests in `tests/tests/`.

pub mod fixtures;
pub mod scenes;

pub mod fuzz_checks;
