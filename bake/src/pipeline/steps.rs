//! The steps a bake's second half shares between one matrix ([`super::matrix`]) and a level
//! ([`super::level`]): the transfer with its `bounces` decision, the storage format, what the
//! runtime draws with (mesh, PARTS, coverage), and the passes that finish the file.

use super::{BakeOutput, BakeParams, FormatChoice, file_mesh};
use crate::BakeError;
use crate::discretise::Discretised;
use crate::effect_plan::{Effect, Effects};
use crate::encode::{
    EmitterColumns, EncodeError, EncodeParams, default_correction_fraction, default_sparse_fraction,
};
use crate::hooks::Hooks;
use crate::passes::{self, sky::PlannedSky, sky::Sky};
use crate::report::BakeReport;
use crate::scene::Scene;
use crate::transfer::{BounceSpec, Dense, TransferError, TransferReport, transfer};
use radiosity_core::{Bounces, Format, RadFile};
use std::borrow::Cow;

/// The transfer stage: `M` from the live patches' F and reflectances under `params.bounces`,
/// and the `bounces` decision in `effects`.
pub(super) fn transfer_step(
    reflectance: &[[f64; 3]],
    channels: usize,
    f: Cow<'_, Dense>,
    params: &BakeParams,
    effects: &mut Effects,
    hooks: Hooks<'_>,
) -> Result<(Vec<f32>, TransferReport), BakeError> {
    let (m, transfer) = transfer(f, reflectance, channels, params.bounces, hooks.progress)
        .map_err(|e| match e {
            TransferError::Divergent { .. } => BakeError::InvalidParams(e.to_string()),
            other => BakeError::InvalidParams(other.to_string()),
        })?;
    effects.insert(
        "bounces",
        Effect::new(
            true,
            match transfer.bounces {
                Bounces::Infinite => format!(
                    "{} bounces needed at energy gain {:.4} per bounce: all of them, by LU (cheaper than 3 or more series terms)",
                    bounces_needed(transfer.max_gain, params.bounces),
                    transfer.max_gain
                ),
                Bounces::Finite(k) => format!(
                    "{k} bounce(s) leave at most {:.1e} of the energy (gain {:.4} per bounce)",
                    transfer.energy_left, transfer.max_gain
                ),
            },
        ),
    );
    Ok((m, transfer))
}

/// The storage format (`params.format`, or the automatic choice for `channels`) and the
/// encode parameters with the format's default sparse and correction shares where `params`
/// leaves them open.
pub(super) fn encode_params_for(params: &BakeParams, channels: usize) -> (Format, EncodeParams) {
    let format = match params.format {
        FormatChoice::Auto if channels == 1 => Format::Bc4,
        FormatChoice::Auto => Format::Bc1,
        FormatChoice::Fixed(f) => f,
    };
    let encode_params = EncodeParams {
        format,
        sparse_fraction: params
            .sparse_fraction
            .unwrap_or_else(|| default_sparse_fraction(format, channels)),
        corrections: params
            .corrections
            .unwrap_or_else(|| default_correction_fraction(format, channels)),
        ..params.encode
    };
    (format, encode_params)
}

/// Gives `file` what the runtime draws and shades with, in the file's numbering (`perm[k]`:
/// the live patch of file patch `k`; `patch_source[k]`: its simplification patch): the mesh,
/// the PARTS section and the triangles' coverage. Returns the object of each of the mesh's
/// direct-light samples.
pub(super) fn attach_runtime(
    file: &mut RadFile<'static>,
    scene: &Scene,
    system: &Discretised,
    perm: &[u32],
    patch_source: &[u32],
    sky: bool,
) -> Vec<u32> {
    let (mesh, sample_objects) = file_mesh(scene, system, patch_source);
    file.parts = part_rows_section(system, perm, &mesh, sky);
    file.bounce = bounce_rows_section(system, perm, &mesh);
    file.mesh = Some(mesh);
    file.coverage = scene
        .coverage
        .iter()
        .any(|&c| c < 1.0)
        .then(|| Cow::Owned(scene.coverage.clone()));
    sample_objects
}

