//! A bake cut into a plan, shards and an assembly: for a cluster (`docs/distributed.md`) and
//! for rebakes of what changed (`docs/decisions/distributed-bake.md`).
//!
//! The plan ([`Plan`]) fixes what a bake otherwise decides from the whole scene: the grid of
//! cells (its size and corner), the systems as regions of space ([`Region`]), the flags.
//! With it, the costly half of a bake, each patch's burial survey and ray-cast hit counts,
//! depends on nothing but that patch and the scene, so it splits into shards of systems
//! ([`shard_rows`]) that run anywhere, in any order, any number of times. [`assemble`]
//! pools their counts and does the rest: the closure, each system's transfer and encoding,
//! the level. [`bake_planned`] runs every shard in one process and assembles with the same
//! code, so the file is the same byte for byte.
//!
//! A rebake ([`Reuse`]) starts from an earlier bake with the same plan: a patch's hit
//! counts are carried over except for the rays that may meet what changed
//! ([`reuse`]), and a system whose transfer inputs are unchanged keeps its matrix.

mod assemble;
pub mod reuse;
pub mod rows;

pub use assemble::{
    Assembled, RebakedSystem, Reuse, ReuseReport, assemble, bake_planned, cache_path,
};
pub use rows::{Cache, Rows};

use crate::BakeError;
use crate::form_factor::{ManyPieces, cast};
use crate::host::BakeFlags;
use crate::patch::Patches;
use crate::pipeline::{BakeParams, Hooks, SystemsChoice, discretise};
use crate::scene::{LoadOptions, Scene};
use crate::simplify::{Resolution, VoxelParams, simplify};
use crate::systems::{Region, partition_regions};
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// `format` of a plan file.
pub const PLAN_FORMAT: &str = "radiosity-plan";
/// `version` of a plan file.
pub const PLAN_VERSION: u32 = 1;
/// Rays per patch of the form factors a plan's cut is chosen from: a sixteenth of the
/// bake's, since the cut only compares the exchange across candidate planes.
pub const PLAN_RAYS: u32 = 256;

/// A bake's plan (`radiosity bake-plan`, `docs/contract.md`, "Plan files").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    /// [`PLAN_FORMAT`].
    pub format: String,
    /// [`PLAN_VERSION`].
    pub version: u32,
    /// The bake flags (the resolution flags as planned; `cell_size` fixes the grid).
    pub flags: BakeFlags,
    /// Edge of the grid's cells, in scene units.
    pub cell_size: f64,
    /// Corner of the grid.
    pub grid_origin: [f64; 3],
    /// The systems, as regions of space.
    pub regions: Region,
    /// The systems of each shard.
    pub shards: Vec<Vec<u32>>,
    /// What the planned scene gave (information only).
    pub planned: Planned,
    /// Hex BLAKE3 of the plan without this field; checked when read.
    #[serde(default)]
    pub plan_hash: String,
}

/// What the planned scene gave.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Planned {
    /// The scene's file name.
    pub scene: String,
    /// Live patches.
    pub patches: usize,
    /// Patches of each system.
    pub sizes: Vec<usize>,
}

fn bad(m: impl std::fmt::Display) -> BakeError {
    BakeError::InvalidParams(format!("bad plan: {m}"))
}

impl Plan {
    /// BLAKE3 of the plan's JSON without `plan_hash`.
    pub fn hash(&self) -> [u8; 32] {
        let mut bare = self.clone();
        bare.plan_hash.clear();
        let text = serde_json::to_vec(&bare).expect("a plan serialises");
        *blake3::hash(&text).as_bytes()
    }

    /// The plan as its file holds it (pretty JSON, `plan_hash` filled in).
    pub fn to_json(&self) -> String {
        let mut out = self.clone();
        out.plan_hash = hex(&self.hash());
        serde_json::to_string_pretty(&out).expect("a plan serialises") + "\n"
    }

    /// Reads and checks a plan file's text.
    pub fn from_json(text: &str) -> Result<Self, BakeError> {
        let plan: Plan = serde_json::from_str(text).map_err(bad)?;
        if plan.format != PLAN_FORMAT || plan.version != PLAN_VERSION {
            return Err(bad(format!(
                "format {:?} version {}: this build reads {PLAN_FORMAT:?} version {PLAN_VERSION}",
                plan.format, plan.version
            )));
        }
        let finite = plan.grid_origin.iter().all(|v| v.is_finite());
        if !(plan.cell_size.is_finite() && plan.cell_size > 0.0 && finite) {
            return Err(bad("cell_size must be positive and grid_origin finite"));
        }
        if !plan.regions.is_well_formed() {
            return Err(bad(
                "regions must number their systems 0, 1, … in order, on axes 0 to 2",
            ));
        }
        let systems = plan.regions.count();
        let mut seen = vec![false; systems];
        for &s in plan.shards.iter().flatten() {
            match seen.get_mut(s as usize) {
                Some(v) if !*v => *v = true,
                _ => return Err(bad(format!("system {s} is in no region or in two shards"))),
            }
        }
        if seen.iter().any(|v| !v) || plan.shards.iter().any(Vec::is_empty) {
            return Err(bad(
                "every system must be in exactly one shard, no shard empty",
            ));
        }
        if !plan.plan_hash.is_empty() && plan.plan_hash != hex(&plan.hash()) {
            return Err(bad(
                "plan_hash does not match its contents (the plan was edited or damaged: make it again with bake-plan)",
            ));
        }
        Ok(plan)
    }

