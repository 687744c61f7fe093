//! The second half of a bake cut into systems (`--systems`, `docs/decisions/systems.md`): the
//! live patches' F cut along the planes of least exchange ([`crate::systems::partition`]),
//! each system's own multi-bounce transfer and encoding, the form factors between systems
//! kept whole as the coupling (nothing truncated), and one level file ([`LevelSystems`]).

use super::measure::{self, BakeSummary, Measured};
use super::{
    BakeOutput, BakeParams, Discretised, Hooks, attach_runtime, encode_error, encode_params_for,
    transfer_step,
};
use crate::BakeError;
use crate::effects::Effect;
use crate::encode::{ErrorWeights, SparseSelection, encode_dense_with};
use crate::form_factor::SparseFormFactors;
use crate::order::{Candidate, OrderKind};
use crate::passes::{
    self,
    sky::{PlannedSky, Sky},
};
use crate::report::SystemsReport;
use crate::scene::Scene;
use crate::systems::{Partition, Region, Split, partition_sites};
use crate::transfer::BounceSpec;
use radiosity_core::container::LevelSystems;
use radiosity_core::{Bounces, DecodeMode, MatrixLayout, RadFile, Rgb, TransferMatrix};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::time::Instant;

/// One system of a planned bake: its region, the hash of everything its matrix is made
/// from, and what the level's report takes from its bake.
#[derive(Clone, Debug, PartialEq)]
pub struct SystemRecord {
    /// Its region in the plan.
    pub region: u32,
    /// BLAKE3 of its transfer's inputs.
    pub input: [u8; 32],
    /// BLAKE3 (16 bytes) of its patches, its reflectances and its own form factors: what
    /// a rebake says changed.
    pub parts: [[u8; 16]; 3],
    /// Squared compression error and squared norm of its matrix.
    pub err2: f64,
    /// Squared norm of its transfer.
    pub norm2: f64,
    /// Bytes of its matrix.
    pub matrix_bytes: u64,
    /// The `bounces` effect line its transfer wrote.
    pub bounces_text: String,
}

/// How a level is cut into systems.
pub(crate) enum SystemsCut<'a> {
    /// Into this many, along the planes of least exchange.
    Least(usize),
    /// By a plan's regions ([`crate::plan`]); the systems of an earlier bake with the same
    /// plan whose inputs are unchanged are taken from it.
    Plan {
        regions: &'a Region,
        plan_hash: [u8; 32],
        old: Option<&'a OldSystems>,
    },
}

/// An earlier level baked with the same plan, its systems' records, the identity of each of
/// its file's patches, and the boxes of what changed since ([`crate::plan::reuse::Diff`]).
pub(crate) struct OldSystems {
    pub(crate) level: RadFile<'static>,
    pub(crate) records: Vec<SystemRecord>,
    pub(crate) file_keys: Vec<[u8; 16]>,
    pub(crate) boxes: Vec<(glam::DVec3, glam::DVec3)>,
}

/// A level's bake with its systems' records, and for each system that was not taken from
/// an earlier bake, why (`None` where it was).
pub(crate) struct SystemsBake {
    pub(crate) output: BakeOutput,
    pub(crate) records: Vec<SystemRecord>,
    pub(crate) rebaked: Vec<Option<String>>,
}

