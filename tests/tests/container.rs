//! `.rad` container: round trips, zero-copy, and every kind of corruption answered by its
//! specific error.

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
            (8..12, _) => matches!(err, RadError::UnsupportedVersion { .. }),
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
    b[8] = 3;
    reseal(&mut b).unwrap();
    assert_eq!(
        RadFile::parse(&b),
        Err(RadError::UnsupportedVersion { found: 3 })
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

#[test]
fn bad_meta_values() {
    assert!(matches!(
        corrupt_meta(|m| m.channels = 2),
        RadError::Layout(LayoutError::Channels(2))
    ));
    assert!(matches!(
        corrupt_meta(|m| m.format = 77),
        RadError::Invalid {
            section: SectionKind::Meta,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.bounces = 0),
        RadError::Invalid {
            section: SectionKind::Meta,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.order = 9),
        RadError::Invalid {
            section: SectionKind::Meta,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.compression_rmse = f32::NAN),
        RadError::Invalid {
            section: SectionKind::Meta,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.reserved[1] = 1),
        RadError::Invalid {
            section: SectionKind::Meta,
            index: 1,
            ..
        }
    ));
    // The sample has block corrections: their count must match the sections, their base be
    // finite and positive in the stored channels.
    assert!(matches!(
        corrupt_meta(|m| m.correction_base[0] = f32::NAN),
        RadError::Invalid {
            section: SectionKind::Meta,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.correction_base[1] = 0.0),
        RadError::Invalid {
            section: SectionKind::Meta,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.correction_count += 1),
        RadError::SectionLength {
            kind: SectionKind::CorrectionCols,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.correction_count = 0),
        RadError::Invalid {
            section: SectionKind::CorrectionRows,
            ..
        }
    ));
    assert!(matches!(
        corrupt_meta(|m| m.max_tile = 6),
        RadError::Layout(LayoutError::MaxTile(6))
    ));
}

fn set_f32(b: &mut [u8], at: usize, v: f32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn nan_payloads_are_invalid_with_their_index() {
    // Patch 5's area (offset 12 in a 56-byte patch).
    let e = corrupt_section(SectionKind::Patches, |b| set_f32(b, 5 * 56 + 12, f32::NAN));
    assert_eq!(
        e,
        RadError::Invalid {
            section: SectionKind::Patches,
            index: 5,
            reason: "patch has a NaN or infinite field"
        }
    );
    let e = corrupt_section(SectionKind::Patches, |b| set_f32(b, 2 * 56 + 32, 1.5));
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Patches,
                index: 2,
                ..
            }
        ),
        "reflectance ≥ 1: {e:?}"
    );
    let e = corrupt_section(SectionKind::Patches, |b| b[7 * 56 + 28] = 9);
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Patches,
                index: 7,
                ..
            }
        ),
        "object index: {e:?}"
    );
    let e = corrupt_section(SectionKind::SparseValues, |b| {
        set_f32(b, 4 * 4, f32::INFINITY)
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::SparseValues,
                index: 4,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_section(SectionKind::SparseValues, |b| set_f32(b, 0, f32::NAN));
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::SparseValues,
                index: 0,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_section(SectionKind::Scales, |b| set_f32(b, 8 * 3, f32::NAN));
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Scales,
                index: 3,
                ..
            }
        ),
        "{e:?}"
    );
    // f32 blocks: a NaN entry in the matrix itself.
    let mut bytes = sample_file(9, 1, Format::F32, 8).to_bytes().unwrap();
    let r = range_of(&bytes, SectionKind::Blocks);
    set_f32(&mut bytes[r], 4 * 10, f32::NAN);
    reseal(&mut bytes).unwrap();
    assert!(matches!(
        RadFile::parse(&bytes),
        Err(RadError::Invalid {
            section: SectionKind::Blocks,
            index: 10,
            ..
        })
    ));
}

