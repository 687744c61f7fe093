//! What the bake reports: the `bake --json` object ([`BakeReport`], `docs/contract.md`), also
//! stored in the file's REPORT section for `inspect`, with the reports of the passes
//! ([`ProbeReport`], [`SkyReport`]) and of a level's cut into systems ([`SystemsReport`]).
//! Every stage's and pass's figures are fields here; the measurements that fill the
//! compression errors are the pipeline's.

use crate::BakeError;
use crate::closure::ClosureReport;
use crate::effect_plan::Effects;
use crate::form_factor::FormFactorSummary;
use radiosity_core::RadFile;
use radiosity_runtime::SharedPatch;
use serde::Serialize;
use std::borrow::Cow;
use std::collections::BTreeMap;

/// Sizes in bytes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bytes {
    /// The whole `.rad` file.
    pub total: usize,
    /// Block data.
    pub blocks: usize,
    /// Sparse arrays.
    pub sparse: usize,
    /// Block corrections (their four arrays).
    pub corrections: usize,
    /// Blocks corrected.
    pub corrected_blocks: usize,
    /// The PROBES section (0 without probes).
    pub probes: usize,
    /// The SKY section (0 without one, or where nothing sees the sky).
    pub sky: usize,
    /// The PARTS section (0 where no patch holds parts of several objects).
    pub parts: usize,
    /// The BOUNCE section (0 where no patch sees another).
    pub bounce: usize,
}

/// What the bake did and measured: the `bake --json` object (`docs/contract.md`), also stored in the
/// file's REPORT section for `inspect`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BakeReport {
    /// Patches in the matrix.
    pub patches: usize,
    /// Stored channels.
    pub channels: usize,
    /// Storage format.
    pub format: &'static str,
    /// Patch order used.
    pub order: &'static str,
    /// Bounces (a number, or "infinite").
    pub bounces: serde_json::Value,
    /// Sizes.
    pub bytes: Bytes,
    /// Shadow rays cast for form factors.
    pub rays_cast: u64,
    /// The form-factor quadrature and rays asked for (`FormFactorParams::summary`).
    pub form_factors: FormFactorSummary,
    /// Relative Frobenius error of the decoded matrix, per order measured (the chosen one
    /// exactly, the others estimated on sampled blocks of the encoder's first pass, which the
    /// bake's own encode improves on: see `order::ErrorMeter`).
    pub compression_rmse: BTreeMap<String, f64>,
    /// RMS error of the compressed log texture in 8-bit codes, per order measured as
    /// `compression_rmse` is (`order::ErrorEstimate::code_rms`): the paper's own measure (its
    /// Fig. 4 compares the compressed texture with the uncompressed one). Empty for the float
    /// formats.
    pub compression_code_rmse: BTreeMap<String, f64>,
    /// Relative L2 error of the irradiance from the scene's own emitters caused by compression
    /// (`null` without emitters).
    pub lighting_error: Option<f64>,
    /// Every effect decision with its reason.
    pub effects: Effects,
    /// Row sums of F before any correction, and the correction applied.
    pub closure: ClosureReport,
    /// Largest reciprocity error of F.
    pub reciprocity_error: f64,
    /// Milliseconds per stage.
    pub timings_ms: BTreeMap<&'static str, f64>,
    /// Warnings from loading and simplification.
    pub warnings: Vec<String>,
    /// Exposed area of each object (file object order): its full-detail area less the part
    /// buried under other objects, dark patches included.
    pub object_areas: Vec<f64>,
    /// Whole full-detail area of each object (file object order), buried and dropped parts
    /// included: what `solve`'s per-object means are taken over.
    pub object_surface_areas: Vec<f64>,
    /// Power each object emits over its whole full-detail surface (file object order, RGB,
    /// `Σ A·E` in W per scene unit² of area): `solve` counts the part outside the matrix with
    /// radiosity `B = E` (it receives nothing).
    pub object_emitted_power: Vec<[f64; 3]>,
    /// The patches holding parts of more than one object (file patch order), with each
    /// object's exposed area in them; every other patch belongs to its `object` whole.
    pub shared_patches: Vec<SharedPatch>,
    /// The light probes' placement and storage (`None` without probes).
    pub probes: Option<ProbeReport>,
    /// The sky visibility's measurement (`None` under `--sky off`).
    pub sky: Option<SkyReport>,
    /// The cut into systems (absent for one matrix).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub systems: Option<SystemsReport>,
}

/// What the bake says about its probes.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ProbeReport {
    /// Probes kept.
    pub placed: usize,
    /// Probes dropped for lying inside solid objects.
    pub dropped_inside: usize,
    /// Weights the rays found (patch and probe pairs), before any factoring.
    pub weights: usize,
    /// The rank of the stored factors, `None` for rows of weights.
    pub rank: Option<usize>,
    /// Bytes of the PROBES section.
    pub bytes: usize,
    /// The lattice step (or the median distance between scattered probes).
    pub spacing: f64,
    /// Seconds spent placing, weighing and factoring.
    pub seconds: f64,
}

/// What the sky stage measured (`sky` in `bake --json`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SkyReport {
    /// Rays cast at the sky.
    pub rays: u64,
    /// Share of the matrix's surface (area-weighted) that sees the sky: the mean over it of
    /// `T_0/(π·Y_0)`.
    pub open_share: f64,
    /// Patches that see any sky.
    pub open_patches: usize,
    /// Bytes of the SKY section (0: nothing sees the sky).
    pub bytes: usize,
    /// Seconds the stage took.
    pub seconds: f64,
}

/// What a systems bake reports (`report.systems`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SystemsReport {
    /// Systems.
    pub count: usize,
    /// Patches of each system, in the level's order.
    pub sizes: Vec<usize>,
    /// Share of the exchange `Σ A_i F_ij` that crosses between systems (carried by the
    /// coupling, not by any system's transfer).
    pub crossing_share: f64,
    /// Entries of the coupling.
    pub coupling_entries: usize,
    /// Share of the exchange dropped between systems: 0, every crossing entry is kept.
    pub dropped_share: f64,
    /// Bytes of the systems' matrices (blocks, sparse entries, corrections) and of the
    /// coupling.
    pub matrix_bytes: usize,
    /// Bytes of the coupling.
    pub coupling_bytes: usize,
}

/// Stores `report` in `file`'s REPORT section with `bytes.total` the size of the file that
/// results; call it again after changing the file (probes added).
pub fn store(file: &mut RadFile<'static>, mut report: BakeReport) -> Result<BakeReport, BakeError> {
    // The report stores the file size, which depends on the report: write twice (the size
    // field has the same width both times only by luck, so measure until it is stable).
    for _ in 0..3 {
        file.report = Some(Cow::Owned(
            serde_json::to_string(&report).expect("report serialises"),
        ));
        let total = file
            .to_bytes()
            .map_err(|e| BakeError::InvalidParams(format!("internal: {e}")))?
            .len();
        if total == report.bytes.total {
            break;
        }
        report.bytes.total = total;
    }
    Ok(report)
}
