//! The points file (`solve --points`, `docs/contract.md`) and the total irradiance at each
//! point: `{"points":[{"position":[x,y,z],"normal":[x,y,z]}]}`.
//!
//! At a point facing `normal`: the direct light of the analytic lights (shadow rays, as at a
//! patch), the direct light of the emitting surfaces (each triangle's exact unoccluded
//! irradiance times the share in view of [`EMITTER_SAMPLES`] shadow rays to points on them,
//! stratified over a pick in proportion to their power and across each triangle:
//! [`Emitters::irradiance_at`], `docs/decisions/exact-emitter-light.md`), and
//! the light the surfaces reflect, gathered over the hemisphere by [`RAYS`] cosine-weighted
//! rays, stratified. Each ray's first surface shows its reflected radiosity:
//! `ρ∘(H_d + H_e + y − y_e)`, with `H_d` from shadow rays to the analytic lights at the hit,
//! `H_e` from [`HIT_EMITTER_SAMPLES`] shadow rays to the emitting surfaces there, and `y − y_e`
//! (the frame's gathered irradiance less each patch's own direct light from the emitters)
//! interpolated from the patches around the hit that it sees. The emitters' direct light peaks
//! under a small light and falls off along the walls beside it, faster than a patch's size;
//! what the patches pass on beyond it is smooth (`docs/decisions/final-gather-emitters.md`).
//! With cosine-weighted rays the irradiance is the mean of those radiosities. A small bright
//! emitter met by the gather's rays instead would be a few dozen of them, a noise of several
//! per cent. A hit closer to the point than [`NEAR_SIDES`] sides of the patches around it,
//! where the point sees more detail than the patches hold, takes `y − y_e` from a second
//! gather of [`SECOND_RAYS`] rays instead (`docs/decisions/secondary-gather.md`). This is a
//! final gather at the point, exact up to the frame's patch resolution one bounce away and the
//! rays' noise; it costs [`RAYS`] rays, and shadow rays and near hits' second gathers at each
//! hit, a point, so it answers queries rather than lighting moving objects every frame.
//!
//! Under a sky or environment light, a ray that leaves the scene brings the sky's radiance
//! itself (the image, not its SH), and a hit's reflected radiosity includes its patch's sky
//! light, interpolated with `y − y_e`.
//!
//! A point whose rays mostly meet the backs of faces is inside an object, and one beyond the
//! bounding box of the scene's mesh whose rays all miss it is outside it: both are answered as
//! such, without a figure, except under a sky, which lights a point anywhere. A point beyond
//! the box that sees the scene (in front of an open scene) is answered.

use crate::BakedScene;
use crate::render::{PatchGrid, triangle_normal};
use glam::{DVec3, Vec3};
use radiosity_core::{Light, Rgb};
use radiosity_geometry::point_polygon::point_to_polygon;
use radiosity_geometry::polygon::Polygon;
use radiosity_geometry::rng::SplitMix64;
use radiosity_geometry::{Hit, Occluders};
use rayon::prelude::*;
use serde::Deserialize;

/// Hemisphere rays a point: 64 × 64 strata, one jittered ray in each.
pub const RAYS: usize = 64 * 64;

/// Shadow rays a point to the emitting surfaces.
pub const EMITTER_SAMPLES: usize = 1024;

/// Shadow rays to the emitting surfaces at each surface a gather ray meets.
pub const HIT_EMITTER_SAMPLES: usize = 16;

/// Hits closer to the point than this many sides (`√area`) of the patches around them gather
/// their reflected light again instead of interpolating it from those patches: the point sees
/// such a hit's surroundings in more detail than the patches hold
/// (`docs/decisions/secondary-gather.md`).
pub const NEAR_SIDES: f64 = 4.0;

/// Cosine-weighted rays of that second gather at a near hit: 4 × 4 strata.
pub const SECOND_RAYS: usize = 4 * 4;

/// Emitting triangles up to which the emitters' direct light starts from each one's exact
/// unoccluded irradiance ([`Emitters::irradiance_at`]); a scene of more samples them all.
const ANALYTIC_EMITTERS: usize = 256;

/// Shadow rays to the emitting surfaces a patch, spread over its direct-light points.
const PATCH_EMITTER_SAMPLES: usize = 256;

