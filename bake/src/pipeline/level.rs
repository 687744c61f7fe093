//! The second half of a bake cut into systems (`--systems`, `docs/decisions/systems.md`): the
//! live patches' F cut along the planes of least exchange ([`crate::systems::partition`]),
//! each system's own multi-bounce transfer and encoding, the form factors between systems
//! kept whole as the coupling (nothing truncated), and one level file ([`LevelSystems`]).

use super::measure::{self, BakeSummary, Measured};
use super::steps::{
    attach_runtime, encode_error, encode_params_for, exact_emitters_effect, finish, objects_of,
    transfer_step,
};
use super::{BakeOutput, BakeParams};
use crate::BakeError;
use crate::discretise::Discretised;
use crate::effect_plan::Effect;
use crate::effect_plan::Effects;
use crate::encode::EncodeParams;
use crate::encode::{EmitterColumns, ErrorWeights, SparseSelection, encode_dense_noting};
use crate::form_factor::SparseFormFactors;
use crate::hooks::{Hooks, Laps};
use crate::order::{Candidate, OrderKind};
use crate::passes::sky::PlannedSky;
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
    let t_all = Instant::now();
    let mut laps = Laps::after(system.timings_ms.clone());
    hooks.start("systems")?;
    let level = Level::cut(system, &ff, cut);
    laps.lap("systems");

    let (format, encode_params) = encode_params_for(params, system.channels);
    let mut matrices = Matrices::new(system.effects.clone(), level.split.ranges.len());
    for s in 0..level.split.ranges.len() {
        hooks.start(&format!("system {} of {}", s + 1, level.split.ranges.len()))?;
        matrices.add(scene, system, &ff, &level, s, params, &encode_params, hooks)?;
    }
    laps.set("transfer", matrices.transfer_ms);
    laps.set("encode", matrices.encode_ms);
    laps.lap("system_matrices");

    let rmse = matrices.rmse();
    let coupling_entries = level.split.coupling.cols.len();
    let coupling_bytes = 4 * (level.split.coupling.row_ptr.len() + 2 * coupling_entries);
    let systems = LevelSystems::from_files(&matrices.files, level.split.coupling.clone())
        .map_err(|e| BakeError::InvalidParams(format!("internal: {e}")))?;
    let order = &level.split.order;
    let patch_source: Vec<u32> = (order.iter())
        .map(|&k| system.live[k as usize] as u32)
        .collect();
    let layout = MatrixLayout::none(system.channels as u32, format, encode_params.max_tile)
        .map_err(|e| BakeError::InvalidParams(e.to_string()))?;
    let mut file = RadFile {
        compression_rmse: Some(rmse as f32),
        systems: Some(systems),
        ..RadFile::new(
            Cow::Owned(
                order
                    .iter()
                    .map(|&k| system.core_patches[k as usize])
                    .collect(),
            ),
            Cow::Owned(order.clone()),
            TransferMatrix::none(layout),
            objects_of(scene),
            matrices.bounces,
        )
    };
    let sample_objects = attach_runtime(&mut file, scene, system, order, &patch_source, params.sky);
    laps.lap("level");
    let sizes: Vec<usize> = level.split.ranges.iter().map(|r| r.len()).collect();
    let why = systems_why(system.len(), &sizes, level.crossing_share, coupling_entries);
    matrices.effects.insert("systems", Effect::new(true, why));
    if let Some(effect) = exact_emitters_effect(&matrices.emitters) {
        matrices.effects.insert("exact_emitters", effect);
    }
    let discretise_ms: f64 = system.timings_ms.values().sum();
    laps.set("total", discretise_ms + t_all.elapsed().as_secs_f64() * 1e3);
    let chosen = unordered(order, &matrices);
    let summary = BakeSummary {
        format,
        chosen: &chosen,
        bounces: matrices.bounces,
        measured: Measured {
            rmse,
            lighting_error: None,
            compression_rmse: BTreeMap::from([(OrderKind::None.name().to_owned(), rmse)]),
            compression_code_rmse: BTreeMap::new(),
        },
        effects: std::mem::take(&mut matrices.effects),
        timings: laps.into_timings(),
        sample_objects,
    };
    let mut report = measure::report(scene, system, &file, summary);
    report.bytes.blocks = matrices.matrix_bytes;
    report.systems = Some(SystemsReport {
        count: sizes.len(),
        sizes,
        crossing_share: level.crossing_share,
        coupling_entries,
        dropped_share: 0.0,
        matrix_bytes: matrices.matrix_bytes,
        coupling_bytes,
    });
    // A level's probes and sky are the passes of one matrix, over the level's file: each
    // probe's weights name the patches it sees, whichever system they are in, and the frame
    // lights them with the level's light.
    let planned = (level.plan_hash).map(|_| planned_sky(system, &file, &patch_source, level.old));
    Ok(SystemsBake {
        output: finish(file, report, patch_source, params, planned, hooks)?,
        records: matrices.records,
        rebaked: matrices.rebaked,
    })
}

