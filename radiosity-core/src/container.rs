//! The `.rad` container: a baked transfer matrix and what the runtime needs beside it.
//!
//! Layout (all little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 0..32 | [`Header`]: magic `\x89RAD\r\n\x1a\n`, version 1, section count, file length, CRC-32 |
//! | 32..32+32·k | k [`SectionEntry`]s: code, offset, length, CRC-32 of the section bytes |
//! | … | the sections in ascending code order, each starting at the next multiple of 16 |
//!
//! Every byte is accounted for: the header CRC covers the header (with its CRC field zero) and
//! the section table; each section has its own CRC; padding must be zero; nothing may follow
//! the last section's padding. Any single flipped bit is therefore reported. Parsing borrows
//! sections in place when the input is aligned (zero-copy casts with bytemuck) and copies them
//! otherwise; every allocation is bounded by the length of a section already checked against
//! the input, so no byte pattern can make it allocate more than the file justifies.
//!
//! The magic's `\x89`, CR-LF and `\x1a` catch 7-bit and text-mode transfers, as PNG's do.

#[cfg(target_endian = "big")]
compile_error!("the .rad zero-copy parser assumes a little-endian target");

use crate::checksum::{Crc32, crc32};
use crate::layout::{Format, MatrixLayout};
use crate::mesh::Mesh;
use crate::{BlockCorrections, Patch, RadError, SectionKind, SparseRows, TransferMatrix};
use alloc::borrow::Cow;
use alloc::string::String;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};

/// The first 8 bytes of every `.rad` file.
pub const MAGIC: [u8; 8] = *b"\x89RAD\r\n\x1a\n";
/// The version this build writes. Version 2 added the block corrections (META's
/// `correction_count` and `correction_base`, sections 12–15).
pub const VERSION: u32 = 2;
/// The oldest version this build reads: version-1 files are version-2 files without block
/// corrections.
pub const OLDEST_VERSION: u32 = 1;
/// Sections start at multiples of this.
pub const SECTION_ALIGN: u64 = 16;

/// The fixed file header.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct Header {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// [`VERSION`].
    pub version: u32,
    /// Entries in the section table.
    pub section_count: u32,
    /// Length of the whole file.
    pub file_len: u64,
    /// CRC-32 of this header (with this field zero) followed by the section table.
    pub checksum: u32,
    /// Zero.
    pub reserved: u32,
}

/// One entry of the section table.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct SectionEntry {
    /// [`SectionKind`] code.
    pub kind: u32,
    /// Zero.
    pub reserved: u32,
    /// Byte offset of the section.
    pub offset: u64,
    /// Length in bytes (without padding).
    pub len: u64,
    /// CRC-32 of the section bytes.
    pub checksum: u32,
    /// Zero.
    pub reserved2: u32,
}

/// The META section.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Meta {
    /// Patches.
    pub n: u32,
    /// Stored channels (1 or 3).
    pub channels: u32,
    /// [`Format`] code.
    pub format: u32,
    /// Largest tile side.
    pub max_tile: u32,
    /// Bounces K (`u32::MAX` for K = ∞; at least 1).
    pub bounces: u32,
    /// [`PatchOrder`] code.
    pub order: u32,
    /// Object names in OBJECTS.
    pub object_count: u32,
    /// Entries in the sparse part.
    pub sparse_nnz: u32,
    /// Relative Frobenius error of the decoded matrix; negative when not measured.
    pub compression_rmse: f32,
    /// Relative L2 error of the lighting from the scene's own emitters; negative when not measured.
    pub lighting_error: f32,
    /// Blocks with a correction ([`crate::BlockCorrections`]); 0 in version-1 files.
    pub correction_count: u32,
    /// [`crate::BlockCorrections::base`].
    pub correction_base: [f32; 3],
    /// Zero.
    pub reserved: [u32; 2],
}

/// How many bounces the matrix carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Bounces {
    /// `K` bounces: `M = Σ_{b<K} (F^C)^b F`, `K ≥ 1`.
    Finite(u32),
    /// K = ∞: `M = (I − F^C)^{-1} F`.
    Infinite,
}