/// Share of rays meeting back faces above which a point is inside an object.
const INSIDE_SHARE: f64 = 0.5;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PointsFile {
    points: Vec<Entry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Entry {
    position: [f64; 3],
    normal: [f64; 3],
}

/// A query point with its unit normal (as given, normalised).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Where the irradiance is asked.
    pub position: DVec3,
    /// The unit normal of the surface it would fall on.
    pub normal: DVec3,
    /// The normal as given.
    pub given_normal: DVec3,
}

/// What a point is answered with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Answer {
    /// Total irradiance, W/m², by the final gather; and where the file has probes, by the
    /// probes (the same direct light plus the probes' reflected light), `None` for a point
    /// outside the probe grid.
    Irradiance {
        /// The total irradiance.
        total: Rgb,
        /// The probes' figure (module doc).
        probes: Option<Option<Rgb>>,
    },
    /// The point lies inside an object (most of its rays meet back faces).
    Inside,
    /// The point lies outside the scene: beyond the bounds of its mesh, and none of its rays
    /// meets a surface (a point just in front of an open scene, looking at it, is answered).
    Outside,
}

/// Parses a points file's text.
pub fn parse(text: &str) -> crate::Result<Vec<Point>> {
    let file: PointsFile = serde_json::from_str(text)
        .map_err(|e| crate::Error::Invalid(format!("not a points file: {e}")))?;
    file.points
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let (p, n) = (DVec3::from(e.position), DVec3::from(e.normal));
            if !p.is_finite() || !n.is_finite() {
                invalid!("point {i}: position and normal must be finite");
            }
            let len = n.length();
            if !(len > 1e-12) {
                invalid!(
                    "point {i}: normal [{}, {}, {}] has zero length",
                    n.x,
                    n.y,
                    n.z
                );
            }
            Ok(Point {
                position: p,
                normal: n / len,
                given_normal: n,
            })
        })
        .collect()
}

/// A cosine-weighted direction about the unit normal `n` from `(u1, u2)` in [0, 1)².
fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let r = u1.sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let z = (1.0 - u1).max(0.0).sqrt();
    let (t1, t2) = n.any_orthonormal_pair();
    (t1 * (r * phi.cos()) + t2 * (r * phi.sin()) + n * z).normalize()
}

/// The base-2 radical inverse of `i` (van der Corput), in [0, 1).
fn radical_inverse(i: u32) -> f64 {
    f64::from(i.reverse_bits()) / 4_294_967_296.0
}

/// The mesh's emitting triangles with the cumulative sums of `area × mean exitance` (the pick).
struct Emitters {
    triangles: Vec<u32>,
    cdf: Vec<f64>,
    /// Whether the direct light starts from each triangle's exact unoccluded irradiance
    /// (at most [`ANALYTIC_EMITTERS`] emitting triangles).
    analytic: bool,
}

