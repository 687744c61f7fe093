//! The `.rad` container: a baked transfer matrix and what the runtime needs beside it.
//!
//! Layout (all little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 0..32 | [`Header`]: magic `\x89RAD\r\n\x1a\n`, version ([`VERSION`]), section count, file length, CRC-32 |
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
//!
//! [`RadFile::parse`] and the byte-level checks are in `read.rs`, [`RadFile::to_bytes`] and
//! [`reseal`] in `write.rs`.

#[cfg(target_endian = "big")]
compile_error!("the .rad zero-copy parser assumes a little-endian target");

mod read;
mod systems;
mod write;

pub use read::{head_len, section_ranges};
pub use systems::{LevelSystems, SystemEntry};
pub use write::reseal;

use crate::bounce::BounceRows;
use crate::checksum::Crc32;
use crate::mesh::Mesh;
use crate::parts::PartRows;
use crate::probes::Probes;
use crate::sky::SkyVisibility;
use crate::{Patch, RadError, SectionKind, TransferMatrix};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};

/// The first 8 bytes of every `.rad` file.
pub const MAGIC: [u8; 8] = *b"\x89RAD\r\n\x1a\n";
/// The newest version this build reads and writes: version 3 added systems (sections
/// 20–22, [`LevelSystems`]); a file of one matrix is still written as [`PLAIN_VERSION`].
pub const VERSION: u32 = 3;
/// The version of a file without systems. Version 2 added the block corrections (META's
/// `correction_count` and `correction_base`, sections 12–15).
pub const PLAIN_VERSION: u32 = 2;
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

/// The patch numbering the bake chose.
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
    /// Light probes, if the bake stored them.
    pub probes: Option<Probes<'a>>,
    /// Sky visibility per patch and probe, if the bake measured it (`None`: a sky cannot
    /// light this file).
    pub sky: Option<SkyVisibility<'a>>,
    /// Each object's own gather row in the patches it shares, if the bake stored them
    /// (`None`: every object takes its patches' bounced light).
    pub parts: Option<PartRows<'a>>,
    /// Each patch's first bounce gathered where its rays land, if the bake stored it
    /// (`None`: every patch sends its mean, [`crate::bounce`]). A file with it has the MESH
    /// section, whose samples its entries name.
    pub bounce: Option<BounceRows<'a>>,
    /// The coverage of each of the mesh's triangles, if some is below 1 (glTF `alphaMode`
    /// MASK or BLEND): the fraction of the triangle that is there, in (0, 1]. Shadow rays
    /// take `1 − c` of the light through a triangle of coverage c. A file with it has the
    /// MESH section, one value a triangle.
    pub coverage: Option<Cow<'a, [f32]>>,
    /// The level's systems, if it is cut into them (`matrix` is then
    /// [`TransferMatrix::none`]: the transfer lives in each system's own file).
    pub systems: Option<LevelSystems<'a>>,
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

/// [`RadError::Invalid`] for entry `index` of `section`.
fn invalid(section: SectionKind, index: usize, reason: &'static str) -> RadError {
    RadError::Invalid {
        section,
        index: index as u64,
        reason,
    }
}

impl<'a> RadFile<'a> {
    /// Patches.
    pub fn n(&self) -> usize {
        match &self.systems {
            Some(s) => s.n(),
            None => self.matrix.layout.n(),
        }
    }

    /// Checks everything [`RadFile::parse`] checks beyond the byte structure.
    pub fn validate(&self) -> Result<(), RadError> {
        let n = self.n();
        self.validate_patches(n)?;
        self.validate_order(n)?;
        self.validate_meta()?;
        self.validate_optional(n)?;
        self.validate_transfer(n)
    }

    /// One patch and one order entry each of the `n`, every patch finite, of positive area,
    /// unit normal, reflectance in [0, 1), emission not negative, its object in range.
    fn validate_patches(&self, n: usize) -> Result<(), RadError> {
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
        let bad = |i: usize, reason| invalid(SectionKind::Patches, i, reason);
        for (i, p) in self.patches.iter().enumerate() {
            let finite = p.centre.iter().chain(&p.normal).all(|v| v.is_finite())
                && p.area.is_finite()
                && p.reflectance.is_finite()
                && p.emission.is_finite();
            if !finite {
                return Err(bad(i, "patch has a NaN or infinite field"));
            }
            if !(p.area > 0.0) {
                return Err(bad(i, "patch area is not positive"));
            }
            let len2: f32 = p.normal.iter().map(|v| v * v).sum();
            if (len2 - 1.0).abs() > 1e-3 {
                return Err(bad(i, "patch normal is not unit length"));
            }
            if p.reflectance.min_channel() < 0.0 || p.reflectance.max_channel() >= 1.0 {
                return Err(bad(i, "reflectance outside [0, 1)"));
            }
            if p.emission.min_channel() < 0.0 {
                return Err(bad(i, "emission is negative"));
            }
            if p.object as usize >= self.objects.len() {
                return Err(bad(i, "object index out of range"));
            }
        }
        Ok(())
    }