    /// The bake's parameters and loading options under this plan: the flags, with the grid
    /// fixed and the form factors ray-cast (a shard's rows are each patch's own rays).
    pub fn params(&self) -> Result<(BakeParams, LoadOptions), BakeError> {
        let (mut p, load) = self.flags.params()?;
        p.voxel = VoxelParams {
            resolution: Resolution::CellSize(self.cell_size),
            origin: Some(DVec3::from(self.grid_origin)),
            ..p.voxel
        };
        p.form_factors.exact_pieces = 0;
        if !matches!(p.form_factors.many_pieces, ManyPieces::Rays { .. }) {
            return Err(bad("a plan's form factors must be ray-cast"));
        }
        p.systems = SystemsChoice::Count(self.regions.count());
        Ok((p, load))
    }

    /// Rays per patch.
    pub fn rays(&self) -> Result<u32, BakeError> {
        match self.params()?.0.form_factors.many_pieces {
            ManyPieces::Rays { per_patch } => Ok(per_patch),
            ManyPieces::Clustered => Err(bad("a plan's form factors must be ray-cast")),
        }
    }

    /// The patches of `shard` (all where `None`), by the region of their centres,
    /// increasing.
    pub fn shard_patches(&self, patches: &Patches, shard: Option<usize>) -> Vec<u32> {
        let mut mine = vec![shard.is_none(); self.regions.count()];
        if let Some(k) = shard {
            for &s in &self.shards[k] {
                mine[s as usize] = true;
            }
        }
        (0..patches.len() as u32)
            .filter(|&i| mine[self.regions.system_of(patches.patches[i as usize].centre) as usize])
            .collect()
    }
}

/// Lower-case hex.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Makes the plan for `scene` baked with `flags` (`params` as they give): the grid the
/// patch target asks for, and systems cut along the planes of least exchange
/// ([`partition_regions`]) from form factors of [`PLAN_RAYS`] rays a patch; `shards`
/// groups of neighbouring systems (default one a system).
pub fn make_plan(
    scene: &Scene,
    flags: &BakeFlags,
    params: &BakeParams,
    shards: Option<usize>,
    hooks: Hooks<'_>,
) -> Result<Plan, BakeError> {
    if params.systems == SystemsChoice::Off {
        return Err(BakeError::InvalidParams(
            "a plan cuts the level into systems: give --systems auto or a count, not off".into(),
        ));
    }
    hooks.start("plan grid")?;
    let grid = simplify(scene, &params.voxel)?;
    let origin = params.voxel.origin.unwrap_or(scene.bounds().0);
    let mut p = params.clone();
    p.voxel = VoxelParams {
        resolution: Resolution::CellSize(grid.cell_size),
        origin: Some(origin),
        ..p.voxel
    };
    p.form_factors.exact_pieces = 0;
    p.form_factors.many_pieces = ManyPieces::Rays {
        per_patch: PLAN_RAYS,
    };
    p.systems = SystemsChoice::Count(1);
    drop(grid);
    let d = discretise(scene, &p, hooks)?;
    let n = d.len();
    let ff = match &d.sparse {
        Some(s) => s.clone(),
        None => crate::form_factor::matrix::dense_live_sparse(&d.f, &(0..n).collect::<Vec<_>>()),
    };
    let count = params.systems.count_for(n).unwrap_or(1).clamp(1, n.max(1));
    let centres: Vec<DVec3> = d
        .live
        .iter()
        .map(|&i| d.patches.patches[i].centre)
        .collect();
    let areas: Vec<f64> = d.live.iter().map(|&i| d.patches.patches[i].area).collect();
    let (partition, regions) = partition_regions(&centres, &areas, &ff, n.div_ceil(count));
    let sizes: Vec<usize> = partition.members().iter().map(Vec::len).collect();
    let groups = group_shards(&sizes, shards.unwrap_or(sizes.len()));
    let mut flags = flags.clone();
    // The grid is fixed by `cell_size`: the target that found it stays as a record only.
    flags.voxel = None;
    // A memory budget bounds the machine that bakes, not the plan.
    flags.memory_budget = None;
    let mut plan = Plan {
        format: PLAN_FORMAT.into(),
        version: PLAN_VERSION,
        flags,
        cell_size: d.patches.cell_size,
        grid_origin: origin.to_array(),
        regions,
        shards: groups,
        planned: Planned {
            scene: scene
                .path
                .file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            patches: n,
            sizes,
        },
        plan_hash: String::new(),
    };
    plan.plan_hash = hex(&plan.hash());
    Ok(plan)
}

