//! The optional BOUNCE section: each patch's first bounce gathered where its rays land
//! ([`BounceRows`]).
//!
//! The matrix sends a patch's light from its whole area as its mean: `x_j = E_j + ρ_j ∘ H_d,j`.
//! Where the direct light varies across a sender (a sunlit strip by a window on a floor patch
//! that reaches the far wall), a receiver that sees only the shaded part of it is sent the
//! sunlit mean, and the error is carried on through every later bounce. A patch's row names
//! the direct-light samples of the mesh ([`crate::mesh::Mesh`]'s samples) that its
//! cosine-weighted rays met first (each ray counts to the sample of the hit patch nearest to
//! the hit), each weighted by its rays' share of the patch's rays (scaled as the closure
//! scaled the patch's row), and gives the correction of its first bounce for where those rays
//! land:
//!
//! `Δ_i = Σ_e w_e · ρ_j(e) ∘ (H_d(s_e) − H_d,j(e))`
//!
//! with `j(e)` the patch of sample `s_e`. The matrix's row keeps the patch-to-patch transport;
//! the rows add only the spread of the senders' direct light within them, zero where it is even.
//! The frame then takes `H_d + Δ` in place of `H_d` ([`first_bounce`]): the first exitance
//! `x = E + ρ∘(H_d + Δ)` carries the correction through every later bounce, and the total is
//! `H = H_d + Δ + M·x` (`docs/decisions/first-bounce-rows.md`).
//!
//! Layout (little-endian; `P` patches, `E` entries; length exactly `16 + 8·P + 4 + 6·E`):
//!
//! | bytes | content |
//! |---|---|
//! | 0..16 | `P: u32`, `E: u32`, two zero `u32` |
//! | 4·P | `f32` unit of each patch's weights, finite and not negative |
//! | 4·(P+1) | `u32` start of each patch's entries, from 0 to `E`, not decreasing |
//! | 4·E | `u32` mesh sample of each entry, increasing within a row |
//! | 2·E | binary16 weight of each entry in its patch's unit, finite and positive: the share of the patch's rays that land nearest that sample, scaled as the closure scaled the patch's row of F |

use crate::half::{f16_is_finite, f16_to_f32};
use crate::pod_bytes::{cast, u32_at};
use crate::{Patch, RadError, Rgb, SectionKind};
use alloc::borrow::Cow;
use alloc::vec::Vec;

/// The BOUNCE section: per patch, its entries `(sample, weight)` and the unit of its weights.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct BounceRows<'a> {
    /// The unit of each patch's weights.
    pub scale: Cow<'a, [f32]>,
    /// Where each patch's entries start (`patches + 1`, the last `E`).
    pub starts: Cow<'a, [u32]>,
    /// The mesh sample of each entry.
    pub samples: Cow<'a, [u32]>,
    /// The weight of each entry in its patch's unit (binary16 bits).
    pub weights: Cow<'a, [u16]>,
}

impl<'a> BounceRows<'a> {
    /// The entries of patch `p`: `(sample, weight)`.
    pub fn row(&self, p: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        let range = self.starts[p] as usize..self.starts[p + 1] as usize;
        let scale = self.scale[p];
        self.samples[range.clone()]
            .iter()
            .zip(&self.weights[range])
            .map(move |(&s, &w)| (s, f16_to_f32(w) * scale))
    }

