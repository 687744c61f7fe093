//! The light probes' frame and the irradiance they give (`radiosity_core::Probes`, baked by
//! `radiosity_bake::probes`).
//!
//! A frame's probe SH is `P·(B − E)` over the patches. A point takes the probes of its lattice
//! cell that it sees (a segment from the point to the probe clear of the mesh), each with its
//! trilinear (tent) weight times `FACING_FLOOR + ((1 + n·ω)/2)²`, more towards probes in front
//! of its surface (`Probes::interpolation_weights`). A probe behind a wall is out of sight, so
//! light does not come through a wall from the next room. Where no probe of the cell is in
//! sight, a tent twice as wide; no probe there either: "outside the probe grid".

use crate::BakedScene;
use glam::{DVec3, Vec3};
use radiosity_core::{DecodedProbes, Light, Rgb, SH_COEFFICIENTS, sh_irradiance};
use rayon::prelude::*;
use std::sync::OnceLock;

/// The probes' radiance SH for a frame of total irradiance `h` (file numbering) under
/// `lights`: `P·(B − E)`, with `B − E = ρ∘H` whatever the frame's emission scale, plus the
/// sky's radiance as each probe sees it (the order-2 product of the sky's SH and the probe's
/// sky visibility, `radiosity_core::sky`). An error for a sky on a file without sky
/// visibility ([`BakedScene::sky_irradiance`]).
pub fn frame_sh(
    rt: &BakedScene,
    h: &[Rgb],
    lights: &[Light],
) -> crate::Result<Vec<[Rgb; SH_COEFFICIENTS]>> {
    let Some(probes) = rt.decoded_probes() else {
        return Ok(Vec::new());
    };
    let reflected: Vec<Rgb> = h
        .iter()
        .zip(rt.file.patches.iter())
        .map(|(h, p)| p.reflectance * *h)
        .collect();
    let mut sh = gather_all(probes, &reflected);
    if let Some(sky) = radiosity_core::sky_sh_of(lights) {
        let Some(vis) = &rt.file.sky else {
            // The same refusal as the patches'.
            rt.sky_irradiance(lights)?;
            return Ok(sh);
        };
        static GAMMA: OnceLock<SkyTensor> = OnceLock::new();
        let gamma = GAMMA.get_or_init(radiosity_core::sky::sh_triple);
        let n = rt.n();
        sh.par_iter_mut().enumerate().for_each(|(j, c)| {
            let add = radiosity_core::sky::sh_product(gamma, &sky, &vis.entry(n + j));
            for (c, a) in c.iter_mut().zip(add) {
                *c += a;
            }
        });
    }
    Ok(sh)
}

/// [`radiosity_core::sky::sh_triple`]'s tensor.
type SkyTensor = [[[f32; SH_COEFFICIENTS]; SH_COEFFICIENTS]; SH_COEFFICIENTS];

/// Every probe's SH from the patches' reflected radiosity, the probes spread over the threads.
pub fn gather_all(probes: &DecodedProbes, reflected: &[Rgb]) -> Vec<[Rgb; SH_COEFFICIENTS]> {
    let modes = probes.modes(reflected);
    (0..probes.len())
        .into_par_iter()
        .map(|p| probes.gather_probe_with(p, reflected, &modes))
        .collect()
}

/// The reflected irradiance at `p` facing unit `n` from the probes around it (module docs), or
/// `None` when no probe in reach is in sight.
pub fn reflected_at(
    rt: &BakedScene,
    sh: &[[Rgb; SH_COEFFICIENTS]],
    p: DVec3,
    n: DVec3,
) -> Option<Rgb> {
    let normal = n.as_vec3().to_array();
    let mut sum = Rgb::ZERO;
    for (i, w) in neighbours(rt, p, Some(n))? {
        sum += sh_irradiance(&sh[i], normal) * w;
    }
    Some(sum)
}

/// The radiance SH at `p` for an object there (a moving one, lit from every side): the probes
/// around it with their trilinear weights, without the facing term; `None` when no probe in
/// reach is in sight. `sh_irradiance` of it gives the object's irradiance for each normal.
pub fn sh_at(
    rt: &BakedScene,
    sh: &[[Rgb; SH_COEFFICIENTS]],
    p: DVec3,
) -> Option<[Rgb; SH_COEFFICIENTS]> {
    let mut sum = [Rgb::ZERO; SH_COEFFICIENTS];
    for (i, w) in neighbours(rt, p, None)? {
        for (s, c) in sum.iter_mut().zip(&sh[i]) {
            *s += *c * w;
        }
    }
    Some(sum)
}

/// The probes `p` takes light from and their weights (`Probes::interpolation_weights`, the
/// runtime's BVH saying which are in sight), or `None` when none is.
fn neighbours(rt: &BakedScene, p: DVec3, n: Option<DVec3>) -> Option<Vec<(usize, f32)>> {
    let probes = rt.file.probes.as_ref()?;
    let occ = rt.occluders()?;
    let mut out = Vec::new();
    let visible = |i: usize| occ.segment_visible(p, Vec3::from(probes.positions[i]).as_dvec3());
    let at = p.as_vec3().to_array();
    let facing = n.map(|n| n.as_vec3().to_array());
    probes
        .interpolation_weights(at, facing, visible, &mut out)
        .then_some(out)
}
