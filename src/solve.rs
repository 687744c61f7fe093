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
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The flags of `radiosity solve`.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct SolveArgs {
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
    /// Gather backend: auto, cpu, gpu or reference (default: $RADIOSITY_BACKEND, else auto).
    #[arg(long)]
    pub(crate) backend: Option<String>,
    /// Reflectance edits of named objects, applied without a re-bake (JSON):
    /// {"materials": [{"object": "leftWall", "reflectance": [r,g,b]}]}, each channel in
    /// [0, 1).
    #[arg(long, value_name = "EDITS.json")]
    pub(crate) materials: Option<PathBuf>,
    /// Points at which to report the total irradiance (JSON): {"points": [{"position":
    /// [x,y,z], "normal": [x,y,z]}]}; a point inside an object or outside the scene is
    /// reported as such.
    #[arg(long, value_name = "POINTS.json")]
    pub(crate) points: Option<PathBuf>,
    /// Print JSON: {"patches", "bounces", "backend", "objects", "effects", "timings_ms"},
    /// "materials" with --materials, "points" with --points.
    #[arg(long)]
    pub(crate) json: bool,
}

/// A level's steady state: the relative change of the exitance in a frame at most this.
const LEVEL_TOLERANCE: f32 = 1e-4;
/// A level's frames at most.
const LEVEL_MAX_FRAMES: usize = 100;

/// What lit the frame: the backend, the gather and its time (ms, the backend's setup apart),
/// and the edit's and the level's summaries for the JSON.
struct Lit {
    kind: &'static str,
    ms: f64,
    gather: String,
    materials: Option<Value>,
    systems: Option<Value>,
}

/// What `solve` reports: the objects and the points, with what lit them.
struct Solved<'a> {
    input: &'a Path,
    n: usize,
    lights: usize,
    bounces: Bounces,
    lit: Lit,
    objects: Vec<Value>,
    effects: Value,
    timings: std::collections::BTreeMap<&'static str, f64>,
    answers: Option<Vec<Answered<'a>>>,
}

/// A point and its answer.
type Answered<'a> = (
    &'a radiosity_runtime::points::Point,
    radiosity_runtime::points::Answer,
);

/// The `solve` command.
pub(crate) fn run(a: &SolveArgs) -> anyhow::Result<()> {
    let (input, backend, json_out) = (a.input.as_path(), a.backend.as_deref(), a.json);
    // Read the lights, edits and points first: a bad file fails before any bake.
    let lights = match &a.lights {
        Some(p) => crate::files::lights(p)?,
        None => Vec::new(),
    };
    let materials = a
        .materials
        .as_deref()
        .map(crate::files::materials)
        .transpose()?;
    let points = a.points.as_deref().map(crate::files::points).transpose()?;
    let crate::scene::Loaded {
        mut runtime,
        effects,
        mut timings,
    } = crate::scene::load(input, &a.bake, json_out)?;
    let edit = match &materials {
        Some(m) => {
            let t = Instant::now();
            let edit = edit_materials(&mut runtime, m, backend)?;
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
    let t = Instant::now();
    let bounce = runtime.first_bounce(&direct, &at_samples);
    timings.insert("first_bounce", t.elapsed().as_secs_f64() * 1e3);
    // What the matrix sends on: the direct light and the first bounce's correction.
    let sent: Vec<Rgb> = direct.iter().zip(&bounce).map(|(d, b)| *d + *b).collect();
    let mut x = vec![Rgb::ZERO; n];
    first_exitance(&file.patches, &sent, &mut x);
    // The backend prints its choice: choose it once the input to the gather is known good, so
    // a failure before it stays one `error:` line.
    let mut y = vec![Rgb::ZERO; n];
    let edited = materials.as_ref().map_or(0, Vec::len);
    let lit = light(file, &x, &mut y, edit, edited, backend)?;
    timings.insert("gather", lit.ms);
    let (mut h, mut b) = (vec![Rgb::ZERO; n], vec![Rgb::ZERO; n]);
    finish_frame(&file.patches, &sent, &y, &mut h, &mut b);
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
            // A hit's light beyond its own direct: the gather's and the first bounce's.
            let beyond: Vec<Rgb> = y.iter().zip(&bounce).map(|(y, d)| *y + *d).collect();
            let a = radiosity_runtime::points::answer(&runtime, &beyond, &h, &lights, points)?;
            timings.insert("points", t.elapsed().as_secs_f64() * 1e3);
            Some(points.iter().zip(a).collect::<Vec<_>>())
        }
        None => None,
    };
    let solved = Solved {
        input,
        n,
        lights: lights.len(),
        bounces: runtime.file.bounces,
        lit,
        objects,
        effects,
        timings,
        answers,
    };
    if json_out {
        print_json(solved)?;
    } else {
        print_text(&solved);
    }
    // After the results, as every warning: a failure stays the one `error:` line.
    crate::scene::warn_if_unlit(&runtime, &lights);
    Ok(())
}

