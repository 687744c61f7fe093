//! The bake flags (`docs/contract.md`, "Command line"), as the command line and the C ABI's
//! `options_json` give them, validated into [`BakeParams`] and [`LoadOptions`] in one place.

use crate::BakeError;
use crate::form_factor::FormFactorParams;
use crate::order::OrderKind;
use crate::passes::probes::{ProbeRank, ProbeSpec};
use crate::pipeline::{BakeParams, FormatChoice, SystemsChoice};
use crate::scene::format::FormatKind;
use crate::scene::{LoadOptions, Scene};
use crate::simplify::VoxelParams;
use crate::transfer::BounceSpec;
use radiosity_core::Format;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A flag's value as JSON gives it: text (`"inf"`, `"auto"`) or a number (`3`).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged)]
pub enum Word {
    /// A string.
    Text(String),
    /// A number, as written.
    Number(serde_json::Number),
}

impl Word {
    fn text(&self) -> String {
        match self {
            Word::Text(s) => s.clone(),
            Word::Number(n) => n.to_string(),
        }
    }
}

impl From<&str> for Word {
    fn from(s: &str) -> Self {
        Word::Text(s.to_owned())
    }
}

/// Every bake flag, by its long name with `_` for `-` (`--form-factors` is `form_factors`);
/// `None` takes the command line's default. Unknown keys are refused when read from JSON
/// ([`BakeFlags::from_json`]).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BakeFlags {
    /// Target patch count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub patches: Option<usize>,
    /// Voxel cell size in scene units (instead of `patches`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voxel: Option<f64>,
    /// Bounces: a number K ≥ 1, `inf`, or `auto` (the default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounces: Option<Word>,
    /// Storage format: auto (the default), bc1, bc4, u8, f16, f32.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub format: Option<String>,
    /// Patch order: none, random, paper, spatial, best (the default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub order: Option<String>,
    /// Fraction of the largest entries kept exactly.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sparse: Option<f32>,
    /// Share of the 4×4 blocks given a block correction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub corrections: Option<f32>,
    /// Largest tile side in patches (a multiple of 4).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tile: Option<u32>,
    /// Form factors: draft, default, fine.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub form_factors: Option<String>,
    /// Lower reflectances at or above this, in (0, 1), to it with a warning.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_reflectance: Option<f64>,
    /// Direct-light points a patch has at least (1 to 64).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direct_points: Option<u32>,
    /// Direct-light points of a patch a shadow may cross (1 to 64).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow_points: Option<u32>,
    /// Light probes: `auto` (the default), `none`, a spacing, or a JSON file of points.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probes: Option<Word>,
    /// What the probes store: `auto` (the default), `full` or a rank.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probe_rank: Option<Word>,
    /// Sky visibility: `on` (the default) or `off`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky: Option<String>,
    /// Systems: `auto` (the default), `off` or a count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub systems: Option<Word>,
    /// The memory the bake may take at its peak, in GB (default: the machine's physical
    /// memory): a patch target whose estimated peak exceeds it is refused before anything is
    /// loaded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory_budget: Option<f64>,
}

/// The keys of [`BakeFlags`] in JSON.
const KEYS: [&str; 17] = [
    "patches",
    "voxel",
    "bounces",
    "format",
    "order",
    "sparse",
    "corrections",
    "tile",
    "form_factors",
    "max_reflectance",
    "direct_points",
    "shadow_points",
    "probes",
    "probe_rank",
    "sky",
    "systems",
    "memory_budget",
];

/// Refuses with a flag's message.
fn refuse<T>(message: String) -> Result<T, BakeError> {
    Err(BakeError::Flag(message))
}

