//! The container's error: what is wrong with a `.rad` file, and where.

use crate::layout::LayoutError;
use core::fmt;

/// The sections of a `.rad` file, by their code in the section table.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SectionKind {
    /// Fixed-size [`crate::container::Meta`]: sizes, format, bounces, order, error estimates.
    Meta = 1,
    /// `[Patch; n]`.
    Patches = 2,
    /// `[u32; n]`: file patch index → patch index in the bake (a permutation).
    Order = 3,
    /// `[LogScale; tiles · channels]` (empty for f16/f32).
    Scales = 4,
    /// Block data, laid out as [`crate::MatrixLayout`] says.
    Blocks = 5,
    /// `[u32; n + 1]` sparse row offsets.
    SparseRows = 6,
    /// `[u32; nnz]` sparse columns.
    SparseCols = 7,
    /// `[f32; nnz · channels]` sparse values.
    SparseValues = 8,
    /// Object names: `[u32; count + 1]` byte offsets, then the UTF-8 bytes.
    Objects = 9,
    /// Optional UTF-8 text (the bake's JSON report).
    Report = 10,
    /// Optional full-detail mesh ([`crate::mesh::Mesh`]).
    Mesh = 11,
    /// `[u32; padded/4 + 1]` block-correction row offsets (only with corrections).
    CorrectionRows = 12,
    /// `[u32; count]` block-correction columns.
    CorrectionCols = 13,
    /// `[u8; count · channels]` block-correction scale exponents.
    CorrectionExponents = 14,
    /// `[u32; count · channels · 2]` block-correction nibbles.
    CorrectionCodes = 15,
    /// Optional light probes ([`crate::probes::Probes`]).
    Probes = 16,
    /// Optional sky visibility ([`crate::sky::SkyVisibility`]).
    Sky = 17,
    /// Optional gather rows of the parts of shared patches ([`crate::parts::PartRows`]).
    Parts = 18,
    /// Optional coverage of the mesh's triangles (`f32` each, see
    /// [`crate::RadFile::coverage`]).
    Coverage = 19,
    /// A level's systems ([`crate::container::SystemEntry`] each; version 3, with
    /// COUPLING and SYSTEM_DATA).
    Systems = 20,
    /// The form factors between systems ([`crate::systems::Coupling`]): `[u32; n + 1]` row
    /// offsets, `[u32; nnz]` columns, `[f32; nnz]` values.
    Coupling = 21,
    /// Each system's own `.rad` file, back to back at multiples of 16 bytes.
    SystemData = 22,
    /// Optional first-bounce rows of every patch ([`crate::bounce::BounceRows`]).
    Bounce = 23,
}

impl SectionKind {
    /// Every kind, in file order.
    pub const ALL: [SectionKind; 23] = [
        SectionKind::Meta,
        SectionKind::Patches,
        SectionKind::Order,
        SectionKind::Scales,
        SectionKind::Blocks,
        SectionKind::SparseRows,
        SectionKind::SparseCols,
        SectionKind::SparseValues,
        SectionKind::Objects,
        SectionKind::Report,
        SectionKind::Mesh,
        SectionKind::CorrectionRows,
        SectionKind::CorrectionCols,
        SectionKind::CorrectionExponents,
        SectionKind::CorrectionCodes,
        SectionKind::Probes,
        SectionKind::Sky,
        SectionKind::Parts,
        SectionKind::Coverage,
        SectionKind::Systems,
        SectionKind::Coupling,
        SectionKind::SystemData,
        SectionKind::Bounce,
    ];

    /// The kind with this code.
    pub fn from_u32(v: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|k| *k as u32 == v)
    }

    /// Whether every file must have it.
    pub fn required(self) -> bool {
        !matches!(
            self,
            SectionKind::Report
                | SectionKind::Mesh
                | SectionKind::CorrectionRows
                | SectionKind::CorrectionCols
                | SectionKind::CorrectionExponents
                | SectionKind::CorrectionCodes
                | SectionKind::Probes
                | SectionKind::Sky
                | SectionKind::Parts
                | SectionKind::Coverage
                | SectionKind::Systems
                | SectionKind::Coupling
                | SectionKind::SystemData
                | SectionKind::Bounce
        )
    }

    /// Upper-case name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            SectionKind::Meta => "META",
            SectionKind::Patches => "PATCHES",
            SectionKind::Order => "ORDER",
            SectionKind::Scales => "SCALES",
            SectionKind::Blocks => "BLOCKS",
            SectionKind::SparseRows => "SPARSE_ROWS",
            SectionKind::SparseCols => "SPARSE_COLS",
            SectionKind::SparseValues => "SPARSE_VALUES",
            SectionKind::Objects => "OBJECTS",
            SectionKind::Report => "REPORT",
            SectionKind::Mesh => "MESH",
            SectionKind::CorrectionRows => "CORRECTION_ROWS",
            SectionKind::CorrectionCols => "CORRECTION_COLS",
            SectionKind::CorrectionExponents => "CORRECTION_EXPONENTS",
            SectionKind::CorrectionCodes => "CORRECTION_CODES",
            SectionKind::Probes => "PROBES",
            SectionKind::Sky => "SKY",
            SectionKind::Parts => "PARTS",
            SectionKind::Coverage => "COVERAGE",
            SectionKind::Systems => "SYSTEMS",
            SectionKind::Coupling => "COUPLING",
            SectionKind::SystemData => "SYSTEM_DATA",
            SectionKind::Bounce => "BOUNCE",
        }
    }
}

