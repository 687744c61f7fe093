//! Parsing: the header and section table first (their own checksum, the length, the count),
//! then each section's placement, padding and checksum, then META and the sections' lengths
//! and contents ([`RadFile::parse`]).

use super::{
    Bounces, Header, LevelSystems, MAGIC, Meta, OLDEST_VERSION, PatchOrder, RadFile, SectionEntry,
    VERSION, align, f32_to_opt, header_checksum,
};
use crate::bounce::BounceRows;
use crate::checksum::crc32;
use crate::layout::{Format, MatrixLayout};
use crate::mesh::Mesh;
use crate::parts::PartRows;
use crate::pod_bytes::{cast, u32_at};
use crate::probes::Probes;
use crate::sky::SkyVisibility;
use crate::{BlockCorrections, Patch, RadError, SectionKind, SparseRows, TransferMatrix};
use alloc::borrow::Cow;
use alloc::vec::Vec;

impl<'a> RadFile<'a> {
    /// Parses and fully validates a `.rad` file. Never panics and never reads out of bounds,
    /// whatever `bytes` holds.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, RadError> {
        Self::parse_structure(read_structure(bytes, false)?)
    }

    /// Parses and validates the head of a level file: every section but SYSTEM_DATA, whose
    /// bytes are not read (`prefix` holds at least the file's first [`head_len`] bytes). The
    /// systems are then loaded one at a time with [`LevelSystems::accept`] from the bytes at
    /// [`LevelSystems::file_range`]. A file without systems is parsed whole (`prefix` must
    /// be all of it).
    pub fn parse_head(prefix: &'a [u8]) -> Result<Self, RadError> {
        Self::parse_structure(read_structure(prefix, true)?)
    }

    fn parse_structure(s: Structure<'a>) -> Result<Self, RadError> {
        let meta = s.meta()?;
        let format = Format::from_u32(meta.format).ok_or(RadError::Invalid {
            section: SectionKind::Meta,
            index: 0,
            reason: "unknown matrix format code",
        })?;
        let level = s.level(&meta)?;
        let layout = if level.is_some() {
            MatrixLayout::none(meta.channels, format, meta.max_tile)?
        } else {
            MatrixLayout::new(meta.n, meta.channels, format, meta.max_tile)?
        };
        let (bounces, patch_order) = meta_codes(&meta)?;
        let corrections = read_corrections(&s, &meta, &layout)?;
        let n = u64::from(meta.n);
        let patches = s.required(SectionKind::Patches)?;
        expect_len(
            SectionKind::Patches,
            patches,
            n * core::mem::size_of::<Patch>() as u64,
        )?;
        let order = s.required(SectionKind::Order)?;
        expect_len(SectionKind::Order, order, 4 * n)?;
        let matrix = s.matrix(&meta, layout, corrections)?;
        let objects = decode_objects(s.required(SectionKind::Objects)?, meta.object_count)?;
        let report = s.report()?;
        let file = RadFile {
            patches: cast(patches),
            order: cast(order),
            matrix,
            objects,
            bounces,
            patch_order,
            compression_rmse: f32_to_opt(meta.compression_rmse),
            lighting_error: f32_to_opt(meta.lighting_error),
            report,
            mesh: s
                .section(SectionKind::Mesh)
                .map(|m| Mesh::from_bytes(m, n as usize))
                .transpose()?,
            probes: s
                .section(SectionKind::Probes)
                .map(Probes::from_bytes)
                .transpose()?,
            sky: s
                .section(SectionKind::Sky)
                .map(SkyVisibility::from_bytes)
                .transpose()?,
            parts: s
                .section(SectionKind::Parts)
                .map(PartRows::from_bytes)
                .transpose()?,
            coverage: s
                .section(SectionKind::Coverage)
                .map(coverage_of)
                .transpose()?,
            systems: level.map(|l| s.with_data(l)),
            bounce: s
                .section(SectionKind::Bounce)
                .map(BounceRows::from_bytes)
                .transpose()?,
        };
        file.validate()?;
        Ok(file)
    }
}

/// META's bounce count and patch order, once its error estimates are known to be finite
/// (negative means "not measured"; NaN and infinity mean corruption).
fn meta_codes(meta: &Meta) -> Result<(Bounces, PatchOrder), RadError> {
    let bad = |reason| RadError::Invalid {
        section: SectionKind::Meta,
        index: 0,
        reason,
    };
    let bounces = Bounces::from_u32(meta.bounces).ok_or(bad("bounces must be at least 1"))?;
    let patch_order = PatchOrder::from_u32(meta.order).ok_or(bad("unknown patch order code"))?;
    if [meta.compression_rmse, meta.lighting_error]
        .iter()
        .any(|v| !v.is_finite())
    {
        return Err(bad("error estimate is not finite"));
    }
    Ok((bounces, patch_order))
}

