//! `radiosity check-rows SCENE.obj`: sampled rows of the form-factor matrix against hemisphere
//! rays (`radiosity_bake::check::row_check`), without computing the whole matrix.

use anyhow::{Context, bail};
use clap::Args;
use radiosity_bake::check::row_check::{RowCheckParams, RowGroup, SceneCheck, check_scene};
use radiosity_bake::scene::LoadOptions;
use radiosity_bake::simplify::VoxelParams;
use std::path::PathBuf;

#[derive(Args)]
pub(crate) struct CheckRowsArgs {
    /// The scene file: OBJ (+ MTL), or glTF 2.0 (.gltf or .glb).
    scene: PathBuf,
    /// Target patch count (as `bake --patches`).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = crate::args::patch_count)]
    patches: Option<usize>,
    /// Voxel cell size in scene units (as `bake --voxel`).
    #[arg(long, allow_negative_numbers = true)]
    voxel: Option<f64>,
    /// Rows of F to check, drawn at random (all rows when the scene has fewer patches).
    #[arg(long, default_value_t = 120)]
    rows: usize,
    /// Check this patch's row instead of a random sample (repeatable; patches in
    /// simplification order, as `bake --json` names the largest row in
    /// `closure.max_row_patch`).
    #[arg(long = "patch", value_name = "N")]
    patch: Vec<usize>,
    /// Hemisphere rays per row (the estimate's standard error is at most 0.5/√rays).
    #[arg(long, default_value_t = 4000)]
    rays: u32,
    /// Form factors, as `bake --form-factors`: draft, default, fine.
    #[arg(
        long = "form-factors",
        value_name = "QUALITY",
        default_value = "default"
    )]
    form_factors: String,
    /// Seed of the row sample and the rays.
    #[arg(long, default_value_t = 11)]
    seed: u64,
    /// Print JSON: {"patches", "shadow_rays", "form_factor_seconds", "hemisphere_seconds",
    /// "check": {"rays", "open", "enclosed", "all", "samples": [{"patch", "row_sum",
    /// "hemisphere", "std_error", "back_faces"}]}}.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(args: &CheckRowsArgs) -> anyhow::Result<()> {
    let voxel = radiosity_bake::host::voxel_params(args.patches, args.voxel)?
        .unwrap_or_else(VoxelParams::default);
    if args.rows == 0 {
        bail!("--rows must be at least 1");
    }
    if args.rays == 0 {
        bail!("--rays must be at least 1");
    }
    let form_factors = radiosity_bake::host::form_factor_params(&args.form_factors)?;
    // Geometry only: the check needs the patches, not valid reflectances.
    let scene = crate::bake::load_scene(&args.scene, &LoadOptions::geometry_only())?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    let params = RowCheckParams {
        rays: args.rays,
        seed: args.seed,
        ..RowCheckParams::default()
    };
    let bar = crate::progress::stage_bar(12, " rows ({eta})", args.json);
    bar.stage("form factors");
    let (_, counted) = crate::progress::callbacks(&bar);
    let progress = |done: usize, total: usize| {
        counted(done, total);
        true
    };
    let out = check_scene(
        &scene,
        &voxel,
        &form_factors,
        args.rows,
        &args.patch,
        &params,
        Some(&progress),
    );
    bar.finish_and_clear();
    let out = out.with_context(|| format!("cannot check {}", args.scene.display()))?;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_table(args, &out, &params);
    }
    Ok(())
}

fn print_table(args: &CheckRowsArgs, out: &SceneCheck, params: &RowCheckParams) {
    let c = &out.check;
    outln!(
        "{}: {} patches, {} rows of F against {} hemisphere rays each",
        args.scene.display(),
        out.patches,
        c.all.rows,
        c.rays
    );
    outln!(
        "  rows of F: {:.1} s, {:.3e} shadow rays; hemisphere rays: {:.1} s",
        out.form_factor_seconds,
        out.shadow_rays as f64,
        out.hemisphere_seconds
    );
    outln!(
        "  {:<34} {:>5} {:>7} {:>8} {:>14} {:>7} {:>8}",
        "row sum − hemisphere share",
        "rows",
        "RMS",
        "mean",
        "worst (patch)",
        "noise",
        format!("> {}", params.over_full)
    );
    let pct = (params.enclosed_share * 100.0).round();
    let line = |name: String, g: &RowGroup| {
        let worst = g
            .worst_patch
            .map_or("-".to_owned(), |p| format!("{:.3} ({p})", g.worst));
        outln!(
            "  {:<34} {:>5} {:>7.4} {:>+8.4} {:>14} {:>7.4} {:>8}",
            name,
            g.rows,
            g.rms,
            g.mean,
            worst,
            g.noise,
            g.over_full
        );
    };
    line(format!("open (back faces first < {pct}%)"), &c.open);
    line(format!("enclosed (back faces first ≥ {pct}%)"), &c.enclosed);
    line("all".to_owned(), &c.all);
    outln!("  (noise: RMS standard error of the hemisphere estimates; --json lists every row)");
}
