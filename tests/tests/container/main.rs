//! `.rad` container: round trips, zero-copy, and every kind of corruption answered by its
//! specific error. The byte structure (table, lengths, checksums, padding) is tested here;
//! `contents.rs` tests what lies behind valid checksums (META values, NaN payloads, broken
//! permutations and sparse structure, block corrections) and the writer's refusals.

mod contents;
mod systems;

use radiosity_core::bytemuck;
use radiosity_core::container::{reseal, section_ranges};
use radiosity_core::{Format, LayoutError, RadError, RadFile, SectionKind};
use radiosity_tests::fixtures::{FORMAT_CASES, sample_file};
use std::borrow::Cow;

fn sample_bytes() -> Vec<u8> {
    sample_file(37, 3, Format::Bc1, 16)
        .to_bytes()
        .expect("valid sample")
}

/// Copies `bytes` into a buffer aligned to 16 so zero-copy casts succeed.
fn aligned(bytes: &[u8]) -> (Vec<u128>, usize) {
    let mut buf = vec![0u128; bytes.len().div_ceil(16)];
    bytemuck::cast_slice_mut::<u128, u8>(&mut buf)[..bytes.len()].copy_from_slice(bytes);
    (buf, bytes.len())
}

fn range_of(bytes: &[u8], kind: SectionKind) -> std::ops::Range<usize> {
    section_ranges(bytes)
        .unwrap()
        .into_iter()
        .find(|(k, _)| *k == kind)
        .expect("section present")
        .1
}

/// Applies `f` to the bytes of one section, reseals the checksums, and parses.
fn corrupt_section(kind: SectionKind, f: impl FnOnce(&mut [u8])) -> RadError {
    let mut bytes = sample_bytes();
    let r = range_of(&bytes, kind);
    f(&mut bytes[r]);
    reseal(&mut bytes).unwrap();
    RadFile::parse(&bytes).expect_err("corruption must be caught")
}

/// Applies `f` to META (as a struct), reseals, parses.
fn corrupt_meta(f: impl FnOnce(&mut radiosity_core::container::Meta)) -> RadError {
    corrupt_section(SectionKind::Meta, |b| {
        let mut m: radiosity_core::container::Meta = bytemuck::pod_read_unaligned(b);
        f(&mut m);
        b.copy_from_slice(bytemuck::bytes_of(&m));
    })
}

#[test]
fn round_trip_every_format() {
    for (format, channels) in FORMAT_CASES {
        for max_tile in [8, 16, 8192] {
            let file = sample_file(37, channels, format, max_tile);
            let bytes = file.to_bytes().unwrap();
            let (buf, len) = aligned(&bytes);
            let aligned_bytes = &bytemuck::cast_slice::<u128, u8>(&buf)[..len];
            let parsed = RadFile::parse(aligned_bytes).unwrap();
            assert_eq!(parsed, file, "{format} × {channels}, tile {max_tile}");
            assert_eq!(
                parsed.to_bytes().unwrap(),
                bytes,
                "writing is deterministic"
            );
            // Aligned input: sections are borrowed, not copied.
            assert!(matches!(parsed.matrix.blocks, Cow::Borrowed(_)));
            assert!(matches!(parsed.patches, Cow::Borrowed(_)));
            assert!(matches!(parsed.matrix.sparse.values, Cow::Borrowed(_)));
            // Misaligned input (shifted by one byte): copied, still equal.
            let mut shifted = vec![0u8; bytes.len() + 1];
            shifted[1..].copy_from_slice(&bytes);
            let parsed = RadFile::parse(&shifted[1..]).unwrap();
            assert_eq!(parsed, file);
            assert!(matches!(parsed.patches, Cow::Owned(_)));
        }
    }
}

#[test]
fn truncation_at_every_boundary_is_truncated() {
    let bytes = sample_bytes();
    let mut cuts = vec![8, 31, 32, 33, 32 + 32 * 10 - 1];
    for (_, r) in section_ranges(&bytes).unwrap() {
        cuts.extend([r.start, r.start + 1, r.end - 1, r.end]);
    }
    for cut in cuts.into_iter().filter(|c| *c < bytes.len()) {
        match RadFile::parse(&bytes[..cut]) {
            Err(RadError::Truncated { needed, actual }) => {
                assert_eq!(actual, cut as u64);
                assert!(needed > actual, "cut {cut}: needed {needed}");
            }
            other => panic!("cut at {cut}: expected Truncated, got {other:?}"),
        }
    }
    assert!(matches!(
        RadFile::parse(&[]),
        Err(RadError::Truncated {
            needed: 32,
            actual: 0
        })
    ));
}

#[test]
fn every_flipped_bit_is_caught_by_the_right_check() {
    let bytes = sample_file(9, 3, Format::Bc1, 8).to_bytes().unwrap();
    let sections = section_ranges(&bytes).unwrap();
    let table_end = 32 + 32 * sections.len();
    for bit in 0..bytes.len() * 8 {
        let mut b = bytes.clone();
        b[bit / 8] ^= 1 << (bit % 8);
        let at = bit / 8;
        let err = RadFile::parse(&b).expect_err("a flipped bit must never parse");
        let section = sections
            .iter()
            .find(|(_, r)| r.contains(&at))
            .map(|(k, _)| *k);
        let ok = match (at, section) {
            (0..8, _) => err == RadError::BadMagic,
            // A flip to another supported version (2 ↔ 3) meets the header checksum first.
            (8..12, _) => matches!(
                err,
                RadError::UnsupportedVersion { .. } | RadError::HeaderChecksum { .. }
            ),
            (12..16, _) => matches!(
                err,
                RadError::SectionCount { .. }
                    | RadError::HeaderChecksum { .. }
                    | RadError::Truncated { .. }
            ),
            (16..32, _) => matches!(err, RadError::HeaderChecksum { .. }),
            (a, _) if a < table_end => matches!(err, RadError::HeaderChecksum { .. }),
            (_, Some(kind)) => {
                matches!(err, RadError::SectionChecksum { kind: k, .. } if k == kind)
            }
            (_, None) => matches!(err, RadError::NonZeroPadding { offset } if offset == at as u64),
        };
        assert!(
            ok,
            "bit {bit} (byte {at}, section {section:?}): unexpected {err:?}"
        );
    }
}

