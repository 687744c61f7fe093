//! The assembly of a planned bake: the shards' rows checked and pooled, then the rest of the
//! bake ([`crate::pipeline`]) with the plan's systems, each kept from an earlier bake where
//! its inputs are unchanged.

use super::reuse::RowStats;
use super::rows::{Cache, Rows};
use super::{Plan, scene_hash, shard_rows};
use crate::BakeError;
use crate::discretise::{Discretised, GivenRows};
use crate::form_factor::cast::HitCounts;
use crate::hooks::Hooks;
use crate::pipeline::BakeOutput;
use crate::pipeline::{OldSystems, SystemRecord, SystemsBake, SystemsCut, systems_bake};
use crate::scene::Scene;
use radiosity_core::RadFile;
use serde::Serialize;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// An earlier bake with the same plan: its level and the cache beside it.
pub struct Reuse {
    /// The level.
    pub level: RadFile<'static>,
    /// Its cache (`LEVEL.rad.rows`).
    pub cache: Cache,
}

/// Where a planned bake's cache lies: beside the level, `.rows` added to its name.
pub fn cache_path(level: &Path) -> PathBuf {
    let mut name = level.as_os_str().to_owned();
    name.push(".rows");
    PathBuf::from(name)
}

impl Reuse {
    /// Reads the level at `path` and its cache.
    pub fn read(path: &Path) -> Result<Self, BakeError> {
        let why = |m: String| BakeError::InvalidParams(format!("--reuse {}: {m}", path.display()));
        let bytes = std::fs::read(path).map_err(|e| why(e.to_string()))?;
        let level = RadFile::parse(&bytes)
            .map_err(|e| why(e.to_string()))?
            .into_owned();
        if level.systems.is_none() {
            return Err(why(
                "not a level cut into systems (bake it with --plan)".into()
            ));
        }
        let cache_at = cache_path(path);
        let cache = std::fs::read(&cache_at)
            .map_err(|e| why(format!("its cache {}: {e}", cache_at.display())))?;
        let cache = Cache::from_bytes(&cache)
            .map_err(|e| why(format!("its cache {}: {e}", cache_at.display())))?;
        if cache.systems.len() != level.systems.as_ref().map_or(0, |s| s.count()) {
            return Err(why(format!(
                "its cache {} belongs to another bake (its systems differ)",
                cache_at.display()
            )));
        }
        Ok(Self { level, cache })
    }
}

/// What a rebake kept and why it baked the rest again (`reuse` in the bake's JSON).
#[derive(Clone, Debug, Default, Serialize)]
pub struct ReuseReport {
    /// Systems of the level.
    pub systems: usize,
    /// Systems whose matrices were taken from the earlier bake.
    pub reused: usize,
    /// The others: system, its region in the plan, and why.
    pub rebaked: Vec<RebakedSystem>,
    /// How the rows came about.
    pub rows: RowStats,
}

/// A system baked again, and why.
#[derive(Clone, Debug, Serialize)]
pub struct RebakedSystem {
    /// Its place in the level.
    pub system: usize,
    /// Its region in the plan.
    pub region: u32,
    /// Why it was not taken from the earlier bake.
    pub why: String,
}

/// An assembled bake: the output, its cache, and what was reused.
pub struct Assembled {
    /// The level.
    pub output: BakeOutput,
    /// The cache to leave beside it ([`cache_path`]).
    pub cache: Cache,
    /// What was reused.
    pub reuse: ReuseReport,
}

fn refuse(m: String) -> BakeError {
    BakeError::InvalidParams(m)
}

