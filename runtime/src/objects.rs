//! Per-object figures (what `radiosity solve` reports): each object's area-weighted mean
//! irradiance and radiosity over its whole full-detail surface, with the patches that hold
//! parts of several objects ([`ObjectShares`], from the bake report's `shared_patches`) split
//! by area.

use radiosity_core::{RadFile, Rgb};
use serde::{Deserialize, Serialize};

/// One object's light in a frame (`docs/contract.md`, `solve --json`'s `objects`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectLight {
    /// The object's name in the file.
    pub name: String,
    /// Its whole full-detail area, buried parts included: what the means are taken over.
    pub area: f64,
    /// The area of its share of the matrix patches.
    pub exposed_area: f64,
    /// Area-weighted mean irradiance, W/m² (RGB).
    pub irradiance: [f64; 3],
    /// Area-weighted mean radiosity, W/m² (RGB).
    pub radiosity: [f64; 3],
}

/// A patch of parts of several objects: the exposed area of each object in it (the patch's
/// own `object` is the largest of them). `objects` and `areas` have one entry per object, in
/// increasing object order; the areas sum to the patch's area.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SharedPatch {
    /// Index of the patch in the file.
    pub patch: u32,
    /// The objects (file object order).
    pub objects: Vec<u32>,
    /// Each object's exposed area in the patch.
    pub areas: Vec<f64>,
    /// The object of each of the patch's direct-light samples (the mesh's `samples_of(patch)`
    /// order): `solve` takes each object's direct light from its own samples.
    #[serde(default)]
    pub sample_objects: Vec<u32>,
}

/// Every file patch's area per object: a patch belongs to its `object` whole, unless the
/// report's `shared_patches` splits it.
pub struct ObjectShares<'a> {
    patches: &'a [radiosity_core::Patch],
    /// Per file patch, its entry in `shared` (`u32::MAX` for none).
    slot: Vec<u32>,
    shared: Vec<SharedPatch>,
}

impl<'a> ObjectShares<'a> {
    /// The shares for `patches` of a file of `objects` objects. `shared` is checked: a list
    /// naming a patch or object past the end, a patch twice, lists of unequal lengths or an
    /// area not finite and at least 0 is not used (every patch then belongs to its `object`),
    /// so a damaged report cannot move light between objects or out of range.
    pub fn new(
        patches: &'a [radiosity_core::Patch],
        objects: usize,
        shared: Vec<SharedPatch>,
    ) -> Self {
        let mut slot = vec![u32::MAX; patches.len()];
        let good = shared.iter().enumerate().all(|(k, s)| {
            let ok = (s.patch as usize) < patches.len()
                && s.objects.len() == s.areas.len()
                && s.objects.iter().all(|&o| (o as usize) < objects)
                && s.sample_objects.iter().all(|&o| (o as usize) < objects)
                && s.areas.iter().all(|a| a.is_finite() && *a >= 0.0)
                && slot[s.patch as usize] == u32::MAX;
            if ok {
                slot[s.patch as usize] = k as u32;
            }
            ok
        });
        if !good {
            slot.fill(u32::MAX);
        }
        Self {
            patches,
            slot,
            shared: if good { shared } else { Vec::new() },
        }
    }

    /// The shares read from a bake report (`shared_patches`; none when it has no such field).
    pub fn from_report(
        patches: &'a [radiosity_core::Patch],
        objects: usize,
        report: Option<&serde_json::Value>,
    ) -> Self {
        let shared = report
            .and_then(|r| r.get("shared_patches"))
            .and_then(|v| serde_json::from_value(v.clone()).ok())
            .unwrap_or_default();
        Self::new(patches, objects, shared)
    }

    /// The object of each direct-light sample of patch `i`, where it is shared and the report
    /// says.
    pub fn sample_objects(&self, i: usize) -> Option<&[u32]> {
        let s = self.shared.get(self.slot[i] as usize)?;
        (!s.sample_objects.is_empty()).then_some(s.sample_objects.as_slice())
    }

    /// `(object, area)` of patch `i`.
    pub fn of(&self, i: usize) -> impl Iterator<Item = (u32, f64)> + '_ {
        let one = (self.slot[i] == u32::MAX)
            .then(|| (self.patches[i].object, f64::from(self.patches[i].area)));
        let many = self
            .shared
            .get(self.slot[i] as usize)
            .into_iter()
            .flat_map(|s| s.objects.iter().copied().zip(s.areas.iter().copied()));
        one.into_iter().chain(many)
    }
}

