//! `radiosity-pathtrace`: the reference Monte-Carlo path tracer: an estimate of the true (continuous, full-detail)
//! solution that a bake only approximates, with error bars.
//!
//! Physics (`docs/contract.md`, "Conventions"): the full-detail triangles, no patches; diffuse only;
//! triangles one-sided for emitting and receiving (front = counter-clockwise), blocking from
//! both sides; a material's stored emission is the exitance `E = π·Ke`, so an emitter's radiance
//! is `E/π`; irradiance `H = ∫ L cosθ dω` over the front hemisphere; radiosity `B = E + ρ∘H`;
//! a surface's radiance is `B/π`. Reflectance is one value per triangle, `Kd` times the mean of
//! `map_Kd` over the triangle (`Scene::reflectance_over`), as the bake sees it at full detail.
//!
//! The estimator of `H` at a point `x` with normal `n` follows one path:
//!
//! - **Analytic lights** (point, spot, directional) by next-event estimation: the unoccluded
//!   irradiance from [`Light::irradiance_at`] times a shadow ray.
//! - **Emissive triangles** by two strategies combined with multiple importance sampling
//!   (balance heuristic, Veach 1997): (a) next-event estimation, one point sampled on the
//!   emitters with probability proportional to power (area × the sum of `E`'s channels) and
//!   uniform by area on the chosen triangle, front side only; (b) the cosine-weighted bounce ray,
//!   when it hits an emitter's front. Each strategy's sample is weighted by its pdf over the sum
//!   of both pdfs (in solid angle), so emission is counted exactly once in expectation. Plain
//!   next-event estimation would also be unbiased, but its variance has the `1/r²` spike of area
//!   sampling where a receiver meets an emitter at an edge (a furnace box, an emitter wall);
//!   there the bounce ray's pdf dominates and the weight removes the spike.
//! - **Indirect light**: the cosine-weighted bounce ray (pdf `cosθ/π`) meets the surface `y`;
//!   its radiance `ρ(y)·H(y)/π` (emission handled above) turns the estimator of `H(x)` into
//!   `ρ(y)·Ĥ(y)`, so the path carries a throughput `β = Πρ`. A back face ends it.
//! - **Sky and environment lights**: a bounce ray that leaves the scene meets the sky, whose
//!   radiance `L(ω)` (the environment image itself, not its SH) gives `β·π·L(ω)`; a path
//!   without a sky ends there with nothing. A camera ray that leaves sees the sky.
//! - **Russian roulette** after every bounce, surviving with probability `max_c β_c` and then
//!   dividing `β` by it: unbiased, and every path's contribution stays bounded (the largest
//!   channel of `β` is 1), so the standard errors are honest even in a furnace. Paths are also
//!   cut at [`PathTracer::MAX_BOUNCES`], a relative bias below `ρ_max^MAX_BOUNCES` (2e-9 for ρ = 0.999).
//!
//! Randomness: [`SplitMix64`] seeded per sample from `(seed, stream, index)`, and sums taken
//! over fixed chunks in a fixed order, so results are identical for a seed whatever the thread
//! count.

#![deny(missing_docs)]

#[cfg(test)]
mod tests;

use glam::{DVec3, Vec3};
use radiosity_core::Light;
use radiosity_geometry::Occluders;
use radiosity_geometry::rng::SplitMix64;
use radiosity_runtime::camera::Camera;
use radiosity_runtime::image::LinearImage;
use radiosity_scene::Scene;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Samples per parallel work item: the unit of the fixed summation order.
const CHUNK: usize = 256;

/// Random-number streams, so objects and the image never share samples.
const RENDER_STREAM: u64 = u64::MAX;
/// Streams of the point queries: `POINT_STREAM ^ point`, apart from objects' and the image's.
const POINT_STREAM: u64 = 1 << 62;

