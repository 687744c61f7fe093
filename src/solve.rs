//! `radiosity solve SCENE.obj|BAKED.rad [--json]`: light a bake and report per object.
//!
//! Light comes from the scene's own emitters and from an optional lights file (`--lights`:
//! direct irradiance with shadow rays through the file's mesh, see `runtime.rs`). The gather is
//! the backend chosen at run time (`--backend`, see `backend.rs`).

use crate::args::BakeArgs;
use radiosity_bake::pipeline::ObjectShares;
use radiosity_core::{
    Bounces, DecodeMode, EditedGather, Gather, RadFile, ReflectanceEdit, Rgb, finish_frame,
    first_exitance,
};
use serde_json::{Value, json};
use std::path::Path;
use std::time::Instant;

/// The files `solve` reads besides its input.
pub(crate) struct Inputs<'a> {
    pub(crate) lights: Option<&'a Path>,
    pub(crate) materials: Option<&'a Path>,
    pub(crate) points: Option<&'a Path>,
}

pub(crate) fn run(
    input: &Path,
    args: &BakeArgs,
    inputs: Inputs<'_>,
    backend: Option<&str>,
    json_out: bool,
) -> anyhow::Result<()> {
    // Read the lights, edits and points first: a bad file fails before any bake.
    let lights = match inputs.lights {
        Some(p) => crate::lights::load(p)?,
        None => Vec::new(),
    };
    let materials = inputs.materials.map(crate::materials::load).transpose()?;
    let points = inputs.points.map(crate::points::load).transpose()?;
    let crate::runtime::Loaded {
        mut runtime,
        effects,
        mut timings,
    } = crate::runtime::load(input, args, json_out)?;
    let edit = match &materials {
        Some(m) => {
            let t = Instant::now();
            let edit = edit_materials(&mut runtime, m)?;
            timings.insert("edit_setup", t.elapsed().as_secs_f64() * 1e3);
            Some(edit)
        }
        None => None,
    };
    let file = &runtime.file;
    let n = file.n();
    let t = Instant::now();
    let (direct, at_samples) = runtime.direct_with_samples(&lights)?;
    timings.insert("direct", t.elapsed().as_secs_f64() * 1e3);
    let mut x = vec![Rgb::ZERO; n];
    first_exitance(&file.patches, &direct, &mut x);
    // The backend prints its choice: choose it once the input to the gather is known good, so
    // a failure before it stays one `error:` line.
    let mut chosen = crate::backend::choose(backend, file.matrix.clone())?;
    let t = Instant::now();
    let mut y = vec![Rgb::ZERO; n];
    let edit_json = match edit {
        Some(edit) => {
            let summary = json!({
                "objects": materials.as_ref().map_or(0, Vec::len),
                "patches": edit.len(),
                "bytes": edit.bytes(),
            });
            EditedGather::new(&mut *chosen.gather, edit)
                .map_err(|e| anyhow::anyhow!("materials: {e}"))?
                .gather(&x, &mut y)?;
            Some(summary)
        }
        None => {
            chosen.gather.gather(&x, &mut y)?;
            None
        }
    };
    timings.insert("gather", t.elapsed().as_secs_f64() * 1e3);
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    finish_frame(&file.patches, &direct, &y, &mut h, &mut b);
    crate::runtime::ensure_finite(&h, &b)?;

    let objects = per_object(file, &h, &b, &direct, &at_samples);
    let answers = match &points {
        Some(points) => {
            let t = Instant::now();
            let a = crate::points::answer(&runtime, &y, &h, &lights, points)?;
            timings.insert("points", t.elapsed().as_secs_f64() * 1e3);
            Some(points.iter().zip(a).collect::<Vec<_>>())
        }
        None => None,
    };
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
        let mut out = out;
        if let Some(m) = edit_json {
            out["materials"] = m;
        }
        if let Some(answers) = &answers {
            out["points"] = answers
                .iter()
                .map(|(p, a)| point_json(p, *a))
                .collect::<Vec<_>>()
                .into();
        }
        outln!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        outln!(
            "{} ({n} patches, {} gather {:.2} ms)",
            input.display(),
            chosen.gather.name(),
            timings["gather"]
        );
        outln!(
            "{:<24} {:>12} {:>12} {:>36} {:>36}",
            "object",
            "area",
            "exposed",
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
                "{:<24} {:>12.5} {:>12.5} {} {}",
                o["name"].as_str().unwrap_or(""),
                o["area"].as_f64().unwrap_or(0.0),
                o["exposed_area"].as_f64().unwrap_or(0.0),
                v("irradiance"),
                v("radiosity")
            );
        }
    }
    if let (false, Some(answers)) = (json_out, &answers) {
        outln!(
            "{:<44} {:>36}",
            "point (position; normal)",
            "irradiance W/m² (r g b)"
        );
        for (p, a) in answers {
            let q = p.position;
            let n = p.given_normal;
            let what = match a {
                crate::points::Answer::Irradiance { total: e, .. } => {
                    format!("{:>11.4} {:>11.4} {:>11.4}", e.r, e.g, e.b)
                }
                crate::points::Answer::Inside => "inside an object".into(),
                crate::points::Answer::Outside => "outside the scene".into(),
            };
            outln!(
                "{:<44} {:>36}",
                format!(
                    "[{:.3}, {:.3}, {:.3}]; [{:.2}, {:.2}, {:.2}]",
                    q.x, q.y, q.z, n.x, n.y, n.z
                ),
                what
            );
        }
    }
    // After the results, as every warning: a failure stays the one `error:` line.
    crate::runtime::warn_if_unlit(&runtime, &lights);
    Ok(())
}