/// The `systems` decision's reason.
fn systems_why(n: usize, sizes: &[usize], crossing_share: f64, coupling_entries: usize) -> String {
    format!(
        "{n} patches cut into {} systems of {:?} patches along the planes of least exchange: {:.2}% of the exchange crosses between them, carried by {coupling_entries} coupling entries (none dropped); each system has its own transfer",
        sizes.len(),
        sizes,
        100.0 * crossing_share
    )
}

/// A level's cut: the split, each system's region, and a planned bake's hash and earlier
/// bake.
struct Level<'a> {
    split: Split,
    region_of: Vec<u32>,
    plan_hash: Option<[u8; 32]>,
    old: Option<&'a OldSystems>,
    crossing_share: f64,
}

impl<'a> Level<'a> {
    /// Cuts the live patches of `system` as `cut` says.
    fn cut(system: &Discretised, ff: &SparseFormFactors, cut: SystemsCut<'a>) -> Self {
        let live = || system.live.iter().map(|&i| &system.patches.patches[i]);
        let centres: Vec<glam::DVec3> = live().map(|p| p.centre).collect();
        let areas: Vec<f64> = live().map(|p| p.area).collect();
        let (partition, region_of, plan_hash, old) = match cut {
            SystemsCut::Least(count) => {
                let p = partition_sites(&centres, &areas, ff, system.len().div_ceil(count));
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
        Self {
            crossing_share: partition.crossing_share_sites(&areas, ff),
            split: Split::new(ff, &partition),
            region_of,
            plan_hash,
            old,
        }
    }
}

/// The systems' matrices as they are made or taken from an earlier bake, with what the
/// level's file and report take from them.
struct Matrices {
    effects: Effects,
    files: Vec<RadFile<'static>>,
    records: Vec<SystemRecord>,
    rebaked: Vec<Option<String>>,
    bounces: Bounces,
    err2: f64,
    norm2: f64,
    matrix_bytes: usize,
    transfer_ms: f64,
    encode_ms: f64,
    /// What each system encoded here did with its emitters' columns.
    emitters: Vec<Option<EmitterColumns>>,
}

impl Matrices {
    fn new(effects: Effects, systems: usize) -> Self {
        Self {
            effects,
            files: Vec::with_capacity(systems),
            records: Vec::with_capacity(systems),
            rebaked: Vec::with_capacity(systems),
            bounces: Bounces::Infinite,
            err2: 0.0,
            norm2: 0.0,
            matrix_bytes: 0,
            transfer_ms: 0.0,
            encode_ms: 0.0,
            emitters: Vec::with_capacity(systems),
        }
    }

    /// The relative Frobenius error of the level's matrices together.
    fn rmse(&self) -> f64 {
        if self.norm2 > 0.0 {
            (self.err2 / self.norm2).sqrt()
        } else {
            0.0
        }
    }

    /// System `s` of `level`: taken from the earlier bake where its inputs are unchanged,
    /// else its own transfer, with every bounce inside it (the light between systems
    /// converges to the infinite-bounce answer at run time, and one count of bounces serves
    /// the whole level), encoded.
    #[allow(clippy::too_many_arguments)]
    fn add(
        &mut self,
        scene: &Scene,
        system: &Discretised,
        ff: &SparseFormFactors,
        level: &Level<'_>,
        s: usize,
        params: &BakeParams,
        encode_params: &EncodeParams,
        hooks: Hooks<'_>,
    ) -> Result<(), BakeError> {
        let members = &level.split.order[level.split.ranges[s].clone()];
        let block = level.split.own_block(ff, s);
        let reflectance: Vec<[f64; 3]> = (members.iter())
            .map(|&k| system.reflectance[k as usize])
            .collect();
        let patches: Vec<radiosity_core::Patch> = (members.iter())
            .map(|&k| system.core_patches[k as usize])
            .collect();
        let region = level.region_of[s];
        let (input, parts) = level.plan_hash.map_or(([0; 32], [[0; 16]; 3]), |h| {
            input_hash(&h, region, &block, &reflectance, &patches, scene)
        });
        let (why, kept) = match level.old {
            None => (None, None),
            Some(old) => match old.records.iter().position(|o| o.region == region) {
                None => (Some("its region held no system before".to_owned()), None),
                Some(k) if old.records[k].input != input => {
                    (Some(changed(&parts, &old.records[k].parts)), None)
                }
                Some(k) => (None, Some(k)),
            },
        };
        if let (Some(k), Some(old)) = (kept, level.old) {
            return self.keep(old, k, region);
        }
        let own_params = BakeParams {
            bounces: match params.bounces {
                BounceSpec::Auto { .. } => BounceSpec::Infinite,
                b => b,
            },
            ..params.clone()
        };
        let t = Instant::now();
        let (m, transfer) = transfer_step(
            &reflectance,
            system.channels,
            Cow::Owned(block),
            &own_params,
            &mut self.effects,
            hooks,
        )?;
        self.transfer_ms += t.elapsed().as_secs_f64() * 1e3;
        self.bounces = transfer.bounces;
        let t = Instant::now();
        let emission: Vec<Rgb> = patches.iter().map(|p| p.emission).collect();
        let (matrix, emitters) = encode_dense_noting(
            members.len(),
            system.channels,
            &m,
            encode_params,
            &ErrorWeights::for_emitters(&emission),
            SparseSelection::ErrorDriven,
        )
        .map_err(encode_error)?;
        self.emitters.push(emitters);
        self.encode_ms += t.elapsed().as_secs_f64() * 1e3;
        let (e, d) = squared_error(&m, &matrix);
        self.err2 += e;
        self.norm2 += d;
        let bytes = matrix.blocks.len() + matrix.sparse.bytes() + matrix.corrections.bytes();
        self.matrix_bytes += bytes;
        self.records.push(SystemRecord {
            region,
            input,
            parts,
            err2: e,
            norm2: d,
            matrix_bytes: bytes as u64,
            bounces_text: (self.effects.get("bounces"))
                .map(|e| e.why.clone())
                .unwrap_or_default(),
        });
        self.rebaked.push(why.or_else(|| {
            (level.plan_hash.is_some()).then(|| "no earlier bake was given".to_owned())
        }));
        self.files.push(RadFile {
            compression_rmse: Some(if d > 0.0 { (e / d).sqrt() as f32 } else { 0.0 }),
            ..RadFile::new(
                Cow::Owned(patches),
                Cow::Owned((0..members.len() as u32).collect()),
                matrix,
                objects_of(scene),
                transfer.bounces,
            )
        });
        Ok(())
    }

    /// The earlier bake's system `k`, now in `region`.
    fn keep(&mut self, old: &OldSystems, k: usize, region: u32) -> Result<(), BakeError> {
        let levels = old.level.systems.as_ref().expect("a level");
        let file = levels
            .system(&old.level, k)
            .map_err(|e| BakeError::InvalidParams(format!("the old level's system {k}: {e}")))?
            .into_owned();
        let record = SystemRecord {
            region,
            ..old.records[k].clone()
        };
        (self.effects).insert("bounces", Effect::new(true, record.bounces_text.clone()));
        self.bounces = file.bounces;
        self.err2 += record.err2;
        self.norm2 += record.norm2;
        self.matrix_bytes += record.matrix_bytes as usize;
        self.files.push(file);
        self.records.push(record);
        self.rebaked.push(None);
        Ok(())
    }
}

/// The squared error of `matrix`, the encode of `m`, and the squared norm of `m`.
fn squared_error(m: &[f32], matrix: &TransferMatrix<'_>) -> (f64, f64) {
    let decoded = matrix.decode_dense(DecodeMode::D3d10);
    m.iter().zip(&decoded).fold((0.0, 0.0), |(e, d), (a, b)| {
        let (a, b) = (f64::from(*a), f64::from(*b));
        (e + (a - b) * (a - b), d + a * a)
    })
}

/// The level's numbering as the report's order: none, its error the systems' measured one.
fn unordered(order: &[u32], matrices: &Matrices) -> Candidate {
    Candidate {
        kind: OrderKind::None,
        perm: order.to_vec(),
        error: crate::order::ErrorEstimate {
            relative: matrices.rmse(),
            squared_error: matrices.err2,
            squared_norm: matrices.norm2,
            relative_std: 0.0,
            blocks_encoded: 0,
            blocks_nonzero: 0,
            exact: true,
            code_rms: None,
        },
        order_ms: 0.0,
        measure_ms: 0.0,
    }
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