/// Gathers `x` into `y` on the chosen backend: a level lit block by block to the steady
/// state (its edit, if any, built into its systems' gathers), or one matrix, through `edit`
/// when there is one (of `edited` objects).
fn light(
    file: &radiosity_core::RadFile<'static>,
    x: &[Rgb],
    y: &mut [Rgb],
    edit: Option<EditSetup>,
    edited: usize,
    backend: Option<&str>,
) -> anyhow::Result<Lit> {
    let (edit, edited_level) = match edit {
        Some(EditSetup::One(e)) => (Some(*e), None),
        Some(EditSetup::Level(level)) => (None, Some(*level)),
        None => (None, None),
    };
    if file.systems.is_some() {
        let (mut level, materials) = match edited_level {
            Some((level, summary)) => (level, Some(summary)),
            None => (crate::backend::choose_level(backend, file, &[])?, None),
        };
        let t = Instant::now();
        let frames = level.light.steady(x, LEVEL_TOLERANCE, LEVEL_MAX_FRAMES)?;
        y.copy_from_slice(level.light.gathered());
        let systems = json!({
            "count": level.light.count(),
            "frames": frames,
            "change": level.light.change(),
            "frame_ms": t.elapsed().as_secs_f64() * 1e3 / frames.max(1) as f64,
        });
        return Ok(Lit {
            kind: level.kind,
            ms: t.elapsed().as_secs_f64() * 1e3,
            gather: level.name,
            materials,
            systems: Some(systems),
        });
    }
    let mut chosen = crate::backend::choose(backend, file.matrix.clone())?;
    let t = Instant::now();
    let materials = match edit {
        Some(edit) => {
            let summary = json!({
                "objects": edited,
                "patches": edit.len(),
                "bytes": edit.bytes(),
            });
            EditedGather::new(&mut *chosen.gather, edit)
                .map_err(|e| anyhow::anyhow!("materials: {e}"))?
                .gather(x, y)?;
            Some(summary)
        }
        None => {
            chosen.gather.gather(x, y)?;
            None
        }
    };
    Ok(Lit {
        kind: chosen.kind,
        ms: t.elapsed().as_secs_f64() * 1e3,
        gather: chosen.gather.name().to_owned(),
        materials,
        systems: None,
    })
}

/// `solve --json`.
fn print_json(s: Solved<'_>) -> anyhow::Result<()> {
    let mut out = json!({
        "patches": s.n,
        "lights": s.lights,
        "bounces": match s.bounces { Bounces::Finite(k) => json!(k), Bounces::Infinite => json!("infinite") },
        "backend": s.lit.kind,
        "gather": s.lit.gather,
        "objects": s.objects,
        "effects": s.effects,
        "timings_ms": s.timings,
    });
    if let Some(m) = s.lit.materials {
        out["materials"] = m;
    }
    if let Some(sys) = s.lit.systems {
        out["systems"] = sys;
    }
    if let Some(answers) = &s.answers {
        out["points"] = answers
            .iter()
            .map(|(p, a)| point_json(p, *a))
            .collect::<Vec<_>>()
            .into();
    }
    outln!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}

/// `solve`'s text: the gather, the level's frames, one line an object, the points.
fn print_text(s: &Solved<'_>) {
    outln!(
        "{} ({} patches, {} gather {:.2} ms)",
        s.input.display(),
        s.n,
        s.lit.gather,
        s.timings["gather"]
    );
    if let Some(sys) = &s.lit.systems {
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
    for o in &s.objects {
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
    if let Some(answers) = &s.answers {
        print_points(answers);
    }
}

/// The points' table of `solve`'s text output.
fn print_points(answers: &[Answered<'_>]) {
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
            chosen.light.set_reflectance(i as usize, rho);
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
