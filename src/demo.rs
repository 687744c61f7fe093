//! `radiosity demo [--out DIR] [--backend auto|cpu|gpu]`: the whole product on the embedded
//! Cornell box. Bakes it (progress bar), then lights it every frame with one gather: writes
//! `demo.png` (the box lit by its own ceiling light) and `demo.gif` (the ceiling light off, a
//! point light circling through the box, its colour bleeding off the walls, and a white sphere
//! that is not in the matrix floating through it, lit by the light probes), and prints the
//! bake time, the file size and the per-frame times.

use crate::args::BakeArgs;
use crate::picture::LinearImage;
use anyhow::Context;
use glam::DVec3;
use radiosity_core::{Gather, Light, Rgb};
use radiosity_runtime::BakedScene;
use std::path::Path;
use std::time::Instant;

/// Frames of the animation (one turn of the light).
const FRAMES: usize = 36;

pub(crate) fn run(out: &Path, backend: Option<&str>, patches: usize) -> anyhow::Result<()> {
    let args = BakeArgs::with_patches(patches);
    let params = radiosity_bake::pipeline::BakeParams {
        probes: radiosity_bake::passes::probes::ProbeSpec::Auto,
        ..crate::bake::params(&args)?
    };
    crate::output::create_dir(out)?;
    for name in ["demo.rad", "demo.png", "demo.gif"] {
        crate::output::check_file(&out.join(name))?;
    }
    let scene_dir = tempfile::tempdir().context("cannot create a temporary directory")?;
    crate::embedded::cornell_box_in(scene_dir.path())?;
    let obj = scene_dir.path().join("CornellBox-Original.obj");

    eprintln!("baking the embedded Cornell box (about {patches} patches)…");
    let t = Instant::now();
    let (baked, _) =
        crate::bake::bake_scene(&obj, Some("embedded"), &Default::default(), &params, false)?;
    let bake_s = t.elapsed().as_secs_f64();
    write_bake(out, &baked, bake_s)?;

    let rt = BakedScene::new(baked.file);
    let mut chosen = crate::backend::choose(backend, rt.file.matrix.clone())?;
    let gather = chosen.gather.as_mut();

    // demo.png: the box by its own light.
    let cam = radiosity_runtime::render::auto_camera(&rt, 512, 512)?;
    let t = Instant::now();
    let (frame, gather_ms) = rt.frame(gather, &[], 1.0)?;
    let prim = radiosity_runtime::render::primary(&rt, &cam, 2)?;
    let img = radiosity_runtime::render::shade(&rt, &prim, &frame, &[], 1.0, None)?;
    let png = out.join("demo.png");
    crate::picture::save_png(&img, &png, img.auto_exposure())?;
    outln!(
        "{}: 512×512, gather {:.2} ms, image {:.0} ms",
        png.display(),
        gather_ms,
        t.elapsed().as_secs_f64() * 1e3 - gather_ms
    );

    let mut anim = animate(&rt, gather)?;
    // One exposure for the whole animation, so that brightness changes are real.
    let mut exposures: Vec<f32> = anim.images.iter().map(LinearImage::auto_exposure).collect();
    exposures.sort_by(f32::total_cmp);
    let exposure = exposures[exposures.len() / 2];
    let gif = out.join("demo.gif");
    write_gif(&gif, &anim.images, Some(exposure))?;
    outln!(
        "{}: {} frames 256×256, per frame: gather {:.2} ms ({}), direct light + gather {:.2} ms, probes {:.2} ms (medians)",
        gif.display(),
        FRAMES,
        median(&mut anim.gathers),
        gather.name(),
        median(&mut anim.frames_ms),
        median(&mut anim.probes_ms)
    );
    Ok(())
}

/// Writes `demo.rad` and prints the bake's summary, the file's size and its probes.
fn write_bake(
    out: &Path,
    baked: &radiosity_bake::pipeline::BakeOutput,
    bake_s: f64,
) -> anyhow::Result<()> {
    let probe_report = baked.report.probes.clone().context("the demo's probes")?;
    let bytes = baked.file.to_bytes()?;
    let rad = out.join("demo.rad");
    crate::output::write_bytes(&rad, &bytes)?;
    let r = &baked.report;
    outln!(
        "bake: {:.1} s, {} patches, {} {} order, {} bounces, lighting error {}",
        bake_s,
        r.patches,
        r.format,
        r.order,
        serde_json::to_string(&r.bounces)?,
        r.lighting_error
            .map_or("n/a".into(), |e| format!("{:.2}%", 100.0 * e))
    );
    let dense = 4.0 * 3.0 * (r.patches as f64).powi(2);
    let rows = r.bytes.bounce;
    let matrix = (bytes.len() - probe_report.bytes - rows) as f64;
    outln!(
        "file: {} ({:.2} MB; without its probes and first-bounce rows {:.2} MB, a dense f32 RGB matrix would be {:.1} MB, {:.1}x more)",
        rad.display(),
        bytes.len() as f64 / 1e6,
        matrix / 1e6,
        dense / 1e6,
        dense / matrix
    );
    outln!(
        "probes: {} ({:.2} MB of the file); first-bounce rows: {:.2} MB of the file",
        probe_report.placed,
        probe_report.bytes as f64 / 1e6,
        rows as f64 / 1e6
    );
    Ok(())
}

