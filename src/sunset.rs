//! `radiosity sunset [--out DIR] [--frames N] [--patches N] [--backend B]`: one bake of the
//! embedded town square (`scenes/sunset/`), then the sun goes down over it. Each frame takes
//! the sun and the sky of `radiosity_runtime::daylight` for the sun's new position, lights the
//! same file with them (direct light with shadow rays, the sky through the file's sky
//! visibility, one gather) and renders it; writes `sunset.gif` and `sunset.rad` and prints
//! the per-frame times.

use crate::args::BakeArgs;
use crate::picture::LinearImage;
use anyhow::Context;
use glam::DVec3;
use radiosity_runtime::BakedScene;
use radiosity_runtime::camera::Camera;
use std::path::Path;
use std::time::Instant;

/// The square's OBJ and MTL (`scripts/sunset_scene.py`).
const SQUARE_OBJ: &str = include_str!("../scenes/sunset/square.obj");
const SQUARE_MTL: &str = include_str!("../scenes/sunset/square.mtl");

/// The sun's path: elevation from `START` to `END` degrees while its azimuth swings from
/// south-west of west towards north-west (the image's azimuth convention: 270° is −X).
const START: f32 = 34.0;
const END: f32 = 0.5;
const AZIMUTH: (f32, f32) = (245.0, 280.0);

/// The view: from the square's south-west corner over the arcade, towards the east houses'
/// fronts, which face the setting sun.
fn camera(width: u32, height: u32) -> Camera {
    Camera {
        position: DVec3::new(-16.0, 6.5, -15.0),
        look_at: DVec3::new(16.0, 5.0, 6.0),
        up: DVec3::Y,
        fov_deg: 60.0,
        width,
        height,
    }
}

/// The sun's elevation and azimuth at frame `f` of `frames`: faster near the horizon, where
/// the light changes most.
fn sun_at(f: usize, frames: usize) -> (f32, f32) {
    let t = if frames > 1 {
        f as f32 / (frames - 1) as f32
    } else {
        0.0
    };
    let ease = 1.0 - (1.0 - t).powi(2);
    (
        START + (END - START) * ease,
        AZIMUTH.0 + (AZIMUTH.1 - AZIMUTH.0) * t,
    )
}

pub(crate) fn run(
    out: &Path,
    backend: Option<&str>,
    patches: usize,
    frames: usize,
    size: (u32, u32),
) -> anyhow::Result<()> {
    anyhow::ensure!(
        (1..=600).contains(&frames),
        "--frames must be 1 to 600, not {frames}"
    );
    let args = BakeArgs::with_patches(patches);
    let params = radiosity_bake::pipeline::BakeParams {
        probes: radiosity_bake::passes::probes::ProbeSpec::None,
        ..crate::bake::params(&args)?
    };
    crate::output::create_dir(out)?;
    for name in ["sunset.rad", "sunset.gif"] {
        crate::output::check_file(&out.join(name))?;
    }
    let dir = tempfile::tempdir().context("cannot create a temporary directory")?;
    for (name, text) in [("square.obj", SQUARE_OBJ), ("square.mtl", SQUARE_MTL)] {
        let p = dir.path().join(name);
        std::fs::write(&p, text).with_context(|| format!("cannot write {}", p.display()))?;
    }
    let obj = dir.path().join("square.obj");

    eprintln!("baking the embedded town square (about {patches} patches)…");
    let t = Instant::now();
    let (baked, _) =
        crate::bake::bake_scene(&obj, Some("embedded"), &Default::default(), &params, false)?;
    let bake_s = t.elapsed().as_secs_f64();
    let sky = baked
        .report
        .sky
        .clone()
        .context("the square's sky visibility")?;
    let rad = out.join("sunset.rad");
    crate::output::write_bytes(&rad, &baked.file.to_bytes()?)?;
    outln!(
        "bake: {:.1} s, {} patches, sky visibility of {} patches ({:.1}% of the surface sees the sky, {:.2} s, {} kB)",
        bake_s,
        baked.report.patches,
        sky.open_patches,
        100.0 * sky.open_share,
        sky.seconds,
        sky.bytes / 1000
    );

    let rt = BakedScene::new(baked.file);
    let mut chosen = crate::backend::choose(backend, rt.file.matrix.clone())?;
    let cam = camera(size.0, size.1);
    cam.validate()?;
    let prim = radiosity_runtime::render::primary(&rt, &cam, 1)?;
    let (mut sky_ms, mut light_ms, mut image_ms) = (Vec::new(), Vec::new(), Vec::new());
    let mut images: Vec<LinearImage> = Vec::with_capacity(frames);
    for f in 0..frames {
        let (elevation, azimuth) = sun_at(f, frames);
        let t = Instant::now();
        let lights = radiosity_runtime::daylight::daylight(elevation, azimuth)?;
        sky_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let (frame, _) = rt.frame(chosen.gather.as_mut(), &lights, 1.0)?;
        light_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        images.push(radiosity_runtime::render::shade(
            &rt, &prim, &frame, &lights, 1.0, None,
        )?);
        image_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    // Each frame exposed for itself, as a camera would: the sun's light falls a
    // hundredfold over the sweep, and one exposure would leave the last frames black.
    let gif = out.join("sunset.gif");
    crate::demo::write_gif(&gif, &images, None)?;
    outln!(
        "{}: {} frames {}×{}, the sun from {:.0}° to {:.1}°; per frame: sun and sky {:.2} ms, direct light (sun and sky) + gather {:.2} ms ({}), image {:.0} ms (medians)",
        gif.display(),
        frames,
        size.0,
        size.1,
        START,
        END,
        crate::demo::median(&mut sky_ms),
        crate::demo::median(&mut light_ms),
        chosen.gather.name(),
        crate::demo::median(&mut image_ms)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_sun_sweeps_from_start_to_end() {
        assert_eq!(super::sun_at(0, 24), (super::START, super::AZIMUTH.0));
        let (e, a) = super::sun_at(23, 24);
        assert!((e - super::END).abs() < 1e-5 && (a - super::AZIMUTH.1).abs() < 1e-4);
        // Monotone: the sun only sets.
        let es: Vec<f32> = (0..24).map(|f| super::sun_at(f, 24).0).collect();
        assert!(es.windows(2).all(|w| w[1] < w[0]), "{es:?}");
    }
}
