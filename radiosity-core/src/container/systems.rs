//! A level's systems in a `.rad` file (version 3): the SYSTEMS table, the COUPLING between
//! systems and SYSTEM_DATA, each system's own `.rad` file (`docs/contract.md`, "Systems files").
//!
//! A level file is an ordinary `.rad` file of the whole level (patches, order, objects, mesh,
//! parts, sky, probes) whose own matrix is [`crate::MatrixLayout::none`]: its transfer lives
//! in its systems. System `s` covers the level's patches `start..start + count` and its file,
//! a complete one-system `.rad` file of those patches (the same [`Patch`] values, in the same
//! order), lies at `offset..offset + len` of SYSTEM_DATA. The systems' files follow each
//! other at multiples of 16 bytes, zero between them, so every byte is accounted for, and each
//! carries its own checksums: an engine that streams a level reads the file's head
//! ([`head_len`], [`RadFile::parse_head`]) and then one system's bytes at a time
//! ([`LevelSystems::file_range`], [`LevelSystems::accept`]).

use crate::pod_bytes::cast;
use crate::systems::Coupling;
use crate::{Patch, RadError, RadFile, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};
use core::ops::Range;

/// One entry of the SYSTEMS section.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct SystemEntry {
    /// The system's first patch in the level's numbering.
    pub start: u32,
    /// Its patches.
    pub count: u32,
    /// Byte offset of its file in SYSTEM_DATA.
    pub offset: u64,
    /// Length of its file.
    pub len: u64,
    /// Zero.
    pub reserved: [u32; 2],
}

/// A level's systems: where each lies, the light between them, and (once loaded) their files.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelSystems<'a> {
    /// One entry a system, their patch ranges tiling the level in order.
    pub entries: Cow<'a, [SystemEntry]>,
    /// The form factors between systems, in the level's numbering.
    pub coupling: Coupling<'a>,
    /// SYSTEM_DATA: the systems' files, or empty where only the file's head was read
    /// ([`RadFile::parse_head`]).
    pub data: Cow<'a, [u8]>,
    /// Byte offset of SYSTEM_DATA in the level file (0 before the file is written).
    pub data_offset: u64,
    /// Length of SYSTEM_DATA.
    pub data_len: u64,
}

fn align16(x: u64) -> u64 {
    x.div_ceil(16) * 16
}

impl<'a> LevelSystems<'a> {
    /// The systems of `files` (each a one-system file, in the level's order) and the
    /// `coupling` between them. Fails if a file does not serialise.
    pub fn from_files(files: &[RadFile<'_>], coupling: Coupling<'a>) -> Result<Self, RadError> {
        let mut entries = Vec::with_capacity(files.len());
        let mut data = Vec::new();
        let mut start = 0u32;
        for f in files {
            let bytes = f.to_bytes()?;
            let offset = data.len() as u64;
            data.extend_from_slice(&bytes);
            data.resize(align16(data.len() as u64) as usize, 0);
            entries.push(SystemEntry {
                start,
                count: f.n() as u32,
                offset,
                len: bytes.len() as u64,
                reserved: [0; 2],
            });
            start += f.n() as u32;
        }
        let data_len = data.len() as u64;
        Ok(Self {
            entries: Cow::Owned(entries),
            coupling,
            data: Cow::Owned(data),
            data_offset: 0,
            data_len,
        })
    }

    /// Systems.
    pub fn count(&self) -> usize {
        self.entries.len()
    }

    /// Patches of the level.
    pub fn n(&self) -> usize {
        self.entries
            .last()
            .map_or(0, |e| e.start as usize + e.count as usize)
    }

    /// The level's patches of system `s`.
    pub fn range(&self, s: usize) -> Range<usize> {
        let e = &self.entries[s];
        e.start as usize..e.start as usize + e.count as usize
    }

    /// Every system's patches, in order.
    pub fn ranges(&self) -> Vec<Range<usize>> {
        (0..self.count()).map(|s| self.range(s)).collect()
    }

    /// The bytes of system `s`'s file within the level file (where [`Self::data_offset`]
    /// says SYSTEM_DATA lies): what a streaming engine reads to load it.
    pub fn file_range(&self, s: usize) -> Range<u64> {
        let e = &self.entries[s];
        let start = self.data_offset + e.offset;
        start..start + e.len
    }

    /// Whether the systems' files are here (a full parse) or only their places (a head).
    pub fn is_loaded(&self) -> bool {
        self.data.len() as u64 == self.data_len
    }

    /// System `s`'s file, parsed from the loaded data and checked against the level
    /// ([`Self::accept`]).
    ///
    /// # Panics
    /// If `s` is not a system of the level.
    pub fn system(&self, level: &RadFile<'_>, s: usize) -> Result<RadFile<'_>, RadError> {
        let e = &self.entries[s];
        let bytes = self
            .data
            .get(e.offset as usize..(e.offset + e.len) as usize)
            .ok_or(RadError::Truncated {
                needed: self.data_offset + e.offset + e.len,
                actual: self.data_offset + self.data.len() as u64,
            })?;
        self.accept(level, s, bytes)
    }

    /// Parses `bytes` as system `s`'s file (read by the caller at [`Self::file_range`]) and
    /// checks that it is this level's: its patches are the level's of that range, bit for
    /// bit, with the same objects and bounces.
    ///
    /// # Panics
    /// If `s` is not a system of the level.
    pub fn accept<'b>(
        &self,
        level: &RadFile<'_>,
        s: usize,
        bytes: &'b [u8],
    ) -> Result<RadFile<'b>, RadError> {
        let file = RadFile::parse(bytes)?;
        let bad = |reason| RadError::Invalid {
            section: SectionKind::SystemData,
            index: s as u64,
            reason,
        };
        if file.systems.is_some() {
            return Err(bad("a system's file is itself a level"));
        }
        let r = self.range(s);
        let same_patches = level.patches.get(r).is_some_and(|p: &[Patch]| {
            bytemuck::cast_slice::<Patch, u8>(p) == bytemuck::cast_slice::<Patch, u8>(&file.patches)
        });
        if !same_patches {
            return Err(bad("a system's patches are not the level's"));
        }
        if file.objects != level.objects || file.bounces != level.bounces {
            return Err(bad("a system's objects or bounces are not the level's"));
        }
        let (a, b) = (&file.matrix.layout, &level.matrix.layout);
        if a.channels() != b.channels() || a.format() != b.format() {
            return Err(bad("a system's channels or format are not the level's"));
        }
        Ok(file)
    }