/// The COVERAGE section as f32s (whole ones; [`RadFile::validate`] checks their values).
fn coverage_of(b: &[u8]) -> Result<Cow<'_, [f32]>, RadError> {
    if b.len().is_multiple_of(4) {
        Ok(cast::<f32>(b))
    } else {
        Err(RadError::SectionLength {
            kind: SectionKind::Coverage,
            expected: (b.len() as u64).next_multiple_of(4),
            found: b.len() as u64,
        })
    }
}

/// The byte-level structure of a file: the header and each known section's bytes.
struct Structure<'a> {
    version: u32,
    sections: [Option<&'a [u8]>; SectionKind::ALL.len()],
    /// SYSTEM_DATA's offset, its bytes (empty when only the head was read) and its length.
    data: Option<(u64, (&'a [u8], u64))>,
}

impl<'a> Structure<'a> {
    /// The bytes of section `kind`, if the file has it.
    fn section(&self, kind: SectionKind) -> Option<&'a [u8]> {
        self.sections[kind as usize - 1]
    }

    /// The bytes of section `kind`, or [`RadError::MissingSection`].
    fn required(&self, kind: SectionKind) -> Result<&'a [u8], RadError> {
        self.section(kind).ok_or(RadError::MissingSection { kind })
    }

    /// META, of its exact length, with its reserved fields zero.
    fn meta(&self) -> Result<Meta, RadError> {
        let meta_bytes = self.required(SectionKind::Meta)?;
        expect_len(
            SectionKind::Meta,
            meta_bytes,
            core::mem::size_of::<Meta>() as u64,
        )?;
        let meta: Meta = bytemuck::pod_read_unaligned(meta_bytes);
        if let Some(i) = meta.reserved.iter().position(|r| *r != 0) {
            return Err(RadError::Invalid {
                section: SectionKind::Meta,
                index: i as u64,
                reason: "reserved field is not zero",
            });
        }
        Ok(meta)
    }

    /// The level's systems from SYSTEMS and COUPLING (a version-3 file with SYSTEM_DATA),
    /// or `None` in a file with none of the three; a file with only some of them is missing
    /// the first of the others.
    fn level(&self, meta: &Meta) -> Result<Option<LevelSystems<'a>>, RadError> {
        match (
            self.section(SectionKind::Systems),
            self.section(SectionKind::Coupling),
        ) {
            (None, None) if self.data.is_none() => Ok(None),
            (Some(table), Some(coupling)) if self.data.is_some() => {
                if self.version < 3 {
                    return Err(RadError::Invalid {
                        section: SectionKind::Systems,
                        index: 0,
                        reason: "systems in a file before version 3",
                    });
                }
                LevelSystems::from_sections(table, coupling, meta.n as usize).map(Some)
            }
            _ => {
                let kind = [
                    SectionKind::Systems,
                    SectionKind::Coupling,
                    SectionKind::SystemData,
                ]
                .into_iter()
                .find(|k| {
                    self.section(*k).is_none()
                        && (*k != SectionKind::SystemData || self.data.is_none())
                })
                .unwrap_or(SectionKind::Systems);
                Err(RadError::MissingSection { kind })
            }
        }
    }

    /// The transfer matrix of `layout` (no rows in a level file): its scales, blocks and
    /// sparse part, each of the length META and the layout give, and `corrections`.
    fn matrix(
        &self,
        meta: &Meta,
        layout: MatrixLayout,
        corrections: BlockCorrections<'a>,
    ) -> Result<TransferMatrix<'a>, RadError> {
        let rows_n = layout.n() as u64;
        let (ch, nnz) = (u64::from(meta.channels), u64::from(meta.sparse_nnz));
        let scales = self.required(SectionKind::Scales)?;
        expect_len(SectionKind::Scales, scales, 8 * layout.scale_count() as u64)?;
        let blocks = self.required(SectionKind::Blocks)?;
        expect_len(SectionKind::Blocks, blocks, layout.block_bytes())?;
        let rows = self.required(SectionKind::SparseRows)?;
        expect_len(SectionKind::SparseRows, rows, 4 * (rows_n + 1))?;
        let cols = self.required(SectionKind::SparseCols)?;
        expect_len(SectionKind::SparseCols, cols, 4 * nnz)?;
        let values = self.required(SectionKind::SparseValues)?;
        expect_len(SectionKind::SparseValues, values, 4 * nnz * ch)?;
        Ok(TransferMatrix {
            layout,
            scales: cast(scales),
            blocks: Cow::Borrowed(blocks),
            sparse: SparseRows {
                row_ptr: cast(rows),
                cols: cast(cols),
                values: cast(values),
            },
            corrections,
        })
    }

    /// The REPORT section's text, if any.
    fn report(&self) -> Result<Option<Cow<'a, str>>, RadError> {
        self.section(SectionKind::Report)
            .map(|r| {
                core::str::from_utf8(r)
                    .map(Cow::Borrowed)
                    .map_err(|e| RadError::Invalid {
                        section: SectionKind::Report,
                        index: e.valid_up_to() as u64,
                        reason: "report is not valid UTF-8",
                    })
            })
            .transpose()
    }

    /// `level` with SYSTEM_DATA's place, length and (when read) bytes.
    fn with_data(&self, mut level: LevelSystems<'a>) -> LevelSystems<'a> {
        if let Some((offset, data)) = self.data {
            level.data_offset = offset;
            level.data_len = data.1;
            level.data = Cow::Borrowed(data.0);
        }
        level
    }
}

