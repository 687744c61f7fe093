//! Cutting a level's patches into systems: pieces of at most a given number of patches, each
//! to carry its own transfer, chosen so that little light crosses between them
//! (`docs/decisions/systems.md`).
//!
//! The cut is recursive: a set of patches that does not fit is split in two by a plane normal
//! to one of the axes, its two sides each taking a share of the systems the set needs. Of
//! every position on every axis that leaves both sides within their share's capacity, the
//! plane taken is the one across which the least exchange `A_i F_ij` flows (summed over the
//! pairs it separates, both directions): a wall, a street between blocks, the gap between two
//! rooms. Every position of an axis is scored at once from the sorted patches: a pair whose
//! ranks are `r < s` is cut by the positions `r + 1 ..= s`, a difference array over the ranks.

use crate::form_factor::SparseFormFactors;
use crate::patch::Patches;
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// How a bake cuts its patches into systems.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SystemsChoice {
    /// One matrix for the whole scene (the bake as it always was).
    Off,
    /// Into this many systems (at least 1; at most one a patch).
    Count(usize),
    /// Systems of at most [`AUTO_SYSTEM_PATCHES`] patches where the live patches are more
    /// than [`AUTO_ONE_MATRIX`], one matrix otherwise (the default).
    #[default]
    Auto,
}

/// The most patches [`SystemsChoice::Auto`] bakes as one matrix: its transfer costs n³
/// (about 4 min at 8192 patches on two cores, 23 min at 16 384), where a system of 2048
/// costs about 2 s (`docs/decisions/systems.md`).
pub const AUTO_ONE_MATRIX: usize = 8192;
/// The largest system [`SystemsChoice::Auto`] makes. MEASURED on a city of 63 011 live
/// patches (`docs/decisions/systems.md`): systems of ≤ 2048 against ≤ 4096 bake in 5 min 24 s
/// against 6 min 50 s and light a CPU frame in about 38 ms against 50 (the systems' gathers
/// read half the bytes; the coupling grows from 19 M to 24 M entries), equally close to the
/// path tracer (0.91% and 0.92% per object).
pub const AUTO_SYSTEM_PATCHES: usize = 2048;

impl SystemsChoice {
    /// The systems for `n` live patches: `None` for one matrix.
    pub fn count_for(self, n: usize) -> Option<usize> {
        match self {
            SystemsChoice::Off => None,
            SystemsChoice::Count(k) => Some(k),
            SystemsChoice::Auto => (n > AUTO_ONE_MATRIX).then(|| n.div_ceil(AUTO_SYSTEM_PATCHES)),
        }
    }
}

/// Space cut into systems by axis-aligned planes (a k-d tree): a point belongs to the leaf it
/// reaches going `below` where its coordinate on `axis` is less than `at`, `above` otherwise.
/// A plan keeps its systems this way ([`crate::plan`]), so they still apply to a scene
/// whose objects moved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Region {
    /// A plane and the two sides.
    Cut {
        /// 0, 1 or 2 (x, y, z).
        axis: u8,
        /// Where the plane crosses the axis.
        at: f64,
        /// The side below the plane.
        below: Box<Region>,
        /// The side at or above it.
        above: Box<Region>,
    },
    /// One system.
    System {
        /// Its number (leaves numbered from 0 in order, below before above).
        system: u32,
    },
}

impl Region {
    /// The system of the point `p`.
    pub fn system_of(&self, p: DVec3) -> u32 {
        let mut node = self;
        loop {
            match node {
                Region::System { system } => return *system,
                Region::Cut {
                    axis,
                    at,
                    below,
                    above,
                } => {
                    node = if p[usize::from(*axis).min(2)] < *at {
                        below
                    } else {
                        above
                    }
                }
            }
        }
    }

    /// Systems (leaves).
    pub fn count(&self) -> usize {
        match self {
            Region::System { .. } => 1,
            Region::Cut { below, above, .. } => below.count() + above.count(),
        }
    }