/// One triangle as the tracer needs it.
#[derive(Clone, Copy, Debug)]
struct Tri {
    p0: DVec3,
    e1: DVec3,
    e2: DVec3,
    /// Unit front normal.
    normal: DVec3,
    area: f64,
    /// Reflectance ρ per channel.
    rho: [f64; 3],
    /// Emitted exitance E per channel (W/m²), from the front.
    emission: [f64; 3],
    /// Probability that next-event estimation picks this triangle (0 for non-emitters).
    pick: f64,
}

impl Tri {
    /// The point with barycentric weights `u` (corner 1) and `v` (corner 2).
    fn at(&self, u: f64, v: f64) -> DVec3 {
        self.p0 + self.e1 * u + self.e2 * v
    }

    /// A point uniformly distributed over the triangle.
    fn sample(&self, rng: &mut SplitMix64) -> DVec3 {
        let s = rng.next_f64().sqrt();
        let t = rng.next_f64();
        self.at(s * (1.0 - t), s * t)
    }
}

/// A shadow-ray target of an analytic light.
#[derive(Clone, Copy, Debug)]
enum Target {
    /// Point and spot lights: the light's position.
    At(DVec3),
    /// Directional lights: nothing may lie anywhere along the ray.
    Infinity,
}

/// The reference path tracer over one scene and its analytic lights.
pub struct PathTracer {
    occ: Occluders,
    tris: Vec<Tri>,
    objects: Vec<String>,
    /// Per object: its triangles and their cumulative areas (for sampling by area).
    object_tris: Vec<(Vec<u32>, Vec<f64>)>,
    /// Emissive triangles and the cumulative pick probabilities (last = 1).
    emitters: Vec<u32>,
    emitter_cdf: Vec<f64>,
    lights: Vec<(Light, Target)>,
    /// Ray origins sit this far in front of their surface (scene units).
    offset: f64,
}

/// An object's estimate: area-weighted means over its whole front surface, the part buried
/// under other objects included (it receives nothing: `H = 0`, `B = E`), as an irradiance
/// meter over the object measures.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectEstimate {
    /// The object's name.
    pub name: String,
    /// Area of its triangles (exact).
    pub area: f64,
    /// Area of its triangles not buried under other objects (estimated by the samples: `area`
    /// times the share of them that are not buried).
    pub exposed_area: f64,
    /// Mean irradiance H (W/m², RGB).
    pub irradiance: [f64; 3],
    /// Standard error of `irradiance` (the sample standard deviation over √samples).
    pub stderr: [f64; 3],
    /// Mean radiosity B = E + ρ∘H (W/m², RGB).
    pub radiosity: [f64; 3],
    /// Standard error of `radiosity`.
    pub radiosity_stderr: [f64; 3],
}

impl ObjectEstimate {
    /// An object without triangles.
    fn empty(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            area: 0.0,
            exposed_area: 0.0,
            irradiance: [0.0; 3],
            stderr: [0.0; 3],
            radiosity: [0.0; 3],
            radiosity_stderr: [0.0; 3],
        }
    }
}

/// The SplitMix64 output function: a bijection of 64-bit words that spreads every input bit.
fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The generator of sample `index` of `stream` for `seed`: independent of which thread runs it.
fn sample_rng(seed: u64, stream: u64, index: u64) -> SplitMix64 {
    SplitMix64(mix64(seed ^ mix64(stream ^ mix64(index))))
}

/// Index of the first entry of the increasing `cdf` above `u · last` (clamped into range).
fn pick(cdf: &[f64], u: f64) -> usize {
    let x = u * cdf[cdf.len() - 1];
    cdf.partition_point(|&c| c <= x).min(cdf.len() - 1)
}

/// A cosine-weighted direction about the unit normal `n` (pdf `cosθ/π`).
fn cosine_direction(n: DVec3, rng: &mut SplitMix64) -> DVec3 {
    let (u1, u2) = (rng.next_f64(), rng.next_f64());
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let z = (1.0 - u1).max(0.0).sqrt();
    // An orthonormal basis about n (Duff et al. 2017, branchless).
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let s = DVec3::new(b, sign + n.y * n.y * a, -n.y);
    (t * (r * phi.cos()) + s * (r * phi.sin()) + n * z).normalize()
}

