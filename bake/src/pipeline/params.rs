//! What a bake can be told: [`BakeParams`] and its presets, and the storage format choice.

use crate::discretise::DiscretiseParams;
use crate::encode::EncodeParams;
use crate::form_factor::FormFactorParams;
use crate::order::OrderKind;
use crate::passes::probes::{ProbeRank, ProbeSpec, ProbesPass};
use crate::simplify::VoxelParams;
use crate::transfer::BounceSpec;
use radiosity_core::Format;

/// Which storage format to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FormatChoice {
    /// BC1 for colour scenes, BC4 for grey ones (BC1 cannot store a single channel).
    #[default]
    Auto,
    /// This format (BC1 on a grey scene is an error).
    Fixed(Format),
}

/// Everything a bake can be told. Presets: [`BakeParams::fast`], [`BakeParams::high_quality`].
#[derive(Clone, Debug, PartialEq)]
pub struct BakeParams {
    /// Simplification: target patch count or voxel size. More patches: finer lighting, n²
    /// memory and n³ transfer time.
    pub voxel: VoxelParams,
    /// Form-factor quadrature and visibility rays (rays are switched off by the effect plan when
    /// nothing can occlude).
    pub form_factors: FormFactorParams,
    /// Bounces carried by M.
    pub bounces: BounceSpec,
    /// Storage format.
    pub format: FormatChoice,
    /// Patch numbering (rows and columns together) before compression.
    pub order: OrderKind,
    /// Quantiser range, tile size, BC1 fit (its `format` and `sparse_fraction` are ignored: see
    /// `format` and `sparse_fraction`).
    pub encode: EncodeParams,
    /// Fraction of entries kept exact; `None` for [`default_sparse_fraction`](crate::encode::default_sparse_fraction) of the format
    /// (a fixed share of the block bytes).
    pub sparse_fraction: Option<f32>,
    /// Share of block positions given a block correction; `None` for
    /// [`default_correction_fraction`](crate::encode::default_correction_fraction) of the format (a fixed share of the block bytes).
    pub corrections: Option<f32>,
    /// A scene is treated as closed when every row of F sums to 1 within this; its rows are then
    /// rebalanced to sum to exactly 1 (the correction is reported).
    pub closure_tolerance: f64,
    /// Seed of the random order.
    pub seed: u64,
    /// Direct-light points a patch has at least in the runtime mesh
    /// ([`crate::simplify::runtime_mesh::direct_points`]), 1 to
    /// [`MAX_DIRECT_POINTS`](crate::simplify::runtime_mesh::MAX_DIRECT_POINTS).
    pub direct_points: u32,
    /// Direct-light points of a patch a shadow may cross ([`crate::shadow_points`]), 1 to
    /// [`MAX_DIRECT_POINTS`](crate::simplify::runtime_mesh::MAX_DIRECT_POINTS); at or below
    /// `direct_points`, every patch has `direct_points`.
    pub shadow_points: u32,
    /// Light probes placed and weighed after the transfer ([`crate::probes`]); `None` by
    /// default here (the command line and the host API default to `Auto`).
    pub probes: ProbeSpec,
    /// What the probes store: rows of weights or factors ([`ProbeRank`]).
    pub probe_rank: ProbeRank,
    /// Measure and store each patch's and probe's sky visibility ([`crate::sky`]), so that a
    /// sky or environment light can light the file. On by default.
    pub sky: bool,
    /// One matrix, or the patches cut into systems ([`super::SystemsChoice`]).
    pub systems: super::SystemsChoice,
}

impl Default for BakeParams {
    fn default() -> Self {
        Self {
            voxel: VoxelParams::default(),
            form_factors: FormFactorParams::default(),
            bounces: BounceSpec::default(),
            format: FormatChoice::Auto,
            order: OrderKind::Best,
            encode: EncodeParams::default(),
            sparse_fraction: None,
            corrections: None,
            closure_tolerance: 0.05,
            seed: 1,
            direct_points: crate::simplify::runtime_mesh::DIRECT_POINTS,
            shadow_points: crate::shadow_points::SHADOW_POINTS,
            probes: ProbeSpec::None,
            probe_rank: ProbeRank::Auto,
            sky: true,
            systems: super::SystemsChoice::Auto,
        }
    }
}

impl BakeParams {
    /// Coarse and quick: previews.
    pub fn fast() -> Self {
        Self {
            voxel: VoxelParams::fast(),
            form_factors: FormFactorParams::fast(),
            order: OrderKind::Spatial,
            ..Self::default()
        }
    }

    /// Fine and slow: final bakes.
    pub fn high_quality() -> Self {
        Self {
            voxel: VoxelParams::high_quality(),
            form_factors: FormFactorParams::high_quality(),
            encode: EncodeParams::high_quality(Format::Bc1),
            ..Self::default()
        }
    }
}

impl BakeParams {
    /// The probes pass these parameters ask for.
    pub fn probes_pass(&self) -> ProbesPass {
        ProbesPass {
            spec: self.probes.clone(),
            rank: self.probe_rank,
        }
    }

    /// The part of these parameters the discretisation looks at.
    pub fn discretise(&self) -> DiscretiseParams {
        DiscretiseParams {
            voxel: self.voxel,
            form_factors: self.form_factors,
            direct_points: self.direct_points,
            shadow_points: self.shadow_points,
            closure_tolerance: self.closure_tolerance,
            seed: self.seed,
            systems: self.systems,
        }
    }
}
