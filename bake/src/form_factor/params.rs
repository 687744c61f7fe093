//! What [`super::form_factors`] can be told: the quadrature, the visibility rays, where
//! exact pairs give way to flat sites and clustered pairs, and the presets.

use crate::geometry::quadrature::{Adaptive, Rule};

/// How visibility between a source point and a target piece is found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visibility {
    /// No rays: every pair sees every other unoccluded (exact for convex enclosures, and what
    /// a caller that already knows nothing occludes asks for).
    Off,
    /// Shadow rays against the full-detail triangles.
    Rays {
        /// Rays per quadrature leaf and target piece (and at least `MIN_PIECE_RAYS` times
        /// this per piece pair), each to its own kernel-distributed point of the piece. More:
        /// smoother penumbrae, proportionally slower.
        per_sample: u32,
        /// Skip the rays for piece pairs that no triangle can come between (a conservative
        /// plane-and-box test per pair of full-detail triangles, cached when the scene has at
        /// most 2048 triangles). Exact, and much faster in mostly open scenes.
        skip_unblockable: bool,
    },
}

/// The form factors of scenes above [`FormFactorParams::exact_pieces`] pieces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ManyPieces {
    /// Every patch casts `per_patch` cosine-weighted rays against the full-detail triangles
    /// and counts where they land (`form_factor::cast`); the two sides of each pair are
    /// pooled. Each row's sum has a standard error of about `0.5 / √per_patch`.
    Rays {
        /// Rays per patch (below 2²⁴).
        per_patch: u32,
    },
    /// Clustered pairs of pieces (module doc of `form_factor`, "clustered pairs").
    Clustered,
}

/// Default rays per patch of [`ManyPieces::Rays`]. On Greg Ward's conference room
/// (`docs/decisions/ray-cast-form-factors.md`) 4096 rays put 120 rows within the hemisphere
/// check's noise, and the ray casting takes less time than the transfer at 4096 patches.
pub const RAYS_PER_PATCH: u32 = 4096;

/// Parameters of [`form_factors`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FormFactorParams {
    /// Source-side quadrature.
    pub quadrature: Adaptive,
    /// Shadow rays.
    pub visibility: Visibility,
    /// Pieces in all up to which every pair is integrated exactly, piece by piece. Above it,
    /// patches of more than [`MAX_EXACT_PIECES`](super::MAX_EXACT_PIECES) pieces are integrated through flat sites
    /// (module doc): a scene of 300 000 triangles becomes feasible at all.
    pub exact_pieces: usize,
    /// The rule of clustered pairs' per-target quadratures (`Pairs::clustered`, scenes above
    /// `exact_pieces`). Their error is the sampled visibility's and the centre-to-centre far
    /// pieces', so the default keeps the centroid there: degree 2 cost the conference room's
    /// rows 69% more time for an RMS against hemisphere rays of 0.0124 instead of 0.0137.
    pub clustered_rule: Rule,
    /// How scenes above `exact_pieces` pieces get their form factors: rays cast from every
    /// patch (the default: the cost follows the patches) or clustered pairs (the cost follows
    /// the pieces' near field; also what a scene without visibility rays takes).
    pub many_pieces: ManyPieces,
    /// Exact pairs: two pieces whose centres are more than this many times the sum of their
    /// radii apart are integrated by the source rule on both sides with the point kernel
    /// `cos cos / (π r²)`, instead of the adaptive quadrature and the exact polygon kernel
    /// (`f64::INFINITY`: never).
    pub far_pieces: f64,
}

impl Default for FormFactorParams {
    fn default() -> Self {
        Self {
            // Degree 2, not the centroid. Each target refines the source on its own, so far
            // targets are read on coarse leaves, where the kernel is concave and one point
            // over-reads it: a closed box's rows of F came out 4.4e-4 high on average
            // (ARCHITECTURE.md, "The quadrature rule"); three points a leaf take them within
            // 1e-5 of 1. Rays are counted per leaf, not per point (`exchange`).
            quadrature: Adaptive {
                rule: Rule::Degree2,
                ratio: 0.5,
                max_depth: 5,
            },
            visibility: Visibility::Rays {
                per_sample: 1,
                skip_unblockable: true,
            },
            exact_pieces: EXACT_PIECES,
            clustered_rule: Rule::Centroid,
            many_pieces: ManyPieces::Rays {
                per_patch: RAYS_PER_PATCH,
            },
            far_pieces: FAR_PIECES,
        }
    }
}

