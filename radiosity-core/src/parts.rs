//! The optional PARTS section: each object's own gather row in a patch it shares with other
//! objects ([`PartRows`]).
//!
//! A patch holds one irradiance, the mean over its area; where the small parts of several
//! objects share a patch (a railing's posts, a bench and a plinth in one cell) they face
//! different ways and stand in different light. A part's row gives it the light bounced onto
//! it itself: `y_part = Σ_e w_e · B(s_e)`, where entry `e` names a direct-light sample `s_e` of
//! the mesh (the point of the patch it sees that the rays hit nearest, [`crate::mesh::Mesh`]'s
//! samples) and `B(s) = B_j + ρ_j ∘ (H_d(s) − H_d,j)` is the radiosity of that sample's patch
//! `j` with the sample's own direct light in place of the patch's mean: the light leaving a
//! sunlit strip of a mostly shaded plinth is seen as sunlit.
//!
//! Where the file has sky visibility (its SKY section), each part also has its own
//! cosine-weighted sky visibility `T` (nine `f32`, the SKY section's convention), measured by
//! the same rays, in place of its patch's: a post under a roof in a patch with the open plinth
//! beside it sees the roof, not the plinth's sky.
//!
//! Layout (little-endian; `P` parts, `E` entries, `S` parts with sky visibility, 0 or `P`;
//! length exactly `16 + 16·P + 36·S + 6·E`):
//!
//! | bytes | content |
//! |---|---|
//! | 0..16 | `P: u32`, `E: u32`, `S: u32`, a zero `u32` |
//! | 16·P | [`Part`]s, in increasing `(patch, object)` order, no pair twice |
//! | 36·S | each part's sky visibility `T`, nine `f32` |
//! | 4·E | `u32` mesh sample of each entry, increasing within a part |
//! | 2·E | `u16` count of each entry: its weight is `count · scale` of its part |

use crate::pod_bytes::{cast, u32_at};
use crate::{RadError, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};

/// One object's part of a shared patch.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Part {
    /// The patch (file numbering).
    pub patch: u32,
    /// The object (an index into the file's objects).
    pub object: u32,
    /// The weight of one count: `1 / rays`, times the closure's scaling of the patch's row.
    pub scale: f32,
    /// Its first entry; its entries end where the next part's start (the last part's at `E`).
    pub start: u32,
}

/// The PARTS section: per part, its entries `(sample, count)`.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct PartRows<'a> {
    /// The parts, in increasing `(patch, object)` order.
    pub parts: Cow<'a, [Part]>,
    /// The mesh sample of each entry.
    pub samples: Cow<'a, [u32]>,
    /// The count of each entry.
    pub counts: Cow<'a, [u16]>,
    /// Each part's cosine-weighted sky visibility, nine values a part (empty: none measured).
    pub sky: Cow<'a, [f32]>,
}

/// A count may not exceed this: a part's rays are at most this many.
pub const MAX_COUNT: u16 = 4096;

impl<'a> PartRows<'a> {
    /// The entries of part `p`: `(sample, weight)`.
    pub fn row(&self, p: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        let part = self.parts[p];
        let end = self
            .parts
            .get(p + 1)
            .map_or(self.samples.len(), |q| q.start as usize);
        let range = part.start as usize..end;
        self.samples[range.clone()]
            .iter()
            .zip(&self.counts[range])
            .map(move |(&s, &c)| (s, f32::from(c) * part.scale))
    }

    /// The parts of patch `patch`: a range of [`PartRows::parts`].
    pub fn of_patch(&self, patch: u32) -> core::ops::Range<usize> {
        let lo = self.parts.partition_point(|p| p.patch < patch);
        let hi = self.parts.partition_point(|p| p.patch <= patch);
        lo..hi
    }

    /// The part of `object` in `patch`, if it has one.
    pub fn find(&self, patch: u32, object: u32) -> Option<usize> {
        self.parts
            .binary_search_by(|p| (p.patch, p.object).cmp(&(patch, object)))
            .ok()
    }

    /// Part `p`'s sky visibility, if the section has it.
    pub fn sky_of(&self, p: usize) -> Option<[f32; SKY]> {
        let t = self.sky.get(SKY * p..SKY * (p + 1))?;
        let mut out = [0.0; SKY];
        out.copy_from_slice(t);
        Some(out)
    }