    /// The section's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(
            16 + 4 * self.scale.len() + 4 * self.starts.len() + 6 * self.samples.len(),
        );
        for w in [self.scale.len() as u32, self.samples.len() as u32, 0, 0] {
            out.extend_from_slice(&w.to_le_bytes());
        }
        out.extend_from_slice(bytemuck::cast_slice(&self.scale));
        out.extend_from_slice(bytemuck::cast_slice(&self.starts));
        out.extend_from_slice(bytemuck::cast_slice(&self.samples));
        out.extend_from_slice(bytemuck::cast_slice(&self.weights));
        out
    }

    /// The section from its bytes: the lengths checked here, the contents by
    /// [`BounceRows::validate`].
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, RadError> {
        let short = |expected: u64| RadError::SectionLength {
            kind: SectionKind::Bounce,
            expected,
            found: bytes.len() as u64,
        };
        if bytes.len() < 16 {
            return Err(short(16));
        }
        let word = |at: usize| u32_at(bytes, at);
        if word(8) != 0 || word(12) != 0 {
            return Err(RadError::Invalid {
                section: SectionKind::Bounce,
                index: 0,
                reason: "reserved field is not zero",
            });
        }
        let (p, e) = (u64::from(word(0)), u64::from(word(4)));
        let expected = 16 + 8 * p + 4 + 6 * e;
        if bytes.len() as u64 != expected {
            return Err(short(expected));
        }
        let a = 16 + 4 * p as usize;
        let b = a + 4 * (p as usize + 1);
        let c = b + 4 * e as usize;
        Ok(BounceRows {
            scale: cast(&bytes[16..a]),
            starts: cast(&bytes[a..b]),
            samples: cast(&bytes[b..c]),
            weights: cast(&bytes[c..]),
        })
    }

    /// Checks the section against a file of `patches` patches and `samples` mesh samples: one
    /// row a patch, each scale finite and not negative, starts from 0 to the entries not
    /// decreasing, each row's samples increasing and within range, weights finite and
    /// positive.
    pub fn validate(&self, patches: usize, samples: usize) -> Result<(), RadError> {
        let bad = |index: usize, reason| RadError::Invalid {
            section: SectionKind::Bounce,
            index: index as u64,
            reason,
        };
        if self.scale.len() != patches {
            return Err(RadError::Count {
                section: SectionKind::Bounce,
                expected: patches as u64,
                found: self.scale.len() as u64,
            });
        }
        if self.starts.len() != patches + 1 || self.samples.len() != self.weights.len() {
            return Err(bad(0, "row starts or entry arrays of the wrong length"));
        }
        let e = self.samples.len();
        if self.starts[0] != 0 || self.starts[patches] as usize != e {
            return Err(bad(0, "row starts do not run from 0 to the entries"));
        }
        if let Some(p) = self.starts.windows(2).position(|w| w[1] < w[0]) {
            return Err(bad(p, "row starts decreasing"));
        }
        for p in 0..patches {
            if !(self.scale[p].is_finite() && self.scale[p] >= 0.0) {
                return Err(bad(p, "scale not finite and non-negative"));
            }
            let mut prev: Option<u32> = None;
            for at in self.starts[p] as usize..self.starts[p + 1] as usize {
                let s = self.samples[at];
                if s as usize >= samples {
                    return Err(bad(at, "sample index out of range"));
                }
                if prev.is_some_and(|q| q >= s) {
                    return Err(bad(at, "samples of a row not increasing"));
                }
                prev = Some(s);
                let w = self.weights[at];
                if !(f16_is_finite(w) && f16_to_f32(w) > 0.0) {
                    return Err(bad(at, "weight not finite and positive"));
                }
            }
        }
        Ok(())
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> BounceRows<'static> {
        BounceRows {
            scale: Cow::Owned(self.scale.into_owned()),
            starts: Cow::Owned(self.starts.into_owned()),
            samples: Cow::Owned(self.samples.into_owned()),
            weights: Cow::Owned(self.weights.into_owned()),
        }
    }
}

