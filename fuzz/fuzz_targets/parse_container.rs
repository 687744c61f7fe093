//! `RadFile::parse` never panics, before and after resealing the checksums; whatever
//! parses writes and re-parses to an equal file. Run with `-malloc_limit_mb` (see `run.sh`).
//! The body is `radiosity_tests::fuzz_checks::check_parse_container`, which the stable test
//! `tests/tests/fuzz_corpus.rs` replays over the corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| radiosity_tests::fuzz_checks::check_parse_container(data));