    /// The section's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let s = self.sky.len() / SKY;
        let mut out = Vec::with_capacity(
            16 + 16 * self.parts.len() + 4 * self.sky.len() + 6 * self.samples.len(),
        );
        for w in [
            self.parts.len() as u32,
            self.samples.len() as u32,
            s as u32,
            0,
        ] {
            out.extend_from_slice(&w.to_le_bytes());
        }
        out.extend_from_slice(bytemuck::cast_slice(&self.parts));
        out.extend_from_slice(bytemuck::cast_slice(&self.sky));
        out.extend_from_slice(bytemuck::cast_slice(&self.samples));
        out.extend_from_slice(bytemuck::cast_slice(&self.counts));
        out
    }

    /// The section from its bytes: the lengths checked here, the contents by
    /// [`PartRows::validate`].
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, RadError> {
        let short = |expected: u64| RadError::SectionLength {
            kind: SectionKind::Parts,
            expected,
            found: bytes.len() as u64,
        };
        if bytes.len() < 16 {
            return Err(short(16));
        }
        let word = |at: usize| u32_at(bytes, at);
        if word(12) != 0 {
            return Err(RadError::Invalid {
                section: SectionKind::Parts,
                index: 0,
                reason: "reserved field is not zero",
            });
        }
        let (p, e, s) = (u64::from(word(0)), u64::from(word(4)), u64::from(word(8)));
        if s != 0 && s != p {
            return Err(RadError::Invalid {
                section: SectionKind::Parts,
                index: 0,
                reason: "sky visibility for neither none nor every part",
            });
        }
        let expected = 16 + 16 * p + 4 * SKY as u64 * s + 6 * e;
        if bytes.len() as u64 != expected {
            return Err(short(expected));
        }
        let a = 16 + 16 * p as usize;
        let b = a + 4 * SKY * s as usize;
        let c = b + 4 * e as usize;
        Ok(PartRows {
            parts: cast(&bytes[16..a]),
            sky: cast(&bytes[a..b]),
            samples: cast(&bytes[b..c]),
            counts: cast(&bytes[c..]),
        })
    }

    /// Checks the section against a file of `patches` patches, `objects` objects and
    /// `samples` mesh samples: parts in increasing `(patch, object)` order within range, each
    /// scale finite and not negative, starts from 0 not decreasing and within the entries,
    /// each part's samples increasing and within range, counts from 1 to [`MAX_COUNT`].
    pub fn validate(&self, patches: usize, objects: usize, samples: usize) -> Result<(), RadError> {
        let bad = |index: usize, reason| RadError::Invalid {
            section: SectionKind::Parts,
            index: index as u64,
            reason,
        };
        if self.samples.len() != self.counts.len() {
            return Err(bad(0, "entry arrays of different lengths"));
        }
        let e = self.samples.len();
        let mut last: Option<(u32, u32)> = None;
        for (k, p) in self.parts.iter().enumerate() {
            if p.patch as usize >= patches {
                return Err(bad(k, "patch index out of range"));
            }
            if p.object as usize >= objects {
                return Err(bad(k, "object index out of range"));
            }
            if last.is_some_and(|l| l >= (p.patch, p.object)) {
                return Err(bad(k, "parts not in increasing (patch, object) order"));
            }
            last = Some((p.patch, p.object));
            if !(p.scale.is_finite() && p.scale >= 0.0) {
                return Err(bad(k, "scale not finite and non-negative"));
            }
            let start_ok = if k == 0 {
                p.start == 0
            } else {
                p.start >= self.parts[k - 1].start
            };
            if !start_ok || p.start as usize > e {
                return Err(bad(k, "entry start out of order or range"));
            }
        }
        if self.parts.is_empty() && e != 0 {
            return Err(bad(0, "entries without parts"));
        }
        if !(self.sky.is_empty() || self.sky.len() == SKY * self.parts.len()) {
            return Err(bad(0, "sky visibility for neither none nor every part"));
        }
        for (k, t) in self.sky.chunks_exact(SKY).enumerate() {
            // The constant term is at most the whole lobe's, π·Y0, as a patch's.
            let most = core::f32::consts::PI * crate::sky::Y0 * 1.001;
            if !t.iter().all(|v| v.is_finite()) || !(0.0..=most).contains(&t[0]) {
                return Err(bad(
                    k,
                    "sky visibility not finite or its constant term outside [0, π·Y0]",
                ));
            }
        }
        for k in 0..self.parts.len() {
            let mut prev: Option<u32> = None;
            let end = self.parts.get(k + 1).map_or(e, |q| q.start as usize);
            for at in self.parts[k].start as usize..end {
                let s = self.samples[at];
                if s as usize >= samples {
                    return Err(bad(at, "sample index out of range"));
                }
                if prev.is_some_and(|q| q >= s) {
                    return Err(bad(at, "samples of a part not increasing"));
                }
                prev = Some(s);
                if !(1..=MAX_COUNT).contains(&self.counts[at]) {
                    return Err(bad(at, "count outside 1 to 4096"));
                }
            }
        }
        Ok(())
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> PartRows<'static> {
        PartRows {
            parts: Cow::Owned(self.parts.into_owned()),
            samples: Cow::Owned(self.samples.into_owned()),
            counts: Cow::Owned(self.counts.into_owned()),
            sky: Cow::Owned(self.sky.into_owned()),
        }
    }
}