/// Assembles `scene`'s bake under `plan` from every shard's rows (`rows`, any order; one
/// [`Rows`] of every patch serves too): a missing, stale or duplicated shard is refused
/// naming it. `reuse`: an earlier bake with the same plan, whose systems are kept where
/// their inputs are unchanged.
pub fn assemble(
    scene: &Scene,
    plan: &Plan,
    rows: Vec<Rows>,
    reuse: Option<&Reuse>,
    hooks: Hooks<'_>,
) -> Result<Assembled, BakeError> {
    let plan_hash = plan.hash();
    let scene_at = scene_hash(scene);
    if let Some(r) = reuse
        && r.cache.plan_hash != plan_hash
    {
        return Err(refuse(
            "--reuse: the earlier bake was made with another plan (reuse needs the same plan)"
                .into(),
        ));
    }
    check_shards(plan, &rows, &plan_hash, &scene_at)?;
    let pooled = pool(rows)?;
    let (params, _) = plan.params()?;
    let given = GivenRows {
        burial: pooled.burial.clone(),
        counts: pooled.counts.clone(),
        rays: pooled.rays,
    };
    let mut d = crate::discretise::discretise(scene, &params.discretise(), hooks, Some(given))?;
    let ff = d
        .sparse
        .take()
        .ok_or_else(|| refuse("internal: a planned bake's form factors are sparse rows".into()))?;
    let old = reuse.map(|r| old_systems(scene, &d, pooled.rays, r));
    let cut = SystemsCut::Plan {
        regions: &plan.regions,
        plan_hash,
        old: old.as_ref(),
    };
    let bake = systems_bake(scene, &d, Cow::Owned(ff), cut, &params, hooks)?;
    let report = reuse_report(&bake);
    let keys = std::mem::take(&mut d.keys);
    let sources = bake.output.patch_source.clone();
    let cache = level_cache(scene, plan_hash, pooled, keys, bake.records, sources);
    Ok(Assembled {
        output: bake.output,
        cache,
        reuse: report,
    })
}

/// Refuses any of `rows` made under another plan or from another scene, and, unless they
/// are one [`Rows`] of every patch, a shard given twice, one the plan does not have, or one
/// of the plan's that is missing.
fn check_shards(
    plan: &Plan,
    rows: &[Rows],
    plan_hash: &[u8; 32],
    scene_at: &[u8; 32],
) -> Result<(), BakeError> {
    let whole = rows.len() == 1 && rows[0].shard == u32::MAX;
    let mut have = vec![false; plan.shards.len()];
    for r in rows {
        let shard = format!("shard {} ({})", r.shard, r.name());
        if r.plan_hash != *plan_hash {
            return Err(refuse(format!("{shard} belongs to another plan")));
        }
        if r.scene_hash != *scene_at {
            return Err(refuse(format!(
                "{shard} was made from another scene (stale)"
            )));
        }
        if whole {
            continue;
        }
        match have.get_mut(r.shard as usize) {
            Some(h) if !*h => *h = true,
            Some(_) => return Err(refuse(format!("{shard} is given twice"))),
            None => return Err(refuse(format!("{shard} is not a shard of this plan"))),
        }
    }
    if let Some(k) = (!whole).then(|| have.iter().position(|h| !h)).flatten() {
        return Err(refuse(format!(
            "shard {k} of {} is missing (its rows would be {})",
            plan.shards.len(),
            Rows::file_name(scene_at, plan_hash, k as u32)
        )));
    }
    Ok(())
}

/// Every patch's rows, pooled from the shards in patch order ([`pool`]).
struct Pooled {
    /// Rays per patch.
    rays: u32,
    /// Each patch's burial survey.
    burial: Vec<Vec<u32>>,
    /// Whether each patch's survey asked about other points too.
    recursed: Vec<bool>,
    /// Each patch's hit counts.
    counts: Vec<HitCounts>,
}

/// The shards' rows (checked by [`check_shards`]) pooled in patch order: a shard that
/// disagrees with the others on the patches or rays, holds a row no shard makes, or leaves
/// a patch without its row is refused.
fn pool(rows: Vec<Rows>) -> Result<Pooled, BakeError> {
    let n = rows.first().map_or(0, |r| r.n_patches as usize);
    let rays = rows.first().map_or(0, |r| r.rays);
    let mut burial = vec![Vec::new(); n];
    let mut recursed = vec![false; n];
    let mut counts = vec![Vec::new(); n];
    let mut seen = vec![false; n];
    for r in rows {
        if r.n_patches as usize != n || r.rays != rays {
            return Err(refuse(format!(
                "shard {} disagrees with the others on the patches or rays (stale)",
                r.shard
            )));
        }
        let rows = r.patches.into_iter().zip(r.burial).zip(r.recursed);
        for (((p, b), q), c) in rows.zip(r.counts) {
            let p = p as usize;
            if p >= n || seen[p] || c.iter().any(|&(j, _)| j as usize >= n) {
                return Err(refuse(format!(
                    "shard {} holds a row no shard of this plan makes (damaged)",
                    r.shard
                )));
            }
            seen[p] = true;
            burial[p] = b;
            recursed[p] = q;
            counts[p] = c;
        }
    }
    if let Some(p) = seen.iter().position(|s| !s) {
        return Err(refuse(format!(
            "no shard holds the row of patch {p}: the shards were made from another scene"
        )));
    }
    Ok(Pooled {
        rays,
        burial,
        recursed,
        counts,
    })
}