    /// The order is a permutation of the `n` patches.
    fn validate_order(&self, n: usize) -> Result<(), RadError> {
        let bad = |i: usize, reason| invalid(SectionKind::Order, i, reason);
        let mut seen = alloc::vec![0u64; n.div_ceil(64)];
        for (i, &o) in self.order.iter().enumerate() {
            let o = o as usize;
            if o >= n {
                return Err(bad(i, "patch index out of range"));
            }
            if seen[o / 64] & (1 << (o % 64)) != 0 {
                return Err(bad(i, "patch index repeated: not a permutation"));
            }
            seen[o / 64] |= 1 << (o % 64);
        }
        Ok(())
    }

    /// What META carries: the object count within a `u32`, error estimates finite and not
    /// negative, at least one bounce.
    fn validate_meta(&self) -> Result<(), RadError> {
        if self.objects.len() > u32::MAX as usize {
            return Err(invalid(SectionKind::Objects, 0, "too many objects"));
        }
        for v in [self.compression_rmse, self.lighting_error]
            .into_iter()
            .flatten()
        {
            if !(v.is_finite() && v >= 0.0) {
                return Err(invalid(
                    SectionKind::Meta,
                    0,
                    "error estimate not finite and non-negative",
                ));
            }
        }
        if let Bounces::Finite(0) = self.bounces {
            return Err(invalid(SectionKind::Meta, 0, "bounces must be at least 1"));
        }
        Ok(())
    }

    /// The optional sections against the `n` patches and each other: probes, mesh, sky
    /// (one entry per patch and probe), parts and first-bounce rows (against the mesh's samples) and coverage (one
    /// value in (0, 1] per mesh triangle).
    fn validate_optional(&self, n: usize) -> Result<(), RadError> {
        if let Some(probes) = &self.probes {
            probes.validate(n)?;
        }
        if let Some(mesh) = &self.mesh {
            mesh.validate(n, self.objects.len())?;
        }
        if let Some(sky) = &self.sky {
            sky.validate(n, self.probes.as_ref().map_or(0, |p| p.positions.len()))?;
        }
        if let Some(parts) = &self.parts {
            let samples = self.mesh.as_ref().map_or(0, |m| m.samples.len());
            parts.validate(n, self.objects.len(), samples)?;
        }
        if let Some(bounce) = &self.bounce {
            let Some(mesh) = &self.mesh else {
                return Err(invalid(
                    SectionKind::Bounce,
                    0,
                    "first-bounce rows without the mesh they name",
                ));
            };
            bounce.validate(n, mesh.samples.len())?;
        }
        if let Some(coverage) = &self.coverage {
            let triangles = self.mesh.as_ref().map_or(0, |m| m.triangles.len());
            if coverage.len() != triangles {
                return Err(RadError::Count {
                    section: SectionKind::Coverage,
                    expected: triangles as u64,
                    found: coverage.len() as u64,
                });
            }
            if let Some(i) = coverage.iter().position(|c| !(*c > 0.0 && *c <= 1.0)) {
                return Err(invalid(SectionKind::Coverage, i, "coverage not in (0, 1]"));
            }
        }
        Ok(())
    }

    /// Where the transfer lives: the file's own matrix, or (a level file) its systems over
    /// the `n` patches, each loaded system checked, and then no matrix of its own.
    fn validate_transfer(&self, n: usize) -> Result<(), RadError> {
        match &self.systems {
            None if self.matrix.layout.is_none() => Err(invalid(
                SectionKind::Meta,
                0,
                "a file without systems has no matrix",
            )),
            None => self.matrix.validate(),
            Some(_) if !self.matrix.layout.is_none() => Err(invalid(
                SectionKind::Systems,
                0,
                "a level file with its own matrix",
            )),
            Some(systems) => {
                systems.validate(n)?;
                if systems.is_loaded() {
                    for s in 0..systems.count() {
                        systems.system(self, s)?;
                    }
                }
                Ok(())
            }
        }
    }

    /// A file of `patches` (in the matrix's numbering; `order[k]` the bake patch of file patch
    /// `k`), `matrix`, `objects` and `bounces`, its patches in natural order, with none of the
    /// optional parts: no compression figures, report, mesh, probes, sky, parts, coverage or
    /// systems. Set the ones that apply with struct update syntax
    /// (`RadFile { mesh: Some(mesh), ..RadFile::new(…) }`).
    pub fn new(
        patches: Cow<'a, [Patch]>,
        order: Cow<'a, [u32]>,
        matrix: TransferMatrix<'a>,
        objects: Vec<Cow<'a, str>>,
        bounces: Bounces,
    ) -> Self {
        RadFile {
            patches,
            order,
            matrix,
            objects,
            bounces,
            patch_order: PatchOrder::Natural,
            compression_rmse: None,
            lighting_error: None,
            report: None,
            mesh: None,
            probes: None,
            sky: None,
            parts: None,
            bounce: None,
            coverage: None,
            systems: None,
        }
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
            probes: self.probes.map(Probes::into_owned),
            sky: self.sky.map(|s| SkyVisibility {
                values: Cow::Owned(s.values.into_owned()),
            }),
            parts: self.parts.map(PartRows::into_owned),
            bounce: self.bounce.map(BounceRows::into_owned),
            coverage: self.coverage.map(|c| Cow::Owned(c.into_owned())),
            systems: self.systems.map(LevelSystems::into_owned),
        }
    }
}

fn header_checksum(header: &Header, table: &[u8]) -> u32 {
    let mut h = *header;
    h.checksum = 0;
    let mut c = Crc32::new();
    c.update(bytemuck::bytes_of(&h));
    c.update(table);
    c.finish()
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