/// The block corrections META announces: all four sections with their exact lengths when
/// `correction_count > 0`, none of them (and a zero base) otherwise, none in a version-1 file.
fn read_corrections<'a>(
    s: &Structure<'a>,
    meta: &Meta,
    layout: &MatrixLayout,
) -> Result<BlockCorrections<'a>, RadError> {
    const KINDS: [SectionKind; 4] = [
        SectionKind::CorrectionRows,
        SectionKind::CorrectionCols,
        SectionKind::CorrectionExponents,
        SectionKind::CorrectionCodes,
    ];
    let sec = |k: SectionKind| s.section(k);
    let count = u64::from(meta.correction_count);
    if count == 0 {
        if let Some(&kind) = KINDS.iter().find(|k| sec(**k).is_some()) {
            return Err(RadError::Invalid {
                section: kind,
                index: 0,
                reason: "block-correction section in a file without corrections",
            });
        }
        if meta.correction_base != [0.0; 3] {
            return Err(RadError::Invalid {
                section: SectionKind::Meta,
                index: 0,
                reason: "correction base set in a file without corrections",
            });
        }
        return Ok(BlockCorrections::empty(layout.n()));
    }
    if s.version < 2 {
        return Err(RadError::Invalid {
            section: SectionKind::Meta,
            index: 0,
            reason: "block corrections in a version-1 file",
        });
    }
    let ch = layout.channels() as u64;
    let side = layout.padded() as u64 / 4;
    let lens = [4 * (side + 1), 4 * count, count * ch, 8 * count * ch];
    let mut bytes = [&[][..]; 4];
    for ((kind, len), out) in KINDS.into_iter().zip(lens).zip(&mut bytes) {
        let b = sec(kind).ok_or(RadError::MissingSection { kind })?;
        expect_len(kind, b, len)?;
        *out = b;
    }
    Ok(BlockCorrections {
        row_ptr: cast(bytes[0]),
        cols: cast(bytes[1]),
        exponents: Cow::Borrowed(bytes[2]),
        codes: cast(bytes[3]),
        base: meta.correction_base,
    })
}
/// Reads the header and the section table; returns them once their own checksum, the length,
/// and the count are plausible (before any section is trusted).
fn read_table(bytes: &[u8]) -> Result<(Header, Vec<SectionEntry>), RadError> {
    let actual = bytes.len() as u64;
    if bytes.len() < 32 {
        if bytes.len() >= 8 && bytes[..8] != MAGIC {
            return Err(RadError::BadMagic);
        }
        return Err(RadError::Truncated { needed: 32, actual });
    }
    let header: Header = bytemuck::pod_read_unaligned(&bytes[..32]);
    if header.magic != MAGIC {
        return Err(RadError::BadMagic);
    }
    if !(OLDEST_VERSION..=VERSION).contains(&header.version) {
        return Err(RadError::UnsupportedVersion {
            found: header.version,
        });
    }
    let required = SectionKind::ALL.iter().filter(|k| k.required()).count() as u32;
    if header.section_count < required || header.section_count > SectionKind::ALL.len() as u32 {
        return Err(RadError::SectionCount {
            found: header.section_count,
        });
    }
    let table_end = 32 + 32 * u64::from(header.section_count);
    if actual < table_end {
        return Err(RadError::Truncated {
            needed: table_end,
            actual,
        });
    }
    let table = &bytes[32..table_end as usize];
    let computed = header_checksum(&header, table);
    if computed != header.checksum {
        return Err(RadError::HeaderChecksum {
            stored: header.checksum,
            computed,
        });
    }
    if header.reserved != 0 {
        return Err(RadError::NonZeroReserved { offset: 28 });
    }
    let entries: Vec<SectionEntry> = table
        .chunks_exact(32)
        .map(bytemuck::pod_read_unaligned)
        .collect();
    Ok((header, entries))
}

