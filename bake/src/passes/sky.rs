//! Sky visibility: the SKY section of a bake's file (`radiosity_core::sky`). Per patch, the
//! cosine-weighted SH of the directions in which its surface sees out of the scene; per probe,
//! the SH of the directions it sees out in. Rays go through the runtime's BVH over the file's
//! mesh (the shadow rays' BVH) from the patch's direct-light samples, so the sky is occluded
//! by the same geometry as the sun.
//!
//! Estimators: a patch of area `A` with samples `s` (area `a_s`) casts `⌈R·a_s/A⌉` rays from
//! each, cosine-weighted about the sample's normal on a scrambled Sobol' sequence; a ray that
//! meets nothing adds `π·Y_k(ω)·a_s/(A·rays_s)` to `T_k`. A probe casts `R_p` rays uniform
//! over the sphere; an escaping one adds `4π·Y_k(ω)/R_p` to `V_k`. An unoccluded patch gets
//! `T_0 = π·Y_0` exactly, whatever the rays (its uniform-sky irradiance is then `π·L`).

use super::Pass;
use crate::BakeError;
use crate::effect_plan::Effect;
use crate::geometry::rng::sobol2;
use crate::hooks::Hooks;
use crate::report::{BakeReport, SkyReport};
use glam::DVec3;
use radiosity_core::probes::sh_basis;
use radiosity_core::{SH_COEFFICIENTS, SkyVisibility};
use radiosity_geometry::Occluders;
use radiosity_runtime::BakedScene;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Rays a patch casts at the sky (at least one a sample). 512 put a half-occluded patch's
/// uniform-sky irradiance within 0.022·π·L (one standard deviation of a binary visibility,
/// before the Sobol' stratification helps) and cost 4.5 s at 4128 patches of a 126 682-triangle
/// scene on two cores, under 5% of its bake (`docs/decisions/sky-visibility.md`).
pub const SKY_RAYS: usize = 512;
/// Rays a probe casts at the sky, over the whole sphere.
pub const PROBE_SKY_RAYS: usize = 1024;

/// The sky pass: measures the sky visibility of a bake's file, stores the SKY section, and
/// records the `sky` effect, report and timing; off, the file gets no SKY section (a sky
/// cannot light it) and the effect says so. Runs after the probes: their visibility is
/// measured too.
pub struct Sky {
    /// Whether to measure (`--sky`).
    pub on: bool,
    /// How a planned bake measures it (`None` for a bake without a plan).
    pub(crate) planned: Option<PlannedSky>,
}

/// How a planned bake measures the sky ([`crate::plan`]): each file patch's rays seeded by
/// the patch's identity, and where an earlier bake is given, a patch's visibility carried
/// over from it.
pub(crate) struct PlannedSky {
    /// Seed of each file patch's rays.
    pub(crate) seeds: Vec<u64>,
    /// For each file patch, the visibility of the earlier bake's patch of the same identity
    /// and the same direct-light samples, where there is one.
    pub(crate) old: Vec<Option<[f32; SH_COEFFICIENTS]>>,
    /// Boxes of what changed since ([`crate::plan::reuse::Diff`]): a patch keeps its old
    /// visibility where none of its rays' lines crosses one.
    pub(crate) boxes: Vec<(DVec3, DVec3)>,
}

impl Pass for Sky {
    fn run(
        &self,
        rt: &mut BakedScene,
        report: &mut BakeReport,
        hooks: Hooks<'_>,
    ) -> Result<(), BakeError> {
        if !self.on {
            report.effects.insert(
                "sky",
                Effect::new(
                    false,
                    "--sky off: no sky visibility stored; a sky cannot light the file",
                ),
            );
            return Ok(());
        }
        hooks.start("sky")?;
        let t = std::time::Instant::now();
        let (visibility, measured) = measure(rt, hooks, self.planned.as_ref())?;
        let bytes = visibility.to_bytes().len();
        let seconds = t.elapsed().as_secs_f64();
        let effect = if visibility.is_closed() {
            Effect::new(
                false,
                format!(
                    "no ray of {} from the patches and probes leaves the scene: closed, a sky adds nothing",
                    measured.rays
                ),
            )
        } else {
            Effect::new(
                true,
                format!(
                    // No seconds here: the report's text stays the same from bake to bake but
                    // for its timings (`timings_ms.sky`, `sky.seconds`).
                    "{} of {} patches see the sky ({:.1}% of the surface, cosine-weighted): {} rays",
                    measured.open_patches,
                    rt.n(),
                    100.0 * measured.open_share,
                    measured.rays,
                ),
            )
        };
        rt.file.sky = Some(visibility);
        report.effects.insert("sky", effect);
        report.bytes.sky = bytes;
        report.sky = Some(SkyReport {
            bytes,
            seconds,
            ..measured
        });
        report.timings_ms.insert("sky", seconds * 1e3);
        *report.timings_ms.entry("total").or_insert(0.0) += seconds * 1e3;
        Ok(())
    }
}

