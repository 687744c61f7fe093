//! The full-detail mesh a `.rad` file may carry (its optional MESH section), so that the
//! runtime can cast shadow rays, light patches from analytic lights, and interpolate indirect
//! light per vertex and per pixel without the original OBJ.
//!
//! Section layout (little-endian, every array 4-byte aligned because the section starts at a
//! multiple of 16 and every element is a multiple of 4 bytes):
//!
//! | bytes | content |
//! |---|---|
//! | 16 | [`MeshCounts`]: vertices `v`, triangles `t`, corner weights `w`, patch samples `s` |
//! | 12·v | positions `[f32; 3]` |
//! | 40·t | [`MeshTriangle`]s |
//! | 4·(3t+1) | corner weight row starts: corner `c` of triangle `i` is row `3i + c` |
//! | 8·w | [`CornerWeight`]s |
//! | 4·(n+1) | patch sample row starts, one row per matrix patch |
//! | 28·s | [`PatchSample`]s |

use crate::pod_bytes::cast;
use crate::{RadError, Rgb, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};

/// The MESH section's counts.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct MeshCounts {
    /// Vertices.
    pub vertices: u32,
    /// Triangles.
    pub triangles: u32,
    /// Corner weights (all rows together).
    pub corner_weights: u32,
    /// Patch samples (all rows together).
    pub samples: u32,
}

/// A full-detail triangle: corners, object and material.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MeshTriangle {
    /// Vertex indices, counter-clockwise seen from the front.
    pub vertices: [u32; 3],
    /// Object index (into the file's object names).
    pub object: u32,
    /// Mean diffuse reflectance over the triangle, each channel in `[0, 1)`.
    pub reflectance: Rgb,
    /// Emitted exitance E = π·L (W/m²), from the front.
    pub emission: Rgb,
}

/// One interpolation weight: a share of a matrix patch's irradiance.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CornerWeight {
    /// Patch index in the matrix numbering.
    pub patch: u32,
    /// Weight in `[0, 1]`; a corner's weights sum to 1 (or the row is empty).
    pub weight: f32,
}

/// A point where direct light on a patch is sampled: the centroid of one piece of the patch, or
/// of one cell of a grid laid over a piece (a patch has at least 16).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PatchSample {
    /// Position.
    pub position: [f32; 3],
    /// Unit front normal.
    pub normal: [f32; 3],
    /// Area the sample stands for (its piece's area); strictly positive.
    pub area: f32,
}

/// The mesh, borrowing from the file where aligned.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh<'a> {
    /// Vertex positions.
    pub positions: Cow<'a, [[f32; 3]]>,
    /// Triangles.
    pub triangles: Cow<'a, [MeshTriangle]>,
    /// Corner weight row starts (`3·triangles + 1`).
    pub corner_rows: Cow<'a, [u32]>,
    /// Corner weights.
    pub corner_weights: Cow<'a, [CornerWeight]>,
    /// Patch sample row starts (`patches + 1`).
    pub sample_rows: Cow<'a, [u32]>,
    /// Patch samples.
    pub samples: Cow<'a, [PatchSample]>,
}

fn invalid(index: usize, reason: &'static str) -> RadError {
    RadError::Invalid {
        section: SectionKind::Mesh,
        index: index as u64,
        reason,
    }
}

/// Checks CSR row starts: `rows` long `count + 1`, from 0, non-decreasing, ending at `total`.
fn check_rows(
    rows: &[u32],
    count: usize,
    total: usize,
    what: &'static str,
) -> Result<(), RadError> {
    if rows.len() != count + 1 {
        return Err(RadError::Count {
            section: SectionKind::Mesh,
            expected: count as u64 + 1,
            found: rows.len() as u64,
        });
    }
    if rows[0] != 0 {
        return Err(invalid(0, what));
    }
    if let Some(i) = rows.windows(2).position(|w| w[1] < w[0]) {
        return Err(invalid(i + 1, what));
    }
    if rows[count] as usize != total {
        return Err(invalid(count, what));
    }
    Ok(())
}

impl<'a> Mesh<'a> {
    /// The counts of the section header.
    pub fn counts(&self) -> MeshCounts {
        MeshCounts {
            vertices: self.positions.len() as u32,
            triangles: self.triangles.len() as u32,
            corner_weights: self.corner_weights.len() as u32,
            samples: self.samples.len() as u32,
        }
    }

    /// Corners of triangle `t`.
    pub fn corners(&self, t: usize) -> [[f32; 3]; 3] {
        self.triangles[t]
            .vertices
            .map(|v| self.positions[v as usize])
    }