impl BakeFlags {
    /// Reads the flags from a JSON object (`{"patches": 1024, "format": "bc1"}`); an unknown
    /// key, a value of the wrong type or anything but an object is an error naming it.
    pub fn from_json(text: &str) -> Result<Self, BakeError> {
        if text.trim().is_empty() {
            return Ok(Self::default());
        }
        let bad = |m: String| BakeError::Flag(format!("bad bake options: {m}"));
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        let Some(object) = value.as_object() else {
            return Err(bad(format!("expected a JSON object, not {value}")));
        };
        // Each key alone first, so that the message names the key at fault.
        for (key, v) in object {
            if !KEYS.contains(&key.as_str()) {
                return Err(bad(format!(
                    "unknown key `{key}` (the keys are {})",
                    KEYS.join(", ")
                )));
            }
            let one = serde_json::json!({ key: v });
            serde_json::from_value::<Self>(one).map_err(|e| bad(format!("`{key}`: {e}")))?;
        }
        serde_json::from_value(value).map_err(|e| bad(e.to_string()))
    }

    /// The bake's parameters and the scene's loading options, every flag checked (a patch
    /// target this machine cannot hold is refused here, before anything is loaded).
    pub fn params(&self) -> Result<(BakeParams, LoadOptions), BakeError> {
        let mut p = BakeParams {
            bounces: parse_bounces(&self.bounces.as_ref().map_or("auto".into(), Word::text))?,
            ..BakeParams::default()
        };
        if let Some(v) = voxel_params(self.patches, self.voxel)? {
            p.voxel = v;
        }
        p.form_factors = form_factor_params(self.form_factors.as_deref().unwrap_or("default"))?;
        p.format = match self.format.as_deref().unwrap_or("auto") {
            "auto" => FormatChoice::Auto,
            name => FormatChoice::Fixed(Format::from_name(name).ok_or_else(|| {
                BakeError::Flag(format!(
                    "unknown --format {name:?} (auto, bc1, bc4, u8, f16, f32)"
                ))
            })?),
        };
        if let Some(f) = self.sparse {
            if !(0.0..=1.0).contains(&f) {
                return refuse(format!("--sparse must be a fraction in [0, 1], not {f}"));
            }
            p.sparse_fraction = Some(f);
        }
        if let Some(f) = self.corrections {
            if !(0.0..=1.0).contains(&f) {
                return refuse(format!(
                    "--corrections must be a fraction in [0, 1], not {f}"
                ));
            }
            p.corrections = Some(f);
        }
        if let Some(t) = self.tile {
            if t < 4 || t % 4 != 0 {
                return refuse(format!("--tile must be a positive multiple of 4, not {t}"));
            }
            p.encode.max_tile = t;
        }
        if let Some(k) = self.direct_points {
            let most = crate::simplify::runtime_mesh::MAX_DIRECT_POINTS;
            if !(1..=most).contains(&k) {
                return refuse(format!("--direct-points must be 1 to {most}, not {k}"));
            }
            p.direct_points = k;
        }
        if let Some(k) = self.shadow_points {
            let most = crate::simplify::runtime_mesh::MAX_DIRECT_POINTS;
            if !(1..=most).contains(&k) {
                return refuse(format!("--shadow-points must be 1 to {most}, not {k}"));
            }
            p.shadow_points = k;
        }
        let order = self.order.as_deref().unwrap_or("best");
        p.order = OrderKind::from_name(order).ok_or_else(|| {
            BakeError::Flag(format!(
                "unknown --order {order:?} (none, random, paper, spatial, best)"
            ))
        })?;
        p.probes = ProbeSpec::parse(&self.probes.as_ref().map_or("auto".into(), Word::text))?;
        p.probe_rank =
            ProbeRank::parse(&self.probe_rank.as_ref().map_or("auto".into(), Word::text))?;
        p.sky = match self.sky.as_deref().unwrap_or("on") {
            "on" => true,
            "off" => false,
            other => return refuse(format!("--sky must be on or off, not {other:?}")),
        };
        p.systems = match self
            .systems
            .as_ref()
            .map_or("auto".into(), Word::text)
            .as_str()
        {
            "auto" => SystemsChoice::Auto,
            "off" => SystemsChoice::Off,
            other => match other.parse::<usize>() {
                Ok(k) if k >= 1 => SystemsChoice::Count(k),
                _ => {
                    return refuse(format!(
                        "--systems must be off, auto or a count of at least 1, not {other:?}"
                    ));
                }
            },
        };
        let budget = match self.memory_budget {
            None => crate::limits::Budget::Machine(crate::limits::physical_memory()),
            Some(gb) if gb.is_finite() && gb > 0.0 => crate::limits::Budget::Given(gb * 1e9),
            Some(gb) => {
                return refuse(format!(
                    "--memory-budget must be a positive number of GB, not {gb}"
                ));
            }
        };
        if let Some(n) = self.patches {
            // Before anything is loaded or allocated: the matrices must fit in memory.
            crate::limits::check_patches_within(n, budget, p.bounces, p.systems)?;
        }
        Ok((p, capped_loading(self.max_reflectance)?))
    }
}

