//! `radiosity render SCENE.obj|BAKED.rad [--lights L] [--camera C] -o OUT.png`: a CPU ray-cast
//! pinhole camera over the file's full-detail mesh. Per pixel: direct light from the analytic
//! lights with a shadow ray at the exact hit point, plus the gathered (indirect and
//! emitter) irradiance interpolated from the patches around the hit point on the same
//! surface; radiance `(E + ρ∘H)/π`, tone mapped to sRGB.
//!
//! Interpolation is a kernel over nearby patch centres (same orientation, same plane), not
//! over the triangle's corners: a wall made of two big triangles has its corners in the room's
//! darkest places, and barycentric blending of corner values would paint the whole wall with
//! them. The mesh's corner weights remain the fallback where no patch is near.

use crate::camera::Camera;
use crate::picture::LinearImage;
use crate::runtime::{Frame, Runtime};
use glam::{DVec3, Vec3};
use radiosity_core::{Light, Rgb};
use rayon::prelude::*;
use std::path::Path;

/// What a camera sample sees first: the mesh triangle, where on it, and whether its front
/// faces the camera.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleHit {
    triangle: u32,
    u: f32,
    v: f32,
    point: DVec3,
    normal: DVec3,
}

/// Primary visibility of an image: `spp_side²` stratified samples per pixel, cached so that
/// a static camera pays for it once however many frames it shows.
pub(crate) struct Primary {
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
pub(crate) struct PatchGrid {
    cell: f64,
    radius: f64,
    /// Half the patch size: how far off a hit's plane a patch centre may lie.
    slab: f64,
    buckets: std::collections::HashMap<[i64; 3], Vec<u32>>,
}

/// Smallest cosine between a patch's normal and the surface's for the patch to count.
const SAME_SURFACE_COS: f64 = 0.8;

impl PatchGrid {
    pub(crate) fn new(patches: &[radiosity_core::Patch]) -> Self {
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
    pub(crate) fn weights(
        &self,
        patches: &[radiosity_core::Patch],
        point: DVec3,
        normal: DVec3,
        out: &mut Vec<(u32, f32)>,
    ) -> bool {
        let start = out.len();
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
                        if q > 0.0 {
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
    /// centres near it ([`PatchGrid::weights`]), or the triangle's corner weights where no
    /// patch is near.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn weights_at_hit(
        &self,
        patches: &[radiosity_core::Patch],
        mesh: &radiosity_core::Mesh<'_>,
        t: usize,
        (u, v): (f32, f32),
        point: DVec3,
        normal: DVec3,
        out: &mut Vec<(u32, f32)>,
    ) {
        if !self.weights(patches, point, normal, out) {
            for (c, bc) in [1.0 - u - v, u, v].into_iter().enumerate() {
                for e in mesh.corner(t, c) {
                    out.push((e.patch, bc * e.weight));
                }
            }
        }
    }
}

/// The unit front normal of mesh triangle `t`.
pub(crate) fn triangle_normal(mesh: &radiosity_core::Mesh<'_>, t: usize) -> DVec3 {
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
pub(crate) struct Sphere {
    pub(crate) centre: DVec3,
    pub(crate) radius: f64,
    pub(crate) reflectance: Rgb,
    pub(crate) sh: [Rgb; radiosity_core::SH_COEFFICIENTS],
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
    fn radiosity(&self, rt: &Runtime, lights: &[Light], p: DVec3) -> Rgb {
        let n = (p - self.centre) / self.radius;
        let reflected = radiosity_core::sh_irradiance(&self.sh, n.as_vec3().to_array());
        let reflected = Rgb::from_array(reflected.to_array().map(|v| v.max(0.0)));
        self.reflectance * (rt.direct_at(lights, p, n) + reflected)
    }
}

/// Casts the camera's primary rays into the runtime's mesh.
pub(crate) fn primary(rt: &Runtime, cam: &Camera, spp_side: u32) -> anyhow::Result<Primary> {
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
/// `sphere` is in front of the mesh, the sphere's radiance instead.
pub(crate) fn shade(
    rt: &Runtime,
    primary: &Primary,
    frame: &Frame,
    lights: &[Light],
    emission: f32,
    sphere: Option<&Sphere>,
) -> anyhow::Result<LinearImage> {
    let mesh = rt.mesh("rendering")?;
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
                let Some(s) = s else { continue };
                let row = pixel * primary.per_pixel + k;
                let range = primary.rows[row] as usize..primary.rows[row + 1] as usize;
                let mut indirect = Rgb::ZERO;
                for &(p, w) in &primary.weights[range] {
                    indirect += frame.gathered[p as usize] * w;
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

/// The camera: from a file, else framed automatically at `width × height`.
pub(crate) fn camera(
    rt: &Runtime,
    file: Option<&Path>,
    width: u32,
    height: u32,
) -> anyhow::Result<Camera> {
    if let Some(p) = file {
        return Camera::load(p);
    }
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

/// The `render` command.
pub(crate) fn run(
    input: &Path,
    args: &crate::args::BakeArgs,
    lights: Option<&Path>,
    camera_file: Option<&Path>,
    output: &Path,
    size: (u32, u32),
    spp_side: u32,
    exposure: Option<f32>,
    backend: Option<&str>,
) -> anyhow::Result<()> {
    crate::picture::check_exposure(exposure)?;
    if !(1..=8).contains(&spp_side) {
        anyhow::bail!("--aa must be 1 to 8 (samples per pixel side), not {spp_side}");
    }
    for (name, s) in [("--width", size.0), ("--height", size.1)] {
        if s == 0 || s > crate::camera::MAX_SIDE {
            anyhow::bail!(
                "{name} must be 1 to {} pixels, not {s}",
                crate::camera::MAX_SIDE
            );
        }
    }
    // An output that cannot be written is refused before any work.
    crate::output::check_file(output)?;
    let lights = match lights {
        Some(p) => crate::lights::load(p)?,
        None => Vec::new(),
    };
    let (cam_from_file, camera_note) = match camera_file {
        Some(p) => {
            let (cam, note) = Camera::load_noting_defaults(p)?;
            (Some(cam), note)
        }
        None => (None, None),
    };
    let loaded = crate::runtime::load(input, args, false)?;
    let rt = &loaded.runtime;
    rt.mesh("rendering")?;
    let cam = match cam_from_file {
        Some(c) => c,
        None => camera(rt, None, size.0, size.1)?,
    };
    // Lights that overflow are an error before the backend prints its choice (one line); the
    // direct light computed for that check is the frame's.
    let t = std::time::Instant::now();
    let direct = rt.direct(&lights)?;
    let direct_ms = t.elapsed().as_secs_f64() * 1e3;
    let mut chosen = crate::backend::choose(backend, rt.file.matrix.clone())?;
    let t = std::time::Instant::now();
    let (frame, gather_ms) = rt.frame_with_direct(chosen.gather.as_mut(), direct, 1.0)?;
    let frame_ms = direct_ms + t.elapsed().as_secs_f64() * 1e3;
    let t = std::time::Instant::now();
    let prim = primary(rt, &cam, spp_side)?;
    let img = shade(rt, &prim, &frame, &lights, 1.0, None)?;
    let render_ms = t.elapsed().as_secs_f64() * 1e3;
    let exposure = exposure.unwrap_or_else(|| img.auto_exposure());
    img.save_png(output, exposure)?;
    eprintln!(
        "wrote {} ({}×{}, {} samples/pixel, exposure {exposure:.6e}): frame {frame_ms:.1} ms (gather {gather_ms:.2} ms), image {render_ms:.0} ms",
        output.display(),
        cam.width,
        cam.height,
        spp_side * spp_side
    );
    if let Some(note) = camera_note {
        eprintln!("note: {note}");
    }
    crate::runtime::warn_if_unlit(rt, &lights);
    Ok(())
}