/// Neighbouring systems (in their order) grouped into `k` shards of about equal patches.
fn group_shards(sizes: &[usize], k: usize) -> Vec<Vec<u32>> {
    let k = k.clamp(1, sizes.len().max(1));
    let total: usize = sizes.iter().sum();
    let mut out: Vec<Vec<u32>> = vec![Vec::new()];
    let mut done = 0usize;
    for (s, &size) in sizes.iter().enumerate() {
        let left = sizes.len() - s;
        let groups_left = k - out.len();
        // Start a new shard once this one holds its share, or when every remaining system
        // must have a shard of its own.
        let full = done * k >= total * out.len();
        if !out.last().expect("one").is_empty() && groups_left > 0 && (full || left <= groups_left)
        {
            out.push(Vec::new());
        }
        out.last_mut().expect("one").push(s as u32);
        done += size;
    }
    out
}

/// BLAKE3 of everything in `scene` a bake reads: positions, texture coordinates, triangles
/// (not their source lines), objects, materials, textures, vertex colours, the reflectance
/// limit and the coverage.
pub fn scene_hash(scene: &Scene) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    let f = |h: &mut blake3::Hasher, v: f64| {
        h.update(&v.to_bits().to_le_bytes());
    };
    h.update(&(scene.positions.len() as u64).to_le_bytes());
    for p in &scene.positions {
        p.to_array().into_iter().for_each(|v| f(&mut h, v));
    }
    h.update(&(scene.texcoords.len() as u64).to_le_bytes());
    for t in &scene.texcoords {
        t.iter().for_each(|&v| f(&mut h, v));
    }
    h.update(&(scene.triangles.len() as u64).to_le_bytes());
    for t in &scene.triangles {
        for v in t.vertices {
            h.update(&v.to_le_bytes());
        }
        match t.texcoords {
            Some(c) => c.iter().for_each(|v| {
                h.update(&v.to_le_bytes());
            }),
            None => {
                h.update(&[0xff; 12]);
            }
        }
        h.update(&t.object.to_le_bytes());
        h.update(&t.material.to_le_bytes());
    }
    h.update(format!("{:?}", scene.objects).as_bytes());
    h.update(format!("{:?}", scene.materials).as_bytes());
    for t in &scene.textures {
        h.update(format!("{t:?}").as_bytes());
    }
    for c in &scene.vertex_colours {
        c.iter().for_each(|&v| f(&mut h, v));
    }
    h.update(format!("{:?}", scene.reflectance_limit).as_bytes());
    h.update(bytemuck::cast_slice(&scene.coverage));
    *h.finalize().as_bytes()
}

