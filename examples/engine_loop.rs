//! Embedding the runtime in an engine: load a baked `.rad` once, then every frame fill the
//! first-exitance vector from the engine's own lighting, gather, and read per-patch irradiance.
//!
//! ```text
//! cargo run --release -- demo --out out          # bakes out/demo.rad
//! cargo run --release --example engine_loop -- out/demo.rad
//! ```
//!
//! Only `radiosity-core` (file format, frame arithmetic) and a gather backend
//! (`radiosity-backend-cpu`) are needed; the engine keeps its own geometry, shadows and
//! light representation. Here the "engine lighting" is an unshadowed point light that
//! orbits the scene's centre, and the baked emitters flicker.

use radiosity_backend_cpu::CpuGather;
use radiosity_core::{Gather, RadFile, Rgb, finish_frame, first_exitance};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args().nth(1).ok_or(
        "usage: engine_loop BAKED.rad (make one with `radiosity demo` or `radiosity bake`)",
    )?;
    let bytes = std::fs::read(&path)?;
    // Parsing validates every section; the file can then be borrowed without copies.
    let file = RadFile::parse(&bytes)?;
    let n = file.n();
    let mut gather = CpuGather::new(file.matrix.clone());
    println!("{path}: {n} patches, gather {}", gather.name());

    // Scene centre, to put the engine's light somewhere sensible.
    let centre = file
        .patches
        .iter()
        .fold([0.0f32; 3], |a, p| {
            [a[0] + p.centre[0], a[1] + p.centre[1], a[2] + p.centre[2]]
        })
        .map(|c| c / n as f32);

    let (mut direct, mut x, mut y) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    for frame in 0..10 {
        let t = Instant::now();
        // 1. The engine's own direct lighting per patch (its shadow maps would go here).
        let a = frame as f32 * 0.6;
        let light = [
            centre[0] + 0.5 * a.cos(),
            centre[1] + 0.5,
            centre[2] + 0.5 * a.sin(),
        ];
        for (d, p) in direct.iter_mut().zip(file.patches.iter()) {
            let v = [
                light[0] - p.centre[0],
                light[1] - p.centre[1],
                light[2] - p.centre[2],
            ];
            let r2 = v.iter().map(|c| c * c).sum::<f32>().max(1e-6);
            let cos = (v[0] * p.normal[0] + v[1] * p.normal[1] + v[2] * p.normal[2]) / r2.sqrt();
            *d = Rgb::splat(2.0) * (cos.max(0.0) / r2); // 2 W/sr, inverse-square cosine law
        }
        // 2. First exitance x = E + ρ∘H_d (`first_exitance` does exactly this); the baked
        //    emitters may change intensity at run time, here they flicker.
        let flicker = 0.5 + 0.5 * (frame as f32).sin().abs();
        if frame == 0 {
            first_exitance(&file.patches, &direct, &mut x);
        } else {
            for ((xi, p), d) in x.iter_mut().zip(file.patches.iter()).zip(&direct) {
                *xi = p.emission * flicker + p.reflectance * *d;
            }
        }
        // 3. One gather: y = M·x (every bounce, baked).
        gather.gather(&x, &mut y)?;
        // 4. Totals per patch: irradiance H = H_d + y, radiosity B = E + ρ∘H.
        finish_frame(&file.patches, &direct, &y, &mut h, &mut b);
        let brightest = h
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.mean().total_cmp(&b.1.mean()))
            .map(|(i, v)| (i, *v))
            .expect("at least one patch");
        println!(
            "frame {frame}: {:.2} ms, brightest patch {} at {:.3?} W/m²",
            t.elapsed().as_secs_f64() * 1e3,
            brightest.0,
            brightest.1.to_array()
        );
    }
    Ok(())
}