impl Bounces {
    fn to_u32(self) -> u32 {
        match self {
            Bounces::Finite(k) => k,
            Bounces::Infinite => u32::MAX,
        }
    }
    fn from_u32(v: u32) -> Option<Self> {
        match v {
            0 => None,
            u32::MAX => Some(Bounces::Infinite),
            k => Some(Bounces::Finite(k)),
        }
    }
}

/// The patch numbering the bake chose (see DESIGN.md, "Encoding").
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PatchOrder {
    /// As patches come out of simplification (`--order none`).
    Natural = 0,
    /// A seeded shuffle: the arbitrary order the paper starts from.
    Random = 1,
    /// The paper's neighbour sort.
    Paper = 2,
    /// A space-filling-curve order over position, grouped by orientation.
    Spatial = 3,
}

impl PatchOrder {
    /// Every order.
    pub const ALL: [PatchOrder; 4] = [
        PatchOrder::Natural,
        PatchOrder::Random,
        PatchOrder::Paper,
        PatchOrder::Spatial,
    ];

    /// The order with this code.
    pub fn from_u32(v: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|o| *o as u32 == v)
    }

    /// The command-line name (`none`, `random`, `paper`, `spatial`).
    pub fn name(self) -> &'static str {
        match self {
            PatchOrder::Natural => "none",
            PatchOrder::Random => "random",
            PatchOrder::Paper => "paper",
            PatchOrder::Spatial => "spatial",
        }
    }
}

/// A whole `.rad` file in memory, borrowing from the parsed bytes where it can.
#[derive(Clone, Debug, PartialEq)]
pub struct RadFile<'a> {
    /// Patches in the matrix's numbering.
    pub patches: Cow<'a, [Patch]>,
    /// File patch index → patch index in the bake (before reordering).
    pub order: Cow<'a, [u32]>,
    /// The transfer matrix.
    pub matrix: TransferMatrix<'a>,
    /// Object names; `Patch::object` indexes them.
    pub objects: Vec<Cow<'a, str>>,
    /// Bounces carried.
    pub bounces: Bounces,
    /// Which numbering the patches are in.
    pub patch_order: PatchOrder,
    /// Relative Frobenius error of the decoded matrix, if measured.
    pub compression_rmse: Option<f32>,
    /// Relative L2 error of the lighting from the scene's own emitters, if measured.
    pub lighting_error: Option<f32>,
    /// Free text (the bake's JSON report), if any.
    pub report: Option<Cow<'a, str>>,
    /// The full-detail mesh, if the bake stored it (runtime lights, rendering).
    pub mesh: Option<Mesh<'a>>,
}

fn align(x: u64) -> u64 {
    x.div_ceil(SECTION_ALIGN) * SECTION_ALIGN
}

fn opt_to_f32(v: Option<f32>) -> f32 {
    v.unwrap_or(-1.0)
}

fn f32_to_opt(v: f32) -> Option<f32> {
    (v >= 0.0).then_some(v)
}

impl<'a> RadFile<'a> {
    /// Patches.
    pub fn n(&self) -> usize {
        self.matrix.layout.n()
    }