    /// Whether the leaves are numbered 0, 1, … in order and every axis is 0 to 2 and every
    /// plane finite (what a plan read from a file must be).
    pub fn is_well_formed(&self) -> bool {
        fn walk(r: &Region, next: &mut u32) -> bool {
            match r {
                Region::System { system } => {
                    let ok = *system == *next;
                    *next += 1;
                    ok
                }
                Region::Cut {
                    axis,
                    at,
                    below,
                    above,
                } => *axis <= 2 && at.is_finite() && walk(below, next) && walk(above, next),
            }
        }
        walk(self, &mut 0)
    }
}

/// The patches as the cut sees them.
struct Sites<'a> {
    centres: &'a [DVec3],
    areas: &'a [f64],
}

/// Which system each patch belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct Partition {
    /// The system of each patch.
    pub system: Vec<u32>,
    /// Systems.
    pub count: usize,
}

impl Partition {
    /// The patches of each system, increasing.
    pub fn members(&self) -> Vec<Vec<u32>> {
        let mut out = vec![Vec::new(); self.count];
        for (i, &s) in self.system.iter().enumerate() {
            out[s as usize].push(i as u32);
        }
        out
    }

    /// The share of the exchange `Σ A_i F_ij` (over every pair, `i ≠ j`) that flows between
    /// patches of different systems: the light the systems must pass to each other.
    pub fn crossing_share(&self, patches: &Patches, ff: &SparseFormFactors) -> f64 {
        let areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
        self.crossing_share_sites(&areas, ff)
    }

    /// [`Self::crossing_share`] for patches of these `areas`.
    pub fn crossing_share_sites(&self, areas: &[f64], ff: &SparseFormFactors) -> f64 {
        let (mut all, mut crossing) = (0.0, 0.0);
        for i in 0..ff.n {
            let a = areas[i];
            for (j, f) in ff.row(i) {
                if j != i {
                    let w = a * f64::from(f);
                    all += w;
                    if self.system[i] != self.system[j] {
                        crossing += w;
                    }
                }
            }
        }
        if all > 0.0 { crossing / all } else { 0.0 }
    }
}

/// Cuts `patches` into systems of at most `max_patches` patches each (at least 1), as few as
/// that allows, along the planes across which the least light flows (module doc). `ff` are
/// the patches' form factors.
///
/// # Panics
/// If `ff` is not of `patches`.
pub fn partition(patches: &Patches, ff: &SparseFormFactors, max_patches: usize) -> Partition {
    let centres: Vec<DVec3> = patches.patches.iter().map(|p| p.centre).collect();
    let areas: Vec<f64> = patches.patches.iter().map(|p| p.area).collect();
    partition_sites(&centres, &areas, ff, max_patches)
}

/// [`partition`] for patches given by their `centres` and `areas`.
///
/// # Panics
/// If `ff`, `centres` and `areas` are not of the same patches.
pub fn partition_sites(
    centres: &[DVec3],
    areas: &[f64],
    ff: &SparseFormFactors,
    max_patches: usize,
) -> Partition {
    cut_sites(centres, areas, ff, max_patches, false).0
}

/// [`partition_sites`] by planes that fall between patch centres, so that the cut is also
/// the [`Region`] returned (a plane never passes between two patches of the same coordinate:
/// where none that keeps both sides within capacity exists, the side nearest its share).
///
/// # Panics
/// If `ff`, `centres` and `areas` are not of the same patches.
pub fn partition_regions(
    centres: &[DVec3],
    areas: &[f64],
    ff: &SparseFormFactors,
    max_patches: usize,
) -> (Partition, Region) {
    cut_sites(centres, areas, ff, max_patches, true)
}

