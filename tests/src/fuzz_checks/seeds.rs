//! The seed corpus of every target, deterministic.

use super::encode_roundtrip::{EncodeCase, rad_file_around, section_range};
use radiosity_bake::encode::encode_dense;
use radiosity_core::SectionKind;
use radiosity_core::container::reseal;

/// One seed file: the target's corpus folder, a file name, the bytes.
#[derive(Clone, Debug)]
pub struct Seed {
    /// Target (corpus folder) name.
    pub target: &'static str,
    /// File name within it.
    pub name: String,
    /// Contents.
    pub bytes: Vec<u8>,
}

/// A tiny xorshift generator: the corpus must be the same on every machine.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn bytes(&mut self, len: usize) -> Vec<u8> {
        (0..len).map(|_| self.next() as u8).collect()
    }
}

/// The encode-roundtrip input that selects `n`, channels, format and so on (see
/// [`EncodeCase::from_bytes`]), followed by `body`.
fn encode_input(
    n: usize,
    three: bool,
    format_sel: u8,
    b1_high: u8,
    b2: u8,
    body: &[u8],
) -> Vec<u8> {
    let mut v = vec![
        (n - 1) as u8,
        u8::from(three) | (format_sel << 1) | b1_high,
        b2,
    ];
    v.extend_from_slice(body);
    v
}

/// The whole seed corpus, deterministic. Written to `fuzz/corpus/<target>/` by the replay
/// test when `RADIOSITY_WRITE_FUZZ_CORPUS=1` (see `fuzz/README.md`).
pub fn seed_corpus() -> Vec<Seed> {
    let mut seeds = Vec::new();
    // One generator through all three, in this order: each file is the same on every run.
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
    decode_blocks_seeds(&mut rng, &mut seeds);
    encode_roundtrip_seeds(&mut rng, &mut seeds);
    parse_container_seeds(&mut rng, &mut seeds);
    seeds
}

/// `decode_blocks`: the special cases, then random blocks.
fn decode_blocks_seeds(rng: &mut XorShift, seeds: &mut Vec<Seed>) {
    let special: [(&str, [u8; 8]); 10] = [
        ("zero", [0; 8]),
        ("ones", [0xff; 8]),
        (
            "bc1-c0-gt-c1",
            [0x00, 0xf8, 0xe0, 0x07, 0xe4, 0xe4, 0x1b, 0x1b],
        ),
        (
            "bc1-c0-eq-c1",
            [0x10, 0x84, 0x10, 0x84, 0xff, 0x00, 0xe4, 0x1b],
        ),
        (
            "bc1-c0-lt-c1",
            [0x41, 0x08, 0x9e, 0xf7, 0xff, 0xe4, 0x1b, 0x00],
        ),
        (
            "bc1-black-white",
            [0x00, 0x00, 0xff, 0xff, 0x1b, 0x1b, 0xe4, 0xe4],
        ),
        ("bc4-r0-gt-r1", [255, 0, 0x88, 0xc6, 0xfa, 0x88, 0xc6, 0xfa]),
        ("bc4-r0-lt-r1", [0, 255, 0x88, 0xc6, 0xfa, 0x88, 0xc6, 0xfa]),
        (
            "bc4-r0-eq-r1",
            [128, 128, 0xff, 0xff, 0xff, 0x00, 0x00, 0x00],
        ),
        ("bc4-near", [201, 200, 0x39, 0x77, 0x05, 0xaf, 0x3b, 0x12]),
    ];
    for (name, block) in special {
        seeds.push(Seed {
            target: "decode_blocks",
            name: format!("{name}.bin"),
            bytes: block.to_vec(),
        });
    }
    for i in 0..6 {
        seeds.push(Seed {
            target: "decode_blocks",
            name: format!("random-{i}.bin"),
            bytes: rng.bytes(64),
        });
    }
}