    /// Interpolation weights of corner `c` (0, 1, 2) of triangle `t`.
    pub fn corner(&self, t: usize, c: usize) -> &[CornerWeight] {
        let r = 3 * t + c;
        &self.corner_weights[self.corner_rows[r] as usize..self.corner_rows[r + 1] as usize]
    }

    /// The direct-light samples of patch `p`.
    pub fn samples_of(&self, p: usize) -> &[PatchSample] {
        &self.samples[self.sample_rows[p] as usize..self.sample_rows[p + 1] as usize]
    }

    /// Per-patch irradiance `per_patch` interpolated to the point of triangle `t` with
    /// barycentrics `(u, v)` of corners 1 and 2.
    pub fn interpolate(&self, t: usize, u: f32, v: f32, per_patch: &[Rgb]) -> Rgb {
        let w = [1.0 - u - v, u, v];
        let mut acc = Rgb::ZERO;
        for (c, wc) in w.into_iter().enumerate() {
            for e in self.corner(t, c) {
                acc += per_patch[e.patch as usize] * (wc * e.weight);
            }
        }
        acc
    }

    /// Checks every index and value against a file of `patches` patches and `objects` objects.
    pub fn validate(&self, patches: usize, objects: usize) -> Result<(), RadError> {
        if self.positions.len() > u32::MAX as usize
            || self.triangles.len() > (u32::MAX as usize - 1) / 3
            || self.corner_weights.len() > u32::MAX as usize
            || self.samples.len() > u32::MAX as usize
        {
            return Err(invalid(0, "mesh too large"));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(invalid(i, "vertex position is NaN or infinite"));
        }
        let nv = self.positions.len();
        for (i, t) in self.triangles.iter().enumerate() {
            if t.vertices.iter().any(|&v| v as usize >= nv) {
                return Err(invalid(i, "triangle vertex index out of range"));
            }
            if t.object as usize >= objects {
                return Err(invalid(i, "triangle object index out of range"));
            }
            if !(t.reflectance.is_finite() && t.emission.is_finite()) {
                return Err(invalid(i, "triangle material is NaN or infinite"));
            }
            if t.reflectance.min_channel() < 0.0 || t.reflectance.max_channel() >= 1.0 {
                return Err(invalid(i, "triangle reflectance outside [0, 1)"));
            }
            if t.emission.min_channel() < 0.0 {
                return Err(invalid(i, "triangle emission is negative"));
            }
        }
        check_rows(
            &self.corner_rows,
            3 * self.triangles.len(),
            self.corner_weights.len(),
            "corner weight rows not increasing from 0 to the weight count",
        )?;
        for (i, w) in self.corner_weights.iter().enumerate() {
            if w.patch as usize >= patches {
                return Err(invalid(i, "corner weight patch index out of range"));
            }
            if !(w.weight >= 0.0 && w.weight <= 1.0) {
                return Err(invalid(i, "corner weight outside [0, 1]"));
            }
        }
        check_rows(
            &self.sample_rows,
            patches,
            self.samples.len(),
            "patch sample rows not increasing from 0 to the sample count",
        )?;
        for (i, s) in self.samples.iter().enumerate() {
            let finite = s.position.iter().chain(&s.normal).all(|v| v.is_finite());
            let has_area = s.area > 0.0 && s.area.is_finite();
            if !(finite && has_area) {
                return Err(invalid(i, "patch sample not finite or without area"));
            }
            let len2: f32 = s.normal.iter().map(|v| v * v).sum();
            if (len2 - 1.0).abs() > 1e-3 {
                return Err(invalid(i, "patch sample normal is not unit length"));
            }
        }
        Ok(())
    }

