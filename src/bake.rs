//! `radiosity bake SCENE.obj -o OUT.rad`: the whole bake, a progress bar, an atomic write.

use crate::args::{BakeArgs, form_factor_params, parse_bounces};
use anyhow::{Context, bail};
use radiosity_bake::order::OrderKind;
use radiosity_bake::pipeline::{BakeOutput, BakeParams, FormatChoice, Hooks, bake};
use radiosity_bake::scene::{LoadOptions, Scene};
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::Format;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// Builds bake parameters from the shared flags (also used by `solve SCENE.obj`).
pub(crate) fn params(args: &BakeArgs) -> anyhow::Result<BakeParams> {
    let mut p = BakeParams::default();
    if let Some(v) = voxel_params(args.patches, args.voxel)? {
        p.voxel = v;
    }
    p.bounces = parse_bounces(&args.bounces)?;
    p.form_factors = form_factor_params(&args.form_factors)?;
    p.format = match args.format.as_str() {
        "auto" => FormatChoice::Auto,
        name => FormatChoice::Fixed(Format::from_name(name).with_context(|| {
            format!("unknown --format {name:?} (auto, bc1, bc4, u8, f16, f32)")
        })?),
    };
    if let Some(f) = args.sparse {
        if !(0.0..=1.0).contains(&f) {
            bail!("--sparse must be a fraction in [0, 1], not {f}");
        }
        p.sparse_fraction = Some(f);
    }
    if let Some(f) = args.corrections {
        if !(0.0..=1.0).contains(&f) {
            bail!("--corrections must be a fraction in [0, 1], not {f}");
        }
        p.corrections = Some(f);
    }
    if let Some(t) = args.tile {
        if t < 4 || t % 4 != 0 {
            bail!("--tile must be a positive multiple of 4, not {t}");
        }
        p.encode.max_tile = t;
    }
    p.order = OrderKind::from_name(&args.order).with_context(|| {
        format!(
            "unknown --order {:?} (none, random, paper, spatial, best)",
            args.order
        )
    })?;
    Ok(p)
}

/// The simplification asked for by `--patches N` or `--voxel SIZE` (`None`: the default).
pub(crate) fn voxel_params(
    patches: Option<usize>,
    voxel: Option<f64>,
) -> anyhow::Result<Option<VoxelParams>> {
    Ok(match (patches, voxel) {
        (Some(_), Some(_)) => bail!("give --patches or --voxel, not both"),
        (Some(0), _) => bail!("--patches must be at least 1"),
        (Some(n), None) => Some(VoxelParams::with_patches(n)),
        (None, Some(s)) if !(s.is_finite() && s > 0.0) => {
            bail!("--voxel must be a positive size, not {s}")
        }
        (None, Some(s)) => Some(VoxelParams::with_cell_size(s)),
        (None, None) => None,
    })
}

/// How to load the scene, from the shared flags.
pub(crate) fn load_options(args: &BakeArgs) -> anyhow::Result<LoadOptions> {
    capped_loading(args.max_reflectance)
}

/// Loading with `--max-reflectance`, checked (`bake`, `solve` and `pathtrace` share it).
pub(crate) fn capped_loading(max_reflectance: Option<f64>) -> anyhow::Result<LoadOptions> {
    let mut o = LoadOptions::default();
    if let Some(r) = max_reflectance {
        if !(r > 0.0 && r < 1.0) {
            bail!("--max-reflectance must be in (0, 1), not {r}");
        }
        o.max_reflectance = Some(r);
    }
    Ok(o)
}

/// Loads and bakes with a progress bar on stderr.
pub(crate) fn bake_scene(
    path: &Path,
    load: &LoadOptions,
    params: &BakeParams,
    quiet: bool,
) -> anyhow::Result<(BakeOutput, f64)> {
    let t = Instant::now();
    let scene = Scene::load_obj_with(path, load).context("cannot load the scene")?;
    let load_ms = t.elapsed().as_secs_f64() * 1e3;
    let bar = crate::progress::stage_bar(14, " ({eta})", quiet);
    let (stage, progress) = crate::progress::callbacks(&bar);
    let out = bake(
        &scene,
        params,
        Hooks {
            stage: Some(&stage),
            progress: Some(&progress),
        },
    );
    bar.finish_and_clear();
    let out = out.with_context(|| format!("cannot bake {}", path.display()))?;
    // Warnings only once the bake has succeeded: a failure stays the one `error:` line. The
    // report's list: the scene's and the simplification's (a missed patch target).
    for w in &out.report.warnings {
        eprintln!("warning: {w}");
    }
    Ok((out, load_ms))
}

pub(crate) fn run(
    scene: &Path,
    output: &Path,
    args: &BakeArgs,
    json_out: bool,
) -> anyhow::Result<()> {
    let params = params(args)?;
    let load = load_options(args)?;
    // Refuse an unwritable destination before spending minutes on the bake.
    let dir = output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!(
            "cannot write {}: directory {} does not exist",
            output.display(),
            dir.display()
        );
    }
    let (mut out, load_ms) = bake_scene(scene, &load, &params, json_out)?;
    out.report.timings_ms.insert("load", load_ms);
    let bytes = out
        .file
        .to_bytes()
        .context("internal error: the bake produced an invalid file")?;
    write_atomically(output, &bytes)?;
    if json_out {
        outln!("{}", serde_json::to_string_pretty(&out.report)?);
    } else {
        let r = &out.report;
        outln!("{} → {}", scene.display(), output.display());
        outln!(
            "  {} patches, {} channel(s), {}, order {}, bounces {}",
            r.patches,
            r.channels,
            r.format,
            r.order,
            r.bounces
                .as_str()
                .map_or_else(|| r.bounces.to_string(), str::to_owned)
        );
        let dense = (r.patches * r.patches * 3 * 4) as f64;
        outln!(
            "  {:.2} MiB ({:.1}× smaller than dense f32 RGB), {} rays",
            bytes.len() as f64 / 1048576.0,
            dense / bytes.len() as f64,
            r.rays_cast
        );
        for (order, e) in &r.compression_rmse {
            match r.compression_code_rmse.get(order) {
                Some(c) => {
                    outln!("  compression error ({order}): {e:.4} (log texture: {c:.2} codes RMS)")
                }
                None => outln!("  compression error ({order}): {e:.4}"),
            }
        }
        match r.lighting_error {
            Some(e) => outln!("  lighting error from compression: {:.3}%", e * 100.0),
            None => outln!("  lighting error: not measured (no emitters)"),
        }
        if let Some(d) =
            crate::inspect::describe_form_factors(&serde_json::to_value(r.form_factors)?)
        {
            outln!("  form factors: {d}");
        }
        for (name, e) in &r.effects {
            outln!(
                "  {:<12} {} {}",
                name,
                if e.on { "on " } else { "off" },
                e.why
            );
        }
        outln!(
            "  {:.1} s in all",
            r.timings_ms.values().copied().fold(0.0, f64::max) / 1e3
        );
    }
    Ok(())
}

/// Writes to a temporary file beside `path`, then renames: readers never see half a file, and
/// a failure leaves nothing behind.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("cannot write {}", path.display()))?;
    tmp.write_all(bytes)
        .with_context(|| format!("cannot write {}", path.display()))?;
    tmp.as_file().sync_all().ok();
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}
