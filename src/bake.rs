//! `radiosity bake SCENE.obj -o OUT.rad`: the whole bake, a progress bar, an atomic write.

use crate::args::{BakeArgs, form_factor_params, parse_bounces};
use anyhow::{Context, bail};
use radiosity_bake::error::BakeError;
use radiosity_bake::order::OrderKind;
use radiosity_bake::pipeline::{BakeOutput, BakeParams, FormatChoice, Hooks, bake};
use radiosity_bake::scene::{LoadOptions, Scene};
use radiosity_bake::simplify::VoxelParams;
use radiosity_core::Format;
use std::path::Path;
use std::time::Instant;

/// Builds bake parameters from the shared flags (also used by `solve SCENE.obj`).
pub(crate) fn params(args: &BakeArgs) -> anyhow::Result<BakeParams> {
    let mut p = BakeParams {
        bounces: parse_bounces(&args.bounces)?,
        ..BakeParams::default()
    };
    if let Some(n) = args.patches {
        // Before anything is loaded or allocated: the dense matrices must fit in memory.
        crate::limits::check_patches(n, p.bounces)?;
    }
    if let Some(v) = voxel_params(args.patches, args.voxel)? {
        p.voxel = v;
    }
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
    if let Some(k) = args.direct_points {
        let most = radiosity_bake::simplify::runtime_mesh::MAX_DIRECT_POINTS;
        if !(1..=most).contains(&k) {
            bail!("--direct-points must be 1 to {most}, not {k}");
        }
        p.direct_points = k;
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
        (Some(n), None) => {
            crate::limits::check_ceiling(n)?;
            Some(VoxelParams::with_patches(n))
        }
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

/// Loads a scene (`Scene::load_with`: glTF for `.gltf` and `.glb`, else OBJ), refusing first
/// an OBJ that is not text (a PNG renamed `.obj` is "not an OBJ file", not a scene without
/// triangles), and naming `--max-reflectance` when a `Kd` or `baseColorFactor` at or above 1
/// is refused. Every command that takes a scene file loads it here.
pub(crate) fn load_scene(path: &Path, load: &LoadOptions) -> anyhow::Result<Scene> {
    if !radiosity_bake::scene::is_gltf_path(path)
        && let Some(why) = binary_data(path)
    {
        bail!("cannot load the scene: {}: {why}", path.display());
    }
    Scene::load_with(path, load)
        .map_err(|e| {
            let hint = load.validate_materials
                && load.max_reflectance.is_none()
                && matches!(&e, BakeError::Material { message, .. } if kd_at_or_above_one(message));
            if hint {
                anyhow::anyhow!(
                    "{e}; --max-reflectance R (e.g. 0.95) lowers such {} to R with a warning",
                    if message_is_gltf(&e) {
                        "baseColorFactor"
                    } else {
                        "Kd"
                    }
                )
            } else {
                anyhow::Error::new(e)
            }
        })
        .context("cannot load the scene")
}

/// Whether a material error comes from a glTF material (`baseColorFactor …`).
fn message_is_gltf(e: &BakeError) -> bool {
    matches!(e, BakeError::Material { message, .. } if message.starts_with("baseColorFactor "))
}

/// Whether a material message is about a `Kd` or `baseColorFactor` with a channel at or above
/// 1 (`Kd 1 1 1 is not a reflectance …`), which `--max-reflectance` would lower.
fn kd_at_or_above_one(message: &str) -> bool {
    let Some(rest) = message
        .strip_prefix("Kd ")
        .or_else(|| message.strip_prefix("baseColorFactor "))
    else {
        return false;
    };
    rest.split_whitespace()
        .take(3)
        .filter_map(|c| c.parse::<f64>().ok())
        .any(|c| c.is_finite() && c >= 1.0)
}

/// Whether the first 64 KiB of `path` are binary data (`not an OBJ file: …`): a NUL byte, or
/// more than 1% control bytes (an OBJ is text; a Latin-1 name is not binary). `None` for
/// text, or a file that cannot be read (the loader says why).
fn binary_data(path: &Path) -> Option<String> {
    use std::io::Read;
    let mut head = Vec::with_capacity(1 << 16);
    std::fs::File::open(path)
        .ok()?
        .take(1 << 16)
        .read_to_end(&mut head)
        .ok()?;
    let line_of = |at: usize| head[..at].iter().filter(|&&b| b == b'\n').count() + 1;
    if let Some(at) = head.iter().position(|&b| b == 0) {
        return Some(format!(
            "not an OBJ file: binary data (a NUL byte on line {})",
            line_of(at)
        ));
    }
    let control = |b: &u8| (*b < 0x20 && !b"\t\n\r\x0c".contains(b)) || *b == 0x7f;
    let count = head.iter().filter(|b| control(b)).count();
    (count * 100 > head.len()).then(|| {
        format!(
            "not an OBJ file: binary data ({count} control bytes in the first {})",
            head.len()
        )
    })
}

/// Loads and bakes with a progress bar on stderr (stage lines when stderr is not a terminal).
/// `shown` names a scene whose path the user never gave (the embedded one, written to a
/// temporary directory): warnings and errors say it instead of that directory.
pub(crate) fn bake_scene(
    path: &Path,
    shown: Option<&str>,
    load: &LoadOptions,
    params: &BakeParams,
    quiet: bool,
) -> anyhow::Result<(BakeOutput, f64)> {
    let rename = |text: String| match (shown, path.parent()) {
        (Some(name), Some(dir)) if !dir.as_os_str().is_empty() => {
            let dir = format!("{}{}", dir.display(), std::path::MAIN_SEPARATOR);
            text.replace(&dir, &format!("{name} "))
        }
        _ => text,
    };
    let renamed = |e: anyhow::Error| match shown {
        Some(_) => anyhow::anyhow!(rename(crate::error_line(&e))),
        None => e,
    };
    let t = Instant::now();
    let scene = load_scene(path, load).map_err(renamed)?;
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
    let out = out
        .with_context(|| format!("cannot bake {}", path.display()))
        .map_err(renamed)?;
    // Warnings only once the bake has succeeded: a failure stays the one `error:` line. The
    // report's list: the scene's and the simplification's (a missed patch target).
    for w in &out.report.warnings {
        eprintln!("warning: {}", rename(w.clone()));
    }
    Ok((out, load_ms))
}

/// Places and weighs the probes of `spec` in a bake's file and stores its report again, with
/// the file's new size. Nothing for `ProbeSpec::None`.
pub(crate) fn attach_probes(
    out: BakeOutput,
    spec: &crate::probes::ProbeSpec,
    rank: crate::probes::ProbeRank,
) -> anyhow::Result<(BakeOutput, Option<crate::probes::ProbeReport>)> {
    if *spec == crate::probes::ProbeSpec::None {
        return Ok((out, None));
    }
    let BakeOutput {
        file,
        mut report,
        patch_source,
    } = out;
    let rt = crate::runtime::Runtime::new(file);
    let baked = crate::probes::bake(&rt, spec, rank)?;
    let mut file = rt.file;
    let probe_report = baked.map(|(probes, r)| {
        file.probes = Some(probes);
        report.bytes.probes = r.bytes;
        r
    });
    let report = radiosity_bake::pipeline::store(&mut file, report)
        .context("internal error: the bake produced an invalid file")?;
    let out = BakeOutput {
        file,
        report,
        patch_source,
    };
    Ok((out, probe_report))
}

pub(crate) fn run(
    scene: &Path,
    output: &Path,
    args: &BakeArgs,
    probes: &str,
    probe_rank: &str,
    json_out: bool,
) -> anyhow::Result<()> {
    let params = params(args)?;
    let load = load_options(args)?;
    let probe_spec = crate::probes::parse_spec(probes)?;
    let probe_rank = crate::probes::parse_rank(probe_rank)?;
    // Refuse an unwritable destination before spending minutes on the bake.
    crate::output::check_file(output)?;
    let (mut out, load_ms) = bake_scene(scene, None, &load, &params, json_out)?;
    out.report.timings_ms.insert("load", load_ms);
    let (out, probe_report) = attach_probes(out, &probe_spec, probe_rank)?;
    let bytes = out
        .file
        .to_bytes()
        .context("internal error: the bake produced an invalid file")?;
    crate::output::write_bytes(output, &bytes)?;
    if json_out {
        let mut v = serde_json::to_value(&out.report)?;
        v["probes"] = serde_json::to_value(&probe_report)?;
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        if let Some(r) = &probe_report {
            let stored = match r.rank {
                Some(k) => format!("{} weights factored to rank {k}", r.weights),
                None => format!("{} weights", r.weights),
            };
            outln!(
                "  probes: {} placed ({} inside objects dropped), {stored}, {:.2} MB, {:.1} s",
                r.placed,
                r.dropped_inside,
                r.bytes as f64 / 1e6,
                r.seconds
            );
        }
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