/// The section and the report's counts (bytes and seconds left to the caller).
fn measure(
    rt: &BakedScene,
    hooks: Hooks<'_>,
    planned: Option<&PlannedSky>,
) -> Result<(SkyVisibility<'static>, SkyReport), BakeError> {
    let n = rt.n();
    let (Some(mesh), Some(occ)) = (rt.file.mesh.as_ref(), rt.occluders()) else {
        // A bake always stores its mesh; without one nothing can be measured.
        return Ok((
            SkyVisibility::new(&[], &[]),
            SkyReport {
                rays: 0,
                open_share: 0.0,
                open_patches: 0,
                bytes: 0,
                seconds: 0.0,
            },
        ));
    };
    let mut patches = Vec::with_capacity(n);
    let mut rays = 0u64;
    const CHUNK: usize = 256;
    for start in (0..n).step_by(CHUNK) {
        hooks.check()?;
        let chunk: Vec<([f32; SH_COEFFICIENTS], u64)> = (start..(start + CHUNK).min(n))
            .into_par_iter()
            .map(|p| {
                let samples = mesh.samples_of(p);
                let Some(plan) = planned else {
                    return patch_visibility(occ, samples, p as u64);
                };
                let seed = plan.seeds[p];
                if let Some(t) = plan.old[p] {
                    let (mut clear, mut rays) = (true, 0u64);
                    sky_rays(samples, seed, |origin, dir, _| {
                        rays += 1;
                        clear &= !plan.boxes.iter().any(|&b| {
                            radiosity_geometry::aabb::crosses(origin, dir, f64::INFINITY, b)
                        });
                    });
                    if clear {
                        return (t, rays);
                    }
                }
                patch_visibility(occ, samples, seed)
            })
            .collect();
        for (t, r) in chunk {
            patches.push(t);
            rays += r;
        }
        hooks.report(patches.len(), n);
    }
    let probes: Vec<[f32; SH_COEFFICIENTS]> = match &rt.file.probes {
        None => Vec::new(),
        Some(p) => p
            .positions
            .par_iter()
            .enumerate()
            .map(|(j, pos)| probe_visibility(occ, DVec3::from(pos.map(f64::from)), j))
            .collect(),
    };
    rays += (probes.len() * PROBE_SKY_RAYS) as u64;
    let full = f64::from(std::f32::consts::PI * radiosity_core::sky::Y0);
    let (mut open_area, mut area) = (0.0f64, 0.0f64);
    for (t, patch) in patches.iter().zip(rt.file.patches.iter()) {
        area += f64::from(patch.area);
        open_area += f64::from(patch.area) * f64::from(t[0]) / full;
    }
    let open_patches = patches.iter().filter(|t| t[0] > 0.0).count();
    Ok((
        SkyVisibility::new(&patches, &probes),
        SkyReport {
            rays,
            open_share: if area > 0.0 { open_area / area } else { 0.0 },
            open_patches,
            bytes: 0,
            seconds: 0.0,
        },
    ))
}

/// The Sobol' scramble of stream `k` (a patch's sample or a probe).
fn scramble(kind: u64, k: u64) -> [u32; 2] {
    let mut rng = crate::rng::SplitMix64(kind ^ k.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    let v = rng.next_u64();
    [v as u32, (v >> 32) as u32]
}

/// Calls `ray(origin, direction, weight)` for each of a patch's sky rays (`seed`: its
/// streams'; the patch's index in a bake without a plan).
fn sky_rays(
    samples: &[radiosity_core::PatchSample],
    seed: u64,
    mut ray: impl FnMut(DVec3, DVec3, f64),
) {
    let total: f64 = samples.iter().map(|s| f64::from(s.area)).sum();
    if !(total > 0.0) {
        return;
    }
    for (k, s) in samples.iter().enumerate() {
        let share = f64::from(s.area) / total;
        let count = ((SKY_RAYS as f64 * share).ceil() as usize).max(1);
        let origin = DVec3::from(s.position.map(f64::from));
        let n = DVec3::from(s.normal.map(f64::from));
        let (t1, t2) = n.any_orthonormal_pair();
        let sc = scramble(0x5c1e_5ca7, (seed << 20) ^ k as u64);
        let w = PI * share / count as f64;
        for i in 0..count {
            let [u1, u2] = sobol2(sc, i as u32);
            let (r, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
            let dir = (t1 * phi.cos() + t2 * phi.sin()) * r + n * (1.0 - u1).max(0.0).sqrt();
            ray(origin, dir, w);
        }
    }
}

/// A patch's `T` (module docs) and the rays it cast.
fn patch_visibility(
    occ: &Occluders,
    samples: &[radiosity_core::PatchSample],
    seed: u64,
) -> ([f32; SH_COEFFICIENTS], u64) {
    let mut t = [0f64; SH_COEFFICIENTS];
    let mut rays = 0u64;
    sky_rays(samples, seed, |origin, dir, w| {
        rays += 1;
        if occ
            .closest_hit_from_stored_point(origin, dir, f64::INFINITY)
            .is_none()
        {
            let y = sh_basis(dir.as_vec3().to_array());
            for (a, y) in t.iter_mut().zip(y) {
                *a += w * f64::from(y);
            }
        }
    });
    (t.map(|v| v as f32), rays)
}

/// A probe's `V` (module docs).
fn probe_visibility(occ: &Occluders, p: DVec3, probe: usize) -> [f32; SH_COEFFICIENTS] {
    let sc = scramble(0x9b0b_e5c7, probe as u64);
    let w = 4.0 * PI / PROBE_SKY_RAYS as f64;
    let mut v = [0f64; SH_COEFFICIENTS];
    for i in 0..PROBE_SKY_RAYS {
        let [u1, u2] = sobol2(sc, i as u32);
        let z = 1.0 - 2.0 * u1;
        let s = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * u2;
        let dir = DVec3::new(s * phi.cos(), s * phi.sin(), z);
        if occ.closest_hit(p, dir, 0.0, f64::INFINITY).is_none() {
            for (a, y) in v.iter_mut().zip(sh_basis(dir.as_vec3().to_array())) {
                *a += w * f64::from(y);
            }
        }
    }
    v.map(|x| x as f32)
}
