//! The per-pixel shading lookup and a CPU ray-cast pinhole camera over the file's full-detail
//! mesh (what `radiosity render` draws). Per pixel: direct light from the analytic
//! lights with a shadow ray at the exact hit point, plus the gathered (indirect and
//! emitter) irradiance interpolated from the patches around the hit point on the same
//! surface; radiance `(E + ρ∘H)/π`, tone mapped to sRGB.
//!
//! Interpolation is a kernel over nearby patch centres (same orientation, same plane, in sight
//! of the hit: a floor beyond a wall standing on it lies in the same plane), not over the
//! triangle's corners: a wall made of two big triangles has its corners in the room's
//! darkest places, and barycentric blending of corner values would paint the whole wall with
//! them. The mesh's corner weights remain the fallback where no patch is near.

use crate::camera::Camera;
use crate::image::LinearImage;
use crate::{BakedScene, Frame};
use glam::{DVec3, Vec3};
use radiosity_core::{Light, Rgb};
use radiosity_geometry::Occluders;
use rayon::prelude::*;

/// What a camera sample sees first: the mesh triangle, where on it, and whether its front
/// faces the camera.
#[derive(Clone, Copy, Debug)]
pub struct SampleHit {
    triangle: u32,
    u: f32,
    v: f32,
    point: DVec3,
    normal: DVec3,
}

/// Primary visibility of an image: `spp_side²` stratified samples per pixel, cached so that
/// a static camera pays for it once however many frames it shows.
pub struct Primary {
    camera: Camera,
    side: u32,
    width: u32,
    height: u32,
    per_pixel: usize,
    /// `width·height·per_pixel` entries; `None` for a miss or a back face.
    hits: Vec<Option<SampleHit>>,
    /// Interpolation weights over patches of each hit (row `k` for `hits[k]`, empty for none).
    rows: Vec<u32>,
    weights: Vec<(u32, f32)>,
}

/// Patch centres bucketed in a grid of cells of the kernel radius.
pub struct PatchGrid {
    cell: f64,
    radius: f64,
    /// Half the patch size: how far off a hit's plane a patch centre may lie.
    slab: f64,
    buckets: std::collections::HashMap<[i64; 3], Vec<u32>>,
}

/// Smallest cosine between a patch's normal and the surface's for the patch to count.
const SAME_SURFACE_COS: f64 = 0.8;

impl PatchGrid {
    /// Buckets patch centres at the median patch's kernel radius.
    pub fn new(patches: &[radiosity_core::Patch]) -> Self {
        let mut areas: Vec<f32> = patches.iter().map(|p| p.area).collect();
        areas.sort_by(f32::total_cmp);
        let h = f64::from(areas.get(areas.len() / 2).copied().unwrap_or(1.0))
            .sqrt()
            .max(1e-12);
        let radius = 1.5 * h;
        let mut buckets: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        for (i, p) in patches.iter().enumerate() {
            let c = Vec3::from(p.centre).as_dvec3();
            buckets
                .entry((c / radius).floor().as_i64vec3().to_array())
                .or_default()
                .push(i as u32);
        }
        Self {
            cell: radius,
            radius,
            slab: 0.5 * h,
            buckets,
        }
    }

    /// Kernel weights `area·(1 − d²/r²)²` of the patches near `point` on the surface with unit
    /// `normal`, normalised; appended to `out`. Returns whether any patch was near.
    ///
    /// With `sight`, a patch counts only where the segment from `point` to its centre (laid
    /// on the surface's tangent plane, both ends lifted a thousandth of a patch side off it)
    /// meets nothing: the floor beyond a wall standing on it lies in the same plane within
    /// the kernel, and without the test a sealed room's floor took the lit room's light
    /// through the wall (2–7 W/m² at points the path tracer reads 0).
    pub fn weights(
        &self,
        patches: &[radiosity_core::Patch],
        point: DVec3,
        normal: DVec3,
        sight: Option<&Occluders>,
        out: &mut Vec<(u32, f32)>,
    ) -> bool {
        let start = out.len();
        let lift = normal * (2e-3 * self.slab);
        let seen = |centre: DVec3| {
            sight.is_none_or(|occ| {
                let on_plane = centre - normal * (centre - point).dot(normal);
                occ.segment_visible(point + lift, on_plane + lift)
            })
        };
        let key = (point / self.cell).floor().as_i64vec3();
        let mut sum = 0.0;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let k = (key + glam::I64Vec3::new(dx, dy, dz)).to_array();
                    for &i in self.buckets.get(&k).map_or(&[][..], Vec::as_slice) {
                        let p = &patches[i as usize];
                        let d = Vec3::from(p.centre).as_dvec3() - point;
                        let n = Vec3::from(p.normal).as_dvec3();
                        if n.dot(normal) < SAME_SURFACE_COS || d.dot(normal).abs() > self.slab {
                            continue;
                        }
                        let q = 1.0 - d.length_squared() / (self.radius * self.radius);
                        if q > 0.0 && seen(point + d) {
                            let w = f64::from(p.area) * q * q;
                            out.push((i, w as f32));
                            sum += w;
                        }
                    }
                }
            }
        }
        if sum > 0.0 {
            for e in &mut out[start..] {
                e.1 = (f64::from(e.1) / sum) as f32;
            }
            true
        } else {
            out.truncate(start);
            false
        }
    }
}

