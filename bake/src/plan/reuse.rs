//! Hit counts carried over from an earlier bake with the same plan (`--reuse OLD.rad`,
//! `docs/decisions/distributed-bake.md`).
//!
//! A patch's rays are seeded by its identity ([`patch_keys`]), so an unchanged patch casts
//! the same rays in both scenes. A ray that meets none of what changed (the triangles of
//! either scene without a twin in the other, and the pieces of patches without one) meets
//! the same surface in both: its hit carries over. Only the rays whose line crosses the
//! boxes of what changed are cast again, in the old scene (from the cache's triangles) to
//! take their old hits out and in the new one to put the new hits in. A patch whose pieces
//! or burial survey changed casts all its rays again; so does every patch when the BVH's
//! f32 frame moved (the scene's bounds changed) or the rays per patch differ. The counts
//! are those a full cast gives, and anything inconsistent falls back to the full cast.

use super::Cache;
use crate::form_factor::Progress;
use crate::form_factor::burial::{survey_one, surveyed_starts};
use crate::form_factor::cast::{self, HitCounts, Starts, first_patch, rays_of, tally};
use crate::geometry::Occluders;
use crate::patch::Patches;
use crate::patch::points::Owners;
use crate::scene::Scene;
use glam::DVec3;
use radiosity_geometry::aabb::crosses;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

/// How a shard's rows came about.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct RowStats {
    /// Rows.
    pub rows: usize,
    /// Rows carried over from the old bake (some of their rays cast again).
    pub carried: usize,
    /// Rows cast in full.
    pub cast: usize,
    /// Rays cast again in carried rows (each in the old and the new scene).
    pub rays_recast: u64,
    /// Patches whose burial survey was made again (the others carried over).
    pub surveyed: usize,
    /// Why every row was cast, where one reason held for all.
    pub why_all: Option<String>,
}

impl RowStats {
    /// Every one of `rows` cast, for `why` (`None`: no old bake was given).
    pub(crate) fn cast(rows: usize, why: Option<&str>) -> Self {
        Self {
            rows,
            cast: rows,
            surveyed: rows,
            why_all: why.map(str::to_owned),
            ..Self::default()
        }
    }
}

/// A triangle's identity: its corners, whether it emits and its coverage.
fn triangle_key(t: &[DVec3; 3], emits: bool, coverage: f32) -> [u64; 11] {
    let mut k = [0u64; 11];
    for (slot, v) in k.iter_mut().zip(t.iter().flat_map(|p| p.to_array())) {
        *slot = v.to_bits();
    }
    k[9] = u64::from(emits);
    k[10] = u64::from(coverage.to_bits());
    k
}

/// Boxes that overlap merged until none does (a moved building's triangles and patches
/// become one box).
fn merge_boxes(mut boxes: Vec<(DVec3, DVec3)>) -> Vec<(DVec3, DVec3)> {
    loop {
        let mut out: Vec<(DVec3, DVec3)> = Vec::with_capacity(boxes.len());
        let mut merged = false;
        for b in boxes {
            match out
                .iter_mut()
                .find(|o| o.0.cmple(b.1).all() && b.0.cmple(o.1).all())
            {
                Some(o) => {
                    *o = (o.0.min(b.0), o.1.max(b.1));
                    merged = true;
                }
                None => out.push(b),
            }
        }
        boxes = out;
        if !merged {
            return boxes;
        }
    }
}

fn bounds(points: impl Iterator<Item = DVec3>) -> (DVec3, DVec3) {
    points.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    })
}

/// What changed between an earlier bake's scene (its cache) and this one, for carrying its
/// surveys and hit counts over (module doc).
pub(crate) struct Diff<'a> {
    patches: &'a Patches,
    occ: &'a Occluders,
    cache: &'a Cache,
    old_occ: Occluders,
    /// Old index of each patch (by identity).
    old_of: Vec<Option<u32>>,
    /// New index of each old patch (`u32::MAX`: none).
    new_of: Vec<u32>,
    /// New index of each old triangle (`u32::MAX`: none).
    twin: Vec<u32>,
    /// Boxes of what changed, padded.
    boxes: Vec<(DVec3, DVec3)>,
    /// Whether the surveys may carry over (the same objects, no emitter changed).
    surveys: bool,
    far: f64,
    rays: u32,
}

