//! `bake-plan`, `bake-shard`, `bake-assemble`, `compare`, and `bake --plan [--reuse]`: the
//! distributed bake's steps (`radiosity_bake::plan`, `docs/distributed.md`).

use crate::args::{BakeArgs, ProbeArgs};
use crate::bake::{flags_with_probes, load_scene};
use anyhow::{Context, anyhow, bail};
use radiosity_bake::host::BakeFlags;
use radiosity_bake::pipeline::Hooks;
use radiosity_bake::plan::{self, Assembled, Plan, Reuse, Rows};
use radiosity_bake::scene::Scene;
use radiosity_core::RadFile;
use std::path::Path;
use std::time::Instant;

/// Reads a plan file.
pub(crate) fn read_plan(path: &Path) -> anyhow::Result<Plan> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the plan {}", path.display()))?;
    Plan::from_json(&text).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Refuses bake flags given on the command line that the plan does not say.
fn refuse_contradictions(
    plan: &Plan,
    args: &BakeArgs,
    probes: &ProbeArgs,
    path: &Path,
) -> anyhow::Result<()> {
    let cli = serde_json::to_value(flags_with_probes(args, probes))?;
    let planned = serde_json::to_value(&plan.flags)?;
    for flag in &args.given {
        let key = flag.trim_start_matches("--").replace('-', "_");
        // The budget bounds this machine's bake, not the file: any may bake the plan.
        if key == "memory_budget" {
            continue;
        }
        if cli.get(&key) != planned.get(&key) {
            bail!(
                "{flag} contradicts the plan {}: a planned bake takes its flags from the plan (make another plan to change them)",
                path.display()
            );
        }
    }
    Ok(())
}