impl FormFactorParams {
    /// Coarser quadrature (`--form-factors draft`): the centroid rule on leaves up to their
    /// distance, depth 3, and a quarter of the rays per patch in scenes of many pieces. On the Cornell box at 4096 patches it saves a tenth of the form
    /// factors' time (most rays are each piece pair's minimum), and its rows read about 8e-4
    /// high, which a nearly closed room at ρ = 0.999 turns into +29% (README, "What
    /// form-factor accuracy costs"). Fewer patches are the better preview.
    pub fn fast() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Centroid,
                ratio: 1.0,
                max_depth: 3,
            },
            many_pieces: ManyPieces::Rays {
                per_patch: RAYS_PER_PATCH / 4,
            },
            ..Self::default()
        }
    }

    /// Finer quadrature and four rays per leaf (`--form-factors fine`): leaves to depth 6,
    /// degree 2 in clustered pairs too, four times the rays per patch of scenes of many pieces, the exact kernel for piece pairs up to 8× their radii
    /// apart. About 4× the rays and 3× the form factors' time of the
    /// default for rows that the default already has within a hemisphere check's noise.
    pub fn high_quality() -> Self {
        Self {
            quadrature: Adaptive {
                rule: Rule::Degree2,
                ratio: 0.5,
                max_depth: 6,
            },
            visibility: Visibility::Rays {
                per_sample: 4,
                skip_unblockable: true,
            },
            exact_pieces: EXACT_PIECES,
            clustered_rule: Rule::Degree2,
            many_pieces: ManyPieces::Rays {
                per_patch: 4 * RAYS_PER_PATCH,
            },
            far_pieces: 8.0,
        }
    }

    /// What these parameters ask for, as the bake report states it.
    pub fn summary(&self) -> FormFactorSummary {
        FormFactorSummary {
            rule: self.quadrature.rule.name(),
            leaf_ratio: self.quadrature.ratio,
            max_depth: self.quadrature.max_depth,
            rays_per_leaf: match self.visibility {
                Visibility::Off => 0,
                Visibility::Rays { per_sample, .. } => per_sample.max(1),
            },
            clustered_rule: self.clustered_rule.name(),
            rays_per_patch: match self.many_pieces {
                ManyPieces::Rays { per_patch } => Some(per_patch),
                ManyPieces::Clustered => None,
            },
            far_pieces: self.far_pieces.is_finite().then_some(self.far_pieces),
        }
    }

    /// The default with visibility rays switched off.
    pub fn unoccluded() -> Self {
        Self {
            visibility: Visibility::Off,
            ..Self::default()
        }
    }
}

/// The form-factor settings a bake used ([`FormFactorParams::summary`]), in its report.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FormFactorSummary {
    /// The quadrature rule on each leaf of the source: `centroid`, `degree 2` or `degree 5`.
    pub rule: &'static str,
    /// A leaf is at most this many times as wide as its distance to the target.
    pub leaf_ratio: f64,
    /// Most halvings of a source triangle.
    pub max_depth: u32,
    /// Shadow rays per leaf and target piece asked for (0: none; the occlusion effect also
    /// switches them off where nothing can occlude).
    pub rays_per_leaf: u32,
    /// The rule of clustered pairs' quadratures (scenes above `exact_pieces` pieces).
    pub clustered_rule: &'static str,
    /// Rays cast per patch in scenes above `exact_pieces` pieces (`None`: clustered pairs
    /// there).
    pub rays_per_patch: Option<u32>,
    /// Piece pairs more than this many times the sum of their radii apart take the rule on
    /// both sides with the point kernel (`None`: every piece pair through the exact kernel).
    pub far_pieces: Option<f64>,
}

/// Default of [`FormFactorParams::exact_pieces`]: the exact cost grows as the square of the
/// piece count (nested spheres of 2 × 1280 triangles take 8 s on 2 cores at any patch count),
/// and flat sites cost accuracy on coarse curved patches (row sums of F off by up to 6% at 58
/// patches on those spheres, where the exact pairs are within 0.3%).
pub(crate) const EXACT_PIECES: usize = 20_000;

/// Default of [`FormFactorParams::far_pieces`]. Against every piece pair exact, on an
/// icosphere of 1280 facets at 398 patches (3668 pieces; a throwaway probe): rows of F 1.7e-6
/// / 4.5e-6 / 8.2e-6 / 1.6e-5 apart (L1, worst row) at 8 / 5 / 4 / 3, the form factors 7.6 s
/// exact and 4.8 s at 5; on a closed box of 1494 pieces, 2.8e-6 at 5.
pub(crate) const FAR_PIECES: f64 = 5.0;
