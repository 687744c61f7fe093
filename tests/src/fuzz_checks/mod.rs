//! The bodies of the fuzz targets in `fuzz/fuzz_targets/`, shared with the stable replay test
//! `tests/tests/fuzz_corpus.rs`: each `check_*` function takes the raw fuzz input and
//! panics, with a message that says what broke, when a property does not hold. The fuzz targets
//! are one-line calls to these; the replay test runs every committed corpus and regression file
//! through the same function, so a crash found by the fuzzer is a failing plain `#[test]` as
//! long as the bug is there.
//!
//! The seed corpus is made here too ([`seed_corpus`]), deterministically, so that it can be
//! regenerated after a format change (see `fuzz/README.md`). One file per target
//! (`decode_blocks.rs`, `parse_container.rs`, `encode_roundtrip.rs`) and one for the seeds.

mod decode_blocks;
mod encode_roundtrip;
mod parse_container;
mod seeds;

pub use decode_blocks::{BC1_MESA_MAX_DIFF, bc4_mesa_max_diff, check_decode_blocks};
pub use encode_roundtrip::{EncodeCase, check_encode_roundtrip, rad_file_around, value_from};
pub use parse_container::{check_parse_container, parse_allocation_bound};
pub use seeds::{Seed, seed_corpus};

/// A fuzz check: panics when its property fails for the input.
pub type Check = fn(&[u8]);

/// The fuzz targets, by the name of their file in `fuzz/fuzz_targets/` and of their corpus
/// folder, with the check each runs.
pub const TARGETS: [(&str, Check); 3] = [
    ("decode_blocks", check_decode_blocks),
    ("parse_container", check_parse_container),
    ("encode_roundtrip", check_encode_roundtrip),
];
