//! `radiosity solve SCENE.obj|BAKED.rad [--json]`: light a bake and report per object.
//!
//! Light comes from the scene's own emitters and from an optional lights file (`--lights`:
//! direct irradiance with shadow rays through the file's mesh, see `runtime.rs`). The gather is
//! the backend chosen at run time (`--backend`, see `backend.rs`).

use crate::args::BakeArgs;
use radiosity_core::{Bounces, RadFile, Rgb, finish_frame, first_exitance};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

pub(crate) fn run(
    input: &Path,
    args: &BakeArgs,
    lights: Option<&Path>,
    backend: Option<&str>,
    json_out: bool,
) -> anyhow::Result<()> {
    // Read the lights first: a bad lights file fails before any bake.
    let lights = match lights {
        Some(p) => crate::lights::load(p)?,
        None => Vec::new(),
    };
    let crate::runtime::Loaded {
        runtime,
        effects,
        mut timings,
    } = crate::runtime::load(input, args, json_out)?;
    let file = &runtime.file;
    let n = file.n();
    let t = Instant::now();
    let direct = runtime.direct(&lights)?;
    timings.insert("direct", t.elapsed().as_secs_f64() * 1e3);
    let mut x = vec![Rgb::ZERO; n];
    first_exitance(&file.patches, &direct, &mut x);
    // The backend prints its choice: choose it once the input to the gather is known good, so
    // a failure before it stays one `error:` line.
    let mut chosen = crate::backend::choose(backend, file.matrix.clone())?;
    let t = Instant::now();
    let mut y = vec![Rgb::ZERO; n];
    chosen.gather.gather(&x, &mut y)?;
    timings.insert("gather", t.elapsed().as_secs_f64() * 1e3);
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    finish_frame(&file.patches, &direct, &y, &mut h, &mut b);
    crate::runtime::ensure_finite(&h, &b)?;

    let objects = per_object(file, &h, &b);
    if json_out {
        let out = json!({
            "patches": n,
            "lights": lights.len(),
            "bounces": match file.bounces { Bounces::Finite(k) => json!(k), Bounces::Infinite => json!("infinite") },
            "backend": chosen.kind,
            "gather": chosen.gather.name(),
            "objects": objects,
            "effects": effects,
            "timings_ms": timings,
        });
        outln!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        outln!(
            "{} ({n} patches, {} gather {:.2} ms)",
            input.display(),
            chosen.gather.name(),
            timings["gather"]
        );
        outln!(
            "{:<24} {:>12} {:>36} {:>36}",
            "object",
            "area",
            "irradiance W/m² (r g b)",
            "radiosity W/m² (r g b)"
        );
        for o in &objects {
            let v = |k: &str| -> String {
                let a = o[k].as_array().cloned().unwrap_or_default();
                a.iter()
                    .map(|x| format!("{:>11.4}", x.as_f64().unwrap_or(0.0)))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            outln!(
                "{:<24} {:>12.5} {} {}",
                o["name"].as_str().unwrap_or(""),
                o["area"].as_f64().unwrap_or(0.0),
                v("irradiance"),
                v("radiosity")
            );
        }
    }
    // After the results, as every warning: a failure stays the one `error:` line.
    crate::runtime::warn_if_unlit(&runtime, &lights);
    Ok(())
}

/// Area-weighted mean irradiance and radiosity per object. The means are over the object's
/// full-detail area when the bake recorded it (`object_areas` in the file's report): patches
/// that see nothing were dropped from the matrix and receive no light from the scene, so they
/// count with zero irradiance and radiosity. Otherwise over the matrix patches.
fn per_object(file: &RadFile<'_>, h: &[Rgb], b: &[Rgb]) -> Vec<Value> {
    let mut acc = vec![(0f64, [0f64; 3], [0f64; 3]); file.objects.len()];
    for (i, p) in file.patches.iter().enumerate() {
        let a = &mut acc[p.object as usize];
        let w = f64::from(p.area);
        a.0 += w;
        for k in 0..3 {
            a.1[k] += w * f64::from(h[i].channel(k));
            a.2[k] += w * f64::from(b[i].channel(k));
        }
    }
    let recorded: Option<Vec<f64>> = file
        .report
        .as_deref()
        .and_then(|r| serde_json::from_str::<Value>(r).ok())
        .and_then(|r| serde_json::from_value(r["object_areas"].clone()).ok())
        .filter(|a: &Vec<f64>| a.len() == file.objects.len());
    file.objects
        .iter()
        .zip(acc)
        .enumerate()
        .map(|(o, (name, (matrix_area, hs, bs)))| {
            let area = recorded.as_ref().map_or(matrix_area, |a| a[o].max(matrix_area));
            let mean = |s: [f64; 3]| {
                if area > 0.0 {
                    s.map(|v| v / area)
                } else {
                    [0.0; 3]
                }
            };
            json!({ "name": name.as_ref(), "area": area, "irradiance": mean(hs), "radiosity": mean(bs) })
        })
        .collect()
}