    /// The section bytes. The caller has validated the mesh.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        out.extend_from_slice(bytemuck::bytes_of(&self.counts()));
        out.extend_from_slice(bytemuck::cast_slice(&self.positions));
        out.extend_from_slice(bytemuck::cast_slice(&self.triangles));
        out.extend_from_slice(bytemuck::cast_slice(&self.corner_rows));
        out.extend_from_slice(bytemuck::cast_slice(&self.corner_weights));
        out.extend_from_slice(bytemuck::cast_slice(&self.sample_rows));
        out.extend_from_slice(bytemuck::cast_slice(&self.samples));
        out
    }

    /// Splits the section bytes (checking the length against the counts) for a file of
    /// `patches` patches. Values are checked by [`Self::validate`].
    pub fn from_bytes(bytes: &'a [u8], patches: usize) -> Result<Self, RadError> {
        if bytes.len() < 16 {
            return Err(RadError::SectionLength {
                kind: SectionKind::Mesh,
                expected: 16,
                found: bytes.len() as u64,
            });
        }
        let c: MeshCounts = bytemuck::pod_read_unaligned(&bytes[..16]);
        let (v, t, w, s) = (
            u64::from(c.vertices),
            u64::from(c.triangles),
            u64::from(c.corner_weights),
            u64::from(c.samples),
        );
        let sizes = [
            12 * v,
            40 * t,
            4 * (3 * t + 1),
            8 * w,
            4 * (patches as u64 + 1),
            28 * s,
        ];
        let expected = 16 + sizes.iter().sum::<u64>();
        if bytes.len() as u64 != expected {
            return Err(RadError::SectionLength {
                kind: SectionKind::Mesh,
                expected,
                found: bytes.len() as u64,
            });
        }
        let mut at = 16usize;
        let mut next = |len: u64| {
            let s = &bytes[at..at + len as usize];
            at += len as usize;
            s
        };
        Ok(Mesh {
            positions: cast(next(sizes[0])),
            triangles: cast(next(sizes[1])),
            corner_rows: cast(next(sizes[2])),
            corner_weights: cast(next(sizes[3])),
            sample_rows: cast(next(sizes[4])),
            samples: cast(next(sizes[5])),
        })
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> Mesh<'static> {
        Mesh {
            positions: Cow::Owned(self.positions.into_owned()),
            triangles: Cow::Owned(self.triangles.into_owned()),
            corner_rows: Cow::Owned(self.corner_rows.into_owned()),
            corner_weights: Cow::Owned(self.corner_weights.into_owned()),
            sample_rows: Cow::Owned(self.sample_rows.into_owned()),
            samples: Cow::Owned(self.samples.into_owned()),
        }
    }
}

/// Why [`Mesh::corner_indirect`] refused its slices: the per-patch input must have one entry
/// per matrix patch and the output one per triangle corner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CornerLengthError {
    /// Matrix patches the mesh was built for.
    pub patches: usize,
    /// Entries in the per-patch slice.
    pub per_patch: usize,
    /// Corners of the mesh (`3 × triangles`).
    pub corners: usize,
    /// Entries in the output slice.
    pub out: usize,
}

impl core::fmt::Display for CornerLengthError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "corner light needs {} per-patch values and room for {} corners (3 per triangle), got {} and {}",
            self.patches, self.corners, self.per_patch, self.out
        )
    }
}

#[cfg(feature = "std")]
impl std::error::Error for CornerLengthError {}

