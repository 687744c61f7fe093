//! Serialising ([`RadFile::to_bytes`]) and [`reseal`].

use super::{
    Header, MAGIC, Meta, PLAIN_VERSION, RadFile, SectionEntry, VERSION, align, header_checksum,
    opt_to_f32,
};
use crate::bounce::BounceRows;
use crate::checksum::crc32;
use crate::mesh::Mesh;
use crate::parts::PartRows;
use crate::probes::Probes;
use crate::{RadError, SectionKind};
use alloc::borrow::Cow;
use alloc::string::String;
use alloc::vec::Vec;

impl RadFile<'_> {
    /// Serialises the file after validating it (a writer never produces a file the parser
    /// would refuse).
    pub fn to_bytes(&self) -> Result<Vec<u8>, RadError> {
        self.validate()?;
        if let Some(s) = self.systems.as_ref().filter(|s| !s.is_loaded()) {
            return Err(RadError::Truncated {
                needed: s.data_offset + s.data_len,
                actual: s.data_offset + s.data.len() as u64,
            });
        }
        let encoded = Encoded::of(self);
        let version = if self.systems.is_some() {
            VERSION
        } else {
            PLAIN_VERSION
        };
        Ok(assemble(&self.sections(&encoded), version))
    }

    /// The META section of the file.
    fn meta(&self) -> Meta {
        let l = &self.matrix.layout;
        Meta {
            n: self.n() as u32,
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
        }
    }

    /// Every section the file has, in ascending code order: the file's own slices, and the
    /// sections `encoded` holds.
    fn sections<'s>(&'s self, encoded: &'s Encoded) -> Vec<(SectionKind, &'s [u8])> {
        let m = &self.matrix;
        let mut sections: Vec<(SectionKind, &[u8])> = alloc::vec![
            (SectionKind::Meta, bytemuck::bytes_of(&encoded.meta)),
            (SectionKind::Patches, bytemuck::cast_slice(&self.patches)),
            (SectionKind::Order, bytemuck::cast_slice(&self.order)),
            (SectionKind::Scales, bytemuck::cast_slice(&m.scales)),
            (SectionKind::Blocks, &m.blocks),
            (
                SectionKind::SparseRows,
                bytemuck::cast_slice(&m.sparse.row_ptr)
            ),
            (
                SectionKind::SparseCols,
                bytemuck::cast_slice(&m.sparse.cols)
            ),
            (
                SectionKind::SparseValues,
                bytemuck::cast_slice(&m.sparse.values)
            ),
            (SectionKind::Objects, &encoded.objects),
        ];
        if let Some(r) = &self.report {
            sections.push((SectionKind::Report, r.as_bytes()));
        }
        if let Some(m) = &encoded.mesh {
            sections.push((SectionKind::Mesh, m));
        }
        let c = &m.corrections;
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
        if let Some(p) = &encoded.probes {
            sections.push((SectionKind::Probes, p));
        }
        if let Some(sky) = &self.sky {
            sections.push((SectionKind::Sky, sky.to_bytes()));
        }
        if let Some(p) = &encoded.parts {
            sections.push((SectionKind::Parts, p));
        }
        if let Some(c) = &self.coverage {
            sections.push((SectionKind::Coverage, bytemuck::cast_slice(c)));
        }
        if let (Some(s), Some(c)) = (&self.systems, &encoded.coupling) {
            sections.extend([
                (SectionKind::Systems, bytemuck::cast_slice(&s.entries)),
                (SectionKind::Coupling, &c[..]),
                (SectionKind::SystemData, &s.data[..]),
            ]);
        }
        if let Some(b) = &encoded.bounce {
            sections.push((SectionKind::Bounce, b));
        }
        sections
    }
}

/// The sections that are not slices of a [`RadFile`] as it stands but encoded from it.
struct Encoded {
    meta: Meta,
    objects: Vec<u8>,
    mesh: Option<Vec<u8>>,
    probes: Option<Vec<u8>>,
    parts: Option<Vec<u8>>,
    bounce: Option<Vec<u8>>,
    coupling: Option<Vec<u8>>,
}

impl Encoded {
    fn of(file: &RadFile<'_>) -> Self {
        Encoded {
            meta: file.meta(),
            objects: encode_objects(&file.objects),
            mesh: file.mesh.as_ref().map(Mesh::to_bytes),
            probes: file.probes.as_ref().map(Probes::to_bytes),
            parts: file.parts.as_ref().map(PartRows::to_bytes),
            bounce: file.bounce.as_ref().map(BounceRows::to_bytes),
            coupling: file.systems.as_ref().map(|s| s.coupling_bytes()),
        }
    }
}

/// The file of `sections` (in ascending code order): header of `version`, section table,
/// each section at the next multiple of [`super::SECTION_ALIGN`], zero padding, checksums.
fn assemble(sections: &[(SectionKind, &[u8])], version: u32) -> Vec<u8> {
    let table_end = 32 + 32 * sections.len() as u64;
    let mut entries = Vec::with_capacity(sections.len());
    let mut pos = table_end;
    for (kind, bytes) in sections {
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
        version,
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
    out
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
