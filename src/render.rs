//! `radiosity render SCENE.obj|BAKED.rad [--lights L] [--camera C] -o OUT.png`: the runtime's
//! ray-cast camera (`radiosity_runtime::render`) over a frame, written as PNG.

use radiosity_runtime::render::{auto_camera, primary, shade};
use std::path::Path;

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
        if s == 0 || s > radiosity_runtime::camera::MAX_SIDE {
            anyhow::bail!(
                "{name} must be 1 to {} pixels, not {s}",
                radiosity_runtime::camera::MAX_SIDE
            );
        }
    }
    // An output that cannot be written is refused before any work.
    crate::output::check_file(output)?;
    let lights = match lights {
        Some(p) => crate::files::lights(p)?,
        None => Vec::new(),
    };
    let (cam_from_file, camera_note) = match camera_file {
        Some(p) => {
            let (cam, note) = crate::files::camera(p)?;
            (Some(cam), note)
        }
        None => (None, None),
    };
    let loaded = crate::scene::load(input, args, false)?;
    let rt = &loaded.runtime;
    rt.mesh("rendering")?;
    let cam = match cam_from_file {
        Some(c) => c,
        None => auto_camera(rt, size.0, size.1)?,
    };
    // Lights that overflow are an error before the backend prints its choice (one line); the
    // direct light computed for that check is the frame's.
    let t = std::time::Instant::now();
    let direct = rt.direct(&lights)?;
    let direct_ms = t.elapsed().as_secs_f64() * 1e3;
    // A level is lit to its steady state through the same frame (its `Gather`).
    let (mut level, mut chosen);
    let gather: &mut dyn radiosity_core::Gather = if rt.file.systems.is_some() {
        level = crate::backend::choose_level(backend, &rt.file, &[])?.0;
        level.gather_mut()
    } else {
        chosen = crate::backend::choose(backend, rt.file.matrix.clone())?;
        chosen.gather.as_mut()
    };
    let t = std::time::Instant::now();
    let (frame, gather_ms) = rt.frame_with_direct(gather, direct, 1.0)?;
    let frame_ms = direct_ms + t.elapsed().as_secs_f64() * 1e3;
    let t = std::time::Instant::now();
    let prim = primary(rt, &cam, spp_side)?;
    let img = shade(rt, &prim, &frame, &lights, 1.0, None)?;
    let render_ms = t.elapsed().as_secs_f64() * 1e3;
    let exposure = exposure.unwrap_or_else(|| img.auto_exposure());
    crate::picture::save_png(&img, output, exposure)?;
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
    crate::scene::warn_if_unlit(rt, &lights);
    Ok(())
}