fn cut_sites(
    centres: &[DVec3],
    areas: &[f64],
    ff: &SparseFormFactors,
    max_patches: usize,
    clean: bool,
) -> (Partition, Region) {
    assert!(
        ff.n == centres.len() && ff.n == areas.len(),
        "form factors of these patches"
    );
    let sites = Sites { centres, areas };
    let max = max_patches.max(1);
    let mut system = vec![0u32; ff.n];
    let mut count = 0;
    let mut rank = vec![u32::MAX; ff.n];
    let all: Vec<u32> = (0..ff.n as u32).collect();
    let parts = ff.n.div_ceil(max).max(1);
    // Centres closer than this on an axis are one coordinate (a wall's patches whose centres
    // differ by rounding): a plane between them would cut the wall.
    let span = centres
        .iter()
        .fold(0f64, |m, c| m.max(c.abs().max_element()));
    let mut state = CutState {
        rank: &mut rank,
        system: &mut system,
        count: &mut count,
        clean,
        gap: 1e-9 * span.max(f64::MIN_POSITIVE),
    };
    let region = cut(&sites, ff, all, parts, max, &mut state);
    (Partition { system, count }, region)
}

/// What [`cut`] writes as it goes: scratch ranks (`u32::MAX` outside the set being cut), each
/// patch's system, the systems so far, and whether planes must fall between centres.
struct CutState<'a> {
    rank: &'a mut [u32],
    system: &'a mut [u32],
    count: &'a mut usize,
    clean: bool,
    gap: f64,
}

/// Cuts `set` into `parts` systems of at most `max` patches, numbered from `*state.count`
/// on; the cut as a [`Region`].
fn cut(
    patches: &Sites<'_>,
    ff: &SparseFormFactors,
    mut set: Vec<u32>,
    parts: usize,
    max: usize,
    state: &mut CutState<'_>,
) -> Region {
    if parts <= 1 || set.len() <= max {
        for &i in &set {
            state.system[i as usize] = *state.count as u32;
        }
        *state.count += 1;
        return Region::System {
            system: *state.count as u32 - 1,
        };
    }
    let rank = &mut *state.rank;
    let left_parts = parts / 2;
    let right_parts = parts - left_parts;
    let n = set.len();
    // Positions k (the left side's size) that keep both sides within capacity.
    let lo = n.saturating_sub(right_parts * max).max(1);
    let hi = (left_parts * max).min(n - 1);
    let mut best: Option<(f64, usize, usize)> = None; // (crossing, axis, k)
    // The proportional split: among positions that cut as little, the nearest to it.
    let target = n * left_parts / parts;
    for axis in 0..3 {
        let key = |i: u32| patches.centres[i as usize][axis];
        set.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        for (r, &i) in set.iter().enumerate() {
            rank[i as usize] = r as u32;
        }
        // diff[k] accumulates the exchange cut by position k (left side ranks < k).
        let mut diff = vec![0.0f64; n + 1];
        for &i in &set {
            let ri = rank[i as usize] as usize;
            let a = patches.areas[i as usize];
            for (j, f) in ff.row(i as usize) {
                let rj = rank[j] as usize;
                if rj == u32::MAX as usize || rj == ri {
                    continue;
                }
                let (r, s) = (ri.min(rj), ri.max(rj));
                let w = a * f64::from(f);
                diff[r + 1] += w;
                diff[s + 1] -= w;
            }
        }
        let mut run = 0.0;
        for (k, d) in diff.iter().enumerate().take(hi + 1) {
            run += d;
            let between = |k: usize| key(set[k]) - key(set[k - 1]) > state.gap;
            if k >= lo && (!state.clean || between(k)) {
                let better = best.is_none_or(|(c, _, bk)| {
                    run < c - 1e-9 * c.abs()
                        || (run <= c + 1e-9 * c.abs() && k.abs_diff(target) < bk.abs_diff(target))
                });
                if better {
                    best = Some((run, axis, k));
                }
            }
        }
    }
    for &i in &set {
        rank[i as usize] = u32::MAX;
    }
    let (axis, k) = match best {
        Some((_, axis, k)) => (axis, k),
        // Only where planes must fall between centres and none within capacity does: the
        // position between distinct centres nearest the share, on the axis that has one.
        None => clean_fallback(patches, &mut set, n * left_parts / parts, state.gap)
            .expect("patches at distinct centres on some axis"),
    };
    let key = |i: u32| patches.centres[i as usize][axis];
    set.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    let at = 0.5 * (key(set[k - 1]) + key(set[k]));
    let right = set.split_off(k);
    let below = cut(patches, ff, set, left_parts, max, state);
    let above = cut(patches, ff, right, right_parts, max, state);
    Region::Cut {
        axis: axis as u8,
        at,
        below: Box::new(below),
        above: Box::new(above),
    }
}

