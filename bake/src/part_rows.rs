//! Each object's own gather row in a patch it shares with other objects: the form factors from
//! that object's part of the patch to every patch, so that `solve` gives the part the light
//! bounced onto it, not the patch's mean (`docs/decisions/part-rows.md`).
//!
//! A patch of several objects' parts (a 5 m cell of a pavilion: a plinth's top, a bench, the
//! posts of a railing, the underside of a beam) holds one irradiance, the mean over its area,
//! and its parts face different ways and stand in different light: the shaded posts of a
//! railing took +40% of the bounced light they get, a fascia facing the sunlit ground −25%.
//! Hierarchical radiosity's answer is to refine the receiver where the light it gathers varies
//! across it; this is that refinement one level down, along the objects: the light still
//! leaves every patch as the patch's radiosity `B`, but each part gathers it through its own
//! row, `y_o = Σ_j F_oj·B_j`, one sparse dot a part a frame.

use crate::geometry::Occluders;
use crate::patch::points::{Owners, cosine_direction, patch_point_on};
use crate::patch::{Patches, Piece};
use crate::rng::SplitMix64;
use radiosity_core::probes::{SH_COEFFICIENTS, sh_basis};
use rayon::prelude::*;

/// Cosine-weighted rays cast from each part: a part's row is a mean over them, with a
/// standard error of about `√(F(1−F)/N)` on an entry `F`, and a part's gathered light, a sum
/// over the patches it sees, much less.
pub(crate) const PART_RAYS: u32 = 256;

/// One object's part of a shared patch ([`part_rows`]).
#[derive(Clone, Debug)]
pub(crate) struct PartRow {
    /// The object.
    pub(crate) object: u32,
    /// The weight of one count: one over the part's rays that start exposed.
    pub(crate) each: f64,
    /// `(patch, sample, count)`: the rays whose first hit is nearest to direct-light sample
    /// `sample` (its index among `samples[patch]`) of `patch` (simplification numbering), in
    /// increasing `(patch, sample)` order.
    pub(crate) entries: Vec<(u32, u32, u16)>,
    /// Its cosine-weighted sky visibility (`radiosity_core::sky`'s `T`): `π/N · Σ Y_k(ω)` over
    /// the rays that leave the scene.
    pub(crate) sky: [f32; SH_COEFFICIENTS],
}

/// Per patch (simplification order), for each of its shared objects (`shared[i]`, in that
/// order) with a row, the [`PartRow`] of [`PART_RAYS`] cosine-weighted rays from the object's
/// part of the patch; empty for a patch of one object. `samples[j]` are patch `j`'s
/// direct-light samples `(position, object, area)` as the runtime mesh holds them: a hit counts to
/// the nearest sample of the hit's object on the hit patch, else the nearest of any. Rays that
/// start buried (their first hit a back face) are not counted: the row is the mean over the
/// part's exposed surface. Deterministic: each part's stream is seeded by its patch and
/// object.
pub(crate) fn part_rows(
    patches: &Patches,
    occ: &Occluders,
    shared: &[Vec<(u32, f64)>],
    samples: &[Vec<(glam::DVec3, u32, f64)>],
    seed: u64,
) -> Vec<Vec<PartRow>> {
    let caster = RowCaster::new(patches, occ, samples);
    (0..patches.len())
        .into_par_iter()
        .map(|i| {
            if shared[i].len() < 2 {
                return Vec::new();
            }
            let pieces = patches.pieces_of(i);
            shared[i]
                .iter()
                .filter_map(|&(o, _)| {
                    let mine: Vec<Piece> = pieces
                        .iter()
                        .filter(|q| q.object == o && q.area > 0.0)
                        .cloned()
                        .collect();
                    let mut rng = SplitMix64(
                        seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
                            ^ u64::from(o).wrapping_mul(0xc2b2_ae3d_27d4_eb4f),
                    );
                    let cast = caster.cast(&mine, PART_RAYS, &mut rng)?;
                    Some(PartRow {
                        object: o,
                        each: cast.each,
                        entries: cast.entries,
                        sky: cast.sky,
                    })
                })
                .collect()
        })
        .collect()
}

