//! `radiosity pathtrace SCENE.obj [--lights F] [--samples N] [--seed S] [--json]
//! [--camera CAMERA.json] [-o IMAGE.png] [--spp N]`: the reference solution of a scene, per
//! object with standard errors, and optionally an image.

use anyhow::bail;
use clap::Args;
use radiosity_pathtrace::{ObjectEstimate, PathTracer};
use radiosity_runtime::camera::Camera;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Largest `--samples` accepted: 2^32 paths per object would take days, a typo not a wish.
const MAX_SAMPLES: usize = 1 << 32;

/// The flags of `radiosity pathtrace`.
#[derive(Args, Clone, Debug)]
pub(crate) struct PathtraceArgs {
    /// The scene file: OBJ (+ MTL), or glTF 2.0 (.gltf or .glb).
    scene: PathBuf,
    /// Analytic lights (JSON, as `solve --lights`: docs/examples/lights.json); the scene's own
    /// emitters always shine.
    #[arg(long, value_name = "LIGHTS.json")]
    lights: Option<PathBuf>,
    /// Sample points (one path each) per object; the standard error falls as 1/√N.
    #[arg(long, default_value_t = 16384)]
    samples: usize,
    /// Seed of the random numbers: the same seed gives the same numbers on any thread count.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON: {"samples_per_object", "seed", "objects":[{"name", "area", "exposed_area",
    /// "irradiance", "radiosity", "stderr", "radiosity_stderr"}], "image", "timings_ms"}.
    #[arg(long)]
    json: bool,
    /// Camera file for the image (JSON, as `render --camera`: docs/examples/camera.json);
    /// without one the camera frames the scene (512×512).
    #[arg(long, value_name = "CAMERA.json")]
    camera: Option<PathBuf>,
    /// Also render an image (tone-mapped PNG, automatic exposure).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Paths per pixel of the image [default: 64].
    #[arg(long)]
    spp: Option<u32>,
    /// Exposure of the image: the factor on linear radiance before tone mapping (default:
    /// automatic, as `render`'s); give both the same value to compare their images.
    #[arg(long, allow_negative_numbers = true)]
    exposure: Option<f32>,
    /// Lower reflectances (MTL Kd, glTF baseColorFactor, times the texture) at or above R, in
    /// (0, 1), to R (default: those at or above 1 to 0.95), as `bake --max-reflectance`, so both
    /// see the same scene
    #[arg(long, value_name = "R")]
    max_reflectance: Option<f64>,
    /// Points at which to estimate the irradiance, `--samples` paths each (JSON, as `solve
    /// --points`); `--json` then gains "points": [{"position", "normal", "irradiance",
    /// "stderr"}].
    #[arg(long, value_name = "POINTS.json")]
    points: Option<std::path::PathBuf>,
}

/// Refuses flags that contradict each other or are out of range, before any work.
fn check_args(args: &PathtraceArgs) -> anyhow::Result<()> {
    if args.samples < 2 {
        bail!(
            "--samples must be at least 2 (a standard error needs two), not {}",
            args.samples
        );
    }
    if args.samples > MAX_SAMPLES {
        bail!(
            "--samples must be at most {MAX_SAMPLES}, not {}",
            args.samples
        );
    }
    if args.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    if args.output.is_none()
        && (args.camera.is_some() || args.spp.is_some() || args.exposure.is_some())
    {
        bail!("--camera, --spp and --exposure describe the image: give -o IMAGE.png too");
    }
    Ok(())
}

/// What `pathtrace` measured: per object, per point, the image, and the time of each step.
struct Traced {
    objects: Vec<ObjectEstimate>,
    /// Per point: irradiance and its standard error.
    points: Option<Vec<([f64; 3], [f64; 3])>>,
    /// The image's JSON (`null` without `-o`).
    image: serde_json::Value,
    timings: serde_json::Map<String, serde_json::Value>,
}

pub(crate) fn run(args: &PathtraceArgs) -> anyhow::Result<()> {
    check_args(args)?;
    crate::picture::check_exposure(args.exposure)?;
    if let Some(out) = &args.output {
        crate::output::check_file(out)?;
    }
    let (camera, camera_note) = match args.camera.as_deref() {
        Some(p) => {
            let (cam, note) = crate::files::camera(p)?;
            (Some(cam), note)
        }
        None => (None, None),
    };
    let lights = match &args.lights {
        Some(p) => crate::files::lights(p)?,
        None => Vec::new(),
    };
    let points = args
        .points
        .as_deref()
        .map(crate::files::points)
        .transpose()?;
    let traced = trace(args, &lights, points.as_deref(), camera)?;
    if args.json {
        print_json(args, lights.len(), points.as_deref(), traced)?;
    } else {
        print_text(args, points.as_deref(), &traced);
    }
    if let Some(note) = camera_note {
        eprintln!("note: {note}");
    }
    Ok(())
}

