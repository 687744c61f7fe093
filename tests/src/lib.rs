//! Shared helpers for the cross-crate tests in `tests/tests/`.

pub mod fixtures;

pub mod fuzz_checks;