impl PatchGrid {
    /// The patches' weights at `point` of mesh triangle `t` (barycentrics `u`, `v` of corners 1
    /// and 2) on its surface with unit `normal`, appended to `out`: the kernel over the patch
    /// centres near it ([`PatchGrid::weights`], seen from `point` where `sight` is given), or
    /// the triangle's corner weights where no patch is.
    #[allow(clippy::too_many_arguments)]
    pub fn weights_at_hit(
        &self,
        patches: &[radiosity_core::Patch],
        mesh: &radiosity_core::Mesh<'_>,
        t: usize,
        (u, v): (f32, f32),
        point: DVec3,
        normal: DVec3,
        sight: Option<&Occluders>,
        out: &mut Vec<(u32, f32)>,
    ) {
        if !self.weights(patches, point, normal, sight, out) {
            for (c, bc) in [1.0 - u - v, u, v].into_iter().enumerate() {
                for e in mesh.corner(t, c) {
                    out.push((e.patch, bc * e.weight));
                }
            }
        }
    }
}

/// The unit front normal of mesh triangle `t`.
pub fn triangle_normal(mesh: &radiosity_core::Mesh<'_>, t: usize) -> DVec3 {
    let [a, b, c] = mesh.corners(t).map(|p| Vec3::from(p).as_dvec3());
    (b - a).cross(c - a).normalize_or_zero()
}

/// The direction of sample `s` (of `side²`, stratified) of pixel `pixel` in an image `width`
/// wide.
fn sample_ray(
    cam: &Camera,
    basis: &crate::camera::Basis,
    width: u32,
    side: u32,
    pixel: usize,
    s: u32,
) -> DVec3 {
    let (px, py) = (
        (pixel % width as usize) as f64,
        (pixel / width as usize) as f64,
    );
    let (sx, sy) = (
        (f64::from(s % side) + 0.5) / f64::from(side),
        (f64::from(s / side) + 0.5) / f64::from(side),
    );
    cam.ray(basis, px + sx, py + sy)
}

/// A moving object a frame draws over the baked mesh: a diffuse sphere that is not in the
/// matrix, lit by the analytic lights (shadow rays from its surface) and by the probes' radiance
/// SH at its centre ([`crate::probes::sh_at`]) for each of its normals.
pub struct Sphere {
    /// Its centre.
    pub centre: DVec3,
    /// Its radius.
    pub radius: f64,
    /// Its diffuse reflectance.
    pub reflectance: Rgb,
    /// The probes' radiance SH at its centre.
    pub sh: [Rgb; radiosity_core::SH_COEFFICIENTS],
}

impl Sphere {
    /// The distance along unit `dir` from `origin` to the sphere's front, if it is hit.
    fn hit(&self, origin: DVec3, dir: DVec3) -> Option<f64> {
        let oc = origin - self.centre;
        let b = oc.dot(dir);
        let disc = b * b - (oc.length_squared() - self.radius * self.radius);
        if disc < 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        (t > 0.0).then_some(t)
    }

    /// Radiosity `ρ∘(H_d + E_probes(n))` at the sphere's surface point `p`.
    fn radiosity(&self, rt: &BakedScene, lights: &[Light], p: DVec3) -> Rgb {
        let n = (p - self.centre) / self.radius;
        let reflected = radiosity_core::sh_irradiance(&self.sh, n.as_vec3().to_array());
        let reflected = Rgb::from_array(reflected.to_array().map(|v| v.max(0.0)));
        self.reflectance * (rt.direct_at(lights, p, n) + reflected)
    }
}

