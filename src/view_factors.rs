//! `radiosity view-factors SCENE.obj [--json]`: object-to-object view factors from the
//! full-detail geometry (`docs/contract.md`, "Command line").

use indicatif::{ProgressBar, ProgressStyle};
use radiosity_bake::check::view_factors::{ViewFactorParams, ViewFactors, view_factors};
use radiosity_bake::scene::LoadOptions;
use serde_json::json;
use std::path::Path;

pub(crate) fn run(scene_path: &Path, json_out: bool) -> anyhow::Result<()> {
    // Geometry only: a material the bake would refuse (Kd 1) is no reason to refuse view factors.
    let scene = crate::bake::load_scene(scene_path, &LoadOptions::geometry_only())?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    let bar = ProgressBar::new(scene.triangles.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} view factors {bar:30} {pos}/{len} triangles ({eta})",
        )
        .expect("static template"),
    );
    let progress = |done: usize, _total: usize| {
        bar.set_position(done as u64);
        true
    };
    let vf = view_factors(&scene, &ViewFactorParams::default(), Some(&progress));
    bar.finish_and_clear();
    if json_out {
        let out = json!({
            "objects": vf.objects,
            "areas": vf.areas,
            "matrix": vf.matrix,
        });
        outln!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_table(scene_path, &vf);
    }
    Ok(())
}

/// A readable table: one row per emitting object, its area, the factors and the row sum.
fn print_table(path: &Path, vf: &ViewFactors) {
    outln!(
        "view factors of {} (row: from, column: to; rows sum to 1 in a closed scene)",
        path.display()
    );
    let w = vf
        .objects
        .iter()
        .map(|n| n.chars().count())
        .max()
        .unwrap_or(4)
        .clamp(4, 24);
    let short = |n: &str| -> String {
        if n.chars().count() > w {
            n.chars().take(w - 1).chain(['…']).collect()
        } else {
            n.to_owned()
        }
    };
    out!("{:<w$} {:>12}", "from \\ to", "area");
    for name in &vf.objects {
        out!(" {:>w$}", short(name));
    }
    outln!(" {:>9}", "sum");
    for (a, row) in vf.matrix.iter().enumerate() {
        out!("{:<w$} {:>12.6e}", short(&vf.objects[a]), vf.areas[a]);
        for f in row {
            out!(" {:>w$.6}", f);
        }
        outln!(" {:>9.6}", row.iter().sum::<f64>());
    }
    outln!("({} shadow rays)", vf.rays_cast);
}