/// Loads the scene and path traces it: per object, at the points, and the image (with `-o`).
fn trace(
    args: &PathtraceArgs,
    lights: &[radiosity_core::Light],
    points: Option<&[radiosity_runtime::points::Point]>,
    camera: Option<Camera>,
) -> anyhow::Result<Traced> {
    let mut timings = serde_json::Map::new();
    let mut lap = |name: &str, t: Instant| {
        timings.insert(name.into(), json!(t.elapsed().as_secs_f64() * 1e3));
    };
    let t = Instant::now();
    let load = crate::bake::capped_loading(args.max_reflectance)?;
    let scene = crate::bake::load_scene(&args.scene, &load)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    lap("load", t);
    let t = Instant::now();
    let tracer = PathTracer::new(&scene, lights).map_err(anyhow::Error::msg)?;
    lap("build", t);
    let t = Instant::now();
    let objects = tracer.object_irradiance(args.samples, args.seed);
    lap("objects", t);
    let point_estimates = points.map(|points| {
        let t = Instant::now();
        let at: Vec<_> = points.iter().map(|p| (p.position, p.normal)).collect();
        let e = tracer.point_irradiance(&at, args.samples, args.seed);
        lap("points", t);
        e
    });
    let mut image = serde_json::Value::Null;
    if let Some(out) = &args.output {
        let camera = camera.unwrap_or_else(|| {
            Camera::frame(&tracer.triangle_corners(), tracer.occluders(), 512, 512)
        });
        let spp = args.spp.unwrap_or(64);
        let t = Instant::now();
        let img = tracer.render(&camera, spp, args.seed);
        lap("render", t);
        let exposure = args.exposure.unwrap_or_else(|| img.auto_exposure());
        crate::picture::save_png(&img, out, exposure)?;
        image = json!({
            "path": out.display().to_string(),
            "width": camera.width,
            "height": camera.height,
            "spp": spp,
            "exposure": exposure,
        });
    }
    Ok(Traced {
        objects,
        points: point_estimates,
        image,
        timings,
    })
}

/// `pathtrace --json`.
fn print_json(
    args: &PathtraceArgs,
    lights: usize,
    points: Option<&[radiosity_runtime::points::Point]>,
    traced: Traced,
) -> anyhow::Result<()> {
    let mut out = json!({
        "samples_per_object": args.samples,
        "seed": args.seed,
        "lights": lights,
        "objects": traced.objects.iter().map(object_json).collect::<Vec<_>>(),
        "image": traced.image,
        "timings_ms": traced.timings,
    });
    if let (Some(points), Some(estimates)) = (points, &traced.points) {
        out["points"] = points
            .iter()
            .zip(estimates)
            .map(|(p, (h, se))| {
                json!({
                    "position": p.position.to_array(),
                    "normal": p.given_normal.to_array(),
                    "irradiance": h,
                    "stderr": se,
                })
            })
            .collect::<Vec<_>>()
            .into();
    }
    outln!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}

/// `pathtrace`'s text: one line an object, one a point, the image's path.
fn print_text(
    args: &PathtraceArgs,
    points: Option<&[radiosity_runtime::points::Point]>,
    traced: &Traced,
) {
    outln!(
        "{} (path traced, {} samples per object, seed {}, {:.0} ms)",
        args.scene.display(),
        args.samples,
        args.seed,
        traced.timings["objects"].as_f64().unwrap_or(0.0)
    );
    outln!(
        "{:<24} {:>12} {:>12} {:>52} {:>36}",
        "object",
        "area",
        "exposed",
        "irradiance W/m² (r g b) ± standard error",
        "radiosity W/m² (r g b)"
    );
    for o in &traced.objects {
        let h: Vec<String> = (0..3)
            .map(|c| format!("{:>9.4} ±{:<7.2e}", o.irradiance[c], o.stderr[c]))
            .collect();
        let b: Vec<String> = o.radiosity.iter().map(|v| format!("{v:>11.4}")).collect();
        outln!(
            "{:<24} {:>12.5} {:>12.5} {} {}",
            o.name,
            o.area,
            o.exposed_area,
            h.join(" "),
            b.join(" ")
        );
    }
    if let (Some(points), Some(estimates)) = (points, &traced.points) {
        for (p, (h, se)) in points.iter().zip(estimates) {
            let q = p.position;
            outln!(
                "point [{:.3}, {:.3}, {:.3}]: {:.4} ±{:.2e} {:.4} ±{:.2e} {:.4} ±{:.2e}",
                q.x,
                q.y,
                q.z,
                h[0],
                se[0],
                h[1],
                se[1],
                h[2],
                se[2]
            );
        }
    }
    if let Some(out) = &args.output {
        outln!("image: {}", out.display());
    }
}

/// The `solve --json` object shape plus the standard errors.
fn object_json(o: &ObjectEstimate) -> serde_json::Value {
    json!({
        "name": o.name,
        "area": o.area,
        "exposed_area": o.exposed_area,
        "irradiance": o.irradiance,
        "radiosity": o.radiosity,
        "stderr": o.stderr,
        "radiosity_stderr": o.radiosity_stderr,
    })
}
