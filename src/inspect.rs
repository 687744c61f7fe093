//! `radiosity inspect FILE [--json]`: what a `.rad` file holds.

use anyhow::Context;
use radiosity_core::{Bounces, RadFile};
use serde_json::{Value, json};
use std::path::Path;

pub(crate) fn run(path: &Path, json_out: bool, export_dds: Option<&Path>) -> anyhow::Result<()> {
    if let Some(dir) = export_dds {
        crate::output::check_dir_path(dir)?;
    }
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let file = RadFile::parse(&bytes)
        .with_context(|| format!("{} is not a valid .rad file", path.display()))?;
    if let Some(dir) = export_dds {
        let count = crate::export_dds::export(&file, dir)?;
        eprintln!(
            "wrote {count} DDS textures and tiles.json to {}",
            dir.display()
        );
    }
    let summary = summarise(&file, bytes.len());
    if json_out {
        outln!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_text(path, &file, &summary);
    }
    Ok(())
}

/// The `inspect --json` object (`docs/contract.md`): the file's own facts, merged over the bake's report
/// (rays cast, effects, timings, per-order errors) when the file carries one.
fn summarise(file: &RadFile<'_>, total: usize) -> Value {
    let m = &file.matrix;
    let l = &m.layout;
    let order = file.patch_order.name();
    let mut out = match file.report.as_deref().map(serde_json::from_str::<Value>) {
        Some(Ok(Value::Object(report))) => Value::Object(report),
        _ => json!({}),
    };
    let mut rmse = out
        .get("compression_rmse")
        .cloned()
        .unwrap_or_else(|| json!({}));
    if let (Some(map), Some(v)) = (rmse.as_object_mut(), file.compression_rmse) {
        map.entry(order).or_insert(json!(v));
    }
    let own = json!({
        "patches": file.n(),
        "channels": l.channels(),
        "format": l.format().name(),
        "order": order,
        "bounces": match file.bounces { Bounces::Finite(k) => json!(k), Bounces::Infinite => json!("infinite") },
        "bytes": {
            "total": total,
            "blocks": m.blocks.len(),
            "sparse": m.sparse.bytes(),
            "corrections": m.corrections.bytes(),
            "scales": m.scales.len() * std::mem::size_of::<radiosity_core::LogScale>(),
            "parts": file.parts.as_ref().map_or(0, |p| p.to_bytes().len()),
            "bounce": file.bounce.as_ref().map_or(0, |b| b.to_bytes().len()),
        },
        "tiles": l.tile_count(),
        "tile_size": l.tile_size(),
        "sparse_entries": m.sparse.nnz(),
        "corrected_blocks": m.corrections.count(),
        "compression_rmse": rmse,
        "lighting_error": file.lighting_error,
        "objects": file.objects.iter().map(|o| o.as_ref()).collect::<Vec<_>>(),
        "probes": file.probes.as_ref().map(|p| json!({
            "count": p.len(),
            "weights": p.weights.len(),
            "rank": p.factors.as_ref().map(|f| f.rank),
            "bytes": p.to_bytes().len(),
            "spacing": p.spacing,
        })),
        "parts": file.parts.as_ref().map(|p| json!({
            "count": p.parts.len(),
            "entries": p.samples.len(),
            "sky": !p.sky.is_empty(),
            "bytes": p.to_bytes().len(),
        })),
        "bounce": file.bounce.as_ref().map(|b| json!({
            "entries": b.samples.len(),
            "bytes": b.to_bytes().len(),
        })),
        "systems": file.systems.as_ref().map(|sys| json!({
            "count": sys.count(),
            "sizes": sys.ranges().iter().map(|r| r.len()).collect::<Vec<_>>(),
            "coupling_entries": sys.coupling.nnz(),
            "bytes": sys.data_len,
        })),
        "coverage": file.coverage.as_ref().map(|c| json!({
            "partial": c.iter().filter(|&&c| c < 1.0).count(),
            "bytes": 4 * c.len(),
        })),
    });
    let obj = out.as_object_mut().expect("object");
    for (k, v) in own.as_object().expect("object") {
        obj.insert(k.clone(), v.clone());
    }
    out
}