fn add_scaled(acc: &mut [f64; 3], w: [f64; 3], v: [f64; 3]) {
    for c in 0..3 {
        acc[c] += w[c] * v[c];
    }
}

impl PathTracer {
    /// Paths end after this many bounces at the latest (see the module docs for the bias).
    pub const MAX_BOUNCES: u32 = 20_000;

    /// Prepares the scene: BVH, per-triangle reflectance and emission, sampling tables.
    /// Errors for an invalid light or a scene without triangles.
    pub fn new(scene: &Scene, lights: &[Light]) -> Result<Self, String> {
        if scene.triangles.is_empty() {
            return Err("the scene has no triangles".into());
        }
        let whole = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mut tris: Vec<Tri> = (0..scene.triangles.len())
            .map(|t| {
                let [a, b, c] = scene.corners(t);
                let material = &scene.materials[scene.triangles[t].material as usize];
                Tri {
                    p0: a,
                    e1: b - a,
                    e2: c - a,
                    normal: scene.triangle_normal(t),
                    area: scene.triangle_area(t),
                    rho: scene.reflectance_over(t, whole),
                    emission: material.emission.to_array().map(f64::from),
                    pick: 0.0,
                }
            })
            .collect();
        for (t, tri) in tris.iter().enumerate() {
            let ok = tri.area.is_finite()
                && tri.area > 0.0
                && tri.normal.is_finite()
                && tri.rho.iter().all(|r| (0.0..1.0).contains(r))
                && tri.emission.iter().all(|e| e.is_finite() && *e >= 0.0);
            if !ok {
                return Err(format!(
                    "triangle {t} (object {}) has no area, no normal, or a reflectance outside [0, 1) or a bad emission",
                    scene.objects[scene.triangles[t].object as usize]
                ));
            }
        }

        // Emitters, picked by power.
        let power = |t: &Tri| t.area * t.emission.iter().sum::<f64>();
        let total: f64 = tris.iter().map(power).sum();
        let mut emitters = Vec::new();
        let mut emitter_cdf = Vec::new();
        if total > 0.0 {
            if !total.is_finite() {
                return Err("the scene's total emitted power is not finite".into());
            }
            let mut acc = 0.0;
            for (t, tri) in tris.iter_mut().enumerate() {
                let p = power(tri);
                if p > 0.0 {
                    tri.pick = p / total;
                    acc += tri.pick;
                    emitters.push(t as u32);
                    emitter_cdf.push(acc);
                }
            }
        }

        let mut object_tris = vec![(Vec::new(), Vec::new()); scene.objects.len()];
        for (t, tri) in scene.triangles.iter().enumerate() {
            let (list, cdf): &mut (Vec<u32>, Vec<f64>) = &mut object_tris[tri.object as usize];
            let acc = cdf.last().copied().unwrap_or(0.0) + tris[t].area;
            list.push(t as u32);
            cdf.push(acc);
        }

        let mut checked = Vec::with_capacity(lights.len());
        for (i, light) in lights.iter().enumerate() {
            light
                .validate()
                .map_err(|why| format!("light {i}: {why}"))?;
            let target = match *light {
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    Target::At(position.as_dvec3())
                }
                // A sky has no shadow ray: a path that leaves the scene meets it.
                Light::Directional { .. } | Light::Sky { .. } | Light::Environment(_) => {
                    Target::Infinity
                }
            };
            checked.push((light.clone(), target));
        }

