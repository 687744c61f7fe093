//! A baked scene for the commands that light one (`solve`, `render`): a `.rad` file read and
//! parsed, or a scene baked on the spot, wrapped in the runtime's [`BakedScene`].

use anyhow::{Context, bail};
use radiosity_core::{Light, RadFile};
use radiosity_runtime::BakedScene;

/// Warns when nothing lights the scene: no patch emits and no lights file was given, so every
/// irradiance is zero and an image is black. Says how to add light.
pub(crate) fn warn_if_unlit(rt: &BakedScene, lights: &[Light]) {
    if rt.is_unlit(lights) {
        eprintln!(
            "warning: nothing lights this scene (no emitting material, no --lights): everything is black; add lights with --lights LIGHTS.json (see docs/examples/lights.json) or give a material emission (MTL Ke, glTF emissiveFactor)"
        );
    }
}

/// A scene ready for the runtime, from a `.rad` file or baked from an OBJ on the spot.
pub(crate) struct Loaded {
    pub(crate) runtime: BakedScene,
    /// The bake's effect plan (`{}` when the file has no report).
    pub(crate) effects: serde_json::Value,
    /// Milliseconds spent loading, and baking when the input was an OBJ.
    pub(crate) timings: std::collections::BTreeMap<&'static str, f64>,
}

/// Loads `input`: a `.rad` file, or an OBJ scene baked with `args` (progress bar unless
/// `quiet`).
pub(crate) fn load(
    input: &std::path::Path,
    args: &crate::args::BakeArgs,
    quiet: bool,
) -> anyhow::Result<Loaded> {
    use serde_json::{Value, json};
    let mut timings = std::collections::BTreeMap::new();
    let t = std::time::Instant::now();
    let is_rad = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("rad"));
    let (file, effects) = if is_rad {
        if !args.given.is_empty() {
            bail!(
                "{} is already baked: the bake flag(s) {} do not apply to it (bake the OBJ scene again with them)",
                input.display(),
                args.given.join(", ")
            );
        }
        let bytes =
            std::fs::read(input).with_context(|| format!("cannot read {}", input.display()))?;
        let file = RadFile::parse(&bytes)
            .with_context(|| format!("{} is not a valid .rad file", input.display()))?
            .into_owned();
        let effects = file
            .report
            .as_deref()
            .and_then(|r| serde_json::from_str::<Value>(r).ok())
            .and_then(|r| r.get("effects").cloned())
            .unwrap_or(json!({}));
        timings.insert("load", t.elapsed().as_secs_f64() * 1e3);
        (file, effects)
    } else {
        let params = crate::bake::params(args)?;
        let load = crate::bake::load_options(args)?;
        let (out, load_ms) = crate::bake::bake_scene(input, None, &load, &params, quiet)?;
        timings.insert("load", load_ms);
        timings.insert(
            "bake",
            out.report.timings_ms.get("total").copied().unwrap_or(0.0),
        );
        (out.file, serde_json::to_value(&out.report.effects)?)
    };
    Ok(Loaded {
        runtime: BakedScene::new(file),
        effects,
        timings,
    })
}
