//! `radiosity bake SCENE.obj -o OUT.rad`: the whole bake, a progress bar, an atomic write.

use crate::args::{BakeArgs, ProbeArgs};
use anyhow::Context;
pub(crate) use radiosity_bake::host::{BakeFlags, capped_loading};
use radiosity_bake::pipeline::{BakeOutput, BakeParams, Hooks, bake};
use radiosity_bake::scene::{LoadOptions, Scene};
use std::path::Path;
use std::time::Instant;

/// The shared flags as the library's [`BakeFlags`] (`probes` and `probe_rank` apart: only
/// `bake` takes them).
pub(crate) fn flags(args: &BakeArgs) -> BakeFlags {
    BakeFlags {
        patches: args.patches,
        voxel: args.voxel,
        bounces: Some(args.bounces.as_str().into()),
        format: Some(args.format.clone()),
        order: Some(args.order.clone()),
        sparse: args.sparse,
        corrections: args.corrections,
        tile: args.tile,
        form_factors: Some(args.form_factors.clone()),
        max_reflectance: args.max_reflectance,
        direct_points: args.direct_points,
        shadow_points: args.shadow_points,
        probes: Some("none".into()),
        probe_rank: None,
        sky: Some(args.sky.clone()),
        systems: Some(args.systems.as_str().into()),
        memory_budget: args.memory_budget,
    }
}

/// The shared flags and the probes' as the library's [`BakeFlags`]: what `bake` and
/// `bake-plan` take.
pub(crate) fn flags_with_probes(args: &BakeArgs, probes: &ProbeArgs) -> BakeFlags {
    BakeFlags {
        probes: Some(probes.probes.as_str().into()),
        probe_rank: Some(probes.probe_rank.as_str().into()),
        ..flags(args)
    }
}

/// Builds bake parameters from the shared flags (also used by `solve SCENE.obj`): no probes.
pub(crate) fn params(args: &BakeArgs) -> anyhow::Result<BakeParams> {
    Ok(flags(args).params()?.0)
}

/// How to load the scene, from the shared flags.
pub(crate) fn load_options(args: &BakeArgs) -> anyhow::Result<LoadOptions> {
    Ok(capped_loading(args.max_reflectance)?)
}

/// Loads a scene ([`radiosity_bake::host::load_scene`]) under "cannot load the scene".
pub(crate) fn load_scene(path: &Path, load: &LoadOptions) -> anyhow::Result<Scene> {
    radiosity_bake::host::load_scene(path, load).context("cannot load the scene")
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
            cancel: None,
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

pub(crate) fn run(
    scene: &Path,
    output: &Path,
    args: &BakeArgs,
    probes: &ProbeArgs,
    json_out: bool,
) -> anyhow::Result<()> {
    let (params, load) = flags_with_probes(args, probes).params()?;
    // Refuse an unwritable destination before spending minutes on the bake.
    crate::output::check_file(output)?;
    let (mut out, load_ms) = bake_scene(scene, None, &load, &params, json_out)?;
    out.report.timings_ms.insert("load", load_ms);
    let bytes = out
        .file
        .to_bytes()
        .context("internal error: the bake produced an invalid file")?;
    crate::output::write_bytes(output, &bytes)?;
    if json_out {
        outln!("{}", serde_json::to_string_pretty(&out.report)?);
    } else {
        if let Some(r) = &out.report.probes {
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