/// A point's entry in `solve --json`: `irradiance` null and `status` saying why for a point
/// inside an object or outside the scene.
fn point_json(p: &crate::points::Point, a: crate::points::Answer) -> Value {
    use crate::points::Answer;
    let rgb = |e: radiosity_core::Rgb| json!([e.r, e.g, e.b]);
    let (irradiance, status, probes) = match a {
        Answer::Irradiance { total, probes } => (rgb(total), "ok", probes),
        Answer::Inside => (Value::Null, "inside an object", None),
        Answer::Outside => (Value::Null, "outside the scene", None),
    };
    let mut v = json!({
        "position": p.position.to_array(),
        "normal": p.given_normal.to_array(),
        "irradiance": irradiance,
        "status": status,
    });
    if let Some(from_probes) = probes {
        v["probe_irradiance"] = from_probes.map_or(Value::Null, rgb);
        if from_probes.is_none() {
            v["probe_status"] = "outside the probe grid".into();
        }
    }
    v
}

/// Prepares the reflectance edit of `materials` on the runtime's file and sets the new
/// reflectance on its patches and mesh triangles (the frame's first exitance and radiosity
/// take them; the matrix stays as baked). `M_SS` is decoded under the CPU backends' rules.
fn edit_materials(
    runtime: &mut crate::runtime::Runtime,
    materials: &[crate::materials::MaterialEdit],
) -> anyhow::Result<ReflectanceEdit> {
    let file = &mut runtime.file;
    if let Bounces::Finite(k) = file.bounces {
        eprintln!(
            "warning: this .rad holds {k} bounce(s), not all of them; a reflectance edit assumes every bounce, so the edited light is off by about the bounces left out"
        );
    }
    let report: Option<Value> = file
        .report
        .as_deref()
        .and_then(|r| serde_json::from_str(r).ok());
    let shares = ObjectShares::from_report(&file.patches, file.objects.len(), report.as_ref());
    let resolved = crate::materials::patch_edits(file, &shares, materials)?;
    let objects = resolved.objects;
    let edit = ReflectanceEdit::new(
        &file.matrix,
        DecodeMode::D3d10,
        &file.patches,
        &resolved.patches,
    )
    .map_err(|e| anyhow::anyhow!("materials: {e}"))?;
    edit.apply_to(file.patches.to_mut());
    if let Some(mesh) = &mut file.mesh {
        for t in mesh.triangles.to_mut() {
            if let Some(&(_, rho)) = objects.iter().find(|o| o.0 == t.object) {
                t.reflectance = rho;
            }
        }
    }
    Ok(edit)
}

/// Area-weighted mean irradiance and radiosity per object, over its whole full-detail surface
/// (`area`): the part outside the matrix (buried under another object, or a patch that sees
/// nothing and was dropped) receives nothing, so it counts with `H = 0` and `B = E`. The
/// matrix patches' own area is `exposed_area`. The whole surface comes from [`surfaces`].
///
/// A patch of several objects' parts (the report's `shared_patches`) counts to each object
/// with that object's area in it, and with the direct light of that object's own samples in
/// place of the patch's mean (`direct`, per patch, and `at_samples`, per mesh sample): the
/// indirect light is the patch's, shared, but a box in a building's shadow whose top shares a
/// patch with the sunlit ground keeps its own shadow.
fn per_object(
    file: &RadFile<'_>,
    h: &[Rgb],
    b: &[Rgb],
    direct: &[Rgb],
    at_samples: &[Rgb],
) -> Vec<Value> {
    // Per object: matrix area, and Σ A·H, Σ A·B, Σ A·E over its share of the matrix patches.
    let report: Option<Value> = file
        .report
        .as_deref()
        .and_then(|r| serde_json::from_str(r).ok());
    let shares = ObjectShares::from_report(&file.patches, file.objects.len(), report.as_ref());
    let mut acc = vec![(0f64, [0f64; 3], [0f64; 3], [0f64; 3]); file.objects.len()];
    for (i, p) in file.patches.iter().enumerate() {
        let own = own_direct(file, &shares, i, at_samples);
        for (o, w) in shares.of(i) {
            // The object's own direct light less the patch's mean, where it has its own.
            let shift = own
                .iter()
                .find(|d| d.0 == o)
                .map_or(Rgb::ZERO, |d| d.1 - direct[i]);
            let (h, b) = (h[i] + shift, b[i] + p.reflectance * shift);
            let a = &mut acc[o as usize];
            a.0 += w;
            for k in 0..3 {
                a.1[k] += w * f64::from(h.channel(k));
                a.2[k] += w * f64::from(b.channel(k));
                a.3[k] += w * f64::from(p.emission.channel(k));
            }
        }
    }
    let whole = surfaces(file, report.as_ref());
    file.objects
        .iter()
        .zip(acc)
        .enumerate()
        .map(|(o, (name, (exposed, hs, bs, es)))| {
            let (area, power) = whole.as_ref().map_or((exposed, None), |w| w[o]);
            // Rounding (f32 patch areas) may put the matrix a hair above the whole surface.
            let area = area.max(exposed);
            let mut bs = bs;
            if let Some(power) = power.filter(|_| area > exposed) {
                for k in 0..3 {
                    bs[k] += (power[k] - es[k]).max(0.0);
                }
            }
            let mean = |s: [f64; 3]| {
                if area > 0.0 {
                    s.map(|v| v / area)
                } else {
                    [0.0; 3]
                }
            };
            json!({
                "name": name.as_ref(),
                "area": area,
                "exposed_area": exposed,
                "irradiance": mean(hs),
                "radiosity": mean(bs),
            })
        })
        .collect()
}