fn hooks_run<T>(quiet: bool, run: impl FnOnce(Hooks<'_>) -> T) -> T {
    let bar = crate::progress::stage_bar(14, " ({eta})", quiet);
    let (stage, progress) = crate::progress::callbacks(&bar);
    let out = run(Hooks {
        stage: Some(&stage),
        progress: Some(&progress),
        cancel: None,
    });
    bar.finish_and_clear();
    out
}

/// Loads the scene as the plan's flags say.
fn scene_of(path: &Path, plan: &Plan) -> anyhow::Result<Scene> {
    load_scene(path, &plan.params()?.1)
}

/// `radiosity bake-plan SCENE -o PLAN.json [bake flags] [--shards N]`.
pub(crate) fn run_plan(
    scene_path: &Path,
    output: &Path,
    args: &BakeArgs,
    probes: &ProbeArgs,
    shards: Option<usize>,
    json: bool,
) -> anyhow::Result<()> {
    let f: BakeFlags = flags_with_probes(args, probes);
    let (params, _) = f.params()?;
    crate::output::check_file(output)?;
    let scene = load_scene(scene_path, &f.params()?.1)?;
    let t = Instant::now();
    let plan = hooks_run(json, |h| plan::make_plan(&scene, &f, &params, shards, h))
        .with_context(|| format!("cannot plan {}", scene_path.display()))?;
    crate::output::write_bytes(output, plan.to_json().as_bytes())?;
    let summary = serde_json::json!({
        "plan": output,
        "plan_hash": plan.plan_hash,
        "patches": plan.planned.patches,
        "systems": plan.planned.sizes.len(),
        "sizes": plan.planned.sizes,
        "shards": plan.shards.len(),
        "cell_size": plan.cell_size,
        "seconds": t.elapsed().as_secs_f64(),
    });
    if json {
        outln!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        outln!(
            "{} → {}: {} patches in {} systems, {} shards, cells of {:.4}",
            scene_path.display(),
            output.display(),
            plan.planned.patches,
            plan.planned.sizes.len(),
            plan.shards.len(),
            plan.cell_size
        );
    }
    Ok(())
}

/// `radiosity bake-shard SCENE --plan PLAN --shard K --out-dir DIR [--reuse OLD.rad]`.
pub(crate) fn run_shard(
    scene_path: &Path,
    plan_path: &Path,
    shard: usize,
    out_dir: &Path,
    reuse: Option<&Path>,
    json: bool,
) -> anyhow::Result<()> {
    let plan = read_plan(plan_path)?;
    crate::output::create_dir(out_dir)?;
    let scene = scene_of(scene_path, &plan)?;
    let old = reuse.map(Reuse::read).transpose()?;
    let t = Instant::now();
    let (rows, stats) = hooks_run(json, |h| {
        plan::shard_rows(
            &scene,
            &plan,
            Some(shard),
            old.as_ref().map(|r| &r.cache),
            h,
        )
    })
    .with_context(|| format!("cannot bake shard {shard} of {}", scene_path.display()))?;
    let path = out_dir.join(rows.name());
    crate::output::write_bytes(&path, &rows.to_bytes())?;
    if json {
        let out = serde_json::json!({
            "shard": shard,
            "path": path,
            "patches": rows.patches.len(),
            "rows": stats,
            "seconds": t.elapsed().as_secs_f64(),
        });
        outln!("{}", serde_json::to_string(&out)?);
    } else {
        outln!("{}", path.display());
    }
    Ok(())
}

/// `radiosity bake-assemble SCENE --plan PLAN --rows DIR -o OUT.rad [--reuse OLD.rad]`.
pub(crate) fn run_assemble(
    scene_path: &Path,
    plan_path: &Path,
    rows_dir: &Path,
    output: &Path,
    reuse: Option<&Path>,
    json: bool,
) -> anyhow::Result<()> {
    let plan = read_plan(plan_path)?;
    crate::output::check_file(output)?;
    let scene = scene_of(scene_path, &plan)?;
    let scene_at = plan::scene_hash(&scene);
    let plan_at = plan.hash();
    let mut rows = Vec::with_capacity(plan.shards.len());
    for k in 0..plan.shards.len() {
        let name = Rows::file_name(&scene_at, &plan_at, k as u32);
        let path = rows_dir.join(&name);
        if !path.exists() {
            let other = std::fs::read_dir(rows_dir)
                .map(|d| {
                    d.filter_map(Result::ok).any(|e| {
                        e.file_name()
                            .to_string_lossy()
                            .starts_with(&format!("rows-{k}-"))
                    })
                })
                .unwrap_or(false);
            bail!(
                "shard {k} is {} in {}: expected {name}",
                if other {
                    "stale (made from another scene or plan)"
                } else {
                    "missing"
                },
                rows_dir.display()
            );
        }
        let bytes = std::fs::read(&path)
            .with_context(|| format!("cannot read shard {k} ({})", path.display()))?;
        let r = Rows::from_bytes(&bytes)
            .map_err(|e| anyhow!("shard {k} ({}) is corrupt: {e}", path.display()))?;
        if r.shard != k as u32 || r.name() != name {
            bail!("shard {k} ({}) holds another shard's rows", path.display());
        }
        rows.push(r);
    }
    let old = reuse.map(Reuse::read).transpose()?;
    let t = Instant::now();
    let out = hooks_run(json, |h| {
        plan::assemble(&scene, &plan, rows, old.as_ref(), h)
    })
    .with_context(|| format!("cannot assemble {}", scene_path.display()))?;
    write_assembled(scene_path, output, out, t, json)
}

/// `radiosity bake SCENE -o OUT.rad --plan PLAN [--reuse OLD.rad]`.
pub(crate) fn run_bake(
    scene_path: &Path,
    output: &Path,
    args: &BakeArgs,
    probes: &ProbeArgs,
    plan_path: &Path,
    reuse: Option<&Path>,
    json: bool,
) -> anyhow::Result<()> {
    let plan = read_plan(plan_path)?;
    refuse_contradictions(&plan, args, probes, plan_path)?;
    crate::output::check_file(output)?;
    let scene = scene_of(scene_path, &plan)?;
    let old = reuse.map(Reuse::read).transpose()?;
    let t = Instant::now();
    let out = hooks_run(json, |h| plan::bake_planned(&scene, &plan, old.as_ref(), h))
        .with_context(|| format!("cannot bake {}", scene_path.display()))?;
    write_assembled(scene_path, output, out, t, json)
}

/// Writes the level and its cache; prints the report (with `reuse`) or a summary.
fn write_assembled(
    scene_path: &Path,
    output: &Path,
    out: Assembled,
    t: Instant,
    json: bool,
) -> anyhow::Result<()> {
    let bytes = out
        .output
        .file
        .to_bytes()
        .context("internal error: the bake produced an invalid file")?;
    // The cache first: a level is never left beside a cache of another bake.
    let cache = plan::cache_path(output);
    crate::output::write_bytes(&cache, &out.cache.to_bytes())?;
    crate::output::write_bytes(output, &bytes)?;
    for w in &out.output.report.warnings {
        eprintln!("warning: {w}");
    }
    let seconds = t.elapsed().as_secs_f64();
    if json {
        let mut v = serde_json::to_value(&out.output.report)?;
        v["reuse"] = serde_json::to_value(&out.reuse)?;
        v["seconds"] = seconds.into();
        outln!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        let r = &out.reuse;
        outln!(
            "{} → {} ({:.1} s): {} patches in {} systems, {} taken from the earlier bake; rows: {} carried, {} cast",
            scene_path.display(),
            output.display(),
            seconds,
            out.output.report.patches,
            r.systems,
            r.reused,
            r.rows.carried,
            r.rows.cast
        );
        for s in &r.rebaked {
            outln!(
                "  system {} (region {}) baked: {}",
                s.system,
                s.region,
                s.why
            );
        }
    }
    Ok(())
}

/// The report without its timings: `timings_ms`, every `seconds`, and `bytes.total` (the
/// file's size, which the timings' digits change).
fn untimed(report: &mut serde_json::Value) {
    match report {
        serde_json::Value::Object(o) => {
            o.remove("timings_ms");
            o.remove("seconds");
            if let Some(b) = o.get_mut("bytes").and_then(|b| b.as_object_mut()) {
                b.remove("total");
            }
            o.values_mut().for_each(untimed);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(untimed),
        _ => {}
    }
}

/// `radiosity compare A.rad B.rad`: the same file but the stored report's timings.
pub(crate) fn run_compare(a: &Path, b: &Path) -> anyhow::Result<bool> {
    let read = |p: &Path| std::fs::read(p).with_context(|| format!("cannot read {}", p.display()));
    let (ba, bb) = (read(a)?, read(b)?);
    let parse = |p: &Path, bytes: &[u8]| -> anyhow::Result<(RadFile<'static>, serde_json::Value)> {
        let mut f = RadFile::parse(bytes)
            .map_err(|e| anyhow!("{}: {e}", p.display()))?
            .into_owned();
        let mut report: serde_json::Value = match f.report.take() {
            Some(text) => {
                serde_json::from_str(&text).unwrap_or(serde_json::Value::String(text.into_owned()))
            }
            None => serde_json::Value::Null,
        };
        untimed(&mut report);
        Ok((f, report))
    };
    let (fa, ra) = parse(a, &ba)?;
    let (fb, rb) = parse(b, &bb)?;
    if ra != rb {
        let key = match (ra.as_object(), rb.as_object()) {
            (Some(x), Some(y)) => x
                .keys()
                .chain(y.keys())
                .find(|k| x.get(*k) != y.get(*k))
                .cloned()
                .unwrap_or_default(),
            _ => String::new(),
        };
        outln!("differ: the stored reports differ (at `{key}`)");
        return Ok(false);
    }
    let (xa, xb) = (fa.to_bytes()?, fb.to_bytes()?);
    if xa != xb {
        let at = xa
            .iter()
            .zip(&xb)
            .position(|(x, y)| x != y)
            .unwrap_or(xa.len().min(xb.len()));
        outln!(
            "differ: {} and {} differ from byte {at} of the file without its report ({} and {} bytes)",
            a.display(),
            b.display(),
            xa.len(),
            xb.len()
        );
        return Ok(false);
    }
    outln!("same");
    Ok(true)
}