/// The BOUNCE section of the file: each patch's first-bounce row
/// ([`Discretised::bounce_rows`]) in file numbering, its entries naming the mesh's samples;
/// `None` where the bake made none (no patch sees another).
fn bounce_rows_section(
    system: &Discretised,
    perm: &[u32],
    mesh: &radiosity_core::Mesh<'_>,
) -> Option<radiosity_core::BounceRows<'static>> {
    if system.bounce_rows.iter().all(Option::is_none) {
        return None;
    }
    let file_of = file_numbers(perm);
    let mut scale = Vec::with_capacity(perm.len());
    let mut starts = Vec::with_capacity(perm.len() + 1);
    let (mut samples, mut weights) = (Vec::new(), Vec::new());
    let mut entries: Vec<(u32, f64)> = Vec::new();
    starts.push(0u32);
    for &at in perm {
        entries.clear();
        if let Some(row) = &system.bounce_rows[system.live[at as usize]] {
            entries.extend(
                row.iter()
                    .map(|&(j, k, w)| (mesh.sample_rows[file_of[j as usize] as usize] + k, w)),
            );
            entries.sort_unstable_by_key(|e| e.0);
        }
        // The largest weight stored as 1024 in binary16: 11 significant bits on every entry
        // down to 2⁻²⁴ of it.
        let most = entries.iter().map(|e| e.1).fold(0.0, f64::max);
        let unit = if most > 0.0 { most / 1024.0 } else { 1.0 };
        scale.push(unit as f32);
        for &(sample, w) in &entries {
            // A weight below binary16's least (2⁻²⁴ of the unit) is left out.
            let h = radiosity_core::half::f32_to_f16((w / unit) as f32);
            if radiosity_core::half::f16_to_f32(h) > 0.0 {
                samples.push(sample);
                weights.push(h);
            }
        }
        starts.push(samples.len() as u32);
    }
    Some(radiosity_core::BounceRows {
        scale: Cow::Owned(scale),
        starts: Cow::Owned(starts),
        samples: Cow::Owned(samples),
        weights: Cow::Owned(weights),
    })
}

/// `file_of[live]`: the file patch of each live patch (`perm` inverted).
fn file_numbers(perm: &[u32]) -> Vec<u32> {
    let mut file_of = vec![0u32; perm.len()];
    for (k, &at) in perm.iter().enumerate() {
        file_of[at as usize] = k as u32;
    }
    file_of
}

/// The PARTS section of the file: each shared patch's part rows ([`Discretised::part_rows`])
/// in file numbering, their entries naming the mesh's samples; `None` where no patch is shared.
fn part_rows_section(
    system: &Discretised,
    perm: &[u32],
    mesh: &radiosity_core::Mesh<'_>,
    with_sky: bool,
) -> Option<radiosity_core::PartRows<'static>> {
    let file_of = file_numbers(perm);
    let mut parts = Vec::new();
    let (mut samples, mut counts, mut sky) = (Vec::new(), Vec::new(), Vec::new());
    let mut entries: Vec<(u32, u16)> = Vec::new();
    for (f, &at) in perm.iter().enumerate() {
        let Some(rows) = system.part_rows.get(system.live[at as usize]) else {
            continue;
        };
        for row in rows {
            entries.clear();
            entries.extend(row.entries.iter().map(|&(j, k, c)| {
                let file_j = file_of[j as usize] as usize;
                (mesh.sample_rows[file_j] + k, c)
            }));
            entries.sort_unstable();
            parts.push(radiosity_core::Part {
                patch: f as u32,
                object: row.object,
                scale: row.each as f32,
                start: samples.len() as u32,
            });
            samples.extend(entries.iter().map(|e| e.0));
            counts.extend(entries.iter().map(|e| e.1));
            if with_sky {
                sky.extend_from_slice(&row.sky);
            }
        }
    }
    (!parts.is_empty()).then_some(radiosity_core::PartRows {
        parts: Cow::Owned(parts),
        samples: Cow::Owned(samples),
        counts: Cow::Owned(counts),
        sky: Cow::Owned(sky),
    })
}