/// The position `k` between two centres more than `gap` apart nearest `target` over the three
/// axes, with its axis.
fn clean_fallback(
    patches: &Sites<'_>,
    set: &mut [u32],
    target: usize,
    gap: f64,
) -> Option<(usize, usize)> {
    let mut best: Option<(usize, usize, usize)> = None; // (distance, axis, k)
    for axis in 0..3 {
        let key = |i: u32| patches.centres[i as usize][axis];
        set.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        for k in 1..set.len() {
            if key(set[k]) - key(set[k - 1]) > gap && best.is_none_or(|b| k.abs_diff(target) < b.0)
            {
                best = Some((k.abs_diff(target), axis, k));
            }
        }
    }
    best.map(|(_, axis, k)| (axis, k))
}

/// A level numbered system by system: what a systems bake stores besides each system's own
/// transfer.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    /// `order[k]`: the patch at position `k` of the level's numbering (systems one after
    /// another, each's patches increasing).
    pub order: Vec<u32>,
    /// Each system's positions.
    pub ranges: Vec<std::ops::Range<usize>>,
    /// The form factors between systems, in the level's numbering.
    pub coupling: radiosity_core::systems::Coupling<'static>,
}

impl Split {
    /// Numbers the patches of `partition` system by system and takes the entries of `ff`
    /// between systems as the coupling.
    pub fn new(ff: &SparseFormFactors, partition: &Partition) -> Self {
        let members = partition.members();
        let mut order = Vec::with_capacity(ff.n);
        let mut ranges = Vec::with_capacity(members.len());
        for m in &members {
            let start = order.len();
            order.extend_from_slice(m);
            ranges.push(start..order.len());
        }
        let mut position = vec![0u32; ff.n];
        for (k, &i) in order.iter().enumerate() {
            position[i as usize] = k as u32;
        }
        let (mut row_ptr, mut cols, mut values) = (vec![0u32], Vec::new(), Vec::new());
        for &i in &order {
            let s = partition.system[i as usize];
            let mut row: Vec<(u32, f32)> = ff
                .row(i as usize)
                .filter(|&(j, _)| partition.system[j] != s)
                .map(|(j, f)| (position[j], f))
                .collect();
            row.sort_unstable_by_key(|e| e.0);
            for (j, f) in row {
                cols.push(j);
                values.push(f);
            }
            row_ptr.push(cols.len() as u32);
        }
        Self {
            order,
            ranges,
            coupling: radiosity_core::systems::Coupling {
                row_ptr: row_ptr.into(),
                cols: cols.into(),
                values: values.into(),
            },
        }
    }

    /// System `s`'s own form factors `F_ss`, dense, in its own numbering (position minus its
    /// range's start): what its transfer is computed from.
    pub fn own_block(&self, ff: &SparseFormFactors, s: usize) -> crate::form_factor::matrix::Dense {
        let r = self.ranges[s].clone();
        let m = r.len();
        let mut local = std::collections::HashMap::with_capacity(m);
        for (k, &i) in self.order[r.clone()].iter().enumerate() {
            local.insert(i as usize, k);
        }
        let mut values = vec![0.0f64; m * m];
        for (k, &i) in self.order[r].iter().enumerate() {
            for (j, f) in ff.row(i as usize) {
                if let Some(&l) = local.get(&j) {
                    values[k * m + l] = f64::from(f);
                }
            }
        }
        crate::form_factor::matrix::Dense::new(m, values)
    }
}