#[test]
fn zeroed_sections_and_garbage_headers() {
    let bytes = sample_bytes();
    for (kind, r) in section_ranges(&bytes).unwrap() {
        let mut b = bytes.clone();
        b[r.clone()].fill(0);
        if bytes[r].iter().all(|x| *x == 0) {
            continue; // already zero: nothing corrupted
        }
        assert!(
            matches!(RadFile::parse(&b), Err(RadError::SectionChecksum { kind: k, .. }) if k == kind),
            "zeroed {kind}"
        );
    }
    let mut b = bytes.clone();
    b[8] = 4;
    reseal(&mut b).unwrap();
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::UnsupportedVersion { found: 4 })
    );
    // Version 1 had no block corrections: a file that has some cannot claim it.
    let mut b = bytes.clone();
    b[8] = 1;
    reseal(&mut b).unwrap();
    assert!(matches!(
        RadFile::parse(&b),
        Err(RadError::Invalid {
            section: SectionKind::Meta,
            ..
        })
    ));
    let mut b = bytes.clone();
    b.push(0);
    assert!(matches!(
        RadFile::parse(&b),
        Err(RadError::TrailingBytes { .. })
    ));
    assert_eq!(
        RadFile::parse(b"GIF89a not a rad file at all, just text...."),
        Err(RadError::BadMagic)
    );
}

#[test]
fn structural_table_errors() {
    let bytes = sample_bytes();
    let entry = |i: usize| 32 + 32 * i;
    // Unknown section code.
    let mut b = bytes.clone();
    b[entry(3)..entry(3) + 4].copy_from_slice(&99u32.to_le_bytes());
    reseal(&mut b).unwrap();
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::UnknownSection { index: 3, kind: 99 })
    );
    // Duplicate / out of order.
    let mut b = bytes.clone();
    b[entry(3)..entry(3) + 4].copy_from_slice(&2u32.to_le_bytes());
    reseal(&mut b).unwrap();
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::SectionOrder {
            index: 3,
            kind: SectionKind::Patches
        })
    );
    // Misplaced section.
    let mut b = bytes.clone();
    let off = u64::from_le_bytes(b[entry(2) + 8..entry(2) + 16].try_into().unwrap());
    b[entry(2) + 8..entry(2) + 16].copy_from_slice(&(off + 16).to_le_bytes());
    reseal(&mut b).unwrap();
    assert!(matches!(
        RadFile::parse(&b),
        Err(RadError::SectionPlacement {
            kind: SectionKind::Order,
            ..
        })
    ));
    // Absurd section count.
    let mut b = bytes.clone();
    b[12..16].copy_from_slice(&1_000_000u32.to_le_bytes());
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::SectionCount { found: 1_000_000 })
    );
    // Reserved field.
    let mut b = bytes.clone();
    b[entry(0) + 4] = 1;
    reseal(&mut b).unwrap();
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::NonZeroReserved {
            offset: entry(0) as u64 + 4
        })
    );
    // Non-zero padding between sections (padding is in no checksum; it is checked directly).
    let mut b = bytes.clone();
    let meta = range_of(&b, SectionKind::Meta);
    let patches = range_of(&b, SectionKind::Patches);
    assert!(
        patches.start > meta.end || b.len() > patches.end,
        "sample has padding somewhere"
    );
    let pad = (meta.end..patches.start).next().unwrap_or(patches.end);
    b[pad] = 7;
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::NonZeroPadding { offset: pad as u64 })
    );
}

#[test]
fn inconsistent_counts_are_section_length_errors() {
    let n = 37u64;
    let e = corrupt_meta(|m| m.n += 1);
    assert_eq!(
        e,
        RadError::SectionLength {
            kind: SectionKind::Patches,
            expected: (n + 1) * 56,
            found: n * 56
        }
    );
    let e = corrupt_meta(|m| m.sparse_nnz += 1);
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::SparseCols,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_meta(|m| m.object_count = 5);
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::Objects,
                ..
            } | RadError::Invalid {
                section: SectionKind::Objects,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_meta(|m| m.max_tile = 8);
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::Scales,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_meta(|m| m.format = 4);
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::Scales,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn huge_counts_fail_before_allocating() {
    // n = 2^31 would need exabytes: refused by the layout or the section lengths, instantly.
    let e = corrupt_meta(|m| m.n = 1 << 31);
    assert!(
        matches!(e, RadError::SectionLength { .. } | RadError::Layout(_)),
        "{e:?}"
    );
    let e = corrupt_meta(|m| m.n = u32::MAX);
    assert_eq!(e, RadError::Layout(LayoutError::TooLarge));
    let e = corrupt_meta(|m| m.sparse_nnz = u32::MAX);
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::SparseCols,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_meta(|m| m.object_count = u32::MAX);
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::Objects,
                ..
            }
        ),
        "{e:?}"
    );
}