/// The animation's frames and their times, ms.
struct Animation {
    images: Vec<LinearImage>,
    gathers: Vec<f64>,
    frames_ms: Vec<f64>,
    probes_ms: Vec<f64>,
}

/// demo.gif's frames: ceiling light off, a point light circling under the ceiling, a sphere
/// floating through the box's middle (over the short block, in front of the tall one).
fn animate(rt: &BakedScene, gather: &mut dyn Gather) -> anyhow::Result<Animation> {
    let (lo, hi) = rt
        .mesh_bounds()
        .context("the demo's mesh has no vertices")?;
    let (centre, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    let cam = radiosity_runtime::render::auto_camera(rt, 256, 256)?;
    let prim = radiosity_runtime::render::primary(rt, &cam, 1)?;
    let mut anim = Animation {
        images: Vec::with_capacity(FRAMES),
        gathers: Vec::with_capacity(FRAMES),
        frames_ms: Vec::with_capacity(FRAMES),
        probes_ms: Vec::with_capacity(FRAMES),
    };
    for f in 0..FRAMES {
        let a = std::f64::consts::TAU * f as f64 / FRAMES as f64;
        let p = DVec3::new(
            centre.x + 0.55 * half.x * a.cos(),
            lo.y + 1.55 * half.y,
            centre.z + 0.55 * half.z * a.sin(),
        );
        let lights = [Light::Point {
            position: p.as_vec3(),
            // W/sr: a warm white bulb bright enough to light the box like its ceiling light.
            intensity: Rgb::new(3.0, 2.6, 2.0),
        }];
        let t = Instant::now();
        let (frame, g) = rt.frame(gather, &lights, 0.0)?;
        anim.frames_ms.push(t.elapsed().as_secs_f64() * 1e3);
        anim.gathers.push(g);
        let t = Instant::now();
        let sh = radiosity_runtime::probes::frame_sh(rt, &frame.irradiance, &lights)?;
        anim.probes_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let b = -2.0 * a;
        let centre = DVec3::new(
            centre.x + 0.1 * half.x + 0.35 * half.x * b.cos(),
            lo.y + (1.05 + 0.25 * (2.0 * b).sin()) * half.y,
            centre.z + 0.5 * half.z + 0.35 * half.z * b.sin(),
        );
        let sphere = radiosity_runtime::render::Sphere {
            centre,
            radius: 0.18 * half.y,
            reflectance: Rgb::splat(0.75),
            sh: radiosity_runtime::probes::sh_at(rt, &sh, centre)
                .context("the demo's sphere left the probe grid")?,
        };
        anim.images.push(radiosity_runtime::render::shade(
            rt,
            &prim,
            &frame,
            &lights,
            0.0,
            Some(&sphere),
        )?);
    }
    Ok(anim)
}

pub(crate) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Writes an animated GIF (looping, 80 ms per frame) atomically, every frame at `exposure`,
/// or each at its own automatic exposure.
pub(crate) fn write_gif(
    path: &Path,
    images: &[LinearImage],
    exposure: Option<f32>,
) -> anyhow::Result<()> {
    use image::codecs::gif::{GifEncoder, Repeat};
    use image::{Delay, Frame};
    crate::output::write_atomic(path, |w| {
        let mut enc = GifEncoder::new_with_speed(w, 10);
        enc.set_repeat(Repeat::Infinite)?;
        for img in images {
            let rgba = image::DynamicImage::ImageRgb8(crate::picture::srgb8(
                img,
                exposure.unwrap_or_else(|| img.auto_exposure()),
            ))
            .to_rgba8();
            enc.encode_frame(Frame::from_parts(
                rgba,
                0,
                0,
                Delay::from_numer_denom_ms(80, 1),
            ))?;
        }
        Ok(())
    })
}