    /// Checks the table, the coupling and the data's placement against a level of `n`
    /// patches (each system's file is checked by [`Self::system`]).
    pub fn validate(&self, n: usize) -> Result<(), RadError> {
        let bad = |section, index: usize, reason| RadError::Invalid {
            section,
            index: index as u64,
            reason,
        };
        if self.entries.is_empty() {
            return Err(bad(SectionKind::Systems, 0, "a level has no system"));
        }
        let mut start = 0u64;
        let mut offset = 0u64;
        for (s, e) in self.entries.iter().enumerate() {
            if e.reserved != [0; 2] {
                return Err(bad(SectionKind::Systems, s, "reserved field is not zero"));
            }
            if u64::from(e.start) != start || e.count == 0 {
                return Err(bad(
                    SectionKind::Systems,
                    s,
                    "systems do not tile the level's patches in order",
                ));
            }
            if e.offset != offset || e.len == 0 {
                return Err(bad(
                    SectionKind::Systems,
                    s,
                    "system files do not follow each other at multiples of 16 bytes",
                ));
            }
            start += u64::from(e.count);
            offset = e.offset.checked_add(e.len).map(align16).ok_or(bad(
                SectionKind::Systems,
                s,
                "system file too long",
            ))?;
        }
        if start != n as u64 {
            return Err(RadError::Count {
                section: SectionKind::Systems,
                expected: n as u64,
                found: start,
            });
        }
        if offset != self.data_len {
            return Err(RadError::Count {
                section: SectionKind::SystemData,
                expected: offset,
                found: self.data_len,
            });
        }
        if self.is_loaded() {
            // The zeros between systems' files.
            for (s, e) in self.entries.iter().enumerate() {
                let end = (e.offset + e.len) as usize;
                let next = align16(end as u64) as usize;
                if self.data[end..next].iter().any(|b| *b != 0) {
                    return Err(bad(
                        SectionKind::SystemData,
                        s,
                        "bytes between systems are not zero",
                    ));
                }
            }
        }
        if !self.coupling.fits(&self.ranges()) {
            return Err(bad(
                SectionKind::Coupling,
                0,
                "coupling rows do not fit the level's systems",
            ));
        }
        Ok(())
    }

    /// The COUPLING section's bytes.
    pub(super) fn coupling_bytes(&self) -> Vec<u8> {
        let c = &self.coupling;
        let mut out = Vec::with_capacity(4 * (c.row_ptr.len() + 2 * c.cols.len()));
        out.extend_from_slice(bytemuck::cast_slice(&c.row_ptr));
        out.extend_from_slice(bytemuck::cast_slice(&c.cols));
        out.extend_from_slice(bytemuck::cast_slice(&c.values));
        out
    }

    /// Reads the SYSTEMS and COUPLING sections of a level of `n` patches.
    pub(super) fn from_sections(
        table: &'a [u8],
        coupling: &'a [u8],
        n: usize,
    ) -> Result<Self, RadError> {
        let size = core::mem::size_of::<SystemEntry>();
        if !table.len().is_multiple_of(size) {
            return Err(RadError::SectionLength {
                kind: SectionKind::Systems,
                expected: (table.len() as u64).next_multiple_of(size as u64),
                found: table.len() as u64,
            });
        }
        let head = 4 * (n as u64 + 1);
        if (coupling.len() as u64) < head {
            return Err(RadError::SectionLength {
                kind: SectionKind::Coupling,
                expected: head,
                found: coupling.len() as u64,
            });
        }
        let (rows, rest) = coupling.split_at(head as usize);
        let nnz = u32::from_le_bytes(rows[rows.len() - 4..].try_into().expect("4 bytes"));
        let expected = head + 8 * u64::from(nnz);
        if coupling.len() as u64 != expected {
            return Err(RadError::SectionLength {
                kind: SectionKind::Coupling,
                expected,
                found: coupling.len() as u64,
            });
        }
        let (cols, values) = rest.split_at(4 * nnz as usize);
        Ok(Self {
            entries: cast(table),
            coupling: Coupling {
                row_ptr: cast(rows),
                cols: cast(cols),
                values: cast(values),
            },
            data: Cow::Borrowed(&[]),
            data_offset: 0,
            data_len: 0,
        })
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> LevelSystems<'static> {
        LevelSystems {
            entries: Cow::Owned(self.entries.into_owned()),
            coupling: self.coupling.into_owned(),
            data: Cow::Owned(self.data.into_owned()),
            data_offset: self.data_offset,
            data_len: self.data_len,
        }
    }
}