impl Mesh<'_> {
    /// Corners of the mesh: three per triangle.
    pub fn corner_count(&self) -> usize {
        3 * self.triangles.len()
    }

    /// Per-corner indirect irradiance of the full-detail mesh from per-patch irradiance
    /// `per_patch` (a gather's `y`, in the file's matrix patch numbering, W/m²).
    ///
    /// `out` has one entry per corner, triangle-major: `out[3·t + c]` is corner `c` of
    /// triangle `t`, the corner whose vertex is `triangles[t].vertices[c]`. A corner's value is
    /// the sum over its weight row ([`Mesh::corner`]) **in stored order**, starting from zero,
    /// of `per_patch[patch] * weight`, per channel, as one f32 multiply and one f32 add per term
    /// (no fused multiply-add); an empty row gives zero. A GPU pass that follows the same order
    /// gives the same values up to FMA contraction. At a corner this equals
    /// [`Mesh::interpolate`] with that corner's barycentrics.
    ///
    /// An engine draws its own mesh with it by giving each corner its value as a vertex
    /// attribute (three vertices per triangle, unshared, since corners of one vertex may
    /// interpolate different patches) and multiplying by the surface's reflectance.
    pub fn corner_indirect(
        &self,
        per_patch: &[Rgb],
        out: &mut [Rgb],
    ) -> Result<(), CornerLengthError> {
        let patches = self.sample_rows.len().saturating_sub(1);
        let corners = self.corner_count();
        if per_patch.len() != patches || out.len() != corners {
            return Err(CornerLengthError {
                patches,
                per_patch: per_patch.len(),
                corners,
                out: out.len(),
            });
        }
        for (r, o) in out.iter_mut().enumerate() {
            let row = self.corner_rows[r] as usize..self.corner_rows[r + 1] as usize;
            let mut acc = Rgb::ZERO;
            for e in &self.corner_weights[row] {
                acc += per_patch[e.patch as usize] * e.weight;
            }
            *o = acc;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::size_of;

    #[test]
    fn layouts_are_stable() {
        assert_eq!(size_of::<MeshCounts>(), 16);
        assert_eq!(size_of::<MeshTriangle>(), 40);
        assert_eq!(size_of::<CornerWeight>(), 8);
        assert_eq!(size_of::<PatchSample>(), 28);
    }

    /// Two triangles over three patches: one corner with an empty row, one with three
    /// weights, the rest with one or two.
    fn two_triangles() -> Mesh<'static> {
        let tri = |vertices| MeshTriangle {
            vertices,
            ..MeshTriangle::default()
        };
        let w = |patch, weight| CornerWeight { patch, weight };
        let rows: [&[CornerWeight]; 6] = [
            &[w(0, 1.0)],
            &[w(0, 0.25), w(2, 0.75)],
            &[],
            &[w(1, 0.5), w(2, 0.25), w(0, 0.25)],
            &[w(2, 1.0)],
            &[w(1, 0.125), w(0, 0.875)],
        ];
        let mut corner_rows = alloc::vec![0u32];
        let mut corner_weights = Vec::new();
        for r in rows {
            corner_weights.extend_from_slice(r);
            corner_rows.push(corner_weights.len() as u32);
        }
        Mesh {
            positions: Cow::Owned(alloc::vec![[0.0; 3]; 4]),
            triangles: Cow::Owned(alloc::vec![tri([0, 1, 2]), tri([0, 2, 3])]),
            corner_rows: Cow::Owned(corner_rows),
            corner_weights: Cow::Owned(corner_weights),
            sample_rows: Cow::Owned(alloc::vec![0; 4]),
            samples: Cow::Owned(Vec::new()),
        }
    }

    #[test]
    fn corner_indirect_sums_rows_in_order() {
        let mesh = two_triangles();
        let y = [
            Rgb::new(1.0, 2.0, 4.0),
            Rgb::new(8.0, 0.0, 1.0),
            Rgb::new(0.5, 0.25, 3.0),
        ];
        let mut out = [Rgb::splat(f32::NAN); 6];
        mesh.corner_indirect(&y, &mut out).unwrap();
        for (r, o) in out.iter().enumerate() {
            let (t, c) = (r / 3, r % 3);
            let mut acc = Rgb::ZERO;
            for e in mesh.corner(t, c) {
                acc += y[e.patch as usize] * e.weight;
            }
            assert_eq!(
                o.to_array().map(f32::to_bits),
                acc.to_array().map(f32::to_bits)
            );
        }
        assert_eq!(out[0], y[0]);
        assert_eq!(out[1], Rgb::new(0.625, 0.6875, 3.25));
        assert_eq!(out[2], Rgb::ZERO);
        assert_eq!(out[4], y[2]);
    }

    #[test]
    fn corner_indirect_equals_interpolate_at_corners() {
        let mesh = two_triangles();
        let y = [
            Rgb::new(0.3, 1.7, 2.9),
            Rgb::new(5.1, 0.01, 1.3),
            Rgb::new(0.77, 0.123, 3.3),
        ];
        let mut out = [Rgb::ZERO; 6];
        mesh.corner_indirect(&y, &mut out).unwrap();
        for t in 0..2 {
            let at = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)];
            for (c, (u, v)) in at.into_iter().enumerate() {
                assert_eq!(out[3 * t + c], mesh.interpolate(t, u, v, &y), "t {t} c {c}");
            }
        }
    }

    #[test]
    fn corner_indirect_refuses_wrong_lengths() {
        let mesh = two_triangles();
        assert_eq!(mesh.corner_count(), 6);
        let y = [Rgb::ONE; 3];
        let mut out = [Rgb::ZERO; 6];
        let err = mesh.corner_indirect(&y[..2], &mut out).unwrap_err();
        assert_eq!(
            err,
            CornerLengthError {
                patches: 3,
                per_patch: 2,
                corners: 6,
                out: 6
            }
        );
        assert!(mesh.corner_indirect(&y, &mut out[..5]).is_err());
        let mut long = [Rgb::ZERO; 7];
        assert!(mesh.corner_indirect(&y, &mut long).is_err());
        assert_eq!(out, [Rgb::ZERO; 6], "nothing written on refusal");
    }

    #[test]
    fn corner_indirect_of_an_empty_mesh_is_empty() {
        let mut mesh = two_triangles();
        mesh.triangles = Cow::Owned(Vec::new());
        mesh.corner_rows = Cow::Owned(alloc::vec![0]);
        mesh.corner_weights = Cow::Owned(Vec::new());
        assert_eq!(mesh.corner_count(), 0);
        mesh.corner_indirect(&[Rgb::ONE; 3], &mut []).unwrap();
    }
}