/// Each patch's correction of its first bounce, `Δ_i = Σ_e w_e · ρ_j ∘ (H_d(s_e) − H_d,j)`
/// ([`BounceRows`]), into `out`: `sample_rows` are the mesh's sample row starts (one row a
/// patch, [`crate::mesh::Mesh::sample_rows`]), `direct` the patches' direct irradiance (the
/// area-weighted means of their samples') and `at_samples` each sample's. The frame then uses
/// `H_d + Δ` for `H_d`.
///
/// Panics if the slices do not fit `rows` and `patches` (a programming error: a parsed file
/// is validated against its mesh).
pub fn first_bounce(
    rows: &BounceRows<'_>,
    patches: &[Patch],
    sample_rows: &[u32],
    direct: &[Rgb],
    at_samples: &[Rgb],
    out: &mut [Rgb],
) {
    let n = patches.len();
    assert!(
        rows.scale.len() == n && direct.len() == n && out.len() == n && sample_rows.len() == n + 1,
        "one row per patch"
    );
    // Each sample's patch, once: a row's samples run across the whole file.
    let mut owner: Vec<u32> = Vec::with_capacity(at_samples.len());
    for (j, w) in sample_rows.windows(2).enumerate() {
        owner.extend(core::iter::repeat_n(
            j as u32,
            w[1].saturating_sub(w[0]) as usize,
        ));
    }
    for (i, o) in out.iter_mut().enumerate() {
        let mut acc = Rgb::ZERO;
        for (s, w) in rows.row(i) {
            let j = owner[s as usize] as usize;
            acc += patches[j].reflectance * (at_samples[s as usize] - direct[j]) * w;
        }
        *o = acc;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> BounceRows<'static> {
        BounceRows {
            scale: Cow::Owned(alloc::vec![0.25, 0.5, 0.125]),
            starts: Cow::Owned(alloc::vec![0, 2, 2, 5]),
            samples: Cow::Owned(alloc::vec![2, 3, 0, 1, 3]),
            weights: Cow::Owned(
                [1.0, 3.0, 2.0, 8.0, 1.0]
                    .map(crate::half::f32_to_f16)
                    .to_vec(),
            ),
        }
    }

    fn patch(reflectance: f32) -> Patch {
        Patch {
            centre: [0.0; 3],
            area: 1.0,
            normal: [0.0, 1.0, 0.0],
            object: 0,
            reflectance: Rgb::splat(reflectance),
            emission: Rgb::ZERO,
        }
    }

    /// The bytes round-trip and each row reads back its own entries with their weights.
    #[test]
    fn round_trip_and_rows() {
        let rows = sample();
        rows.validate(3, 4).unwrap();
        let bytes = rows.to_bytes();
        assert_eq!(bytes.len(), 16 + 8 * 3 + 4 + 6 * 5);
        let back = BounceRows::from_bytes(&bytes).unwrap();
        assert_eq!(back, rows);
        assert_eq!(back.row(0).collect::<Vec<_>>(), [(2, 0.25), (3, 0.75)]);
        assert_eq!(back.row(1).count(), 0);
        assert_eq!(
            back.row(2).collect::<Vec<_>>(),
            [(0, 0.25), (1, 1.0), (3, 0.125)]
        );
    }

    /// A sender lit on one sample and dark on the other: a receiver whose rays all land on
    /// the lit one gains what the mean lost, one whose rays land evenly gains nothing, one
    /// with no entries nothing.
    #[test]
    fn the_correction_is_the_spread_where_the_rays_land() {
        // Patch 0 holds samples 0 and 1 (lit 10, dark 0, equal areas: mean 5); patch 1 holds
        // sample 2; patch 2 none.
        let patches = [patch(0.5), patch(0.5), patch(0.5)];
        let sample_rows = [0u32, 2, 3, 3];
        let at = [Rgb::splat(10.0), Rgb::ZERO, Rgb::splat(4.0)];
        let direct = [Rgb::splat(5.0), Rgb::splat(4.0), Rgb::ZERO];
        let rows = BounceRows {
            scale: Cow::Owned(alloc::vec![0.1, 0.1, 0.0]),
            starts: Cow::Owned(alloc::vec![0, 1, 4, 4]),
            samples: Cow::Owned(alloc::vec![0, 0, 1, 2]),
            weights: Cow::Owned([2.0, 3.0, 3.0, 4.0].map(crate::half::f32_to_f16).to_vec()),
        };
        rows.validate(3, 3).unwrap();
        let mut out = [Rgb::splat(9.0); 3];
        first_bounce(&rows, &patches, &sample_rows, &direct, &at, &mut out);
        // Patch 1's rays do not see patch 1 itself in a real file; the sums only test the sum.
        // 2 rays × 0.1 × ρ × (10 − 5); within f32 rounding of the products' order.
        assert!((out[0].g - 0.5).abs() < 1e-6, "{:?}", out[0]);
        assert_eq!(out[1], Rgb::ZERO); // 3 on the lit, 3 on the dark, 4 on an even patch
        assert_eq!(out[2], Rgb::ZERO);
    }

    /// Each broken promise is refused with its own reason.
    #[test]
    fn broken_sections_are_refused() {
        let reason = |r: &BounceRows<'_>| match r.validate(3, 4) {
            Err(RadError::Invalid { reason, .. }) => reason,
            other => panic!("{other:?}"),
        };
        let r = sample();
        assert!(matches!(r.validate(4, 4), Err(RadError::Count { .. })));
        let mut r = sample();
        r.starts.to_mut()[0] = 1;
        assert_eq!(reason(&r), "row starts do not run from 0 to the entries");
        let mut r = sample();
        r.starts.to_mut()[1] = 3;
        r.starts.to_mut()[2] = 2;
        assert_eq!(reason(&r), "row starts decreasing");
        let mut r = sample();
        r.scale.to_mut()[1] = f32::NAN;
        assert_eq!(reason(&r), "scale not finite and non-negative");
        let mut r = sample();
        r.samples.to_mut()[4] = 4;
        assert_eq!(reason(&r), "sample index out of range");
        let mut r = sample();
        r.samples.to_mut()[1] = 2;
        assert_eq!(reason(&r), "samples of a row not increasing");
        let mut r = sample();
        r.weights.to_mut()[0] = 0;
        assert_eq!(reason(&r), "weight not finite and positive");
        let mut r = sample();
        r.weights.to_mut()[0] = 0x7c00; // +∞
        assert_eq!(reason(&r), "weight not finite and positive");
        let mut r = sample();
        r.weights.to_mut().pop();
        assert_eq!(reason(&r), "row starts or entry arrays of the wrong length");
        let mut bytes = sample().to_bytes();
        bytes.pop();
        assert!(matches!(
            BounceRows::from_bytes(&bytes),
            Err(RadError::SectionLength { .. })
        ));
        let mut bytes = sample().to_bytes();
        bytes[8] = 1;
        assert!(matches!(
            BounceRows::from_bytes(&bytes),
            Err(RadError::Invalid { .. })
        ));
    }
}
