//! A small wgpu "engine" that keeps the whole frame on its own GPU: it draws a baked `.rad`'s
//! full-detail mesh with a render pipeline, lit by a point light that moves over the frames
//! and by the baked indirect light, all on one device and one queue.
//!
//! ```text
//! cargo run --release -- demo --out out          # bakes out/demo.rad
//! cargo run --release --example gpu_engine -- out/demo.rad --camera CAMERA.json --frames 8 --out frames
//! ```
//!
//! Every frame:
//!
//! 1. **CPU**: the point light's direct irradiance per patch, averaged over the patch's
//!    samples with one shadow ray each through a BVH over the file's mesh (as `radiosity
//!    render` does), and the first exitance `x = E + ρ∘H_d`, written into a GPU buffer.
//! 2. **GPU, one encoder**: the gather `y = M·x` ([`HostGather`], on the engine's device, into
//!    the engine's buffer), the corner pass ([`CornerPass`]: per-corner indirect irradiance
//!    into a vertex buffer), a cube shadow map of the light (six faces, distance to the light),
//!    and the main pass: per pixel, the light's inverse-square cosine law shadowed by the cube
//!    map, plus the corners' indirect light interpolated across each triangle; radiance
//!    `(E + ρ∘H)/π` into a float texture. A level file (`.rad` cut into systems) takes
//!    [`HostLevel`] in place of the gather: four level frames a draw (every system's gather and
//!    the light between systems, on the same device), each picture within 0.01% of its light's
//!    steady state.
//! 3. The texture is read back and written as `DIR/frame-NNN.png` with `radiosity render`'s
//!    exposure and tone map (99th percentile of luminance to 0.8, extended Reinhard with
//!    white 4, sRGB); `DIR/lights-NNN.json` is the frame's light as a lights file, so that
//!    `radiosity render BAKED.rad --lights DIR/lights-NNN.json --camera CAMERA.json --aa 1`
//!    draws the same frame by ray casting.
//!
//! The camera file is `radiosity render`'s (`position`, `look_at`, optional `up`, `fov_deg`,
//! `width`, `height`). The light orbits the centre of the mesh's bounds, a fifth of the way
//! down from the top, at a third of the horizontal half-extent.
//!
//! The files: `camera` (the camera file, the light, the direct light per patch on the CPU),
//! `device` (the adapter and device), `pipelines` (`gpu_engine.wgsl`'s render pipelines),
//! `renderer` (buffers, passes, targets and the frame on the GPU), `picture` (tone map and
//! output files).

mod camera;
mod device;
mod picture;
mod pipelines;
mod renderer;

use camera::{Camera, direct_per_patch, light_at};
use glam::{DVec3, Vec3};
use radiosity_bake::geometry::Occluders;
use radiosity_core::{Light, RadFile, Rgb, first_exitance};
use renderer::Renderer;
use std::error::Error;
use std::path::PathBuf;

type Result<T> = std::result::Result<T, Box<dyn Error>>;

/// What the command line asks for.
pub(crate) struct Options {
    pub(crate) rad: PathBuf,
    pub(crate) camera: PathBuf,
    pub(crate) frames: u32,
    pub(crate) out: PathBuf,
}

impl Options {
    /// `BAKED.rad --camera CAMERA.json [--frames N] --out DIR`.
    pub(crate) fn parse(args: &[String]) -> Result<Self> {
        let usage = "usage: gpu_engine BAKED.rad --camera CAMERA.json [--frames N] --out DIR";
        let (mut rad, mut camera, mut frames, mut out) = (None, None, 8, None);
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let mut value = || {
                it.next()
                    .ok_or_else(|| format!("{a} needs a value; {usage}"))
            };
            match a.as_str() {
                "--camera" => camera = Some(PathBuf::from(value()?)),
                "--out" => out = Some(PathBuf::from(value()?)),
                "--frames" => {
                    let v = value()?;
                    frames = v
                        .parse()
                        .ok()
                        .filter(|f| (1..=10_000).contains(f))
                        .ok_or_else(|| format!("--frames must be 1 to 10000, not {v:?}"))?;
                }
                s if s.starts_with("--") => {
                    return Err(format!("unknown option {s}; {usage}").into());
                }
                s if rad.is_none() => rad = Some(PathBuf::from(s)),
                s => return Err(format!("unexpected argument {s:?}; {usage}").into()),
            }
        }
        Ok(Options {
            rad: rad.ok_or(usage)?,
            camera: camera.ok_or(usage)?,
            frames,
            out: out.ok_or(usage)?,
        })
    }
}