fn print_text(path: &Path, file: &RadFile<'_>, s: &Value) {
    let l = &file.matrix.layout;
    let mib = |b: &Value| b.as_f64().unwrap_or(0.0) / (1024.0 * 1024.0);
    outln!("{}", path.display());
    outln!(
        "  patches      {} ({} objects)",
        file.n(),
        file.objects.len()
    );
    let bounces = match file.bounces {
        Bounces::Finite(k) => format!("{k} bounce(s)"),
        Bounces::Infinite => "all bounces".to_owned(),
    };
    outln!(
        "  matrix       {} × {} channel(s), {bounces}",
        l.format(),
        l.channels()
    );
    if let Some(sys) = &file.systems {
        let sizes: Vec<usize> = sys.ranges().iter().map(|r| r.len()).collect();
        let (lo, hi) = (
            sizes.iter().min().copied().unwrap_or(0),
            sizes.iter().max().copied().unwrap_or(0),
        );
        outln!(
            "  systems      {} (a level: {lo} to {hi} patches each, {} coupling entries, systems' files {:.3} MiB)",
            sys.count(),
            sys.coupling.nnz(),
            mib(&s["systems"]["bytes"])
        );
    }
    outln!("  order        {}", file.patch_order.name());
    outln!(
        "  tiles        {} of up to {}²",
        l.tile_count(),
        l.tile_size()
    );
    outln!(
        "  bytes        {:.3} MiB total: blocks {:.3} MiB, sparse {:.3} MiB ({} entries), corrections {:.3} MiB ({} blocks)",
        mib(&s["bytes"]["total"]),
        mib(&s["bytes"]["blocks"]),
        mib(&s["bytes"]["sparse"]),
        file.matrix.sparse.nnz(),
        mib(&s["bytes"]["corrections"]),
        file.matrix.corrections.count()
    );
    let dense_rgb = (file.n() * file.n() * 3 * 4) as f64;
    outln!(
        "               {:.1}× smaller than a dense f32 RGB matrix",
        dense_rgb / s["bytes"]["total"].as_f64().unwrap_or(1.0)
    );
    let codes = s["compression_code_rmse"][file.patch_order.name()].as_f64();
    match (file.compression_rmse, codes) {
        (Some(v), Some(c)) => {
            outln!("  compression  relative Frobenius error {v:.4}; log texture {c:.2} codes RMS")
        }
        (Some(v), None) => outln!("  compression  relative Frobenius error {v:.4}"),
        (None, _) => outln!("  compression  error not measured"),
    }
    print_extras(file, s);
}

/// The lines after the matrix's: the lighting error, the form factors, the probes, the
/// parts, the coverage and the effects, each where the file has it.
fn print_extras(file: &RadFile<'_>, s: &Value) {
    let mib = |b: &Value| b.as_f64().unwrap_or(0.0) / (1024.0 * 1024.0);
    if let Some(v) = file.lighting_error {
        // As `bake` prints it: a percentage (`--json` keeps the fraction).
        outln!(
            "  lighting     relative L2 error {:.3}% (scene's own emitters)",
            v * 100.0
        );
    }
    if let Some(d) = describe_form_factors(&s["form_factors"]) {
        outln!("  form factors {d}");
    }
    if let Some(p) = &file.probes {
        let stored = match &p.factors {
            Some(f) => format!("weights factored to rank {}", f.rank),
            None => format!("{} patch weights", p.weights.len()),
        };
        outln!(
            "  probes       {} ({stored}, spacing {}, {:.3} MiB)",
            p.len(),
            p.spacing,
            mib(&s["probes"]["bytes"])
        );
    }
    if let Some(p) = &file.parts {
        outln!(
            "  parts        {} objects' parts of shared patches with rows of their own ({} entries{}, {:.3} MiB)",
            p.parts.len(),
            p.samples.len(),
            if p.sky.is_empty() {
                ""
            } else {
                ", sky visibility"
            },
            mib(&s["parts"]["bytes"])
        );
    }
    if let Some(b) = &file.bounce {
        outln!(
            "  bounce       each patch's first bounce gathered where its rays land ({} entries, {:.3} MiB)",
            b.samples.len(),
            mib(&s["bounce"]["bytes"])
        );
    }
    if let Some(c) = &file.coverage {
        outln!(
            "  coverage     {} of {} mesh triangles partly covered (alphaMode)",
            c.iter().filter(|&&c| c < 1.0).count(),
            c.len()
        );
    }
    if let Some(effects) = s.get("effects").and_then(Value::as_object) {
        outln!("  effects");
        for (name, e) in effects {
            let on = if e["on"].as_bool().unwrap_or(false) {
                "on "
            } else {
                "off"
            };
            outln!("    {name:<12} {on} {}", e["why"].as_str().unwrap_or(""));
        }
    }
}

/// One line for a bake report's `form_factors` object (`FormFactorSummary`): shared by `bake`
/// and `inspect`, which reads it back from the file's report. `None` for a file without one.
pub(crate) fn describe_form_factors(v: &Value) -> Option<String> {
    let rule = v["rule"].as_str()?;
    let rays = match v["rays_per_leaf"].as_u64()? {
        0 => "no shadow rays".to_owned(),
        1 => "1 shadow ray per leaf".to_owned(),
        k => format!("{k} shadow rays per leaf"),
    };
    // A file without `far_pieces` integrated every piece pair exactly.
    let far = match v["far_pieces"].as_f64() {
        Some(k) => format!("; piece pairs beyond {k} × their radii by the rule on both sides"),
        None => String::new(),
    };
    // A file without `rays_per_patch` took clustered pairs in scenes of many pieces.
    let many = match v["rays_per_patch"].as_u64() {
        Some(k) => format!("scenes of many pieces: {k} rays cast per patch"),
        None => format!("clustered pairs: {}", v["clustered_rule"].as_str()?),
    };
    Some(format!(
        "{rule} rule on leaves at most {} × their distance, depth ≤ {}, {rays} ({many}){far}",
        v["leaf_ratio"].as_f64()?,
        v["max_depth"].as_u64()?,
    ))
}