/// Values of a part's sky visibility: the SH coefficients of orders 0 to 2.
pub const SKY: usize = crate::probes::SH_COEFFICIENTS;

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PartRows<'static> {
        PartRows {
            parts: Cow::Owned(alloc::vec![
                Part {
                    patch: 0,
                    object: 1,
                    scale: 0.25,
                    start: 0
                },
                Part {
                    patch: 0,
                    object: 2,
                    scale: 0.5,
                    start: 2
                },
                Part {
                    patch: 3,
                    object: 0,
                    scale: 0.125,
                    start: 3
                },
            ]),
            samples: Cow::Owned(alloc::vec![4, 9, 2, 0, 5]),
            counts: Cow::Owned(alloc::vec![1, 3, 2, 8, 1]),
            sky: Cow::Owned((0..27).map(|k| k as f32 / 64.0).collect()),
        }
    }

    /// The bytes round-trip, and each part reads back its own entries with their weights.
    #[test]
    fn round_trip_and_rows() {
        let rows = sample();
        rows.validate(4, 3, 10).unwrap();
        let bytes = rows.to_bytes();
        assert_eq!(bytes.len(), 16 + 16 * 3 + 36 * 3 + 6 * 5);
        let back = PartRows::from_bytes(&bytes).unwrap();
        assert_eq!(back, rows);
        let r: Vec<(u32, f32)> = back.row(1).collect();
        assert_eq!(r, [(2, 1.0)]);
        let r: Vec<(u32, f32)> = back.row(2).collect();
        assert_eq!(r, [(0, 1.0), (5, 0.125)]);
        assert_eq!(back.of_patch(0), 0..2);
        assert_eq!(back.of_patch(1), 2..2);
        assert_eq!(back.find(3, 0), Some(2));
        assert_eq!(back.find(3, 1), None);
        assert_eq!(back.sky_of(1).unwrap()[0], 9.0 / 64.0);
        // Without sky visibility too.
        let bare = PartRows {
            sky: Cow::Owned(Vec::new()),
            ..rows
        };
        let bytes = bare.to_bytes();
        let back = PartRows::from_bytes(&bytes).unwrap();
        assert_eq!(back, bare);
        assert_eq!(back.sky_of(0), None);
    }

    /// Each broken promise is refused with its own reason.
    #[test]
    fn broken_sections_are_refused() {
        let reason = |r: &PartRows<'_>| match r.validate(4, 3, 10) {
            Err(RadError::Invalid { reason, .. }) => reason,
            other => panic!("{other:?}"),
        };
        let mut r = sample();
        r.parts.to_mut()[2].patch = 4;
        assert_eq!(reason(&r), "patch index out of range");
        let mut r = sample();
        r.parts.to_mut()[1].object = 1;
        assert_eq!(reason(&r), "parts not in increasing (patch, object) order");
        let mut r = sample();
        r.parts.to_mut()[0].scale = f32::NAN;
        assert_eq!(reason(&r), "scale not finite and non-negative");
        let mut r = sample();
        r.parts.to_mut()[2].start = 6;
        assert_eq!(reason(&r), "entry start out of order or range");
        let mut r = sample();
        r.samples.to_mut()[1] = 10;
        assert_eq!(reason(&r), "sample index out of range");
        let mut r = sample();
        r.samples.to_mut()[1] = 4;
        assert_eq!(reason(&r), "samples of a part not increasing");
        let mut r = sample();
        r.counts.to_mut()[0] = 0;
        assert_eq!(reason(&r), "count outside 1 to 4096");
        let mut r = sample();
        r.sky.to_mut().pop();
        assert_eq!(reason(&r), "sky visibility for neither none nor every part");
        let mut r = sample();
        r.sky.to_mut()[9] = -0.5;
        assert_eq!(
            reason(&r),
            "sky visibility not finite or its constant term outside [0, π·Y0]"
        );
        // A length that does not match the counts in the head.
        let mut bytes = sample().to_bytes();
        bytes.pop();
        assert!(matches!(
            PartRows::from_bytes(&bytes),
            Err(RadError::SectionLength { .. })
        ));
    }
}