/// The direct irradiance of each object's own samples in shared patch `i` (area-weighted
/// means, `(object, irradiance)`); empty for a patch of one object, without lights or mesh, or
/// where the report's sample objects do not match the mesh's samples.
fn own_direct(
    file: &RadFile<'_>,
    shares: &ObjectShares<'_>,
    i: usize,
    at_samples: &[Rgb],
) -> Vec<(u32, Rgb)> {
    let (Some(objects), Some(mesh)) = (shares.sample_objects(i), file.mesh.as_ref()) else {
        return Vec::new();
    };
    let samples = mesh.samples_of(i);
    let start = mesh.sample_rows[i] as usize;
    let Some(at) = at_samples.get(start..start + samples.len()) else {
        return Vec::new();
    };
    if objects.len() != samples.len() {
        return Vec::new();
    }
    let mut sums: Vec<(u32, Rgb, f32)> = Vec::new();
    for ((s, &o), &d) in samples.iter().zip(objects).zip(at) {
        match sums.iter_mut().find(|e| e.0 == o) {
            Some(e) => {
                e.1 += d * s.area;
                e.2 += s.area;
            }
            None => sums.push((o, d * s.area, s.area)),
        }
    }
    sums.into_iter()
        .filter(|e| e.2 > 0.0)
        .map(|(o, d, a)| (o, d * (1.0 / a)))
        .collect()
}

/// Each object's whole full-detail area and the power it emits over it (file object order),
/// from the first source the file has: the bake report's `object_surface_areas` and
/// `object_emitted_power`; else the file's full-detail mesh (files baked before those fields);
/// else the report's `object_areas` (the full-detail area less the buried part) with no power
/// (nothing counted as emitted outside the matrix); and `None` without any of them: the matrix
/// patches are then the whole surface.
fn surfaces(file: &RadFile<'_>, report: Option<&Value>) -> Option<Vec<(f64, Option<[f64; 3]>)>> {
    let n = file.objects.len();
    let field = |key: &str| report.map(|r| r[key].clone());
    // A figure per object, each finite and not negative, or none.
    let good = |v: &f64| v.is_finite() && *v >= 0.0;
    let areas: Option<Vec<f64>> = field("object_surface_areas")
        .and_then(|v| serde_json::from_value(v).ok())
        .filter(|a: &Vec<f64>| a.len() == n && a.iter().all(good));
    let power: Option<Vec<[f64; 3]>> = field("object_emitted_power")
        .and_then(|v| serde_json::from_value(v).ok())
        .filter(|p: &Vec<[f64; 3]>| p.len() == n && p.iter().flatten().all(good));
    if let (Some(areas), Some(power)) = (areas, power) {
        return Some(areas.into_iter().zip(power.into_iter().map(Some)).collect());
    }
    if let Some(mesh) = &file.mesh {
        let mut w = vec![(0.0, [0.0; 3]); n];
        let at = |v: u32| {
            mesh.positions
                .get(v as usize)
                .map(|p| glam::DVec3::from(p.map(f64::from)))
        };
        for t in mesh.triangles.iter() {
            let (Some(a), Some(b), Some(c)) =
                (at(t.vertices[0]), at(t.vertices[1]), at(t.vertices[2]))
            else {
                continue;
            };
            let Some(o) = w.get_mut(t.object as usize) else {
                continue;
            };
            let area = 0.5 * (b - a).cross(c - a).length();
            o.0 += area;
            for k in 0..3 {
                o.1[k] += area * f64::from(t.emission.channel(k));
            }
        }
        return Some(w.into_iter().map(|(a, p)| (a, Some(p))).collect());
    }
    field("object_areas")
        .and_then(|v| serde_json::from_value(v).ok())
        .filter(|a: &Vec<f64>| a.len() == n && a.iter().all(good))
        .map(|a| a.into_iter().map(|a| (a, None)).collect())
}
