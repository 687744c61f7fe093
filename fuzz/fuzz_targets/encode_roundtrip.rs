//! A small dense matrix through every encoder, the container and back: per-format
//! error bounds, and the reference gather against a dense mat-vec.
//! The body is `radiosity_tests::fuzz_checks::check_encode_roundtrip`, which the stable test
//! `tests/tests/fuzz_corpus.rs` replays over the corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| radiosity_tests::fuzz_checks::check_encode_roundtrip(data));