/// The earlier bake `r` as the systems' bake takes it: its level, its systems' records, the
/// identity of each of its file's patches, and the boxes of what changed since, `d` being
/// this bake's discretisation at `rays` rays a patch.
fn old_systems(scene: &Scene, d: &Discretised, rays: u32, r: &Reuse) -> OldSystems {
    let occ = scene.occluders().robust();
    let boxes = super::reuse::Diff::new(scene, &d.patches, &occ, rays, &d.keys, &r.cache)
        .map(|diff| diff.boxes().to_vec());
    OldSystems {
        level: r.level.clone(),
        records: r.cache.systems.clone(),
        file_keys: (r.cache.sources.iter())
            .map(|&i| r.cache.keys[i as usize])
            .collect(),
        // Where every row was cast again (the bounds moved), nothing is carried: the
        // whole scene is a box.
        boxes: boxes.unwrap_or_else(|_| {
            vec![(
                glam::DVec3::splat(f64::NEG_INFINITY),
                glam::DVec3::splat(f64::INFINITY),
            )]
        }),
    }
}

/// Which of `bake`'s systems were kept and why the others were baked again (the rows'
/// statistics left at their default, for the caller to fill).
fn reuse_report(bake: &SystemsBake) -> ReuseReport {
    let rebaked: Vec<RebakedSystem> = (bake.rebaked.iter().enumerate())
        .filter_map(|(s, why)| {
            why.as_ref().map(|why| RebakedSystem {
                system: s,
                region: bake.records[s].region,
                why: why.clone(),
            })
        })
        .collect();
    ReuseReport {
        systems: bake.records.len(),
        reused: bake.records.len() - rebaked.len(),
        rebaked,
        rows: RowStats::default(),
    }
}

/// The cache a planned bake leaves beside its level: the pooled rows, every patch's
/// identity (`keys`), the scene's objects, triangles, emitters and coverage, the level's
/// systems and the patch of each file patch (`sources`).
fn level_cache(
    scene: &Scene,
    plan_hash: [u8; 32],
    rows: Pooled,
    keys: Vec<[u8; 16]>,
    systems: Vec<SystemRecord>,
    sources: Vec<u32>,
) -> Cache {
    let emits = (scene.triangles.iter())
        .map(|t| scene.materials[t.material as usize].emission.mean() > 0.0)
        .collect();
    Cache {
        plan_hash,
        rays: rows.rays,
        burial: rows.burial,
        recursed: rows.recursed,
        objects: scene.objects.clone(),
        counts: rows.counts,
        keys,
        triangles: (0..scene.triangles.len())
            .map(|t| scene.corners(t))
            .collect(),
        emits,
        coverage: scene.coverage.clone(),
        systems,
        sources,
    }
}

/// `scene`'s bake under `plan` in one process: every shard's rows, then [`assemble`]: the
/// same file as the shards assembled, byte for byte but the report's timings.
pub fn bake_planned(
    scene: &Scene,
    plan: &Plan,
    reuse: Option<&Reuse>,
    hooks: Hooks<'_>,
) -> Result<Assembled, BakeError> {
    let (rows, stats) = shard_rows(scene, plan, None, reuse.map(|r| &r.cache), hooks)?;
    let mut out = assemble(scene, plan, vec![rows], reuse, hooks)?;
    out.reuse.rows = stats;
    Ok(out)
}