impl<'a> Diff<'a> {
    /// The difference, or why every row must be cast again.
    pub(crate) fn new(
        scene: &Scene,
        patches: &'a Patches,
        occ: &'a Occluders,
        rays: u32,
        keys: &[[u8; 16]],
        cache: &'a Cache,
    ) -> Result<Self, &'static str> {
        if cache.rays != rays {
            return Err("the old bake cast another number of rays a patch");
        }
        let old_occ = Occluders::with_emitters(&cache.triangles, cache.emits.clone())
            .with_coverage(cache.coverage.clone())
            .robust();
        if old_occ.frame() != occ.frame() || old_occ.extent() != occ.extent() {
            return Err("the scene's bounds changed, and with them every ray's f32 coordinates");
        }
        let old_at: HashMap<[u8; 16], u32> = (cache.keys.iter().enumerate())
            .map(|(i, k)| (*k, i as u32))
            .collect();
        let old_of: Vec<Option<u32>> = keys.iter().map(|k| old_at.get(k).copied()).collect();
        let mut new_of = vec![u32::MAX; cache.keys.len()];
        for (i, o) in old_of.iter().enumerate() {
            if let Some(o) = o {
                new_of[*o as usize] = i as u32;
            }
        }
        // Triangles: new index of each old one; boxes of those without a twin.
        let cover = |c: &[f32], t: usize| c.get(t).copied().unwrap_or(1.0);
        let emits = |t: usize| {
            scene.materials[scene.triangles[t].material as usize]
                .emission
                .mean()
                > 0.0
        };
        let new_tris: Vec<[DVec3; 3]> = (0..scene.triangles.len())
            .map(|t| scene.corners(t))
            .collect();
        let new_keys: HashMap<[u64; 11], u32> = (new_tris.iter().enumerate())
            .map(|(t, c)| {
                (
                    triangle_key(c, emits(t), cover(&scene.coverage, t)),
                    t as u32,
                )
            })
            .collect();
        let mut twin = vec![u32::MAX; cache.triangles.len()];
        let mut boxes = Vec::new();
        let mut has_twin = vec![false; new_tris.len()];
        let mut emitter_changed = false;
        for (t, c) in cache.triangles.iter().enumerate() {
            match new_keys.get(&triangle_key(c, cache.emits[t], cover(&cache.coverage, t))) {
                Some(&n) => {
                    twin[t] = n;
                    has_twin[n as usize] = true;
                }
                None => {
                    emitter_changed |= cache.emits[t];
                    boxes.push(bounds(c.iter().copied()));
                }
            }
        }
        for (t, c) in new_tris.iter().enumerate() {
            if !has_twin[t] {
                emitter_changed |= emits(t);
                boxes.push(bounds(c.iter().copied()));
            }
        }
        for (i, o) in old_of.iter().enumerate() {
            if o.is_none() {
                let pieces = patches.pieces_of(i);
                boxes.push(bounds(
                    pieces
                        .iter()
                        .flat_map(|q| q.polygon.vertices().iter().copied()),
                ));
            }
        }
        // A margin of two millionths of the scene: the f32 BVH's rounding near a box's faces,
        // and the burial question's look a millionth of the scene behind its point.
        let pad = DVec3::splat(2e-6 * occ.extent());
        let boxes: Vec<(DVec3, DVec3)> = merge_boxes(boxes)
            .into_iter()
            .map(|(lo, hi)| (lo - pad, hi + pad))
            .collect();
        Ok(Self {
            patches,
            occ,
            cache,
            old_occ,
            old_of,
            new_of,
            twin,
            boxes,
            surveys: !emitter_changed && cache.objects == scene.objects,
            far: 10.0 * occ.extent(),
            rays,
        })
    }

    /// Boxes of what changed, padded.
    pub(crate) fn boxes(&self) -> &[(DVec3, DVec3)] {
        &self.boxes
    }

    /// Whether the ray from `x` along `d` crosses what changed.
    fn crosses(&self, x: DVec3, d: DVec3) -> bool {
        self.boxes.iter().any(|&b| crosses(x, d, self.far, b))
    }

    /// Whether no ray of patch `i` can reach what changed: every box lies behind the plane of
    /// each of its pieces (rays leave a piece into the half-space its normal faces).
    fn out_of_sight(&self, i: usize) -> bool {
        self.patches.pieces_of(i).iter().all(|q| {
            let n = q.normal;
            let front = q
                .polygon
                .vertices()
                .iter()
                .map(|p| n.dot(*p))
                .fold(f64::INFINITY, f64::min);
            self.boxes.iter().all(|&(lo, hi)| {
                let far_corner = DVec3::select(n.cmpge(DVec3::ZERO), hi, lo);
                n.dot(far_corner) < front
            })
        })
    }

    /// The burial surveys of `rows`, and whether each asked about other points: carried over
    /// where the patch is unchanged, its survey asked about its own points only, and none of
    /// the burial questions' rays ([`Occluders::burial_directions`]) from its surveyed starts
    /// crosses what changed; surveyed again otherwise. Also the rows surveyed again.
    pub(crate) fn surveys(&self, rows: &[u32]) -> (Vec<Vec<u32>>, Vec<bool>, usize) {
        let again = AtomicUsize::new(0);
        let (burial, recursed) = rows
            .par_iter()
            .map(|&i| {
                let i = i as usize;
                let kept = self.old_of[i].map(|o| o as usize).filter(|&o| {
                    self.surveys
                        && !self.cache.recursed[o]
                        && self.survey_rays_clear(i, &self.cache.burial[o])
                });
                match kept {
                    Some(o) => (self.cache.burial[o].clone(), false),
                    None => {
                        again.fetch_add(1, Ordering::Relaxed);
                        survey_one(self.patches, self.occ, i)
                    }
                }
            })
            .unzip();
        (burial, recursed, again.into_inner())
    }

    /// Whether no burial question of patch `i`'s surveyed starts looks across what changed.
    fn survey_rays_clear(&self, i: usize, seen: &[u32]) -> bool {
        let Some(starts) = Starts::new(self.patches, i) else {
            return true;
        };
        (0..surveyed_starts(seen)).all(|k| {
            let (_, _, x, n) = starts.point(k);
            Occluders::burial_directions(n)
                .into_iter()
                .all(|d| !self.crosses(x, d))
        })
    }

    /// The hit counts of `rows` (burial surveys `burial`, in order), carried over where they
    /// can be (module doc), with how they came about.
    pub(crate) fn counts(
        &self,
        rows: &[u32],
        burial: &[Vec<u32>],
        progress: Progress<'_>,
    ) -> (Vec<HitCounts>, RowStats) {
        let (patches, occ, rays, far) = (self.patches, self.occ, self.rays, self.far);
        let owners = Owners::new(patches);
        let done = AtomicUsize::new(0);
        let recast = AtomicU64::new(0);
        let carried = AtomicUsize::new(0);
        let total = rows.len();
        let counts: Vec<HitCounts> = rows
            .par_iter()
            .zip(burial)
            .map(|(&i, buried)| {
                let i = i as usize;
                let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                let _ = progress(d, total);
                let full = || cast::count_row(patches, &owners, occ, i, rays, buried);
                let Some(o) = self.old_of[i].map(|o| o as usize) else {
                    return full();
                };
                if self.cache.burial[o] != *buried {
                    return full();
                }
                let old = &self.cache.counts[o];
                if self.out_of_sight(i) {
                    // No ray of it can meet what changed: its hits are all carried over.
                    if let Some(row) = self.renumbered(old) {
                        carried.fetch_add(1, Ordering::Relaxed);
                        return row;
                    }
                    return full();
                }
                // The old counts by old patch, less the old hits of the rays cast again.
                let mut left: Vec<(u32, i64)> =
                    old.iter().map(|&(j, c)| (j, i64::from(c))).collect();
                let mut fresh: Vec<u32> = Vec::new();
                let mut sound = true;
                let mut again = 0u64;
                rays_of(patches, i, rays, buried, |x, d| {
                    if !self.crosses(x, d) {
                        return;
                    }
                    again += 1;
                    if let Some((h, true)) = self.old_occ.first_surface_from_surface(x, d, far) {
                        let t = self.twin[h.triangle as usize];
                        let old = (t != u32::MAX)
                            .then(|| owners.patch_at(&patches.pieces, t, x + d * h.distance))
                            .flatten()
                            .and_then(|j| self.old_of[j]);
                        // An old hit on a patch without a twin needs no taking out: its
                        // column goes whole (every ray that reached it is cast again).
                        if let Some(j) = old {
                            match left.binary_search_by_key(&j, |e| e.0) {
                                Ok(k) => left[k].1 -= 1,
                                Err(_) => sound = false,
                            }
                        }
                    }
                    if let Some(j) = first_patch(patches, &owners, occ, x, d, far) {
                        fresh.push(j as u32);
                    }
                });
                let mut row: HitCounts = Vec::with_capacity(left.len() + fresh.len());
                for (j, c) in left {
                    let n = self.new_of[j as usize];
                    if c < 0 {
                        sound = false;
                    } else if c > 0 && n != u32::MAX {
                        row.push((n, c as u32));
                    }
                }
                if !sound {
                    return full();
                }
                recast.fetch_add(again, Ordering::Relaxed);
                carried.fetch_add(1, Ordering::Relaxed);
                row.extend(tally(fresh));
                merge_sorted(row)
            })
            .collect();
        let carried = carried.into_inner();
        let stats = RowStats {
            rows: rows.len(),
            carried,
            cast: rows.len() - carried,
            rays_recast: recast.into_inner(),
            surveyed: 0,
            why_all: None,
        };
        (counts, stats)
    }

    /// An old row in the new numbering; `None` where a hit patch has no twin (then a ray of it
    /// met what changed after all: it is cast again).
    fn renumbered(&self, old: &HitCounts) -> Option<HitCounts> {
        let row: Option<HitCounts> = old
            .iter()
            .map(|&(j, c)| {
                let n = self.new_of[j as usize];
                (n != u32::MAX).then_some((n, c))
            })
            .collect();
        row.map(merge_sorted)
    }
}

/// `(patch, count)` pairs sorted by patch, counts of one patch summed.
fn merge_sorted(mut row: HitCounts) -> HitCounts {
    row.sort_unstable_by_key(|e| e.0);
    let mut merged: HitCounts = Vec::with_capacity(row.len());
    for (j, c) in row {
        match merged.last_mut() {
            Some((k, n)) if *k == j => *n += c,
            _ => merged.push((j, c)),
        }
    }
    merged
}
