//! What lies behind valid checksums: META values, NaN payloads, broken permutations and sparse
//! structure, block corrections; and what the writer refuses.

use super::*;

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

#[test]
fn coverage_round_trips_and_bad_values_are_refused_with_their_index() {
    let file = sample_file(37, 3, Format::Bc1, 16);
    let bytes = file.to_bytes().unwrap();
    let parsed = RadFile::parse(&bytes).unwrap();
    assert_eq!(parsed.coverage, file.coverage);
    // The second triangle's coverage: 0 (nothing there: the bake leaves such triangles out),
    // NaN, above 1, negative.
    for v in [0.0, f32::NAN, 1.5, -0.25] {
        let e = corrupt_section(SectionKind::Coverage, |b| set_f32(b, 4, v));
        assert_eq!(
            e,
            RadError::Invalid {
                section: SectionKind::Coverage,
                index: 1,
                reason: "coverage not in (0, 1]"
            },
            "{v}"
        );
    }
    // One value a mesh triangle, and a file with coverage has a mesh.
    let mut short = file.clone();
    short.coverage = Some(Cow::Owned(vec![1.0; 3]));
    assert!(matches!(
        short.to_bytes(),
        Err(RadError::Count {
            section: SectionKind::Coverage,
            ..
        })
    ));
    let mut meshless = file;
    meshless.mesh = None;
    meshless.parts = None;
    meshless.bounce = None;
    assert!(matches!(
        meshless.to_bytes(),
        Err(RadError::Count {
            section: SectionKind::Coverage,
            expected: 0,
            ..
        })
    ));
}

#[test]
fn first_bounce_rows_round_trip_and_bad_ones_are_refused_with_their_index() {
    let file = sample_file(37, 3, Format::Bc1, 16);
    let bytes = file.to_bytes().unwrap();
    let parsed = RadFile::parse(&bytes).unwrap();
    assert!(
        parsed
            .bounce
            .as_ref()
            .is_some_and(|b| !b.samples.is_empty())
    );
    assert_eq!(parsed.bounce, file.bounce);
    // The first patch's weight (f32 at byte 16): NaN, negative.
    for v in [f32::NAN, -1.0] {
        let e = corrupt_section(SectionKind::Bounce, |b| set_f32(b, 16, v));
        assert_eq!(
            e,
            RadError::Invalid {
                section: SectionKind::Bounce,
                index: 0,
                reason: "scale not finite and non-negative"
            },
            "{v}"
        );
    }
    // A row naming a sample past the mesh's, and a count of zero.
    let rows = file.bounce.as_ref().unwrap();
    let samples = file.mesh.as_ref().unwrap().samples.len();
    let mut bad = file.clone();
    bad.bounce.as_mut().unwrap().samples.to_mut()[0] = samples as u32;
    assert!(matches!(
        bad.to_bytes(),
        Err(RadError::Invalid {
            section: SectionKind::Bounce,
            index: 0,
            reason: "sample index out of range"
        })
    ));
    let mut bad = file.clone();
    bad.bounce.as_mut().unwrap().weights.to_mut()[1] = 0;
    assert!(matches!(
        bad.to_bytes(),
        Err(RadError::Invalid {
            section: SectionKind::Bounce,
            index: 1,
            reason: "weight not finite and positive"
        })
    ));
    // One row a patch, and the mesh its entries name.
    let mut short = file.clone();
    short.bounce.as_mut().unwrap().scale.to_mut().pop();
    assert!(matches!(
        short.to_bytes(),
        Err(RadError::Count {
            section: SectionKind::Bounce,
            expected: 37,
            ..
        })
    ));
    assert!(rows.starts.len() == 38);
    let mut meshless = file;
    meshless.mesh = None;
    meshless.parts = None;
    meshless.coverage = None;
    assert!(matches!(
        meshless.to_bytes(),
        Err(RadError::Invalid {
            section: SectionKind::Bounce,
            reason: "first-bounce rows without the mesh they name",
            ..
        })
    ));
}