impl fmt::Display for SectionKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything that can be wrong with a `.rad` file (or with a [`crate::RadFile`] about to be
/// written). Each variant says where: a byte offset, or a section and an item index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RadError {
    /// The file ends before something it must contain.
    Truncated {
        /// Bytes needed.
        needed: u64,
        /// Bytes present.
        actual: u64,
    },
    /// The file has bytes after its declared end.
    TrailingBytes {
        /// Length the header declares.
        expected: u64,
        /// Actual length.
        actual: u64,
    },
    /// The first 8 bytes are not the `.rad` magic.
    BadMagic,
    /// A version this build does not read.
    UnsupportedVersion {
        /// The version in the file.
        found: u32,
    },
    /// The section count is outside what any valid file has.
    SectionCount {
        /// The count in the header.
        found: u32,
    },
    /// The header or section table does not match its checksum.
    HeaderChecksum {
        /// Checksum in the file.
        stored: u32,
        /// Checksum of the bytes.
        computed: u32,
    },
    /// A reserved field is not zero.
    NonZeroReserved {
        /// Byte offset of the field.
        offset: u64,
    },
    /// A section code this version does not know.
    UnknownSection {
        /// Position in the section table.
        index: u32,
        /// The code.
        kind: u32,
    },
    /// A section appears twice or out of order.
    SectionOrder {
        /// Position in the section table.
        index: u32,
        /// The section.
        kind: SectionKind,
    },
    /// A section does not start where the previous one (aligned to 16) ends.
    SectionPlacement {
        /// The section.
        kind: SectionKind,
        /// Its offset in the table.
        offset: u64,
        /// Where it must start.
        expected: u64,
    },
    /// A section's bytes do not match its checksum.
    SectionChecksum {
        /// The section.
        kind: SectionKind,
        /// Its byte offset.
        offset: u64,
        /// Checksum in the table.
        stored: u32,
        /// Checksum of the bytes.
        computed: u32,
    },
    /// Alignment padding holds a non-zero byte.
    NonZeroPadding {
        /// Byte offset of the first non-zero padding byte.
        offset: u64,
    },
    /// A required section is absent.
    MissingSection {
        /// The section.
        kind: SectionKind,
    },
    /// A section's length disagrees with the counts in META.
    SectionLength {
        /// The section.
        kind: SectionKind,
        /// Length the counts call for.
        expected: u64,
        /// Length in the table.
        found: u64,
    },
    /// An array has the wrong number of items (in-memory form of [`RadError::SectionLength`]).
    Count {
        /// The section the array belongs to.
        section: SectionKind,
        /// Items expected.
        expected: u64,
        /// Items found.
        found: u64,
    },
    /// META describes an impossible matrix.
    Layout(LayoutError),
    /// An item holds a value it must not (NaN, out of range, not a permutation, …).
    Invalid {
        /// The section.
        section: SectionKind,
        /// Index of the first bad item in that section's array (byte offset for text).
        index: u64,
        /// What is wrong.
        reason: &'static str,
    },
}

impl fmt::Display for RadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use RadError::*;
        match self {
            Truncated { needed, actual } => {
                write!(f, "truncated .rad file: needs {needed} bytes, has {actual}")
            }
            TrailingBytes { expected, actual } => write!(
                f,
                "{} unexpected bytes after the end of the .rad data at offset {expected}",
                actual - expected
            ),
            BadMagic => f.write_str("not a .rad file (bad magic in the first 8 bytes)"),
            UnsupportedVersion { found } => {
                write!(
                    f,
                    ".rad version {found} is not supported (this build reads version 1)"
                )
            }
            SectionCount { found } => {
                write!(f, "section count {found} in the header is impossible")
            }
            HeaderChecksum { stored, computed } => write!(
                f,
                "header checksum mismatch (stored {stored:#010x}, computed {computed:#010x}): header or section table is corrupt"
            ),
            NonZeroReserved { offset } => {
                write!(f, "reserved field at offset {offset} is not zero")
            }
            UnknownSection { index, kind } => {
                write!(
                    f,
                    "section table entry {index} has unknown section code {kind}"
                )
            }
            SectionOrder { index, kind } => {
                write!(
                    f,
                    "section {kind} at table entry {index} is duplicated or out of order"
                )
            }
            SectionPlacement {
                kind,
                offset,
                expected,
            } => {
                write!(
                    f,
                    "section {kind} starts at offset {offset}, expected {expected}"
                )
            }
            SectionChecksum {
                kind,
                offset,
                stored,
                computed,
            } => write!(
                f,
                "section {kind} at offset {offset} is corrupt (checksum {computed:#010x}, expected {stored:#010x})"
            ),
            NonZeroPadding { offset } => write!(f, "padding byte at offset {offset} is not zero"),
            MissingSection { kind } => write!(f, "required section {kind} is missing"),
            SectionLength {
                kind,
                expected,
                found,
            } => {
                write!(
                    f,
                    "section {kind} is {found} bytes, but META calls for {expected}"
                )
            }
            Count {
                section,
                expected,
                found,
            } => {
                write!(f, "{section} holds {found} items, expected {expected}")
            }
            Layout(e) => write!(f, "META describes an impossible matrix: {e}"),
            Invalid {
                section,
                index,
                reason,
            } => write!(f, "{section}[{index}]: {reason}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for RadError {}

impl From<LayoutError> for RadError {
    fn from(e: LayoutError) -> Self {
        RadError::Layout(e)
    }
}
