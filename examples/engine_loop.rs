//! An engine's whole loop through the library crates: bake a scene (or load a `.rad`), then
//! every frame light it with a moving point light **with shadows**, gather, carry the light to
//! the mesh's corners, and query the irradiance at a point.
//!
//! ```text
//! cargo run --release --example engine_loop -- scenes/cornell-box/CornellBox-Original.obj
//! cargo run --release --example engine_loop -- out/demo.rad
//! ```
//!
//! - `radiosity-bake`'s host API bakes with a progress callback (an editor's progress bar; a
//!   `false` from it would cancel the bake and leave nothing behind).
//! - `radiosity-runtime`'s `BakedScene` holds the file and the ray caster over its full-detail
//!   mesh: direct light per patch with shadow rays, and the irradiance at any point.
//! - `radiosity-backend-cpu` gathers (`radiosity-backend-wgpu` is a drop-in).

use radiosity_backend_cpu::CpuGather;
use radiosity_bake::host::{BakeFlags, bake_file};
use radiosity_core::{Gather, Light, RadFile, Rgb, finish_frame, first_exitance};
use radiosity_runtime::BakedScene;
use radiosity_runtime::points::{Answer, Point};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let input = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: engine_loop SCENE.obj|SCENE.gltf|BAKED.rad")?,
    );
    // 1. Bake (an editor would do this once and ship the .rad).
    let rad = if input.extension().is_some_and(|e| e == "rad") {
        input
    } else {
        let out = std::env::temp_dir().join("engine_loop.rad");
        let flags = BakeFlags::from_json(r#"{"patches": 1024, "probes": "none"}"#)?;
        let mut shown = 0.0;
        let baked = bake_file(&input, &out, &flags, &mut |stage, done| {
            if done >= shown + 0.1 || done == 1.0 {
                shown = done;
                println!("bake: {stage} {:.0}%", 100.0 * done);
            }
            true // false cancels the bake
        })?;
        println!(
            "baked {} patches into {}",
            baked.report.patches,
            out.display()
        );
        out
    };
    run(&rad)
}

fn run(rad: &Path) -> Result<(), Box<dyn std::error::Error>> {
    // 2. Load once: the file and the BVH over its full-detail mesh.
    let bytes = std::fs::read(rad)?;
    let rt = BakedScene::new(RadFile::parse(&bytes)?.into_owned());
    let n = rt.file.n();
    let mut gather = CpuGather::new(rt.file.matrix.clone());
    let mesh = rt.mesh("the corner light")?;
    let (lo, hi) = rt.mesh_bounds().ok_or("the mesh has no vertices")?;
    let centre = (lo + hi) * 0.5;
    println!("{}: {n} patches, gather {}", rad.display(), gather.name());

    let (mut x, mut y) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    let mut corners = vec![Rgb::ZERO; mesh.corner_count()];
    // A meter lying at the centre of the scene's box, facing up.
    let meter = [Point {
        position: centre,
        normal: glam::DVec3::Y,
        given_normal: glam::DVec3::Y,
    }];
    for frame in 0..10 {
        let t = Instant::now();
        // 3. The engine's light of this frame: 2 W/sr orbiting above the centre.
        let a = frame as f64 * 0.6;
        let size = (hi - lo).max_element();
        let at = centre + glam::DVec3::new(a.cos(), 1.0, a.sin()) * (0.25 * size);
        let lights = [Light::Point {
            position: at.as_vec3(),
            intensity: Rgb::splat(2.0),
        }];
        // 4. Direct light per patch with shadow rays, first exitance, gather, totals.
        let direct = rt.direct(&lights)?;
        first_exitance(&rt.file.patches, &direct, &mut x); // x = E + ρ∘H_d
        gather.gather(&x, &mut y)?; // y = M·x, every bounce
        finish_frame(&rt.file.patches, &direct, &y, &mut h, &mut b); // H = H_d + y, B = E + ρ∘H
        // 5. The indirect light at the mesh's corners (a vertex attribute for the shader).
        mesh.corner_indirect(&y, &mut corners)?;
        let frame_ms = t.elapsed().as_secs_f64() * 1e3;
        // 6. A query: the total irradiance at the meter (a final gather: milliseconds, not a
        //    per-frame cost for many points).
        let t = Instant::now();
        let answer = radiosity_runtime::points::answer(&rt, &y, &h, &lights, &meter)?;
        let reading = match answer[0] {
            Answer::Irradiance { total, .. } => format!("{:.3?} W/m²", total.to_array()),
            Answer::Inside => "inside an object".into(),
            Answer::Outside => "outside the scene".into(),
        };
        println!(
            "frame {frame}: {frame_ms:.2} ms (direct with shadows, gather, corners); meter {reading} in {:.0} ms",
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    Ok(())
}