/// The bytes a streaming reader needs before [`RadFile::parse_head`]: up to SYSTEM_DATA in a
/// level file, the whole file otherwise. `prefix` must hold the header and the section table
/// (`32 + 32 · section_count` bytes; shorter: [`RadError::Truncated`] says how many).
pub fn head_len(prefix: &[u8]) -> Result<u64, RadError> {
    let (header, entries) = read_table(prefix)?;
    Ok(entries
        .iter()
        .find(|e| e.kind == SectionKind::SystemData as u32)
        .map_or(header.file_len, |e| e.offset))
}

/// The structure of `bytes`; with `head`, of a level file's head: SYSTEM_DATA's place is
/// checked but its bytes are not read (they need not be in `bytes`).
fn read_structure(bytes: &[u8], head: bool) -> Result<Structure<'_>, RadError> {
    let (header, entries) = read_table(bytes)?;
    let head = head
        && entries
            .iter()
            .any(|e| e.kind == SectionKind::SystemData as u32);
    let actual = bytes.len() as u64;
    if !head {
        check_file_len(&header, actual)?;
    }
    let mut sections = [None; SectionKind::ALL.len()];
    let mut data = None;
    let mut pos = 32 + 32 * u64::from(header.section_count);
    let mut last_kind = 0u32;
    for (i, e) in entries.iter().enumerate() {
        let kind = check_entry(i, e, last_kind, pos)?;
        last_kind = e.kind;
        if head && kind == SectionKind::SystemData {
            // The last section (the highest code): only its place, and the padding before it.
            pos = place_unread(bytes, pos, e)?;
            data = Some((e.offset, (&bytes[..0], e.len)));
            continue;
        }
        let section = read_section(bytes, pos, e, kind)?;
        if kind == SectionKind::SystemData {
            data = Some((e.offset, (section, e.len)));
        } else {
            sections[kind as usize - 1] = Some(section);
        }
        pos = e.offset + section.len() as u64;
    }
    if align(pos) != header.file_len {
        // The declared length must end exactly at the last section's padding.
        return Err(RadError::TrailingBytes {
            expected: align(pos),
            actual,
        });
    }
    if !head {
        check_padding(bytes, pos, header.file_len)?;
    }
    for k in SectionKind::ALL {
        if k.required() && sections[k as usize - 1].is_none() {
            return Err(RadError::MissingSection { kind: k });
        }
    }
    Ok(Structure {
        version: header.version,
        sections,
        data,
    })
}

/// A whole file is exactly as long as its header says.
fn check_file_len(header: &Header, actual: u64) -> Result<(), RadError> {
    if actual < header.file_len {
        return Err(RadError::Truncated {
            needed: header.file_len,
            actual,
        });
    }
    if actual > header.file_len {
        return Err(RadError::TrailingBytes {
            expected: header.file_len,
            actual,
        });
    }
    Ok(())
}

/// Section table entry `i`, `e`, before its bytes are looked at: a known kind, above the
/// previous entry's `last_kind`, reserved fields zero, placed at the first multiple of
/// [`super::SECTION_ALIGN`] from `pos` (the end of what comes before it). Returns its kind.
fn check_entry(
    i: usize,
    e: &SectionEntry,
    last_kind: u32,
    pos: u64,
) -> Result<SectionKind, RadError> {
    let entry_offset = 32 + 32 * i as u64;
    let kind = SectionKind::from_u32(e.kind).ok_or(RadError::UnknownSection {
        index: i as u32,
        kind: e.kind,
    })?;
    if e.kind <= last_kind {
        return Err(RadError::SectionOrder {
            index: i as u32,
            kind,
        });
    }
    if e.reserved != 0 {
        return Err(RadError::NonZeroReserved {
            offset: entry_offset + 4,
        });
    }
    if e.reserved2 != 0 {
        return Err(RadError::NonZeroReserved {
            offset: entry_offset + 28,
        });
    }
    let expected = align(pos);
    if e.offset != expected {
        return Err(RadError::SectionPlacement {
            kind,
            offset: e.offset,
            expected,
        });
    }
    Ok(kind)
}