/// `encode_roundtrip`: every format and channel count, edge sizes, zeros, both ranges.
fn encode_roundtrip_seeds(rng: &mut XorShift, seeds: &mut Vec<Seed>) {
    let mut enc: Vec<(String, Vec<u8>)> = Vec::new();
    let names = ["bc1", "bc4", "u8", "f16", "f32"];
    for (sel, name) in names.iter().enumerate() {
        for (n, three) in [(1, true), (5, true), (17, false), (24, true)] {
            if sel == 0 && !three {
                continue;
            }
            let format_sel = if three {
                sel as u8
            } else {
                (sel as u8).saturating_sub(1)
            };
            // narrow range, 1% sparse, tiles of 8
            let body = rng.bytes(2 * n * n * if three { 3 } else { 1 } + 2 * n);
            enc.push((
                format!("{name}-n{n}-ch{}-narrow.bin", if three { 3 } else { 1 }),
                encode_input(n, three, format_sel, 0x40 | 0x10, 0x80, &body),
            ));
        }
        // wide range, 10% sparse, tiles of 4, shift 4, with a report and finite bounces
        enc.push((
            format!("{name}-n9-wide.bin"),
            encode_input(
                9,
                true,
                sel as u8,
                0x80,
                0x62,
                &rng.bytes(2 * 9 * 9 * 3 + 18),
            ),
        ));
    }
    enc.push((
        "all-zero.bin".into(),
        encode_input(12, true, 0, 0x40, 0, &[0; 8]),
    ));
    enc.push(("empty.bin".into(), Vec::new()));
    enc.push((
        "bc1-all-sparse.bin".into(),
        encode_input(7, true, 0, 0xc0, 0x80, &rng.bytes(40)),
    ));
    for (name, bytes) in enc {
        seeds.push(Seed {
            target: "encode_roundtrip",
            name,
            bytes,
        });
    }
}