impl Emitters {
    fn new(mesh: &radiosity_core::Mesh<'_>) -> Self {
        let (mut triangles, mut cdf, mut total) = (Vec::new(), Vec::new(), 0.0);
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let e = f64::from(tri.emission.mean());
            if e > 0.0 {
                let [a, b, c] = mesh.corners(t).map(|v| Vec3::from(v).as_dvec3());
                total += 0.5 * (b - a).cross(c - a).length() * e;
                triangles.push(t as u32);
                cdf.push(total);
            }
        }
        let analytic = triangles.len() <= ANALYTIC_EMITTERS;
        Self {
            triangles,
            cdf,
            analytic,
        }
    }

    /// Direct irradiance at `p` facing unit `n` from every emitting surface's front, with
    /// `samples` shadow rays to stratified points on them.
    ///
    /// With at most [`ANALYTIC_EMITTERS`] emitting triangles and [`HIT_EMITTER_SAMPLES`] or
    /// more samples (not the second gather's single ray: its error is a bounce away and
    /// spread over thousands of hits, and it would pay the contour integral of every
    /// triangle for one shadow ray): each one's exact unoccluded
    /// irradiance `E_t·F(p → t)` (Lambert's contour integral, clipped to the front of `p`)
    /// times the share of it the shadow rays find in view, `Σ V·g / Σ g` over its samples
    /// (`g = cosθ_p·cosθ_e / r² / pdf`; all samples' share for a triangle none landed on). A
    /// point in full view of a light gets it exactly however near it lies (1 mm under the
    /// light, area samples alone find a sixteenth of it), one in full shadow gets nothing, and
    /// only a penumbra is estimated. With more triangles: `Σ V·L_e·g` over the samples,
    /// `L_e = E/π`.
    fn irradiance_at(
        &self,
        rt: &BakedScene,
        mesh: &radiosity_core::Mesh<'_>,
        p: DVec3,
        n: DVec3,
        samples: usize,
        rng: &mut SplitMix64,
    ) -> Rgb {
        let Some(&total) = self.cdf.last() else {
            return Rgb::ZERO;
        };
        let occ = rt.occluders().expect("a mesh has a BVH");
        let analytic = self.analytic && samples >= HIT_EMITTER_SAMPLES;
        // In view and in all, per triangle (analytic) or over all of them (index 0).
        let shares = if analytic { self.triangles.len() } else { 1 };
        let mut seen = vec![[0f64; 3]; shares];
        let mut all = vec![0f64; shares];
        let shift = rng.next_f64();
        for s in 0..samples {
            let u = (s as f64 + rng.next_f64()) / samples as f64 * total;
            let k = self
                .cdf
                .partition_point(|&c| c <= u)
                .min(self.cdf.len() - 1);
            let t = self.triangles[k] as usize;
            let tri = &mesh.triangles[t];
            let [a, b, c] = mesh.corners(t).map(|v| Vec3::from(v).as_dvec3());
            // Stratified over the triangle too: the pick's own coordinate across it and the
            // radical inverse of the sample's index (rotated) along it, so that a point in a
            // penumbra sees the light's visible part sampled evenly (a tenth of the noise of
            // random points on the light at 1024 samples).
            let below = if k == 0 { 0.0 } else { self.cdf[k - 1] };
            let across = ((u - below) / (self.cdf[k] - below)).clamp(0.0, 1.0);
            let along = (radical_inverse(s as u32) + shift).fract();
            let (r1, r2) = (across.sqrt(), along);
            let y = a * (1.0 - r1) + b * (r1 * (1.0 - r2)) + c * (r1 * r2);
            let normal = (b - a).cross(c - a).normalize_or_zero();
            let d = y - p;
            let dist2 = d.length_squared();
            if !(dist2 > 0.0) {
                continue;
            }
            let dir = d / dist2.sqrt();
            let (cos_p, cos_e) = (n.dot(dir), -normal.dot(dir));
            if cos_p <= 0.0 || cos_e <= 0.0 {
                continue;
            }
            // pdf over area: mean(E_t) / total; L_e = E_t / π.
            let g = cos_p * cos_e / dist2 * total
                / f64::from(tri.emission.mean())
                / std::f64::consts::PI;
            let i = if analytic { k } else { 0 };
            all[i] += g;
            if occ.segment_visible(p, y) {
                for (ch, acc) in seen[i].iter_mut().enumerate() {
                    *acc += f64::from(tri.emission.channel(ch)) * g;
                }
            }
        }
        if !analytic {
            let m = samples as f64;
            return Rgb::new(
                (seen[0][0] / m) as f32,
                (seen[0][1] / m) as f32,
                (seen[0][2] / m) as f32,
            );
        }
        // Over every triangle, for one no sample landed on: Σ V·E·g / Σ E·g, channels summed.
        let (mut seen_all, mut all_all) = (0.0, 0.0);
        for (k, &t) in self.triangles.iter().enumerate() {
            seen_all += seen[k].iter().sum::<f64>();
            all_all += 3.0 * f64::from(mesh.triangles[t as usize].emission.mean()) * all[k];
        }
        let mut sum = [0f64; 3];
        for (k, &t) in self.triangles.iter().enumerate() {
            let [a, b, c] = mesh.corners(t as usize).map(|v| Vec3::from(v).as_dvec3());
            let normal = (b - a).cross(c - a).normalize_or_zero();
            let f = point_to_polygon(p, n, &Polygon::triangle(a, b, c), normal);
            if f <= 0.0 {
                continue;
            }
            let e = mesh.triangles[t as usize].emission;
            for (ch, acc) in sum.iter_mut().enumerate() {
                // The share in view, by the triangle's own samples' channel: Σ V·E·g / Σ E·g.
                let emitted = f64::from(e.channel(ch));
                let share = if all[k] > 0.0 && emitted > 0.0 {
                    seen[k][ch] / (emitted * all[k])
                } else if all_all > 0.0 {
                    seen_all / all_all
                } else {
                    1.0
                };
                *acc += emitted * f * share.clamp(0.0, 1.0);
            }
        }
        Rgb::new(sum[0] as f32, sum[1] as f32, sum[2] as f32)
    }

    /// Each patch's direct irradiance from the emitting surfaces, the area-weighted mean over
    /// its direct-light points: the first-bounce share of its gathered irradiance, which the
    /// final gather replaces by the figure at the point its ray meets.
    fn per_patch(&self, rt: &BakedScene, mesh: &radiosity_core::Mesh<'_>, n: usize) -> Vec<Rgb> {
        if self.triangles.is_empty() {
            return vec![Rgb::ZERO; n];
        }
        (0..n)
            .into_par_iter()
            .map(|p| {
                let samples = mesh.samples_of(p);
                let each = PATCH_EMITTER_SAMPLES.div_ceil(samples.len().max(1)).max(16);
                let mut rng = SplitMix64(0xd1ec7 ^ p as u64);
                let (mut acc, mut area) = (Rgb::ZERO, 0f32);
                for s in samples {
                    let (at, normal) = (
                        Vec3::from(s.position).as_dvec3(),
                        Vec3::from(s.normal).as_dvec3(),
                    );
                    acc += self.irradiance_at(rt, mesh, at, normal, each, &mut rng) * s.area;
                    area += s.area;
                }
                if area > 0.0 { acc * (1.0 / area) } else { acc }
            })
            .collect()
    }
}