/// Renders the frames and writes them (module docs). Returns the PNG paths.
pub(crate) fn run(options: &Options) -> Result<Vec<PathBuf>> {
    let bytes = std::fs::read(&options.rad)
        .map_err(|e| format!("cannot read {}: {e}", options.rad.display()))?;
    let file = RadFile::parse(&bytes).map_err(|e| format!("{}: {e}", options.rad.display()))?;
    let mesh = file
        .mesh
        .as_ref()
        .ok_or("this .rad file has no mesh section; bake it again with this version")?;
    let cam = Camera::load(&options.camera)?;
    std::fs::create_dir_all(&options.out)
        .map_err(|e| format!("cannot create {}: {e}", options.out.display()))?;
    let n = file.n();
    let tris: Vec<[DVec3; 3]> = (0..mesh.triangles.len())
        .map(|t| mesh.corners(t).map(|c| Vec3::from(c).as_dvec3()))
        .collect();
    let occ = Occluders::from_triangles(&tris);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in mesh.positions.iter() {
        lo = lo.min(Vec3::from(*p));
        hi = hi.max(Vec3::from(*p));
    }
    let (device, queue, adapter) = device::open()?;
    eprintln!(
        "{}: {n} patches, {} triangles on {adapter}",
        options.rad.display(),
        mesh.triangles.len(),
    );
    let renderer = Renderer::new(&device, &queue, &file, mesh, (cam.width, cam.height))?;

    // Depth range of both projections: the whole scene from anywhere inside its bounds.
    let extent = (hi - lo).length().max(1e-6);
    let far = 4.0 * extent + (cam.position - (lo + hi) * 0.5).length();
    let near = 1e-3 * extent;
    let mut x = vec![Rgb::ZERO; n];
    let mut written = Vec::new();
    for f in 0..options.frames {
        let light = light_at(lo, hi, f, options.frames);
        let Light::Point {
            position,
            intensity,
        } = light
        else {
            unreachable!("light_at makes point lights")
        };
        // 1. CPU: the light's direct irradiance per patch and the first exitance.
        let t = std::time::Instant::now();
        let direct = direct_per_patch(mesh, &occ, &light, n);
        first_exitance(&file.patches, &direct, &mut x);
        renderer.write_x(&queue, &x);
        let cpu_ms = t.elapsed().as_secs_f64() * 1e3;
        renderer.write_light(
            &queue,
            (position, intensity),
            cam.view_proj(near, far),
            (near, far),
        );

        // 2. GPU: gather, corner pass, shadow cube, image; one encoder, one submission.
        let t = std::time::Instant::now();
        let pixels = renderer.draw(&device, &queue)?;
        let gpu_ms = t.elapsed().as_secs_f64() * 1e3;

        // 3. The picture: tone mapped, written with the frame's lights file.
        let size = (cam.width, cam.height);
        let png = picture::write_frame(&options.out, f, &pixels, size, position, intensity)?;
        let [px, py, pz] = position.to_array();
        eprintln!(
            "frame {f}: light at [{px:.3}, {py:.3}, {pz:.3}], direct light {cpu_ms:.1} ms, GPU frame and readback {gpu_ms:.1} ms, wrote {}",
            png.display()
        );
        written.push(png);
    }
    Ok(written)
}

/// Whether `adapter` can render to the example's float targets (Mesa's GL adapter cannot).
pub(crate) fn renders_float(adapter: &wgpu::Adapter) -> bool {
    [
        wgpu::TextureFormat::R32Float,
        wgpu::TextureFormat::Rgba32Float,
    ]
    .iter()
    .all(|&f| {
        adapter
            .get_texture_format_features(f)
            .allowed_usages
            .contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
    })
}

#[allow(
    dead_code,
    reason = "the comparison test includes this file as a module and calls `run`"
)]
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Err(e) = Options::parse(&args).and_then(|o| run(&o)) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