/// Casts the camera's primary rays into the runtime's mesh.
pub fn primary(rt: &BakedScene, cam: &Camera, spp_side: u32) -> crate::Result<Primary> {
    let mesh = rt.mesh("rendering")?;
    let occ = rt.occluders().expect("a mesh has a BVH");
    let basis = cam.basis();
    let side = spp_side.max(1);
    let per_pixel = (side * side) as usize;
    let (w, h) = (cam.width, cam.height);
    let hits = (0..(w as usize * h as usize * per_pixel))
        .into_par_iter()
        .map(|k| {
            let pixel = k / per_pixel;
            let s = (k % per_pixel) as u32;
            let dir = sample_ray(cam, &basis, w, side, pixel, s);
            // The two sheets of a panel modelled a hair out of order show the near one's front
            // (`Occluders::first_surface`), as the bake's rays see it.
            let (hit, front) = occ.first_surface(cam.position, dir, 0.0, f64::INFINITY)?;
            if !front {
                return None; // the back of a one-sided surface sends nothing
            }
            let normal = triangle_normal(mesh, hit.triangle as usize);
            Some(SampleHit {
                triangle: hit.triangle,
                u: hit.u,
                v: hit.v,
                point: cam.position + dir * hit.distance,
                normal,
            })
        })
        .collect::<Vec<Option<SampleHit>>>();
    // Interpolation weights, once per hit (a static camera reuses them every frame).
    let grid = PatchGrid::new(&rt.file.patches);
    let per_hit: Vec<Vec<(u32, f32)>> = hits
        .par_iter()
        .map(|h| {
            let mut out = Vec::new();
            if let Some(s) = h {
                grid.weights_at_hit(
                    &rt.file.patches,
                    mesh,
                    s.triangle as usize,
                    (s.u, s.v),
                    s.point,
                    s.normal,
                    rt.occluders(),
                    &mut out,
                );
            }
            out
        })
        .collect();
    let mut rows = Vec::with_capacity(per_hit.len() + 1);
    rows.push(0u32);
    let mut weights = Vec::new();
    for r in per_hit {
        weights.extend(r);
        rows.push(weights.len() as u32);
    }
    Ok(Primary {
        camera: *cam,
        side,
        width: w,
        height: h,
        per_pixel,
        hits,
        rows,
        weights,
    })
}

/// Shades a frame: radiance `(s·E + ρ∘(H_d + y))/π` per sample, averaged per pixel; where
/// `sphere` is in front of the mesh, the sphere's radiance instead; where the ray leaves the
/// scene, the sky's radiance (black without a sky).
pub fn shade(
    rt: &BakedScene,
    primary: &Primary,
    frame: &Frame,
    lights: &[Light],
    emission: f32,
    sphere: Option<&Sphere>,
) -> crate::Result<LinearImage> {
    let mesh = rt.mesh("rendering")?;
    // The sky lights each surface as baked (interpolated like the gathered light) and shows
    // where a camera ray leaves the scene.
    let sky = rt.sky_irradiance(lights)?;
    let mut img = LinearImage::new(primary.width, primary.height);
    let inv = 1.0 / primary.per_pixel as f32;
    let cam = &primary.camera;
    let basis = cam.basis();
    img.pixels
        .par_iter_mut()
        .zip(primary.hits.par_chunks(primary.per_pixel))
        .enumerate()
        .for_each(|(pixel, (px, samples))| {
            let mut acc = Rgb::ZERO;
            for (k, s) in samples.iter().enumerate() {
                if let Some(sphere) = sphere {
                    let dir = sample_ray(cam, &basis, primary.width, primary.side, pixel, k as u32);
                    let behind = s.map_or(f64::INFINITY, |s| s.point.distance(cam.position));
                    if let Some(t) = sphere.hit(cam.position, dir).filter(|&t| t < behind) {
                        let b = sphere.radiosity(rt, lights, cam.position + dir * t);
                        acc += b * (1.0 / std::f32::consts::PI);
                        continue;
                    }
                }
                let Some(s) = s else {
                    if sky.is_some() {
                        let dir =
                            sample_ray(cam, &basis, primary.width, primary.side, pixel, k as u32);
                        acc += radiosity_core::sky_radiance_of(lights, dir.as_vec3());
                    }
                    continue;
                };
                let row = pixel * primary.per_pixel + k;
                let range = primary.rows[row] as usize..primary.rows[row + 1] as usize;
                let mut indirect = Rgb::ZERO;
                for &(p, w) in &primary.weights[range] {
                    // The light beyond the direct: the gather's and the first bounce's
                    // correction (none in a frame built without it).
                    let bounce = frame.bounce.get(p as usize).copied().unwrap_or(Rgb::ZERO);
                    indirect += (frame.gathered[p as usize] + bounce) * w;
                    if let Some(sky) = &sky {
                        indirect += sky[p as usize] * w;
                    }
                }
                let tri = &mesh.triangles[s.triangle as usize];
                let direct = rt.direct_at(lights, s.point, s.normal);
                let b = tri.emission * emission + tri.reflectance * (direct + indirect);
                acc += b * (1.0 / std::f32::consts::PI);
            }
            let c = acc * inv;
            *px = Vec3::new(c.r, c.g, c.b);
        });
    Ok(img)
}

/// A camera framing the whole mesh automatically at `width × height`
/// ([`Camera::frame`]).
pub fn auto_camera(rt: &BakedScene, width: u32, height: u32) -> crate::Result<Camera> {
    let mesh = rt.mesh("rendering")?;
    let tris: Vec<[DVec3; 3]> = (0..mesh.triangles.len())
        .map(|t| mesh.corners(t).map(|c| Vec3::from(c).as_dvec3()))
        .collect();
    let cam = Camera::frame(
        &tris,
        rt.occluders().expect("a mesh has a BVH"),
        width,
        height,
    );
    cam.validate()?;
    Ok(cam)
}