/// What a gather ray's hit shows of the frame: the mesh, its analytic lights and emitting
/// surfaces, and what the patches gathered beyond the emitters' direct light (`y − y_e`, file
/// numbering): that part is smooth across a patch, the direct light is not (it peaks under a
/// small light), so each hit takes the second from the patches around it and the first from
/// shadow rays of its own.
struct Surfaces<'a> {
    rt: &'a BakedScene,
    mesh: &'a radiosity_core::Mesh<'static>,
    occ: &'a Occluders,
    lights: &'a [Light],
    grid: PatchGrid,
    emitters: Emitters,
    indirect: Vec<Rgb>,
}

impl<'a> Surfaces<'a> {
    fn new(rt: &'a BakedScene, lights: &'a [Light], gathered: &[Rgb]) -> crate::Result<Self> {
        let mesh = rt.mesh("--points")?;
        let grid = PatchGrid::new(&rt.file.patches);
        let emitters = Emitters::new(mesh);
        let first = emitters.per_patch(rt, mesh, gathered.len());
        // The sky's light at a hit is its patch's, interpolated with the gathered light.
        let sky = rt.sky_irradiance(lights)?;
        let indirect = gathered
            .iter()
            .zip(&first)
            .enumerate()
            .map(|(p, (&y, &d))| y - d + sky.as_ref().map_or(Rgb::ZERO, |s| s[p]))
            .collect();
        Ok(Self {
            rt,
            mesh,
            occ: rt.occluders().expect("a mesh has a BVH"),
            lights,
            grid,
            emitters,
            indirect,
        })
    }