#[test]
fn broken_permutation_and_sparse_structure() {
    let e = corrupt_section(SectionKind::Order, |b| {
        let v: [u8; 4] = b[4 * 3..4 * 4].try_into().unwrap();
        b[4 * 4..4 * 5].copy_from_slice(&v);
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Order,
                index: 4,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_section(SectionKind::Order, |b| {
        b[..4].copy_from_slice(&1000u32.to_le_bytes())
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Order,
                index: 0,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_section(SectionKind::SparseCols, |b| {
        b[..4].copy_from_slice(&37u32.to_le_bytes())
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::SparseCols,
                index: 0,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_section(SectionKind::SparseRows, |b| {
        b[..4].copy_from_slice(&1u32.to_le_bytes())
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::SparseRows,
                index: 0,
                ..
            }
        ),
        "{e:?}"
    );
    let e = corrupt_section(SectionKind::Objects, |b| {
        let last = b.len() - 1;
        b[last] = 0xff; // invalid UTF-8
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Objects,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn writer_refuses_what_the_parser_would() {
    let mut f = sample_file(9, 3, Format::U8, 8);
    f.patches.to_mut()[0].area = 0.0;
    assert!(matches!(
        f.to_bytes(),
        Err(RadError::Invalid {
            section: SectionKind::Patches,
            index: 0,
            ..
        })
    ));
    let mut f = sample_file(9, 3, Format::U8, 8);
    f.order.to_mut()[0] = 1;
    assert!(matches!(
        f.to_bytes(),
        Err(RadError::Invalid {
            section: SectionKind::Order,
            ..
        })
    ));
    let mut f = sample_file(9, 3, Format::U8, 8);
    f.matrix.blocks.to_mut().pop();
    assert!(matches!(
        f.to_bytes(),
        Err(RadError::Count {
            section: SectionKind::Blocks,
            ..
        })
    ));
}

#[test]
fn errors_say_what_and_where() {
    let e = RadError::Invalid {
        section: SectionKind::Patches,
        index: 5,
        reason: "patch has a NaN or infinite field",
    };
    assert_eq!(
        e.to_string(),
        "PATCHES[5]: patch has a NaN or infinite field"
    );
    let e = RadError::SectionChecksum {
        kind: SectionKind::Blocks,
        offset: 4096,
        stored: 1,
        computed: 2,
    };
    assert!(e.to_string().contains("BLOCKS") && e.to_string().contains("4096"));
}

#[test]
fn version_one_files_still_load() {
    // A version-1 file is a version-2 file without block corrections (META's correction
    // fields were reserved zeros, sections 12–15 did not exist).
    let mut file = sample_file(37, 3, Format::Bc1, 16);
    file.matrix.corrections = radiosity_core::BlockCorrections::empty(37);
    let mut b = file.to_bytes().expect("valid");
    assert_eq!(b[8], 2, "this build writes version 2");
    b[8] = 1;
    reseal(&mut b).unwrap();
    assert_eq!(RadFile::parse(&b), Ok(file));
}

#[test]
fn corrections_round_trip_and_count() {
    let file = sample_file(37, 3, Format::Bc1, 16);
    let c = &file.matrix.corrections;
    // 10 × 10 block positions, a quarter corrected at most (fewer where nothing is left).
    assert!(
        c.count() > 0 && c.count() <= 25,
        "{} corrections",
        c.count()
    );
    let bytes = file.to_bytes().unwrap();
    let parsed = RadFile::parse(&bytes).unwrap();
    assert_eq!(parsed.matrix.corrections, *c);
}

#[test]
fn corrupt_corrections_are_refused_with_their_section() {
    let bytes = sample_bytes();
    let range = |kind: SectionKind| {
        section_ranges(&bytes)
            .unwrap()
            .into_iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, r)| r)
            .expect("the sample has corrections")
    };
    let corrupt = |kind: SectionKind, edit: &dyn Fn(&mut [u8])| {
        let mut b = bytes.clone();
        let r = range(kind);
        edit(&mut b[r]);
        reseal(&mut b).unwrap();
        RadFile::parse(&b).expect_err("corruption must be caught")
    };
    // 37 patches: 10 block columns, the last one half padding.
    let past_end = corrupt(SectionKind::CorrectionCols, &|s| {
        s[..4].copy_from_slice(&10u32.to_le_bytes())
    });
    assert!(
        matches!(
            past_end,
            RadError::Invalid {
                section: SectionKind::CorrectionCols,
                index: 0,
                ..
            }
        ),
        "{past_end}"
    );
    let decreasing = corrupt(SectionKind::CorrectionRows, &|s| {
        s[4..8].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    assert!(
        matches!(
            decreasing,
            RadError::Invalid {
                section: SectionKind::CorrectionRows,
                ..
            }
        ),
        "{decreasing}"
    );
    // The last correction moved to the last block column (still the largest of its block
    // row), and every multiple −7: it now corrects texels past patch 37.
    let mut b = bytes.clone();
    let cols = range(SectionKind::CorrectionCols);
    b[cols.end - 4..cols.end].copy_from_slice(&9u32.to_le_bytes());
    b[range(SectionKind::CorrectionCodes)].fill(0x11);
    reseal(&mut b).unwrap();
    let padding = RadFile::parse(&b).expect_err("corruption must be caught");
    assert!(
        matches!(
            padding,
            RadError::Invalid {
                section: SectionKind::CorrectionCodes,
                ..
            }
        ),
        "{padding}"
    );
}
