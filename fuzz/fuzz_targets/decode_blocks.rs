//! Differential BC1/BC4 block decoding: ours against texpresso, and the Mesa palettes
//! within their documented distance of the D3D10 ones.
//! The body is `radiosity_tests::fuzz_checks::check_decode_blocks`, which the stable test
//! `tests/tests/fuzz_corpus.rs` replays over the corpus and the regressions.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| radiosity_tests::fuzz_checks::check_decode_blocks(data));
