//! `radiosity render SCENE.obj|BAKED.rad [--lights L] [--camera C] -o OUT.png`: the runtime's
//! ray-cast camera (`radiosity_runtime::render`) over a frame, written as PNG.

use crate::args::BakeArgs;
use radiosity_runtime::render::{auto_camera, primary, shade};
use std::path::PathBuf;

/// The flags of `radiosity render`.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct RenderArgs {
    /// A scene, OBJ or glTF 2.0 (.gltf/.glb; baked first, with the bake flags), or a .rad
    /// file.
    pub(crate) input: PathBuf,
    #[command(flatten)]
    pub(crate) bake: BakeArgs,
    /// Analytic lights added to the scene's emitters (JSON; every field:
    /// docs/examples/lights.json).
    ///
    /// {"lights": [...]}, each light one of {"type": "point", "position": [x,y,z],
    /// "intensity": [r,g,b]}, {"type": "spot", "position", "direction": [x,y,z] (the cone's
    /// axis), "cone_deg": the cone's half-angle in degrees, in (0, 180], "intensity"} or
    /// {"type": "directional", "direction" (the way the light travels), "irradiance":
    /// [r,g,b]}. Every field required; positions in scene units, intensity in W/sr,
    /// irradiance in W/m² on a surface facing the light.
    #[arg(long, value_name = "LIGHTS.json")]
    pub(crate) lights: Option<PathBuf>,
    /// Camera (JSON; every field: docs/examples/camera.json); default: framed
    /// automatically.
    ///
    /// {"position": [x,y,z], "look_at": [x,y,z]} (scene units), and optionally "up"
    /// (default [0,1,0]), "fov_deg" (the vertical field of view in degrees, in (0, 180),
    /// default 40), "width" and "height" (pixels, 1 to 8192, default 512 each: a camera
    /// file sets the size, not --width and --height).
    #[arg(long, value_name = "CAMERA.json")]
    pub(crate) camera: Option<PathBuf>,
    /// Where to write the PNG (written atomically).
    #[arg(short, long)]
    pub(crate) output: PathBuf,
    /// Image width when the camera is framed automatically.
    #[arg(long, default_value_t = 512, allow_negative_numbers = true)]
    pub(crate) width: u32,
    /// Image height when the camera is framed automatically.
    #[arg(long, default_value_t = 512, allow_negative_numbers = true)]
    pub(crate) height: u32,
    /// Antialiasing: N×N camera samples per pixel (1 to 8).
    #[arg(long, default_value_t = 2, allow_negative_numbers = true)]
    pub(crate) aa: u32,
    /// Exposure: the factor on linear radiance before tone mapping (default: automatic,
    /// the 99th percentile of luminance to 0.8; the value used is printed). Give `render`
    /// and `pathtrace` the same value to compare their images.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) exposure: Option<f32>,
    /// Gather backend: auto, cpu, gpu or reference (default: $RADIOSITY_BACKEND, else auto).
    #[arg(long)]
    pub(crate) backend: Option<String>,
}

/// The `render` command.
pub(crate) fn run(a: &RenderArgs) -> anyhow::Result<()> {
    let (input, args, output) = (a.input.as_path(), &a.bake, a.output.as_path());
    let (size, spp_side, exposure) = ((a.width, a.height), a.aa, a.exposure);
    let (lights, camera_file, backend) = (
        a.lights.as_deref(),
        a.camera.as_deref(),
        a.backend.as_deref(),
    );
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
    let (direct, at) = rt.direct_with_samples(&lights)?;
    let bounce = rt.first_bounce(&direct, &at);
    let direct_ms = t.elapsed().as_secs_f64() * 1e3;
    // A level is lit to its steady state through the same frame (its `Gather`).
    let (mut level, mut chosen);
    let gather: &mut dyn radiosity_core::Gather = if rt.file.systems.is_some() {
        level = crate::backend::choose_level(backend, &rt.file, &[])?.light;
        level.gather_mut()
    } else {
        chosen = crate::backend::choose(backend, rt.file.matrix.clone())?;
        chosen.gather.as_mut()
    };
    let t = std::time::Instant::now();
    let (frame, gather_ms) = rt.frame_with_direct(gather, direct, bounce, 1.0)?;
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