/// [`super::second_half`] for `count` systems: each system's own transfer and encoding, in a
/// level file.
pub(super) fn second_half_systems(
    scene: &Scene,
    system: &Discretised,
    ff: Cow<'_, SparseFormFactors>,
    count: usize,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<BakeOutput, BakeError> {
    let n = system.len();
    if count == 0 || count > n {
        return Err(BakeError::InvalidParams(format!(
            "systems must be 1 to the {n} patches, not {count}"
        )));
    }
    let cut = SystemsCut::Least(count);
    Ok(systems_bake(scene, system, ff, cut, params, hooks)?.output)
}

/// The systems of the live patches by the region of their centres (the regions no patch
/// lies in left out), and each system's region.
fn plan_partition(system: &Discretised, regions: &Region) -> (Partition, Vec<u32>) {
    let of: Vec<u32> = (system.live.iter())
        .map(|&i| regions.system_of(system.patches.patches[i].centre))
        .collect();
    let mut used = of.clone();
    used.sort_unstable();
    used.dedup();
    let system = of
        .iter()
        .map(|r| used.binary_search(r).expect("a used region") as u32)
        .collect();
    let count = used.len();
    (Partition { system, count }, used)
}

/// BLAKE3 of everything system `s`'s file is made from (the plan, its region, its own form
/// factors, reflectances, patches and the scene's object names), and of three parts of it to
/// say what changed: its patches with the object names, its reflectances, its own form
/// factors.
fn input_hash(
    plan_hash: &[u8; 32],
    region: u32,
    block: &crate::transfer::Dense,
    reflectance: &[[f64; 3]],
    patches: &[radiosity_core::Patch],
    scene: &Scene,
) -> ([u8; 32], [[u8; 16]; 3]) {
    let short = |h: blake3::Hasher| {
        let mut k = [0u8; 16];
        k.copy_from_slice(&h.finalize().as_bytes()[..16]);
        k
    };
    let mut own = blake3::Hasher::new();
    own.update(bytemuck::cast_slice(patches));
    for o in &scene.objects {
        own.update(o.as_bytes());
        own.update(&[0xff]);
    }
    let mut rho = blake3::Hasher::new();
    reflectance.iter().flatten().for_each(|v| {
        rho.update(&v.to_bits().to_le_bytes());
    });
    let mut paths = blake3::Hasher::new();
    paths.update(&(block.n as u64).to_le_bytes());
    block.values.iter().for_each(|v| {
        paths.update(&v.to_bits().to_le_bytes());
    });
    let parts = [short(own), short(rho), short(paths)];
    let mut h = blake3::Hasher::new();
    h.update(plan_hash);
    h.update(&region.to_le_bytes());
    parts.iter().for_each(|p| {
        h.update(p);
    });
    (*h.finalize().as_bytes(), parts)
}

/// Why a system whose inputs' parts are `now` was not taken from a bake whose were `then`.
fn changed(now: &[[u8; 16]; 3], then: &[[u8; 16]; 3]) -> String {
    let what = [
        "its patches (their geometry, reflectance or emission, or the scene's object names)",
        "its reflectances",
        "the light paths among its patches (its own form factors)",
    ];
    let list: Vec<&str> = (0..3)
        .filter(|&k| now[k] != then[k])
        .map(|k| what[k])
        .collect();
    if list.is_empty() {
        "the plan's parameters for it changed".to_owned()
    } else {
        format!("changed: {}", list.join("; "))
    }
}

/// [`second_half_systems`] cut as `cut` says, with its systems' records.
pub(crate) fn systems_bake(
    scene: &Scene,
    system: &Discretised,
    ff: Cow<'_, SparseFormFactors>,
    cut: SystemsCut<'_>,
    params: &BakeParams,
    hooks: Hooks<'_>,
) -> Result<SystemsBake, BakeError> {
    let mut timings = system.timings_ms.clone();
    let t_all = Instant::now();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, timings: &mut BTreeMap<&'static str, f64>| {
        timings.insert(name, clock.elapsed().as_secs_f64() * 1e3);
        clock = Instant::now();
    };
    let n = system.len();
    let channels = system.channels;
    let mut effects = system.effects.clone();

    let probes_note = match params.probes {
        crate::passes::probes::ProbeSpec::None => None,
        crate::passes::probes::ProbeSpec::Auto => Some(
            "a level cut into systems has no probes yet (their rows would gather across systems)",
        ),
        _ => {
            return Err(BakeError::InvalidParams(
                "probes are not baked into a level cut into systems yet: give --probes none or --systems off".into(),
            ));
        }
    };
    hooks.start("systems")?;
    let centres: Vec<glam::DVec3> = system
        .live
        .iter()
        .map(|&i| system.patches.patches[i].centre)
        .collect();
    let areas: Vec<f64> = system
        .live
        .iter()
        .map(|&i| system.patches.patches[i].area)
        .collect();
    let (partition, region_of, plan_hash, old) = match cut {
        SystemsCut::Least(count) => {
            let p = partition_sites(&centres, &areas, &ff, n.div_ceil(count));
            let regions = (0..p.count as u32).collect();
            (p, regions, None, None)
        }
        SystemsCut::Plan {
            regions,
            plan_hash,
            old,
        } => {
            let (p, used) = plan_partition(system, regions);
            (p, used, Some(plan_hash), old)
        }
    };
    let crossing_share = partition.crossing_share_sites(&areas, &ff);
    let split = Split::new(&ff, &partition);
    lap("systems", &mut timings);

    let (format, encode_params) = encode_params_for(params, channels);
    // Every bounce inside each system: the light between systems converges to the
    // infinite-bounce answer at run time, and one count of bounces serves the whole level.
    let own_params = BakeParams {
        bounces: match params.bounces {
            BounceSpec::Auto { .. } => BounceSpec::Infinite,
            b => b,
        },
        ..params.clone()
    };
    let (mut transfer_ms, mut encode_ms) = (0.0, 0.0);
    let (mut err2, mut norm2) = (0.0f64, 0.0f64);
    let mut files = Vec::with_capacity(split.ranges.len());
    let mut bounces = Bounces::Infinite;
    let mut matrix_bytes = 0;
    let mut records = Vec::with_capacity(split.ranges.len());
    let mut rebaked = Vec::with_capacity(split.ranges.len());
    for (s, r) in split.ranges.iter().enumerate() {
        hooks.start(&format!("system {} of {}", s + 1, split.ranges.len()))?;
        let members = &split.order[r.clone()];
        let block = split.own_block(&ff, s);
        let reflectance: Vec<[f64; 3]> = members
            .iter()
            .map(|&k| system.reflectance[k as usize])
            .collect();
        let patches: Vec<radiosity_core::Patch> = members
            .iter()
            .map(|&k| system.core_patches[k as usize])
            .collect();
        let region = region_of[s];
        let (input, parts) = plan_hash.map_or(([0; 32], [[0; 16]; 3]), |h| {
            input_hash(&h, region, &block, &reflectance, &patches, scene)
        });
        let (why, kept) = match old {
            None => (None, None),
            Some(old) => match old.records.iter().position(|o| o.region == region) {
                None => (Some("its region held no system before".to_owned()), None),
                Some(k) if old.records[k].input != input => {
                    (Some(changed(&parts, &old.records[k].parts)), None)
                }
                Some(k) => (None, Some(k)),
            },
        };
        if let (Some(k), Some(old)) = (kept, old) {
            let levels = old.level.systems.as_ref().expect("a level");
            let file = levels
                .system(&old.level, k)
                .map_err(|e| BakeError::InvalidParams(format!("the old level's system {k}: {e}")))?
                .into_owned();
            let record = SystemRecord {
                region,
                ..old.records[k].clone()
            };
            effects.insert("bounces", Effect::new(true, record.bounces_text.clone()));
            bounces = file.bounces;
            err2 += record.err2;
            norm2 += record.norm2;
            matrix_bytes += record.matrix_bytes as usize;
            files.push(file);
            records.push(record);
            rebaked.push(None);
            continue;
        }
        let t = Instant::now();
        let (m, transfer) = transfer_step(
            &reflectance,
            channels,
            Cow::Owned(block),
            &own_params,
            &mut effects,
            hooks,
        )?;
        transfer_ms += t.elapsed().as_secs_f64() * 1e3;
        bounces = transfer.bounces;
        let t = Instant::now();
        let emission: Vec<Rgb> = patches.iter().map(|p| p.emission).collect();
        let matrix = encode_dense_with(
            r.len(),
            channels,
            &m,
            &encode_params,
            &ErrorWeights::for_emitters(&emission),
            SparseSelection::ErrorDriven,
        )
        .map_err(encode_error)?;
        encode_ms += t.elapsed().as_secs_f64() * 1e3;
        let decoded = matrix.decode_dense(DecodeMode::D3d10);
        let (e, d) = m.iter().zip(&decoded).fold((0.0, 0.0), |(e, d), (a, b)| {
            let (a, b) = (f64::from(*a), f64::from(*b));
            (e + (a - b) * (a - b), d + a * a)
        });
        err2 += e;
        norm2 += d;
        let bytes = matrix.blocks.len() + matrix.sparse.bytes() + matrix.corrections.bytes();
        matrix_bytes += bytes;
        records.push(SystemRecord {
            region,
            input,
            parts,
            err2: e,
            norm2: d,
            matrix_bytes: bytes as u64,
            bounces_text: effects
                .get("bounces")
                .map(|e| e.why.clone())
                .unwrap_or_default(),
        });
        rebaked.push(why.or_else(|| {
            plan_hash
                .is_some()
                .then(|| "no earlier bake was given".to_owned())
        }));
        files.push(RadFile {
            compression_rmse: Some(if d > 0.0 { (e / d).sqrt() as f32 } else { 0.0 }),
            ..RadFile::new(
                Cow::Owned(patches),
                Cow::Owned((0..r.len() as u32).collect()),
                matrix,
                objects_of(scene),
                transfer.bounces,
            )
        });
    }
    timings.insert("transfer", transfer_ms);
    timings.insert("encode", encode_ms);
    lap("system_matrices", &mut timings);
    let rmse = if norm2 > 0.0 {
        (err2 / norm2).sqrt()
    } else {
        0.0
    };

    let coupling_entries = split.coupling.cols.len();
    let coupling_bytes = 4 * (split.coupling.row_ptr.len() + 2 * coupling_entries);
    let systems = LevelSystems::from_files(&files, split.coupling.clone())
        .map_err(|e| BakeError::InvalidParams(format!("internal: {e}")))?;
    drop(files);
    let patch_source: Vec<u32> = split
        .order
        .iter()
        .map(|&k| system.live[k as usize] as u32)
        .collect();
    let layout = MatrixLayout::none(channels as u32, format, encode_params.max_tile)
        .map_err(|e| BakeError::InvalidParams(e.to_string()))?;
    let mut file = RadFile {
        compression_rmse: Some(rmse as f32),
        systems: Some(systems),
        ..RadFile::new(
            Cow::Owned(
                split
                    .order
                    .iter()
                    .map(|&k| system.core_patches[k as usize])
                    .collect(),
            ),
            Cow::Owned(split.order.clone()),
            TransferMatrix::none(layout),
            objects_of(scene),
            bounces,
        )
    };
    let sample_objects = attach_runtime(
        &mut file,
        scene,
        system,
        &split.order,
        &patch_source,
        params.sky,
    );
    lap("level", &mut timings);
    let sizes: Vec<usize> = split.ranges.iter().map(|r| r.len()).collect();
    effects.insert(
        "systems",
        Effect::new(
            true,
            format!(
                "{n} patches cut into {} systems of {:?} patches along the planes of least exchange: {:.2}% of the exchange crosses between them, carried by {coupling_entries} coupling entries (none dropped); each system has its own transfer",
                sizes.len(),
                sizes,
                100.0 * crossing_share
            ),
        ),
    );
    if let Some(why) = probes_note {
        effects.insert("probes", Effect::new(false, why.to_owned()));
    }
    let discretise_ms: f64 = system.timings_ms.values().sum();
    timings.insert("total", discretise_ms + t_all.elapsed().as_secs_f64() * 1e3);
    let chosen = Candidate {
        kind: OrderKind::None,
        perm: split.order.clone(),
        error: crate::order::ErrorEstimate {
            relative: rmse,
            squared_error: err2,
            squared_norm: norm2,
            relative_std: 0.0,
            blocks_encoded: 0,
            blocks_nonzero: 0,
            exact: true,
            code_rms: None,
        },
        order_ms: 0.0,
        measure_ms: 0.0,
    };
    let measured = Measured {
        rmse,
        lighting_error: None,
        compression_rmse: BTreeMap::from([(OrderKind::None.name().to_owned(), rmse)]),
        compression_code_rmse: BTreeMap::new(),
    };
    let summary = BakeSummary {
        format,
        chosen: &chosen,
        bounces,
        measured,
        effects,
        timings,
        sample_objects,
    };
    let mut report = measure::report(scene, system, &file, summary);
    report.bytes.blocks = matrix_bytes;
    report.systems = Some(SystemsReport {
        count: sizes.len(),
        sizes,
        crossing_share,
        coupling_entries,
        dropped_share: 0.0,
        matrix_bytes,
        coupling_bytes,
    });
    // A level's probes and sky are the passes of one matrix, over the level's file: each
    // probe's weights name the patches it sees, whichever system they are in, and the frame
    // lights them with the level's light.
    let sky = Sky {
        on: params.sky,
        planned: plan_hash.map(|_| planned_sky(system, &file, &patch_source, old)),
    };
    let robust = plan_hash.is_some();
    let (file, report) = passes::run(file, report, &[&params.probes_pass(), &sky], robust, hooks)?;
    Ok(SystemsBake {
        output: BakeOutput {
            file,
            report,
            patch_source,
        },
        records,
        rebaked,
    })
}