/// One shard's rows of `scene` under `plan` (`shard`: its index; `None`: every patch):
/// each of its patches' burial survey and hit counts. `reuse`: an earlier bake's cache with
/// the same plan, whose counts are carried over where no ray may meet what changed
/// ([`reuse`]): the rows are the same either way.
pub fn shard_rows(
    scene: &Scene,
    plan: &Plan,
    shard: Option<usize>,
    reuse: Option<&Cache>,
    hooks: Hooks<'_>,
) -> Result<(Rows, reuse::RowStats), BakeError> {
    if let Some(k) = shard
        && k >= plan.shards.len()
    {
        return Err(BakeError::InvalidParams(format!(
            "shard {k} does not exist: the plan has {} (0 to {})",
            plan.shards.len(),
            plan.shards.len() - 1
        )));
    }
    let (params, _) = plan.params()?;
    let rays = plan.rays()?;
    hooks.start("simplify")?;
    let mut patches = simplify(scene, &params.voxel)?;
    let keys = crate::patch::identity::seed_patches(scene, &mut patches);
    let occ = scene.occluders().robust();
    let rows = plan.shard_patches(&patches, shard);
    let go_on = |done: usize, total: usize| hooks.report(done, total);
    let diff = reuse.map(|cache| {
        if cache.plan_hash != plan.hash() {
            return Err("the old bake had another plan");
        }
        reuse::Diff::new(scene, &patches, &occ, rays, &keys, cache)
    });
    let (burial, recursed, counts, stats) = match diff {
        Some(Ok(diff)) => {
            hooks.start("burial")?;
            let (burial, recursed, surveyed) = diff.surveys(&rows);
            hooks.start("form factors")?;
            let (counts, mut stats) = diff.counts(&rows, &burial, &go_on);
            stats.surveyed = surveyed;
            (burial, recursed, counts, stats)
        }
        why => {
            hooks.start("burial")?;
            let (burial, recursed) = crate::form_factor::burial::survey_rows(&patches, &occ, &rows);
            hooks.start("form factors")?;
            let burial_of = |k: usize| {
                let at = rows.binary_search(&(k as u32)).expect("a row of the shard");
                burial[at].as_slice()
            };
            let counts = cast::count_rows(&patches, &occ, rays, &rows, &burial_of, Some(&go_on));
            let why = why.and_then(Result::err);
            (
                burial,
                recursed,
                counts,
                reuse::RowStats::cast(rows.len(), why),
            )
        }
    };
    hooks.check()?;
    Ok((
        Rows {
            plan_hash: plan.hash(),
            scene_hash: scene_hash(scene),
            shard: shard.map_or(u32::MAX, |k| k as u32),
            n_patches: patches.len() as u32,
            rays,
            patches: rows,
            burial,
            recursed,
            counts,
        },
        stats,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_group_neighbouring_systems_evenly() {
        let sizes = [100, 100, 100, 100, 100, 100, 100, 100];
        assert_eq!(
            group_shards(&sizes, 8),
            (0..8).map(|s| vec![s]).collect::<Vec<_>>()
        );
        assert_eq!(
            group_shards(&sizes, 4),
            vec![vec![0, 1], vec![2, 3], vec![4, 5], vec![6, 7]]
        );
        assert_eq!(group_shards(&sizes, 1), vec![(0..8).collect::<Vec<_>>()]);
        // More shards than systems: one a system.
        assert_eq!(group_shards(&sizes[..3], 9).len(), 3);
        // Uneven systems: every system in one shard, none empty, in order.
        let uneven = [500, 10, 10, 10, 400, 70];
        for k in 1..=6 {
            let g = group_shards(&uneven, k);
            assert_eq!(g.len(), k, "{g:?}");
            assert_eq!(g.concat(), (0..6).collect::<Vec<u32>>());
        }
    }

    fn plan() -> Plan {
        let regions = Region::Cut {
            axis: 0,
            at: 0.1 + 0.2,
            below: Box::new(Region::System { system: 0 }),
            above: Box::new(Region::System { system: 1 }),
        };
        let mut plan = Plan {
            format: PLAN_FORMAT.into(),
            version: PLAN_VERSION,
            flags: BakeFlags {
                patches: Some(4096),
                ..BakeFlags::default()
            },
            cell_size: 1.0 / 3.0,
            grid_origin: [-1.0, 0.0, 1e-17],
            regions,
            shards: vec![vec![0], vec![1]],
            planned: Planned {
                scene: "x.obj".into(),
                patches: 10,
                sizes: vec![4, 6],
            },
            plan_hash: String::new(),
        };
        plan.plan_hash = hex(&plan.hash());
        plan
    }

    #[test]
    fn a_plan_reads_back_to_the_same_bits_and_its_damage_is_refused() {
        let p = plan();
        let back = Plan::from_json(&p.to_json()).unwrap();
        // The planes and the grid to the bit: the hash (and every shard's name) follows them.
        assert_eq!(back, p);
        assert_eq!(back.hash(), p.hash());
        let edited = p.to_json().replace("4096", "4097");
        let e = Plan::from_json(&edited).unwrap_err().to_string();
        assert!(e.contains("plan_hash does not match"), "{e}");
        let mut twice = p.clone();
        twice.shards = vec![vec![0, 1], vec![1]];
        twice.plan_hash.clear();
        let e = Plan::from_json(&twice.to_json()).unwrap_err().to_string();
        assert!(e.contains("two shards"), "{e}");
        let mut bad = p.clone();
        bad.regions = Region::System { system: 3 };
        let e = Plan::from_json(&bad.to_json()).unwrap_err().to_string();
        assert!(e.contains("regions"), "{e}");
        let unknown = p.to_json().replacen('{', "{\"extra\": 1,", 1);
        assert!(Plan::from_json(&unknown).is_err());
        // Its parameters: the grid fixed, the form factors ray-cast, a system a region.
        let (params, _) = p.params().unwrap();
        assert_eq!(params.voxel.resolution, Resolution::CellSize(1.0 / 3.0));
        assert_eq!(params.form_factors.exact_pieces, 0);
        assert_eq!(params.systems, SystemsChoice::Count(2));
    }
}
