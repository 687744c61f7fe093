//! What `radiosity bench` measures of a frame around the gather: the box's probes and their
//! CPU frame, the direct light with shadow rays (through `solve`'s path and the C ABI's
//! `rad_scene_direct`), and the host-device frame on every adapter.

use crate::Progress;
use crate::timing::ms;
use anyhow::Context;
use radiosity_backend_wgpu::time_host_frame;
use radiosity_bake::order;
use radiosity_bake::pipeline::Discretised;
use radiosity_core::Rgb;
use serde::Serialize;
use std::time::Instant;

/// One adapter's host-device frame: [`time_host_frame`]'s medians.
#[derive(Serialize)]
pub struct HostFrameOut {
    pub adapter: String,
    pub format: &'static str,
    pub path: String,
    pub dispatches: usize,
    pub corners: usize,
    /// CPU time to record the gather and the corner pass into the host's encoder, ms.
    pub record_ms: f64,
    /// GPU time of the gather's pass, ms (`null` without timestamps).
    pub gather_ms: Option<f64>,
    /// GPU time of the corner pass, ms (`null` without timestamps).
    pub corners_ms: Option<f64>,
    /// Probes the probe pass writes.
    pub probes: usize,
    /// GPU time of the probe pass, ms (`null` without probes or timestamps).
    pub probes_ms: Option<f64>,
    pub frames: usize,
}

/// One frame's direct light per patch with shadow rays (a point light under the ceiling):
/// medians over [`HOST_FRAMES`] frames, ms.
#[derive(Serialize)]
pub struct DirectOut {
    /// Shadow rays a frame (the mesh's direct-light points).
    pub points: usize,
    /// `BakedScene::direct`, what `solve --lights` runs.
    pub cli_ms: f64,
    /// The C ABI's `rad_scene_direct` on a scene opened from the same file's bytes.
    pub c_ms: f64,
}

/// [`DirectOut`] for the file `rt` holds.
pub(super) fn bench_direct(rt: &radiosity_runtime::BakedScene) -> anyhow::Result<DirectOut> {
    let lights = [radiosity_core::Light::Point {
        position: glam::Vec3::new(0.0, 1.5, 0.0),
        intensity: Rgb::splat(2.0),
    }];
    let n = rt.file.n();
    let median = |mut t: Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let cli = median(
        (0..HOST_FRAMES)
            .map(|_| {
                let t = Instant::now();
                std::hint::black_box(rt.direct(&lights)).map(|_| ms(t.elapsed()))
            })
            .collect::<Result<_, _>>()?,
    );
    let bytes = rt.file.to_bytes()?;
    let light = radiosity_capi::RadLight {
        kind: radiosity_capi::RAD_LIGHT_POINT,
        position: [0.0, 1.5, 0.0],
        value: radiosity_capi::RadRgb {
            r: 2.0,
            g: 2.0,
            b: 2.0,
        },
        ..Default::default()
    };
    let mut scene = std::ptr::null_mut();
    let mut out = vec![radiosity_capi::RadRgb::default(); n];
    // SAFETY: `bytes` is a live slice of `len` bytes and `scene` a writable pointer; the
    // scene is freed below and not used after.
    let opened =
        unsafe { radiosity_capi::rad_scene_from_bytes(bytes.as_ptr(), bytes.len(), &mut scene) };
    anyhow::ensure!(
        opened == radiosity_capi::RAD_OK,
        "rad_scene_from_bytes failed"
    );
    let c: Vec<f64> = (0..HOST_FRAMES)
        .map(|_| {
            let t = Instant::now();
            // SAFETY: a live scene, one light, `n` writable values.
            let code =
                unsafe { radiosity_capi::rad_scene_direct(scene, &light, 1, out.as_mut_ptr(), n) };
            (code, ms(t.elapsed()))
        })
        .collect::<Vec<_>>()
        .into_iter()
        .map(|(code, t)| {
            if code == radiosity_capi::RAD_OK {
                t
            } else {
                f64::NAN
            }
        })
        .collect();
    // SAFETY: made by rad_scene_from_bytes above, freed once.
    unsafe { radiosity_capi::rad_scene_free(scene) };
    anyhow::ensure!(c.iter().all(|t| t.is_finite()), "rad_scene_direct failed");
    Ok(DirectOut {
        points: rt.file.mesh.as_ref().map_or(0, |m| m.samples.len()),
        cli_ms: cli,
        c_ms: median(c),
    })
}