/// The simplification asked for by `--patches N` or `--voxel SIZE` (`None`: the default).
pub fn voxel_params(
    patches: Option<usize>,
    voxel: Option<f64>,
) -> Result<Option<VoxelParams>, BakeError> {
    Ok(match (patches, voxel) {
        (Some(_), Some(_)) => return refuse("give --patches or --voxel, not both".into()),
        (Some(0), _) => return refuse("--patches must be at least 1".into()),
        (Some(n), None) => {
            crate::limits::check_ceiling(n)?;
            Some(VoxelParams::with_patches(n))
        }
        (None, Some(s)) if !(s.is_finite() && s > 0.0) => {
            return refuse(format!("--voxel must be a positive size, not {s}"));
        }
        (None, Some(s)) => Some(VoxelParams::with_cell_size(s)),
        (None, None) => None,
    })
}

/// Loading with `--max-reflectance`, checked.
pub fn capped_loading(max_reflectance: Option<f64>) -> Result<LoadOptions, BakeError> {
    let mut o = LoadOptions::default();
    if let Some(r) = max_reflectance {
        if !(r > 0.0 && r < 1.0) {
            return refuse(format!("--max-reflectance must be in (0, 1), not {r}"));
        }
        o.max_reflectance = Some(r);
    }
    Ok(o)
}

/// The form-factor settings named by `--form-factors` (`FormFactorParams`'s presets).
pub fn form_factor_params(name: &str) -> Result<FormFactorParams, BakeError> {
    Ok(match name {
        "draft" => FormFactorParams::fast(),
        "default" => FormFactorParams::default(),
        "fine" => FormFactorParams::high_quality(),
        other => {
            return refuse(format!(
                "unknown --form-factors {other:?} (draft, default, fine)"
            ));
        }
    })
}

/// `--bounces`: `auto`, `inf` or a count of at least 1.
fn parse_bounces(s: &str) -> Result<BounceSpec, BakeError> {
    Ok(match s {
        "auto" => BounceSpec::default(),
        "inf" | "infinite" => BounceSpec::Infinite,
        k => match k.parse::<u32>() {
            Ok(0) => return refuse("--bounces must be at least 1".into()),
            Ok(k) => BounceSpec::Fixed(k),
            Err(_) => {
                return refuse(format!(
                    "--bounces must be a number, `inf` or `auto`, not {k:?}"
                ));
            }
        },
    })
}

/// Loads a scene (`Scene::load_with`, by the format table: glTF for `.gltf` and `.glb`, else
/// OBJ), refusing first an OBJ that is not text (a PNG renamed `.obj` is "not an OBJ file", not
/// a scene without triangles).
pub fn load_scene(path: &Path, load: &LoadOptions) -> Result<Scene, BakeError> {
    if crate::scene::format::of(path).kind == FormatKind::Obj
        && let Some(why) = binary_data(path)
    {
        return Err(BakeError::NotText {
            path: path.to_owned(),
            message: why,
        });
    }
    Ok(Scene::load_with(path, load)?)
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