/// `parse_container`: real files, then truncated, flipped and resealed variants; semantic
/// corruptions behind valid checksums; a file with block corrections and corruptions of them.
/// Last, the `encode_roundtrip` seed of a grey matrix with block corrections.
fn parse_container_seeds(rng: &mut XorShift, seeds: &mut Vec<Seed>) {
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for (name, input) in [
        (
            "bc1-n6",
            encode_input(6, true, 0, 0x40 | 0x10, 0x80, &rng.bytes(60)),
        ),
        (
            "bc4-n5-grey",
            encode_input(5, false, 0, 0x80, 0xa0, &rng.bytes(50)),
        ),
        (
            "u8-n9-tiles4",
            encode_input(9, true, 2, 0x40, 0x80, &rng.bytes(60)),
        ),
        ("f16-n3", encode_input(3, false, 2, 0, 0x80, &rng.bytes(20))),
        ("f32-n2", encode_input(2, true, 4, 0, 0x60, &rng.bytes(20))),
    ] {
        let case = EncodeCase::from_bytes(&input);
        let m =
            encode_dense(case.n, case.channels, &case.dense, &case.params).expect("seed encodes");
        let file = rad_file_around(m, case.bounces, case.patch_order, case.report);
        files.push((name.into(), file.to_bytes().expect("seed writes")));
    }
    // A level file (version 3): two systems, their coupling, each system's own file.
    files.push((
        "level-2-systems".into(),
        crate::fixtures::sample_level(&[3, 2])
            .to_bytes()
            .expect("level seed writes"),
    ));
    for (name, bytes) in &files {
        seeds.push(Seed {
            target: "parse_container",
            name: format!("{name}.rad"),
            bytes: bytes.clone(),
        });
    }
    let (_, base) = &files[0];
    let ranges = radiosity_core::container::section_ranges(base).expect("seed has sections");
    for (kind, range) in &ranges {
        // Truncated at the start of each section, and one byte into it.
        seeds.push(Seed {
            target: "parse_container",
            name: format!("truncated-at-{}.rad", kind.name().to_lowercase()),
            bytes: base[..range.start].to_vec(),
        });
    }
    seeds.push(Seed {
        target: "parse_container",
        name: "header-only.rad".into(),
        bytes: base[..32].to_vec(),
    });
    for (i, at) in [0usize, 9, 20, 40, 70, base.len() - 1]
        .into_iter()
        .enumerate()
    {
        let mut b = base.clone();
        b[at] ^= 1 << (i % 8);
        seeds.push(Seed {
            target: "parse_container",
            name: format!("flipped-{at}.rad"),
            bytes: b,
        });
    }
    // Semantic corruptions behind valid checksums: a NaN value, a bad count, a repeated order
    // entry, a huge object count.
    let find = |kind: SectionKind| section_range(&ranges, kind);
    let mut resealed = |name: &str, edit: &dyn Fn(&mut Vec<u8>)| {
        let mut b = base.clone();
        edit(&mut b);
        reseal(&mut b).expect("reseal");
        seeds.push(Seed {
            target: "parse_container",
            name: format!("resealed-{name}.rad"),
            bytes: b,
        });
    };
    let meta = find(SectionKind::Meta);
    let patches = find(SectionKind::Patches);
    let order = find(SectionKind::Order);
    let scales = find(SectionKind::Scales);
    let objects = find(SectionKind::Objects);
    resealed("nan-area", &|b| {
        b[patches.start + 12..patches.start + 16].copy_from_slice(&f32::NAN.to_le_bytes())
    });
    resealed("zero-scale", &|b| b[scales.start..scales.start + 4].fill(0));
    resealed("order-repeat", &|b| {
        let first: [u8; 4] = b[order.start..order.start + 4].try_into().unwrap();
        b[order.start + 4..order.start + 8].copy_from_slice(&first);
    });
    resealed("n-huge", &|b| {
        b[meta.start..meta.start + 4].copy_from_slice(&u32::MAX.to_le_bytes())
    });
    resealed("object-count-huge", &|b| {
        b[meta.start + 24..meta.start + 28].copy_from_slice(&0x4000_0000u32.to_le_bytes())
    });
    resealed("object-offset-past-end", &|b| {
        b[objects.start + 4..objects.start + 8].copy_from_slice(&1000u32.to_le_bytes())
    });
    resealed("section-count-11", &|b| b[12] = 11);
    seeds.push(Seed {
        target: "parse_container",
        name: "empty.rad".into(),
        bytes: Vec::new(),
    });

    // A file with block corrections (every block that gains), 10 patches so that the last
    // block row and column hold padding, and two corruptions of its corrections.
    let mut input = encode_input(10, true, 0, 0x40, 0x80, &rng.bytes(80));
    input[0] += 48;
    let case = EncodeCase::from_bytes(&input);
    assert_eq!(
        case.params.corrections, 1.0,
        "the seed asks for corrections"
    );
    let m = encode_dense(case.n, case.channels, &case.dense, &case.params).expect("seed encodes");
    assert!(!m.corrections.is_empty(), "the seed has corrections");
    let corrected = rad_file_around(m, case.bounces, case.patch_order, case.report)
        .to_bytes()
        .expect("seed writes");
    let ranges = radiosity_core::container::section_ranges(&corrected).expect("sections");
    let find = |kind: SectionKind| section_range(&ranges, kind);
    let (cols, codes) = (
        find(SectionKind::CorrectionCols),
        find(SectionKind::CorrectionCodes),
    );
    let mut variants = vec![("bc1-n10-corrected.rad", corrected.clone())];
    let mut b = corrected.clone();
    b[cols.start..cols.start + 4].copy_from_slice(&3u32.to_le_bytes());
    variants.push(("resealed-correction-column-past-end.rad", b));
    let mut b = corrected.clone();
    b[codes.start..codes.end].fill(0x11);
    variants.push(("resealed-correction-codes-all-minus-7.rad", b));
    for (name, mut bytes) in variants {
        if name.starts_with("resealed") {
            reseal(&mut bytes).expect("reseal");
        }
        seeds.push(Seed {
            target: "parse_container",
            name: name.into(),
            bytes,
        });
    }
    let mut input = encode_input(9, false, 0, 0x40, 0x80, &rng.bytes(60));
    input[0] += 24;
    seeds.push(Seed {
        target: "encode_roundtrip",
        name: "bc4-grey-corrected.bin".into(),
        bytes: input,
    });
}
