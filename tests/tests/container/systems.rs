//! Level files (version 3): a level's systems, its coupling and each system's own file; the
//! whole file and its head parsed, each system loaded alone, and corruptions refused.

use super::{aligned, range_of};
use radiosity_core::container::{PLAIN_VERSION, VERSION, head_len, reseal};
use radiosity_core::{RadError, RadFile, SectionKind, bytemuck};
use radiosity_tests::fixtures::{sample_file, sample_level};

fn level_bytes() -> Vec<u8> {
    sample_level(&[9, 14, 5]).to_bytes().expect("valid level")
}

fn version(bytes: &[u8]) -> u32 {
    u32::from_le_bytes(bytes[8..12].try_into().unwrap())
}

#[test]
fn a_level_round_trips_and_a_plain_file_keeps_its_version() {
    let level = sample_level(&[9, 14, 5]);
    let bytes = level.to_bytes().unwrap();
    assert_eq!(version(&bytes), VERSION);
    let (buf, len) = aligned(&bytes);
    let parsed = RadFile::parse(&bytemuck::cast_slice(&buf)[..len]).unwrap();
    assert_eq!(parsed.n(), 28);
    let systems = parsed.systems.as_ref().unwrap();
    assert_eq!(systems.count(), 3);
    assert_eq!(systems.ranges(), vec![0..9, 9..23, 23..28]);
    // Written again, the same bytes: nothing lost or added on the way through.
    assert_eq!(parsed.to_bytes().unwrap(), bytes);
    for s in 0..3 {
        let file = systems.system(&parsed, s).unwrap();
        assert_eq!(file.n(), systems.range(s).len());
        assert!(file.systems.is_none());
    }
    // A file of one matrix is written as before systems existed.
    let plain = sample_file(37, 3, radiosity_core::Format::Bc1, 16)
        .to_bytes()
        .unwrap();
    assert_eq!(version(&plain), PLAIN_VERSION);
}

#[test]
fn a_level_streams_one_system_at_a_time() {
    let bytes = level_bytes();
    // A reader that has the header and table knows how much to read before any system.
    let table = 32 + 32 * u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert!(matches!(
        head_len(&bytes[..table - 1]),
        Err(RadError::Truncated { .. })
    ));
    let head = head_len(&bytes[..table]).unwrap() as usize;
    assert!(head < bytes.len());
    let level = RadFile::parse_head(&bytes[..head]).unwrap();
    let systems = level.systems.as_ref().unwrap();
    assert!(!systems.is_loaded());
    assert_eq!(level.n(), 28);
    for s in 0..systems.count() {
        let r = systems.file_range(s);
        let file = systems
            .accept(&level, s, &bytes[r.start as usize..r.end as usize])
            .unwrap();
        assert_eq!(file.n(), systems.range(s).len());
    }
    // Another system's bytes are refused as this one.
    let r = systems.file_range(1);
    let e = systems
        .accept(&level, 0, &bytes[r.start as usize..r.end as usize])
        .unwrap_err();
    assert!(matches!(
        e,
        RadError::Invalid {
            section: SectionKind::SystemData,
            index: 0,
            ..
        }
    ));
    // A head cut inside a section before SYSTEM_DATA is refused; the head of a plain file is
    // the whole file.
    assert!(RadFile::parse_head(&bytes[..head - 20]).is_err());
    // Writing a head (no systems' bytes) is refused rather than written half.
    assert!(level.to_bytes().is_err());
}

#[test]
fn every_flipped_bit_of_a_system_is_caught() {
    let bytes = level_bytes();
    let data = range_of(&bytes, SectionKind::SystemData);
    for at in (data.start..data.end).step_by(97) {
        let mut b = bytes.clone();
        b[at] ^= 0x10;
        assert!(RadFile::parse(&b).is_err(), "flip at {at} not caught");
        // Resealed, the level's own checksum agrees and the system's own catches it (or its
        // padding, or its contents).
        reseal(&mut b).unwrap();
        assert!(
            RadFile::parse(&b).is_err(),
            "flip at {at} resealed not caught"
        );
    }
}

#[test]
fn the_table_and_the_coupling_are_checked_behind_their_checksums() {
    let corrupt = |kind: SectionKind, f: &dyn Fn(&mut [u8])| {
        let mut b = level_bytes();
        let r = range_of(&b, kind);
        f(&mut b[r]);
        reseal(&mut b).unwrap();
        RadFile::parse(&b).unwrap_err()
    };
    // A system's count changed: the systems no longer tile the level.
    let e = corrupt(SectionKind::Systems, &|b| b[4] += 1);
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Systems,
                index: 1,
                ..
            }
        ),
        "{e:?}"
    );
    // A system's file moved by 16 bytes.
    let e = corrupt(SectionKind::Systems, &|b| b[32 + 8] = 16);
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Systems,
                ..
            }
        ),
        "{e:?}"
    );
    // A reserved word set.
    let e = corrupt(SectionKind::Systems, &|b| b[24] = 1);
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Systems,
                ..
            }
        ),
        "{e:?}"
    );
    // A coupling column inside its row's own system (row 0 → patch 0).
    let e = corrupt(SectionKind::Coupling, &|b| {
        let at = 4 * 29;
        b[at..at + 4].copy_from_slice(&0u32.to_le_bytes());
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Coupling,
                ..
            }
        ),
        "{e:?}"
    );
    // A NaN coupling value.
    let e = corrupt(SectionKind::Coupling, &|b| {
        let n = b.len();
        b[n - 4..].copy_from_slice(&f32::NAN.to_le_bytes());
    });
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Coupling,
                ..
            }
        ),
        "{e:?}"
    );
    // An entry count that claims more entries than the section holds.
    let e = corrupt(SectionKind::Coupling, &|b| {
        let at = 4 * 28;
        b[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    });
    assert!(
        matches!(
            e,
            RadError::SectionLength {
                kind: SectionKind::Coupling,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn systems_need_version_three_and_all_three_sections() {
    let mut b = level_bytes();
    b[8..12].copy_from_slice(&2u32.to_le_bytes());
    reseal(&mut b).unwrap();
    let e = RadFile::parse(&b).unwrap_err();
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::Systems,
                ..
            }
        ),
        "{e:?}"
    );
    // A level without its systems' data is refused by the writer.
    let mut level = sample_level(&[4, 4]);
    let s = level.systems.take().unwrap();
    // (its patches now count for no matrix: refused, as any count that disagrees)
    assert!(level.to_bytes().is_err());
    // A system whose patches are not the level's.
    level.patches.to_mut()[2].area += 1.0;
    level.systems = Some(s);
    let e = level.to_bytes().unwrap_err();
    assert!(
        matches!(
            e,
            RadError::Invalid {
                section: SectionKind::SystemData,
                index: 0,
                ..
            }
        ),
        "{e:?}"
    );
}