/// Area-weighted mean irradiance and radiosity per object, over its whole full-detail surface
/// (`area`): the part outside the matrix (buried under another object, or a patch that sees
/// nothing and was dropped) receives nothing, so it counts with `H = 0` and `B = E`. The
/// matrix patches' own area is `exposed_area`. The whole surface comes from [`surfaces`].
///
/// A patch of several objects' parts (the report's `shared_patches`) counts to each object
/// with that object's area in it, and with the direct light of that object's own samples in
/// place of the patch's mean (`direct`, per patch, and `at_samples`, per mesh sample): the
/// indirect light is the patch's, shared, but a box in a building's shadow whose top shares a
/// patch with the sunlit ground keeps its own shadow.
///
/// Where the file gives the parts of a shared patch rows of their own (its PARTS section), a
/// part takes its bounced light from its row ([`part_light`]) and, under a sky (`sky`, the
/// frame's sky radiance SH, `radiosity_core::sky_sh_of`), the sky's light from its own sky
/// visibility in place of the patch's.
pub fn per_object(
    file: &RadFile<'_>,
    h: &[Rgb],
    b: &[Rgb],
    direct: &[Rgb],
    at_samples: &[Rgb],
    sky: Option<&radiosity_core::SkySh>,
) -> Vec<ObjectLight> {
    // Per object: matrix area, and Σ A·H, Σ A·B, Σ A·E over its share of the matrix patches.
    let report: Option<serde_json::Value> = file
        .report
        .as_deref()
        .and_then(|r| serde_json::from_str(r).ok());
    let shares = ObjectShares::from_report(&file.patches, file.objects.len(), report.as_ref());
    let mut acc = vec![(0f64, [0f64; 3], [0f64; 3], [0f64; 3]); file.objects.len()];
    for (i, p) in file.patches.iter().enumerate() {
        let own = own_direct(file, &shares, i, at_samples);
        for (o, w) in shares.of(i) {
            // The object's own direct light less the patch's mean, where it has its own.
            let shift = own
                .iter()
                .find(|d| d.0 == o)
                .map_or(Rgb::ZERO, |d| d.1 - direct[i]);
            // The object's own bounced light, where the file gives its part a row of its own.
            let shift = match part_light(file, i, o, b, direct, at_samples) {
                Some(own) => shift + own - (h[i] - direct[i]),
                None => shift,
            } + sky.map_or(Rgb::ZERO, |sh| part_sky(file, i, o, sh));
            let (h, b) = (h[i] + shift, b[i] + p.reflectance * shift);
            let a = &mut acc[o as usize];
            a.0 += w;
            for k in 0..3 {
                a.1[k] += w * f64::from(h.channel(k));
                a.2[k] += w * f64::from(b.channel(k));
                a.3[k] += w * f64::from(p.emission.channel(k));
            }
        }
    }
    let whole = surfaces(file, report.as_ref());
    file.objects
        .iter()
        .zip(acc)
        .enumerate()
        .map(|(o, (name, (exposed, hs, bs, es)))| {
            let (area, power) = whole.as_ref().map_or((exposed, None), |w| w[o]);
            // Rounding (f32 patch areas) may put the matrix a hair above the whole surface.
            let area = area.max(exposed);
            let mut bs = bs;
            if let Some(power) = power.filter(|_| area > exposed) {
                for k in 0..3 {
                    bs[k] += (power[k] - es[k]).max(0.0);
                }
            }
            let mean = |s: [f64; 3]| {
                if area > 0.0 {
                    s.map(|v| v / area)
                } else {
                    [0.0; 3]
                }
            };
            ObjectLight {
                name: name.to_string(),
                area,
                exposed_area: exposed,
                irradiance: mean(hs),
                radiosity: mean(bs),
            }
        })
        .collect()
}

/// The light bounced onto object `o`'s part of patch `i` through the part's own row (the
/// file's PARTS section, [`radiosity_core::PartRows`]): `Σ w·B(s)` over its entries, `B(s)` the
/// radiosity of sample `s`'s patch with the sample's own direct light in place of the patch's
/// mean. `None` where the part has no row, or `b`, `direct` or `at_samples` do not fit
/// the file.
pub fn part_light(
    file: &RadFile<'_>,
    i: usize,
    o: u32,
    b: &[Rgb],
    direct: &[Rgb],
    at_samples: &[Rgb],
) -> Option<Rgb> {
    let (parts, mesh) = (file.parts.as_ref()?, file.mesh.as_ref()?);
    let p = parts.find(i as u32, o)?;
    if b.len() != file.patches.len()
        || direct.len() != file.patches.len()
        || at_samples.len() != mesh.samples.len()
    {
        return None;
    }
    let mut own = Rgb::ZERO;
    let mut j = 0usize;
    for (s, w) in parts.row(p) {
        // The patch of sample `s`: samples are in patch order, and a part's in increasing order.
        while mesh.sample_rows[j + 1] <= s {
            j += 1;
        }
        own += (b[j] + file.patches[j].reflectance * (at_samples[s as usize] - direct[j])) * w;
    }
    Some(own)
}