    /// Checks everything [`RadFile::parse`] checks beyond the byte structure.
    pub fn validate(&self) -> Result<(), RadError> {
        let n = self.n();
        let bad = |section, index: usize, reason| RadError::Invalid {
            section,
            index: index as u64,
            reason,
        };
        if self.patches.len() != n {
            return Err(RadError::Count {
                section: SectionKind::Patches,
                expected: n as u64,
                found: self.patches.len() as u64,
            });
        }
        if self.order.len() != n {
            return Err(RadError::Count {
                section: SectionKind::Order,
                expected: n as u64,
                found: self.order.len() as u64,
            });
        }
        for (i, p) in self.patches.iter().enumerate() {
            let finite = p.centre.iter().chain(&p.normal).all(|v| v.is_finite())
                && p.area.is_finite()
                && p.reflectance.is_finite()
                && p.emission.is_finite();
            if !finite {
                return Err(bad(
                    SectionKind::Patches,
                    i,
                    "patch has a NaN or infinite field",
                ));
            }
            if !(p.area > 0.0) {
                return Err(bad(SectionKind::Patches, i, "patch area is not positive"));
            }
            let len2: f32 = p.normal.iter().map(|v| v * v).sum();
            if (len2 - 1.0).abs() > 1e-3 {
                return Err(bad(
                    SectionKind::Patches,
                    i,
                    "patch normal is not unit length",
                ));
            }
            if p.reflectance.min_channel() < 0.0 || p.reflectance.max_channel() >= 1.0 {
                return Err(bad(SectionKind::Patches, i, "reflectance outside [0, 1)"));
            }
            if p.emission.min_channel() < 0.0 {
                return Err(bad(SectionKind::Patches, i, "emission is negative"));
            }
            if p.object as usize >= self.objects.len() {
                return Err(bad(SectionKind::Patches, i, "object index out of range"));
            }
        }
        let mut seen = alloc::vec![0u64; n.div_ceil(64)];
        for (i, &o) in self.order.iter().enumerate() {
            let o = o as usize;
            if o >= n {
                return Err(bad(SectionKind::Order, i, "patch index out of range"));
            }
            if seen[o / 64] & (1 << (o % 64)) != 0 {
                return Err(bad(
                    SectionKind::Order,
                    i,
                    "patch index repeated: not a permutation",
                ));
            }
            seen[o / 64] |= 1 << (o % 64);
        }
        if self.objects.len() > u32::MAX as usize {
            return Err(bad(SectionKind::Objects, 0, "too many objects"));
        }
        for v in [self.compression_rmse, self.lighting_error]
            .into_iter()
            .flatten()
        {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(
                    SectionKind::Meta,
                    0,
                    "error estimate not finite and non-negative",
                ));
            }
        }
        if let Bounces::Finite(0) = self.bounces {
            return Err(bad(SectionKind::Meta, 0, "bounces must be at least 1"));
        }
        if let Some(mesh) = &self.mesh {
            mesh.validate(n, self.objects.len())?;
        }
        self.matrix.validate()
    }

    /// Serialises the file after validating it (a writer never produces a file the parser
    /// would refuse).
    pub fn to_bytes(&self) -> Result<Vec<u8>, RadError> {
        self.validate()?;
        let l = &self.matrix.layout;
        let meta = Meta {
            n: l.n() as u32,
            channels: l.channels() as u32,
            format: l.format() as u32,
            max_tile: l.max_tile(),
            bounces: self.bounces.to_u32(),
            order: self.patch_order as u32,
            object_count: self.objects.len() as u32,
            sparse_nnz: self.matrix.sparse.nnz() as u32,
            compression_rmse: opt_to_f32(self.compression_rmse),
            lighting_error: opt_to_f32(self.lighting_error),
            correction_count: self.matrix.corrections.count() as u32,
            correction_base: self.matrix.corrections.base,
            reserved: [0; 2],
        };
        let objects = encode_objects(&self.objects);
        let mut sections: Vec<(SectionKind, &[u8])> = alloc::vec![
            (SectionKind::Meta, bytemuck::bytes_of(&meta)),
            (SectionKind::Patches, bytemuck::cast_slice(&self.patches)),
            (SectionKind::Order, bytemuck::cast_slice(&self.order)),
            (
                SectionKind::Scales,
                bytemuck::cast_slice(&self.matrix.scales)
            ),
            (SectionKind::Blocks, &self.matrix.blocks),
            (
                SectionKind::SparseRows,
                bytemuck::cast_slice(&self.matrix.sparse.row_ptr)
            ),
            (
                SectionKind::SparseCols,
                bytemuck::cast_slice(&self.matrix.sparse.cols)
            ),
            (
                SectionKind::SparseValues,
                bytemuck::cast_slice(&self.matrix.sparse.values)
            ),
            (SectionKind::Objects, &objects),
        ];
        if let Some(r) = &self.report {
            sections.push((SectionKind::Report, r.as_bytes()));
        }
        let mesh = self.mesh.as_ref().map(Mesh::to_bytes);
        if let Some(m) = &mesh {
            sections.push((SectionKind::Mesh, m));
        }
        let c = &self.matrix.corrections;
        if !c.is_empty() {
            sections.extend([
                (
                    SectionKind::CorrectionRows,
                    bytemuck::cast_slice(&c.row_ptr),
                ),
                (SectionKind::CorrectionCols, bytemuck::cast_slice(&c.cols)),
                (SectionKind::CorrectionExponents, &c.exponents[..]),
                (SectionKind::CorrectionCodes, bytemuck::cast_slice(&c.codes)),
            ]);
        }
        let table_end = 32 + 32 * sections.len() as u64;
        let mut entries = Vec::with_capacity(sections.len());
        let mut pos = table_end;
        for (kind, bytes) in &sections {
            let offset = align(pos);
            entries.push(SectionEntry {
                kind: *kind as u32,
                reserved: 0,
                offset,
                len: bytes.len() as u64,
                checksum: crc32(bytes),
                reserved2: 0,
            });
            pos = offset + bytes.len() as u64;
        }
        let file_len = align(pos);
        let mut out = alloc::vec![0u8; file_len as usize];
        let mut header = Header {
            magic: MAGIC,
            version: VERSION,
            section_count: sections.len() as u32,
            file_len,
            checksum: 0,
            reserved: 0,
        };
        out[32..table_end as usize].copy_from_slice(bytemuck::cast_slice(&entries));
        header.checksum = header_checksum(&header, &out[32..table_end as usize]);
        out[..32].copy_from_slice(bytemuck::bytes_of(&header));
        for ((_, bytes), e) in sections.iter().zip(&entries) {
            out[e.offset as usize..e.offset as usize + bytes.len()].copy_from_slice(bytes);
        }
        Ok(out)
    }

    /// Parses and fully validates a `.rad` file. Never panics and never reads out of bounds,
    /// whatever `bytes` holds.
    pub fn parse(bytes: &'a [u8]) -> Result<Self, RadError> {
        let s = read_structure(bytes)?;
        let sec = |k: SectionKind| s.sections[k as usize - 1];
        let meta_bytes = sec(SectionKind::Meta).ok_or(RadError::MissingSection {
            kind: SectionKind::Meta,
        })?;
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
        let format = Format::from_u32(meta.format).ok_or(RadError::Invalid {
            section: SectionKind::Meta,
            index: 0,
            reason: "unknown matrix format code",
        })?;
        let layout = MatrixLayout::new(meta.n, meta.channels, format, meta.max_tile)?;
        let bounces = Bounces::from_u32(meta.bounces).ok_or(RadError::Invalid {
            section: SectionKind::Meta,
            index: 0,
            reason: "bounces must be at least 1",
        })?;
        let patch_order = PatchOrder::from_u32(meta.order).ok_or(RadError::Invalid {
            section: SectionKind::Meta,
            index: 0,
            reason: "unknown patch order code",
        })?;
        for v in [meta.compression_rmse, meta.lighting_error] {
            // Negative means "not measured"; NaN and infinity mean corruption.
            if !v.is_finite() {
                return Err(RadError::Invalid {
                    section: SectionKind::Meta,
                    index: 0,
                    reason: "error estimate is not finite",
                });
            }
        }
        let (n, ch, nnz) = (meta.n as u64, meta.channels as u64, meta.sparse_nnz as u64);
        let corrections = read_corrections(&s, &meta, &layout)?;
        let required = |k: SectionKind| sec(k).ok_or(RadError::MissingSection { kind: k });
        let patches = required(SectionKind::Patches)?;
        expect_len(
            SectionKind::Patches,
            patches,
            n * core::mem::size_of::<Patch>() as u64,
        )?;
        let order = required(SectionKind::Order)?;
        expect_len(SectionKind::Order, order, 4 * n)?;
        let scales = required(SectionKind::Scales)?;
        expect_len(SectionKind::Scales, scales, 8 * layout.scale_count() as u64)?;
        let blocks = required(SectionKind::Blocks)?;
        expect_len(SectionKind::Blocks, blocks, layout.block_bytes())?;
        let rows = required(SectionKind::SparseRows)?;
        expect_len(SectionKind::SparseRows, rows, 4 * (n + 1))?;
        let cols = required(SectionKind::SparseCols)?;
        expect_len(SectionKind::SparseCols, cols, 4 * nnz)?;
        let values = required(SectionKind::SparseValues)?;
        expect_len(SectionKind::SparseValues, values, 4 * nnz * ch)?;
        let objects = decode_objects(required(SectionKind::Objects)?, meta.object_count)?;
        let report = match sec(SectionKind::Report) {
            None => None,
            Some(r) => Some(Cow::Borrowed(core::str::from_utf8(r).map_err(|e| {
                RadError::Invalid {
                    section: SectionKind::Report,
                    index: e.valid_up_to() as u64,
                    reason: "report is not valid UTF-8",
                }
            })?)),
        };
        let file = RadFile {
            patches: cast(patches),
            order: cast(order),
            matrix: TransferMatrix {
                layout,
                scales: cast(scales),
                blocks: Cow::Borrowed(blocks),
                sparse: SparseRows {
                    row_ptr: cast(rows),
                    cols: cast(cols),
                    values: cast(values),
                },
                corrections,
            },
            objects,
            bounces,
            patch_order,
            compression_rmse: f32_to_opt(meta.compression_rmse),
            lighting_error: f32_to_opt(meta.lighting_error),
            report,
            mesh: sec(SectionKind::Mesh)
                .map(|m| Mesh::from_bytes(m, n as usize))
                .transpose()?,
        };
        file.validate()?;
        Ok(file)
    }

    /// Copies every borrowed part, so the file outlives the bytes it was parsed from.
    pub fn into_owned(self) -> RadFile<'static> {
        RadFile {
            patches: Cow::Owned(self.patches.into_owned()),
            order: Cow::Owned(self.order.into_owned()),
            matrix: self.matrix.into_owned(),
            objects: self
                .objects
                .into_iter()
                .map(|o| Cow::Owned(o.into_owned()))
                .collect(),
            bounces: self.bounces,
            patch_order: self.patch_order,
            compression_rmse: self.compression_rmse,
            lighting_error: self.lighting_error,
            report: self.report.map(|r| Cow::Owned(r.into_owned())),
            mesh: self.mesh.map(Mesh::into_owned),
        }
    }
}