    /// The reflected radiosity `ρ∘(H_d + H_e + y − y_e)` at a front-face `hit`: `H_d` by shadow
    /// rays to the analytic lights, `H_e` by `emitter_samples` shadow rays to the emitting
    /// surfaces, and `y − y_e` interpolated from the patches around the hit, or, for a hit of
    /// a ray from the point that gathers (`from_point`) closer than [`NEAR_SIDES`] sides of
    /// those patches, gathered again by [`SECOND_RAYS`] rays. `weights` is scratch.
    fn reflected(
        &self,
        hit: &Hit,
        emitter_samples: usize,
        from_point: bool,
        rng: &mut SplitMix64,
        weights: &mut Vec<(u32, f32)>,
    ) -> Rgb {
        let t = hit.triangle as usize;
        let normal = triangle_normal(self.mesh, t);
        // On the triangle's plane to f64 rounding, so that a ray from it passes its own plane.
        let [a, b, c] = self.mesh.corners(t).map(|v| Vec3::from(v).as_dvec3());
        let (u, v) = (f64::from(hit.u), f64::from(hit.v));
        let at = a * (1.0 - u - v) + b * u + c * v;
        let patches = &self.rt.file.patches;
        weights.clear();
        let sight = Some(self.occ);
        (self.grid).weights_at_hit(
            patches,
            self.mesh,
            t,
            (hit.u, hit.v),
            at,
            normal,
            sight,
            weights,
        );
        // The side of the patches the kernel takes: their weighted mean area, rooted.
        let area: f64 = weights
            .iter()
            .map(|&(i, w)| f64::from(w) * f64::from(patches[i as usize].area))
            .sum();
        let indirect = if from_point && hit.distance < NEAR_SIDES * area.sqrt() {
            self.gathered_again(at, normal, rng, weights)
        } else {
            weights
                .iter()
                .fold(Rgb::ZERO, |y, &(i, w)| y + self.indirect[i as usize] * w)
        };
        let emitted =
            (self.emitters).irradiance_at(self.rt, self.mesh, at, normal, emitter_samples, rng);
        // Emitted light is the emitters' own shadow rays' at the point that gathers.
        self.mesh.triangles[t].reflectance
            * (self.rt.direct_at(self.lights, at, normal) + emitted + indirect)
    }

    /// The irradiance estimate `π·L(ω)` of a cosine-weighted ray that leaves the scene in
    /// direction `dir`: the sky's, zero without one.
    fn sky(&self, dir: DVec3) -> Rgb {
        radiosity_core::sky_radiance_of(self.lights, dir.as_vec3()) * std::f32::consts::PI
    }

    /// `y − y_e` at `at` (on a surface with unit `normal`) by [`SECOND_RAYS`] cosine-weighted
    /// rays, stratified, each hit's reflected radiosity with one shadow ray to the emitters
    /// and the rest interpolated: the light the surfaces reflect onto `at`.
    fn gathered_again(
        &self,
        at: DVec3,
        normal: DVec3,
        rng: &mut SplitMix64,
        weights: &mut Vec<(u32, f32)>,
    ) -> Rgb {
        let side = SECOND_RAYS.isqrt();
        let mut sum = Rgb::ZERO;
        for s in 0..side * side {
            let u1 = ((s % side) as f64 + rng.next_f64()) / side as f64;
            let u2 = ((s / side) as f64 + rng.next_f64()) / side as f64;
            let dir = cosine_direction(normal, u1, u2);
            match self.occ.first_surface_from_surface(at, dir, f64::INFINITY) {
                Some((hit, true)) => sum += self.reflected(&hit, 1, false, rng, weights),
                Some((_, false)) => {}
                None => sum += self.sky(dir),
            }
        }
        sum * (1.0 / (side * side) as f32)
    }
}