/// Runs the passes `params` asks for (probes, then sky visibility: `planned` for a planned
/// bake's, through the robust ray tree) over a finished file, and stores the report in it.
pub(super) fn finish(
    file: RadFile<'static>,
    report: BakeReport,
    patch_source: Vec<u32>,
    params: &BakeParams,
    planned: Option<PlannedSky>,
    hooks: Hooks<'_>,
) -> Result<BakeOutput, BakeError> {
    let robust = planned.is_some();
    let sky = Sky {
        on: params.sky,
        planned,
    };
    let (file, report) = passes::run(file, report, &[&params.probes_pass(), &sky], robust, hooks)?;
    Ok(BakeOutput {
        file,
        report,
        patch_source,
    })
}

/// The scene's object names, as a file holds them.
pub(super) fn objects_of(scene: &Scene) -> Vec<Cow<'static, str>> {
    scene
        .objects
        .iter()
        .map(|o| Cow::Owned(o.clone()))
        .collect()
}

pub(super) fn encode_error(e: EncodeError) -> BakeError {
    BakeError::InvalidParams(e.to_string())
}

/// The `exact_emitters` decision of one matrix or of a level's systems (`None` for each
/// system without emitters; no decision when none has them).
pub(super) fn exact_emitters_effect(systems: &[Option<EmitterColumns>]) -> Option<Effect> {
    let with: Vec<&EmitterColumns> = systems.iter().flatten().collect();
    let worst = with
        .iter()
        .map(|c| c.error_in_blocks)
        .fold(None, |m: Option<f64>, e| Some(m.map_or(e, |m| m.max(e))))?;
    let kept: Vec<&&EmitterColumns> = with.iter().filter(|c| c.kept).collect();
    let columns: usize = kept.iter().map(|c| c.columns).sum();
    let bytes: usize = kept.iter().map(|c| c.bytes).sum();
    let of = if systems.len() > 1 {
        format!(" in {} of {} systems with emitters", kept.len(), with.len())
    } else {
        String::new()
    };
    let limit = 100.0 * f64::from(crate::encode::EMITTER_ERROR_LIMIT);
    Some(if !kept.is_empty() {
        Effect::new(
            true,
            format!(
                "the blocks light the scene by its own emitters {:.2}% off (more than {limit:.2}%): their {columns} columns kept exact in the sparse list{of}, {:.1} KiB more",
                100.0 * worst,
                bytes as f64 / 1024.0
            ),
        )
    } else if with
        .iter()
        .any(|c| c.error_in_blocks > f64::from(crate::encode::EMITTER_ERROR_LIMIT))
    {
        let share = with.iter().map(|c| c.share_of_blocks).fold(0.0, f64::max);
        Effect::new(
            false,
            format!(
                "the blocks light the scene by its own emitters {:.2}% off, but exact columns would add {:.0}% to the block bytes (at most {:.0}%): emitters too large a share of the scene",
                100.0 * worst,
                100.0 * share,
                100.0 * crate::encode::EXACT_EMITTERS_CAP
            ),
        )
    } else {
        Effect::new(
            false,
            format!(
                "the blocks light the scene by its own emitters {:.3}% off (at most {limit:.2}%): the columns stay in the blocks",
                100.0 * worst
            ),
        )
    })
}

fn bounces_needed(gain: f64, spec: BounceSpec) -> String {
    let tol = match spec {
        BounceSpec::Auto { tolerance } => tolerance,
        _ => 1e-3,
    };
    if gain >= 1.0 || gain <= 0.0 {
        return "unbounded".into();
    }
    format!("{:.0}", (tol.ln() / gain.ln()).ceil())
}