/// The box's probes (`bake --probes auto`) and one CPU frame of them, `P·(B − E)`.
#[derive(Serialize)]
pub struct ProbesOut {
    pub count: usize,
    pub weights: usize,
    pub bytes: usize,
    /// Median CPU time of `P·(B − E)` (the probes over the threads) over [`HOST_FRAMES`]
    /// frames, ms.
    pub cpu_ms: f64,
}

/// Probes over the box as `bake --probes auto` places them, for a file of `matrix` over the
/// patches of `sys` in the order `perm` with the full-detail `mesh`; and their CPU frame time.
/// A direct-light frame that cannot run is a note of `progress`.
pub(super) fn bench_probes(
    progress: &Progress<'_>,
    scene: &radiosity_bake::scene::Scene,
    sys: &Discretised,
    perm: &[u32],
    matrix: &radiosity_core::TransferMatrix<'_>,
    mesh: &radiosity_core::Mesh<'static>,
) -> anyhow::Result<(
    radiosity_core::Probes<'static>,
    Vec<radiosity_core::Patch>,
    ProbesOut,
    Option<DirectOut>,
)> {
    use std::borrow::Cow;
    let patches = order::permute_rows(&sys.core_patches, perm);
    let file = radiosity_core::RadFile {
        mesh: Some(mesh.clone()),
        ..radiosity_core::RadFile::new(
            Cow::Owned(patches.clone()),
            Cow::Owned(perm.to_vec()),
            matrix.clone().into_owned(),
            scene
                .objects
                .iter()
                .map(|o| Cow::Owned(o.clone()))
                .collect(),
            radiosity_core::Bounces::Infinite,
        )
    };
    let rt = radiosity_runtime::BakedScene::new(file);
    let direct = bench_direct(&rt)
        .map_err(|e| (progress.note)(&format!("note: no direct-light frame: {e:#}")))
        .ok();
    let (probes, report) = radiosity_bake::passes::probes::bake(
        &rt,
        &radiosity_bake::passes::probes::ProbeSpec::Auto,
        radiosity_bake::passes::probes::ProbeRank::Auto,
        radiosity_bake::pipeline::Hooks::default(),
    )?
    .context("probes at auto")?;
    let reflected: Vec<Rgb> = (0..patches.len())
        .map(|i| Rgb::splat(1.0 + (i % 7) as f32))
        .collect();
    let decoded = radiosity_core::DecodedProbes::new(&probes);
    let mut times: Vec<f64> = (0..HOST_FRAMES)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(radiosity_runtime::probes::gather_all(&decoded, &reflected));
            ms(t.elapsed())
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let cpu = ProbesOut {
        count: probes.len(),
        weights: report.weights,
        bytes: report.bytes,
        cpu_ms: times[times.len() / 2],
    };
    Ok((probes, patches, cpu, direct))
}

/// Frames each host-device measurement runs (medians over them).
pub const HOST_FRAMES: usize = 21;

/// [`time_host_frame`] of `matrix`, `mesh` and `probes` on every adapter; an adapter that
/// cannot run it gets a note of `progress` instead of a row.
pub(super) fn host_frames(
    progress: &Progress<'_>,
    matrix: &radiosity_core::TransferMatrix<'_>,
    mesh: &radiosity_core::Mesh<'_>,
    probes: Option<(&radiosity_core::Probes<'_>, &[radiosity_core::Patch])>,
) -> Vec<HostFrameOut> {
    let format = matrix.layout.format();
    radiosity_backend_wgpu::adapters()
        .iter()
        .filter_map(
            |a| match time_host_frame(a, matrix, mesh, probes, HOST_FRAMES) {
                Ok(t) => Some(HostFrameOut {
                    adapter: t.adapter.to_string(),
                    format: format.name(),
                    path: t.path.to_string(),
                    dispatches: t.dispatches,
                    corners: t.corners,
                    record_ms: t.record_ms,
                    gather_ms: t.gather_ms,
                    corners_ms: t.corners_ms,
                    probes: t.probes,
                    probes_ms: t.probes_ms,
                    frames: HOST_FRAMES,
                }),
                Err(e) => {
                    (progress.note)(&format!("note: no host-device frame on {}: {e}", a.info));
                    None
                }
            },
        )
        .collect()
}