/// `p` moved off a surface it lies on (within a few `slack`, the f32 rounding the mesh's own
/// coordinates carry) to `slack` from its plane, on the side unit `n` faces (the surface's
/// front for `n` along it); `p` unchanged where no surface is that near. A meter laid on the
/// block's top at y = 0.6 lies 2.4e-8 inside the block as the mesh stores it: facing up or
/// sideways it sees the room, facing down the block.
fn off_the_surface(surfaces: &Surfaces<'_>, p: DVec3, n: DVec3, slack: f64) -> DVec3 {
    let reach = 4.0 * slack;
    // Short segments through `p` along the axes and the normal: the nearest plane they cross.
    let nearest = [DVec3::X, DVec3::Y, DVec3::Z, n]
        .into_iter()
        .filter_map(|d| {
            let hit = surfaces
                .occ
                .closest_hit(p - d * reach, d, 0.0, 2.0 * reach)?;
            Some((hit.triangle, (hit.distance - reach).abs()))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let Some((t, _)) = nearest else {
        return p;
    };
    let front = triangle_normal(surfaces.mesh, t as usize);
    let corner = Vec3::from(surfaces.mesh.corners(t as usize)[0]).as_dvec3();
    let side = if n.dot(front) < 0.0 { -1.0 } else { 1.0 };
    p + front * (side * slack - front.dot(p - corner))
}

/// The answer at every point for a frame whose light beyond the direct is `gathered` (the
/// gather's `y`, plus the first bounce's correction where the file has BOUNCE rows:
/// [`crate::BakedScene::first_bounce`]) and total irradiance `irradiance` (file numbering)
/// under `lights`. The file needs its mesh.
pub fn answer(
    rt: &BakedScene,
    gathered: &[Rgb],
    irradiance: &[Rgb],
    lights: &[Light],
    points: &[Point],
) -> crate::Result<Vec<Answer>> {
    let probe_sh = crate::probes::frame_sh(rt, irradiance, lights)?;
    let surfaces = Surfaces::new(rt, lights, gathered)?;
    let has_sky = lights.iter().any(Light::is_sky);
    // A mesh without vertices holds every point outside it.
    let (lo, hi) = rt
        .mesh_bounds()
        .unwrap_or((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)));
    // A point on the box's faces (a floor at y = 0, a wall at z = −1.04 given in f64 where
    // the mesh holds its f32 rounding) is inside it: a few f32 steps of the coordinates.
    let slack = 1e-6
        * (hi - lo)
            .max_element()
            .max(lo.abs().max(hi.abs()).max_element());
    let slack = slack.max(1e-300);
    let side = RAYS.isqrt();
    Ok(points
        .par_iter()
        .enumerate()
        .map(|(k, q)| {
            let n = q.normal;
            let beyond = q.position.cmplt(lo - slack).any() || q.position.cmpgt(hi + slack).any();
            let p = off_the_surface(&surfaces, q.position, n, slack);
            let mut rng = SplitMix64(0x5eed ^ k as u64);
            let (mut sum, mut backs, mut missed) = (Rgb::ZERO, 0usize, 0usize);
            let mut weights = Vec::new();
            for s in 0..side * side {
                let u1 = ((s % side) as f64 + rng.next_f64()) / side as f64;
                let u2 = ((s / side) as f64 + rng.next_f64()) / side as f64;
                let dir = cosine_direction(n, u1, u2);
                match surfaces.occ.first_surface(p, dir, 0.0, f64::INFINITY) {
                    None => {
                        missed += 1;
                        sum += surfaces.sky(dir);
                    }
                    Some((_, false)) => backs += 1, // the back of a one-sided surface: nothing
                    Some((hit, true)) => {
                        let samples = HIT_EMITTER_SAMPLES;
                        sum += surfaces.reflected(&hit, samples, true, &mut rng, &mut weights);
                    }
                }
            }
            if backs as f64 > INSIDE_SHARE * (side * side) as f64 {
                return Answer::Inside;
            }
            // Under a sky a point out in the open still has its light.
            if beyond && missed == side * side && !has_sky {
                return Answer::Outside;
            }
            let direct = rt.direct_at(lights, p, n)
                + (surfaces.emitters).irradiance_at(
                    rt,
                    surfaces.mesh,
                    p,
                    n,
                    EMITTER_SAMPLES,
                    &mut rng,
                );
            let total = sum * (1.0 / (side * side) as f32) + direct;
            let probes = rt
                .file
                .probes
                .as_ref()
                .map(|_| crate::probes::reflected_at(rt, &probe_sh, p, n).map(|r| r + direct));
            Answer::Irradiance { total, probes }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_refuses_with_the_reason() {
        let p = parse(r#"{"points":[{"position":[1,2,3],"normal":[0,2,0]}]}"#).unwrap();
        assert_eq!(p[0].position, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(p[0].normal, DVec3::Y);
        for (text, needle) in [
            ("[", "not a points file"),
            (
                r#"{"points":[{"position":[0,0,0],"normal":[0,0,0]}]}"#,
                "zero length",
            ),
            (
                r#"{"points":[{"position":[0,0],"normal":[0,1,0]}]}"#,
                "not a points file",
            ),
            (
                r#"{"points":[{"position":[0,0,0],"normal":[0,1,0],"x":1}]}"#,
                "not a points file",
            ),
        ] {
            let err = format!("{:#}", parse(text).unwrap_err());
            assert!(err.contains(needle), "{text}: {err}");
        }
    }
}