/// A planned level's sky: each file patch's rays seeded by its identity, and the visibility
/// of an earlier bake's patch of the same identity and samples offered for carrying over.
fn planned_sky(
    system: &Discretised,
    file: &RadFile<'_>,
    patch_source: &[u32],
    old: Option<&OldSystems>,
) -> PlannedSky {
    let seeds = (patch_source.iter())
        .map(|&i| system.patches.patches[i as usize].seed)
        .collect();
    let none = || vec![None; patch_source.len()];
    let carried = old.and_then(|o| {
        let (mesh, old_mesh, old_sky) = (
            file.mesh.as_ref()?,
            o.level.mesh.as_ref()?,
            o.level.sky.as_ref()?,
        );
        let at: std::collections::HashMap<[u8; 16], usize> = (o.file_keys.iter().enumerate())
            .map(|(p, k)| (*k, p))
            .collect();
        let nine = radiosity_core::SH_COEFFICIENTS;
        Some(
            (0..patch_source.len())
                .map(|p| {
                    let q = *at.get(&system.keys[patch_source[p] as usize])?;
                    (mesh.samples_of(p) == old_mesh.samples_of(q)).then(|| {
                        let mut t = [0f32; radiosity_core::SH_COEFFICIENTS];
                        t.copy_from_slice(old_sky.values.get(q * nine..(q + 1) * nine)?);
                        Some(t)
                    })?
                })
                .collect(),
        )
    });
    PlannedSky {
        seeds,
        old: carried.unwrap_or_else(none),
        boxes: old.map(|o| o.boxes.clone()).unwrap_or_default(),
    }
}

fn objects_of(scene: &Scene) -> Vec<Cow<'static, str>> {
    scene
        .objects
        .iter()
        .map(|o| Cow::Owned(o.clone()))
        .collect()
}