/// The sky's light on object `o`'s part of patch `i` through the part's own sky visibility,
/// less the patch's (what [`per_object`] adds to the patch's light); zero where the file has
/// no part sky visibility for it.
fn part_sky(file: &RadFile<'_>, i: usize, o: u32, sh: &radiosity_core::SkySh) -> Rgb {
    let (Some(parts), Some(vis)) = (file.parts.as_ref(), file.sky.as_ref()) else {
        return Rgb::ZERO;
    };
    let Some(t) = parts.find(i as u32, o).and_then(|p| parts.sky_of(p)) else {
        return Rgb::ZERO;
    };
    radiosity_core::sky_irradiance(&t, sh) - radiosity_core::sky_irradiance(&vis.entry(i), sh)
}

/// The direct irradiance of each object's own samples in shared patch `i` (area-weighted
/// means, `(object, irradiance)`); empty for a patch of one object, without lights or mesh, or
/// where the report's sample objects do not match the mesh's samples.
fn own_direct(
    file: &RadFile<'_>,
    shares: &ObjectShares<'_>,
    i: usize,
    at_samples: &[Rgb],
) -> Vec<(u32, Rgb)> {
    let (Some(objects), Some(mesh)) = (shares.sample_objects(i), file.mesh.as_ref()) else {
        return Vec::new();
    };
    let samples = mesh.samples_of(i);
    let start = mesh.sample_rows[i] as usize;
    let Some(at) = at_samples.get(start..start + samples.len()) else {
        return Vec::new();
    };
    if objects.len() != samples.len() {
        return Vec::new();
    }
    let mut sums: Vec<(u32, Rgb, f32)> = Vec::new();
    for ((s, &o), &d) in samples.iter().zip(objects).zip(at) {
        match sums.iter_mut().find(|e| e.0 == o) {
            Some(e) => {
                e.1 += d * s.area;
                e.2 += s.area;
            }
            None => sums.push((o, d * s.area, s.area)),
        }
    }
    sums.into_iter()
        .filter(|e| e.2 > 0.0)
        .map(|(o, d, a)| (o, d * (1.0 / a)))
        .collect()
}

/// Each object's whole full-detail area and the power it emits over it (file object order),
/// from the first source the file has: the bake report's `object_surface_areas` and
/// `object_emitted_power`; else the file's full-detail mesh (files baked before those fields);
/// else the report's `object_areas` (the full-detail area less the buried part) with no power
/// (nothing counted as emitted outside the matrix); and `None` without any of them: the matrix
/// patches are then the whole surface.
fn surfaces(
    file: &RadFile<'_>,
    report: Option<&serde_json::Value>,
) -> Option<Vec<(f64, Option<[f64; 3]>)>> {
    let n = file.objects.len();
    let field = |key: &str| report.map(|r| r[key].clone());
    // A figure per object, each finite and not negative, or none.
    let good = |v: &f64| v.is_finite() && *v >= 0.0;
    let areas: Option<Vec<f64>> = field("object_surface_areas")
        .and_then(|v| serde_json::from_value(v).ok())
        .filter(|a: &Vec<f64>| a.len() == n && a.iter().all(good));
    let power: Option<Vec<[f64; 3]>> = field("object_emitted_power")
        .and_then(|v| serde_json::from_value(v).ok())
        .filter(|p: &Vec<[f64; 3]>| p.len() == n && p.iter().flatten().all(good));
    if let (Some(areas), Some(power)) = (areas, power) {
        return Some(areas.into_iter().zip(power.into_iter().map(Some)).collect());
    }
    if let Some(mesh) = &file.mesh {
        let mut w = vec![(0.0, [0.0; 3]); n];
        let at = |v: u32| {
            mesh.positions
                .get(v as usize)
                .map(|p| glam::DVec3::from(p.map(f64::from)))
        };
        for t in mesh.triangles.iter() {
            let (Some(a), Some(b), Some(c)) =
                (at(t.vertices[0]), at(t.vertices[1]), at(t.vertices[2]))
            else {
                continue;
            };
            let Some(o) = w.get_mut(t.object as usize) else {
                continue;
            };
            let area = 0.5 * (b - a).cross(c - a).length();
            o.0 += area;
            for k in 0..3 {
                o.1[k] += area * f64::from(t.emission.channel(k));
            }
        }
        return Some(w.into_iter().map(|(a, p)| (a, Some(p))).collect());
    }
    field("object_areas")
        .and_then(|v| serde_json::from_value(v).ok())
        .filter(|a: &Vec<f64>| a.len() == n && a.iter().all(good))
        .map(|a| a.into_iter().map(|a| (a, None)).collect())
}
