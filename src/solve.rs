//! `radiosity solve SCENE.obj|BAKED.rad [--json]`: light a bake and report per object.
//!
//! Light comes from the scene's own emitters and from an optional lights file (`--lights`:
//! direct irradiance with shadow rays through the file's mesh, see `runtime.rs`). The gather is
//! the backend chosen at run time (`--backend`, see `backend.rs`).

use crate::args::BakeArgs;
use radiosity_bake::pipeline::ObjectShares;
use radiosity_core::{
    Bounces, DecodeMode, EditedGather, Gather, ReflectanceEdit, Rgb, finish_frame, first_exitance,
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

/// A level's steady state: the relative change of the exitance in a frame at most this.
const LEVEL_TOLERANCE: f32 = 1e-4;
/// A level's frames at most.
const LEVEL_MAX_FRAMES: usize = 100;

pub(crate) fn run(
    input: &Path,
    args: &BakeArgs,
    inputs: Inputs<'_>,
    backend: Option<&str>,
    json_out: bool,
) -> anyhow::Result<()> {
    // Read the lights, edits and points first: a bad file fails before any bake.
    let lights = match inputs.lights {
        Some(p) => crate::files::lights(p)?,
        None => Vec::new(),
    };
    let materials = inputs.materials.map(crate::files::materials).transpose()?;
    let points = inputs.points.map(crate::files::points).transpose()?;
    let crate::scene::Loaded {
        mut runtime,
        effects,
        mut timings,
    } = crate::scene::load(input, args, json_out)?;
    let (edit, mut edited_level) = match &materials {
        Some(m) => {
            let t = Instant::now();
            let edit = edit_materials(&mut runtime, m, backend)?;
            timings.insert("edit_setup", t.elapsed().as_secs_f64() * 1e3);
            match edit {
                EditSetup::One(e) => (Some(*e), None),
                EditSetup::Level(level) => (None, Some(*level)),
            }
        }
        None => (None, None),
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
    let mut y = vec![Rgb::ZERO; n];
    let (kind, gather_name, edit_json, systems_json);
    let t;
    if file.systems.is_some() {
        // A level: each system's CPU gather, lit block by block to the steady state.
        let ((mut level, chosen, name), edited) = match edited_level.take() {
            Some((level, summary)) => (level, Some(summary)),
            None => (crate::backend::choose_level(backend, file, &[])?, None),
        };
        t = Instant::now();
        let frames = level.steady(&x, LEVEL_TOLERANCE, LEVEL_MAX_FRAMES)?;
        y.copy_from_slice(level.gathered());
        kind = chosen;
        gather_name = name;
        edit_json = edited;
        systems_json = Some(json!({
            "count": level.count(),
            "frames": frames,
            "change": level.change(),
            "frame_ms": t.elapsed().as_secs_f64() * 1e3 / frames.max(1) as f64,
        }));
    } else {
        let mut chosen = crate::backend::choose(backend, file.matrix.clone())?;
        t = Instant::now();
        edit_json = match edit {
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
        kind = chosen.kind;
        gather_name = chosen.gather.name().to_owned();
        systems_json = None;
    }
    timings.insert("gather", t.elapsed().as_secs_f64() * 1e3);
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    finish_frame(&file.patches, &direct, &y, &mut h, &mut b);
    radiosity_runtime::scene::ensure_finite(&h, &b)?;

    let objects: Vec<Value> = radiosity_runtime::objects::per_object(
        file,
        &h,
        &b,
        &direct,
        &at_samples,
        radiosity_core::sky_sh_of(&lights).as_ref(),
    )
    .iter()
    .map(serde_json::to_value)
    .collect::<Result<_, _>>()?;
    let answers = match &points {
        Some(points) => {
            let t = Instant::now();
            let a = radiosity_runtime::points::answer(&runtime, &y, &h, &lights, points)?;
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
            "backend": kind,
            "gather": gather_name,
            "objects": objects,
            "effects": effects,
            "timings_ms": timings,
        });
        let mut out = out;
        if let Some(m) = edit_json {
            out["materials"] = m;
        }
        if let Some(sys) = systems_json {
            out["systems"] = sys;
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
            gather_name,
            timings["gather"]
        );
        if let Some(sys) = &systems_json {
            outln!(
                "{} systems lit to the steady state in {} frame(s) of {:.1} ms (last relative change {:.2e})",
                sys["count"],
                sys["frames"],
                sys["frame_ms"].as_f64().unwrap_or(f64::NAN),
                sys["change"].as_f64().unwrap_or(f64::NAN)
            );
        }
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
        print_points(answers);
    }
    // After the results, as every warning: a failure stays the one `error:` line.
    crate::scene::warn_if_unlit(&runtime, &lights);
    Ok(())
}

/// The points' table of `solve`'s text output.
fn print_points(
    answers: &[(
        &radiosity_runtime::points::Point,
        radiosity_runtime::points::Answer,
    )],
) {
    outln!(
        "{:<44} {:>36}",
        "point (position; normal)",
        "irradiance W/m² (r g b)"
    );
    for (p, a) in answers {
        let q = p.position;
        let n = p.given_normal;
        let what = match a {
            radiosity_runtime::points::Answer::Irradiance { total: e, .. } => {
                format!("{:>11.4} {:>11.4} {:>11.4}", e.r, e.g, e.b)
            }
            radiosity_runtime::points::Answer::Inside => "inside an object".into(),
            radiosity_runtime::points::Answer::Outside => "outside the scene".into(),
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

/// A point's entry in `solve --json`: `irradiance` null and `status` saying why for a point
/// inside an object or outside the scene.
fn point_json(p: &radiosity_runtime::points::Point, a: radiosity_runtime::points::Answer) -> Value {
    use radiosity_runtime::points::Answer;
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

/// A reflectance edit ready to light: one matrix's, or a level built with each system's own
/// edit (with the edit's summary for the JSON).
enum EditSetup {
    One(Box<ReflectanceEdit>),
    Level(Box<(crate::backend::ChosenLevel, Value)>),
}

/// Prepares the reflectance edit of `materials` on the runtime's file and sets the new
/// reflectance on its patches and mesh triangles (the frame's first exitance and radiosity
/// take them; the matrix stays as baked). `M_SS` is decoded under the CPU backends' rules.
/// A level is built here, each system's gather carrying its patches' edit, before its
/// patches change (a system's file must match the level's patches as baked).
fn edit_materials(
    runtime: &mut radiosity_runtime::BakedScene,
    materials: &[radiosity_runtime::materials::MaterialEdit],
    backend: Option<&str>,
) -> anyhow::Result<EditSetup> {
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
    let resolved = radiosity_runtime::materials::patch_edits(file, &shares, materials)?;
    let objects = resolved.objects;
    let set_mesh = |file: &mut radiosity_core::RadFile<'_>| {
        if let Some(mesh) = &mut file.mesh {
            for t in mesh.triangles.to_mut() {
                if let Some(&(_, rho)) = objects.iter().find(|o| o.0 == t.object) {
                    t.reflectance = rho;
                }
            }
        }
    };
    if file.systems.is_some() {
        let mut chosen = crate::backend::choose_level(backend, file, &resolved.patches)?;
        let patches = file.patches.to_mut();
        for &(i, rho) in &resolved.patches {
            patches[i as usize].reflectance = rho;
            chosen.0.set_reflectance(i as usize, rho);
        }
        set_mesh(file);
        let summary = json!({
            "objects": materials.len(),
            "patches": resolved.patches.len(),
            "bytes": 0,
        });
        return Ok(EditSetup::Level(Box::new((chosen, summary))));
    }
    let edit = ReflectanceEdit::new(
        &file.matrix,
        DecodeMode::D3d10,
        &file.patches,
        &resolved.patches,
    )
    .map_err(|e| anyhow::anyhow!("materials: {e}"))?;
    edit.apply_to(file.patches.to_mut());
    set_mesh(file);
    Ok(EditSetup::One(Box::new(edit)))
}