/// What [`RowCaster::cast`] found: the rays' first hits counted per direct-light sample.
pub(crate) struct Cast {
    /// The weight of one count: one over the rays that start exposed.
    pub(crate) each: f64,
    /// `(patch, sample, count)` in increasing `(patch, sample)` order (simplification
    /// numbering; `sample` an index among the patch's samples).
    pub(crate) entries: Vec<(u32, u32, u16)>,
    /// The cosine-weighted sky visibility of the rays that leave the scene.
    pub(crate) sky: [f32; SH_COEFFICIENTS],
}

/// Casts gather rows from pieces of surface: stratified cosine-weighted rays, each first hit
/// counted to the nearest direct-light sample of the hit's object on the hit patch, else the
/// nearest of any (`samples[j]`: patch `j`'s samples `(position, object, area)` as the runtime mesh
/// holds them). Rays that start buried (their first hit a back face) are not counted: a row is
/// the mean over the exposed surface.
pub(crate) struct RowCaster<'a> {
    patches: &'a Patches,
    occ: &'a Occluders,
    samples: &'a [Vec<(glam::DVec3, u32, f64)>],
    owners: Owners,
    far: f64,
}

impl<'a> RowCaster<'a> {
    pub(crate) fn new(
        patches: &'a Patches,
        occ: &'a Occluders,
        samples: &'a [Vec<(glam::DVec3, u32, f64)>],
    ) -> Self {
        RowCaster {
            patches,
            occ,
            samples,
            owners: Owners::new(patches),
            far: 10.0 * occ.extent(),
        }
    }

    /// `rays` rays from `pieces` (stratified by area); `None` when they have no area or no
    /// ray starts exposed.
    pub(crate) fn cast(&self, pieces: &[Piece], rays: u32, rng: &mut SplitMix64) -> Option<Cast> {
        let area: f64 = pieces.iter().map(|q| q.area).sum();
        if pieces.is_empty() || !(area > 0.0) {
            return None;
        }
        let patches = self.patches;
        let mut hits: Vec<(u32, u32)> = Vec::new();
        let mut exposed = 0u32;
        let mut sky = [0f64; SH_COEFFICIENTS];
        let nf = f64::from(rays);
        for k in 0..rays {
            let u = (f64::from(k) + 0.5) / nf;
            let v = (f64::from(k.reverse_bits()) / 4_294_967_296.0 + 0.5 / nf).fract();
            let (_, x, n) = patch_point_on(pieces, area, u, v);
            let d = cosine_direction(n, rng);
            match self.occ.first_surface_from_surface(x, d, self.far) {
                Some((_, false)) => {}
                Some((h, true)) => {
                    exposed += 1;
                    let at = x + d * h.distance;
                    if let Some(j) = self.owners.patch_at(&patches.pieces, h.triangle, at) {
                        hits.push((j as u32, self.nearest_sample(j, h.triangle, at)));
                    }
                }
                None => {
                    exposed += 1;
                    for (t, y) in sky.iter_mut().zip(sh_basis(d.as_vec3().to_array())) {
                        *t += f64::from(y);
                    }
                }
            }
        }
        if exposed == 0 {
            return None;
        }
        hits.sort_unstable();
        let mut entries: Vec<(u32, u32, u16)> = Vec::new();
        for (j, k) in hits {
            match entries.last_mut() {
                Some(e) if e.0 == j && e.1 == k => e.2 += 1,
                _ => entries.push((j, k, 1)),
            }
        }
        let each = 1.0 / f64::from(exposed);
        Some(Cast {
            each,
            entries,
            sky: sky.map(|t| (std::f64::consts::PI * each * t) as f32),
        })
    }

    /// The sample of patch `j` nearest to `at` on `triangle`: of the triangle's object where
    /// the patch has samples of it, else of any.
    fn nearest_sample(&self, j: usize, triangle: u32, at: glam::DVec3) -> u32 {
        let patches = self.patches;
        let obj = patches.pieces[patches.patches[j].pieces.clone()]
            .iter()
            .find(|q| q.triangle == triangle)
            .map_or(u32::MAX, |q| q.object);
        let near = |same: bool| {
            self.samples[j]
                .iter()
                .enumerate()
                .filter(|(_, s)| !same || s.1 == obj)
                .min_by(|a, b| {
                    a.1.0
                        .distance_squared(at)
                        .total_cmp(&b.1.0.distance_squared(at))
                })
                .map(|(k, _)| k as u32)
        };
        near(true).or_else(|| near(false)).unwrap_or(0)
    }
}