/// The byte-level structure of a file: the header and each known section's bytes.
struct Structure<'a> {
    version: u32,
    sections: [Option<&'a [u8]>; SectionKind::ALL.len()],
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
    let sec = |k: SectionKind| s.sections[k as usize - 1];
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

fn header_checksum(header: &Header, table: &[u8]) -> u32 {
    let mut h = *header;
    h.checksum = 0;
    let mut c = Crc32::new();
    c.update(bytemuck::bytes_of(&h));
    c.update(table);
    c.finish()
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

fn read_structure(bytes: &[u8]) -> Result<Structure<'_>, RadError> {
    let (header, entries) = read_table(bytes)?;
    let actual = bytes.len() as u64;
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
    let mut sections = [None; SectionKind::ALL.len()];
    let mut pos = 32 + 32 * u64::from(header.section_count);
    let mut last_kind = 0u32;
    for (i, e) in entries.iter().enumerate() {
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
        last_kind = e.kind;
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
        check_padding(bytes, pos, e.offset)?;
        let end = e
            .offset
            .checked_add(e.len)
            .filter(|end| *end <= actual)
            .ok_or(RadError::Truncated {
                needed: e.offset.saturating_add(e.len),
                actual,
            })?;
        let data = &bytes[e.offset as usize..end as usize];
        let computed = crc32(data);
        if computed != e.checksum {
            return Err(RadError::SectionChecksum {
                kind,
                offset: e.offset,
                stored: e.checksum,
                computed,
            });
        }
        sections[kind as usize - 1] = Some(data);
        pos = end;
    }
    if align(pos) != header.file_len {
        // The declared length must end exactly at the last section's padding.
        return Err(RadError::TrailingBytes {
            expected: align(pos),
            actual,
        });
    }
    check_padding(bytes, pos, header.file_len)?;
    for k in SectionKind::ALL {
        if k.required() && sections[k as usize - 1].is_none() {
            return Err(RadError::MissingSection { kind: k });
        }
    }
    Ok(Structure {
        version: header.version,
        sections,
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

/// Borrows `bytes` as `[T]` when aligned, copies otherwise. The caller has checked that the
/// length is a multiple of `size_of::<T>()`.
pub(crate) fn cast<T: Pod>(bytes: &[u8]) -> Cow<'_, [T]> {
    match bytemuck::try_cast_slice(bytes) {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => {
            let mut v = alloc::vec![T::zeroed(); bytes.len() / core::mem::size_of::<T>()];
            bytemuck::cast_slice_mut::<T, u8>(&mut v).copy_from_slice(bytes);
            Cow::Owned(v)
        }
    }
}

fn encode_objects(names: &[Cow<'_, str>]) -> Vec<u8> {
    let mut offsets = Vec::with_capacity(names.len() + 1);
    let mut text = String::new();
    offsets.push(0u32);
    for name in names {
        text.push_str(name);
        offsets.push(text.len() as u32);
    }
    let mut out: Vec<u8> = bytemuck::cast_slice(&offsets).to_vec();
    out.extend_from_slice(text.as_bytes());
    out
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
    let offsets: Vec<u32> = offsets
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
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

/// Recomputes every checksum in `bytes` so they agree with the content.
///
/// For tests and fuzzers only: it lets a deliberately corrupted payload (a NaN, a bad count)
/// reach the semantic checks behind the checksums. Sections outside the buffer are skipped.
pub fn reseal(bytes: &mut [u8]) -> Result<(), RadError> {
    if bytes.len() < 32 {
        return Err(RadError::Truncated {
            needed: 32,
            actual: bytes.len() as u64,
        });
    }
    let mut header: Header = bytemuck::pod_read_unaligned(&bytes[..32]);
    let count = u64::from(header.section_count).min(SectionKind::ALL.len() as u64);
    let table_end = (32 + 32 * count) as usize;
    if bytes.len() < table_end {
        return Err(RadError::Truncated {
            needed: table_end as u64,
            actual: bytes.len() as u64,
        });
    }
    for i in 0..count as usize {
        let at = 32 + 32 * i;
        let mut e: SectionEntry = bytemuck::pod_read_unaligned(&bytes[at..at + 32]);
        if let Some(end) = e
            .offset
            .checked_add(e.len)
            .filter(|end| *end <= bytes.len() as u64)
        {
            e.checksum = crc32(&bytes[e.offset as usize..end as usize]);
            bytes[at..at + 32].copy_from_slice(bytemuck::bytes_of(&e));
        }
    }
    header.checksum = header_checksum(&header, &bytes[32..table_end]);
    bytes[..32].copy_from_slice(bytemuck::bytes_of(&header));
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layouts_are_stable() {
        assert_eq!(size_of::<Header>(), 32);
        assert_eq!(offset_of!(Header, file_len), 16);
        assert_eq!(offset_of!(Header, checksum), 24);
        assert_eq!(size_of::<SectionEntry>(), 32);
        assert_eq!(offset_of!(SectionEntry, offset), 8);
        assert_eq!(offset_of!(SectionEntry, checksum), 24);
        assert_eq!(size_of::<Meta>(), 64);
        assert_eq!(offset_of!(Meta, compression_rmse), 32);
        assert_eq!(size_of::<crate::LogScale>(), 8);
    }
}