/// The bytes of section `e` of `kind`, which starts after zero padding from `pos`: within
/// `bytes`, matching its checksum.
fn read_section<'b>(
    bytes: &'b [u8],
    pos: u64,
    e: &SectionEntry,
    kind: SectionKind,
) -> Result<&'b [u8], RadError> {
    let actual = bytes.len() as u64;
    check_padding(bytes, pos, e.offset)?;
    let end = e
        .offset
        .checked_add(e.len)
        .filter(|end| *end <= actual)
        .ok_or(RadError::Truncated {
            needed: e.offset.saturating_add(e.len),
            actual,
        })?;
    let section = &bytes[e.offset as usize..end as usize];
    let computed = crc32(section);
    if computed != e.checksum {
        return Err(RadError::SectionChecksum {
            kind,
            offset: e.offset,
            stored: e.checksum,
            computed,
        });
    }
    Ok(section)
}

/// Checks the place of section `e`, whose bytes are not read (a level file's SYSTEM_DATA in
/// its head): `bytes` reach its start after zero padding from `pos`. Returns its end.
fn place_unread(bytes: &[u8], pos: u64, e: &SectionEntry) -> Result<u64, RadError> {
    let actual = bytes.len() as u64;
    if actual < e.offset {
        return Err(RadError::Truncated {
            needed: e.offset,
            actual,
        });
    }
    check_padding(bytes, pos, e.offset)?;
    e.offset.checked_add(e.len).ok_or(RadError::Truncated {
        needed: u64::MAX,
        actual,
    })
}

fn check_padding(bytes: &[u8], from: u64, to: u64) -> Result<(), RadError> {
    let to = to.min(bytes.len() as u64);
    if from >= to {
        return Ok(());
    }
    match bytes[from as usize..to as usize]
        .iter()
        .position(|b| *b != 0)
    {
        Some(i) => Err(RadError::NonZeroPadding {
            offset: from + i as u64,
        }),
        None => Ok(()),
    }
}

fn expect_len(kind: SectionKind, bytes: &[u8], expected: u64) -> Result<(), RadError> {
    if bytes.len() as u64 != expected {
        return Err(RadError::SectionLength {
            kind,
            expected,
            found: bytes.len() as u64,
        });
    }
    Ok(())
}

fn decode_objects(bytes: &[u8], count: u32) -> Result<Vec<Cow<'_, str>>, RadError> {
    let head = 4 * (u64::from(count) + 1);
    if (bytes.len() as u64) < head {
        return Err(RadError::SectionLength {
            kind: SectionKind::Objects,
            expected: head,
            found: bytes.len() as u64,
        });
    }
    let (offsets, text) = bytes.split_at(head as usize);
    let bad = |index: usize, reason| RadError::Invalid {
        section: SectionKind::Objects,
        index: index as u64,
        reason,
    };
    let text = core::str::from_utf8(text)
        .map_err(|e| bad(e.valid_up_to(), "object names are not valid UTF-8"))?;
    let offsets: Vec<u32> = offsets.chunks_exact(4).map(|c| u32_at(c, 0)).collect();
    if offsets[0] != 0 {
        return Err(bad(0, "first name offset is not 0"));
    }
    if offsets[count as usize] as usize != text.len() {
        return Err(bad(
            count as usize,
            "last name offset is not the text length",
        ));
    }
    let mut names = Vec::with_capacity(count as usize);
    for i in 0..count as usize {
        let (a, b) = (offsets[i] as usize, offsets[i + 1] as usize);
        let name = text.get(a..b).ok_or(bad(
            i + 1,
            "name offset decreasing or not on a character boundary",
        ))?;
        names.push(Cow::Borrowed(name));
    }
    Ok(names)
}
/// The byte range of each section of a structurally valid file, in table order: for tests that
/// corrupt one section at a time, and for `inspect`.
pub fn section_ranges(
    bytes: &[u8],
) -> Result<Vec<(SectionKind, core::ops::Range<usize>)>, RadError> {
    let (_, entries) = read_table(bytes)?;
    entries
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let kind = SectionKind::from_u32(e.kind).ok_or(RadError::UnknownSection {
                index: i as u32,
                kind: e.kind,
            })?;
            let end = e
                .offset
                .checked_add(e.len)
                .filter(|end| *end <= bytes.len() as u64)
                .ok_or(RadError::Truncated {
                    needed: e.offset.saturating_add(e.len),
                    actual: bytes.len() as u64,
                })?;
            Ok((kind, e.offset as usize..end as usize))
        })
        .collect()
}