        let occ = scene.occluders();
        // f32 traversal keeps about 1e-7 of the extent; a hundredfold margin keeps a ray from
        // meeting its own surface at any angle, and shifts nothing a form factor can see.
        let offset = 1e-6 * occ.extent();
        Ok(Self {
            occ,
            tris,
            objects: scene.objects.clone(),
            object_tris,
            emitters,
            emitter_cdf,
            lights: checked,
            offset,
        })
    }

    /// The BVH over the scene (for framing a camera).
    pub fn occluders(&self) -> &Occluders {
        &self.occ
    }

    /// Corners of every triangle (for framing a camera).
    pub fn triangle_corners(&self) -> Vec<[DVec3; 3]> {
        self.tris
            .iter()
            .map(|t| [t.p0, t.p0 + t.e1, t.p0 + t.e2])
            .collect()
    }

    /// Area-weighted mean irradiance and radiosity (W/m², RGB) over each object's whole front
    /// surface, with standard errors: `samples_per_object` points uniform by area over the
    /// object, one path each from those not buried under another object
    /// ([`Occluders::buried`]); a buried point receives nothing and counts with `H = 0`,
    /// `B = E`. The buried share also gives the exposed area. Panics if
    /// `samples_per_object < 2` (a standard error needs two samples).
    pub fn object_irradiance(&self, samples_per_object: usize, seed: u64) -> Vec<ObjectEstimate> {
        assert!(
            samples_per_object >= 2,
            "object_irradiance needs at least two samples per object"
        );
        let n = samples_per_object;
        self.objects
            .iter()
            .zip(&self.object_tris)
            .enumerate()
            .map(|(o, (name, (list, cdf)))| {
                let area = cdf.last().copied().unwrap_or(0.0);
                if list.is_empty() {
                    return ObjectEstimate::empty(name);
                }
                // Per chunk: sums and sums of squares of H and B, in sample order, and the
                // number of points not buried under another object (no light reaches a buried
                // point: it counts with H = 0 and B = E, the exitance it has of its own).
                let chunks: Vec<([[f64; 3]; 4], usize)> = (0..n.div_ceil(CHUNK))
                    .into_par_iter()
                    .map(|k| {
                        let mut s = [[0.0; 3]; 4];
                        let mut exposed = 0;
                        for i in k * CHUNK..((k + 1) * CHUNK).min(n) {
                            let mut rng = sample_rng(seed, o as u64, i as u64);
                            let t = &self.tris[list[pick(cdf, rng.next_f64())] as usize];
                            let x = t.sample(&mut rng);
                            let h = if self.occ.buried(x, t.normal) {
                                [0.0; 3]
                            } else {
                                exposed += 1;
                                self.irradiance_at(x, t.normal, &mut rng)
                            };
                            for c in 0..3 {
                                let b = t.emission[c] + t.rho[c] * h[c];
                                s[0][c] += h[c];
                                s[1][c] += h[c] * h[c];
                                s[2][c] += b;
                                s[3][c] += b * b;
                            }
                        }
                        (s, exposed)
                    })
                    .collect();
                let mut s = [[0.0; 3]; 4];
                let mut exposed = 0;
                for (chunk, e) in &chunks {
                    exposed += e;
                    for (acc, v) in s.iter_mut().zip(chunk) {
                        for c in 0..3 {
                            acc[c] += v[c];
                        }
                    }
                }
                let nf = n as f64;
                let mean = |sum: [f64; 3]| sum.map(|v| v / nf);
                let stderr = |sum: [f64; 3], sq: [f64; 3]| {
                    let mut e = [0.0; 3];
                    for c in 0..3 {
                        let m = sum[c] / nf;
                        let var = ((sq[c] - nf * m * m) / (nf - 1.0)).max(0.0);
                        e[c] = (var / nf).sqrt();
                    }
                    e
                };
                ObjectEstimate {
                    name: name.clone(),
                    area,
                    exposed_area: area * exposed as f64 / nf,
                    irradiance: mean(s[0]),
                    stderr: stderr(s[0], s[1]),
                    radiosity: mean(s[2]),
                    radiosity_stderr: stderr(s[2], s[3]),
                }
            })
            .collect()
    }

    /// Linear radiance image (W·sr⁻¹·m⁻²) seen by `camera` (validated), `spp` jittered paths per
    /// pixel. Back faces and the background are black (one-sided surfaces).
    pub fn render(&self, camera: &Camera, spp: u32, seed: u64) -> LinearImage {
        let basis = camera.basis();
        let (w, h) = (camera.width as usize, camera.height as usize);
        let mut img = LinearImage::new(camera.width, camera.height);
        let spp = spp.max(1);
        img.pixels
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, px) in row.iter_mut().enumerate() {
                    let mut acc = [0.0; 3];
                    for s in 0..spp {
                        let index = ((y * w + x) as u64) * u64::from(spp) + u64::from(s);
                        let mut rng = sample_rng(seed, RENDER_STREAM, index);
                        let (jx, jy) = (rng.next_f64(), rng.next_f64());
                        let dir = camera.ray(&basis, x as f64 + jx, y as f64 + jy);
                        let l = self.radiance(camera.position, dir, &mut rng);
                        for c in 0..3 {
                            acc[c] += l[c];
                        }
                    }
                    let k = 1.0 / f64::from(spp);
                    *px = Vec3::new(
                        (acc[0] * k) as f32,
                        (acc[1] * k) as f32,
                        (acc[2] * k) as f32,
                    );
                }
            });
        debug_assert_eq!(img.pixels.len(), w * h);
        img
    }

    /// Radiance arriving at `origin` from direction `dir` (one path).
    fn radiance(&self, origin: DVec3, dir: DVec3, rng: &mut SplitMix64) -> [f64; 3] {
        let Some((hit, front)) = self.occ.first_surface(origin, dir, 0.0, f64::INFINITY) else {
            return self.sky(dir);
        };
        if !front {
            return [0.0; 3]; // a back face: neither emits nor reflects
        }
        let t = &self.tris[hit.triangle as usize];
        let y = t.at(f64::from(hit.u), f64::from(hit.v));
        let h = self.irradiance_at(y, t.normal, rng);
        let mut l = [0.0; 3];
        for c in 0..3 {
            l[c] = (t.emission[c] + t.rho[c] * h[c]) / PI;
        }
        l
    }

    /// Irradiance at each `(point, unit normal)` with `samples` paths a point: the mean and its
    /// standard error per channel. A point inside a closed object sees its back faces, which
    /// are black: it reads (near) zero.
    pub fn point_irradiance(
        &self,
        points: &[(DVec3, DVec3)],
        samples: usize,
        seed: u64,
    ) -> Vec<([f64; 3], [f64; 3])> {
        points
            .par_iter()
            .enumerate()
            .map(|(k, &(x, n))| {
                let (mut sum, mut sq) = ([0.0; 3], [0.0; 3]);
                for i in 0..samples {
                    let mut rng = sample_rng(seed, POINT_STREAM ^ k as u64, i as u64);
                    let h = self.irradiance_at(x, n, &mut rng);
                    for c in 0..3 {
                        sum[c] += h[c];
                        sq[c] += h[c] * h[c];
                    }
                }
                let m = samples as f64;
                let mean = sum.map(|v| v / m);
                let stderr = [0, 1, 2]
                    .map(|c| ((sq[c] / m - mean[c] * mean[c]).max(0.0) / (m - 1.0)).sqrt());
                (mean, stderr)
            })
            .collect()
    }

    /// One-path estimate of the irradiance at `x` on the front of a surface with unit normal `n`.
    pub fn irradiance_at(&self, x: DVec3, n: DVec3, rng: &mut SplitMix64) -> [f64; 3] {
        let mut h = [0.0; 3];
        let mut beta = [1.0; 3];
        let (mut x, mut n) = (x, n);
        for _ in 0..Self::MAX_BOUNCES {
            let origin = x + n * self.offset;
            add_scaled(&mut h, beta, self.direct(x, origin, n, rng));

            let dir = cosine_direction(n, rng);
            // A panel's two sheets modelled a hair out of order show the near one's front.
            let Some((hit, front)) = self.occ.first_surface(origin, dir, 0.0, f64::INFINITY) else {
                // Out of the scene: the sky's radiance, whose estimate of H is π·L (the
                // direction was drawn with pdf cosθ/π).
                add_scaled(&mut h, beta, self.sky(dir).map(|l| PI * l));
                break;
            };
            let t = &self.tris[hit.triangle as usize];
            let cos_y = -t.normal.dot(dir);
            if !front || cos_y <= 0.0 {
                break; // a back face: black
            }
            if t.pick > 0.0 {
                // Emission met by the bounce ray: its estimate of H is π·L_e = E, weighted
                // against the chance that next-event estimation would have sampled this point.
                let pdf_bounce = n.dot(dir).max(0.0) / PI;
                let pdf_light = t.pick / t.area * hit.distance * hit.distance / cos_y;
                let w = pdf_bounce / (pdf_bounce + pdf_light);
                if w.is_finite() {
                    add_scaled(&mut h, beta, t.emission.map(|e| e * w));
                }
            }
            for c in 0..3 {
                beta[c] *= t.rho[c];
            }
            let q = beta[0].max(beta[1]).max(beta[2]);
            if !(q > 0.0) || rng.next_f64() >= q {
                break;
            }
            beta = beta.map(|b| b / q);
            x = t.at(f64::from(hit.u), f64::from(hit.v));
            n = t.normal;
        }
        h
    }

    /// Radiance from every sky and environment light in direction `dir` (towards the sky).
    fn sky(&self, dir: DVec3) -> [f64; 3] {
        let mut l = [0.0; 3];
        for (light, _) in &self.lights {
            if let Some(r) = light.sky_radiance(dir.as_vec3()) {
                for (c, v) in l.iter_mut().enumerate() {
                    *v += f64::from(r.channel(c));
                }
            }
        }
        l
    }

    /// Direct irradiance at `x` (normal `n`, rays from `origin`): analytic lights with shadow
    /// rays, plus one MIS-weighted emitter sample.
    fn direct(&self, x: DVec3, origin: DVec3, n: DVec3, rng: &mut SplitMix64) -> [f64; 3] {
        let mut h = [0.0; 3];
        for (light, target) in &self.lights {
            let Some((e, ray)) = light.irradiance_at(x.as_vec3(), n.as_vec3()) else {
                continue;
            };
            let visible = match *target {
                Target::At(p) => self.occ.segment_visible(origin, p),
                Target::Infinity => self
                    .occ
                    .closest_hit(origin, ray.direction.as_dvec3(), 0.0, f64::INFINITY)
                    .is_none(),
            };
            if visible {
                for c in 0..3 {
                    h[c] += f64::from(e.channel(c));
                }
            }
        }
        if self.emitters.is_empty() {
            return h;
        }
        let t = &self.tris[self.emitters[pick(&self.emitter_cdf, rng.next_f64())] as usize];
        let y = t.sample(rng);
        let d = y - x;
        let r2 = d.length_squared();
        if !(r2 > 0.0) {
            return h;
        }
        let dir = d / r2.sqrt();
        let (cos_x, cos_y) = (n.dot(dir), -t.normal.dot(dir));
        if cos_x <= 0.0 || cos_y <= 0.0 || !self.occ.segment_visible(origin, y) {
            return h;
        }
        let pdf_light = t.pick / t.area * r2 / cos_y;
        let pdf_bounce = cos_x / PI;
        let w = pdf_light / (pdf_light + pdf_bounce);
        // L_e cosθ / pdf_light · w, with L_e = E/π.
        let k = cos_x / (PI * pdf_light) * w;
        if k.is_finite() {
            for c in 0..3 {
                h[c] += t.emission[c] * k;
            }
        }
        h
    }
}
