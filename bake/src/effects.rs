//! Effect planning: decide, from the scene itself, which effects the bake must simulate, and say
//! why. Each decision changes the work done (channels stored, rays cast, bounces computed,
//! patches kept), and is reported under `effects` in `bake --json`.

use crate::scene::Scene;
use crate::voxel::Patches;
use glam::DVec3;
use serde::Serialize;
use std::collections::BTreeMap;

/// One decision: whether the effect is simulated, and the reason in a sentence.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Effect {
    /// Simulated or not.
    pub on: bool,
    /// Why, with the numbers that decided it.
    pub why: String,
}

impl Effect {
    /// A decision.
    pub fn new(on: bool, why: impl Into<String>) -> Self {
        Self {
            on,
            why: why.into(),
        }
    }
}

/// Every decision, by name (`colour`, `occlusion`, `bounces`, `emission`, `closed`,
/// `dark_patches`), in a stable order.
pub type Effects = BTreeMap<&'static str, Effect>;

/// Whether every patch is grey (R = G = B to 1e-6): then one channel carries all colours.
pub fn plan_colour(patches: &Patches) -> Effect {
    let coloured = patches.patches.iter().position(|p| {
        let r = p.reflectance;
        (r.max_channel() - r.min_channel()).abs() > 1e-6
    });
    match coloured {
        None => Effect::new(
            false,
            "every material is grey: one channel stored and gathered, light keeps its colour",
        ),
        Some(i) => {
            let r = patches.patches[i].reflectance;
            Effect::new(
                true,
                format!(
                    "patch {i} has coloured reflectance ({:.3}, {:.3}, {:.3}): three channels",
                    r.r, r.g, r.b
                ),
            )
        }
    }
}

/// Whether anything can occlude anything: `false` when the scene is the inside of a convex
/// polyhedron (every vertex on or in front of every triangle's plane), where every pair of
/// front faces sees each other unobstructed. Planes are de-duplicated first, so a finely meshed
/// box costs six plane tests per vertex.
pub fn plan_occlusion(scene: &Scene) -> Effect {
    let (lo, hi) = scene.bounds();
    let tol = 1e-9 * (hi - lo).length().max(f64::MIN_POSITIVE);
    let mut planes: Vec<(DVec3, f64)> = Vec::new();
    for t in 0..scene.triangles.len() {
        let n = scene.triangle_normal(t);
        let d = n.dot(scene.corners(t)[0]);
        if !planes
            .iter()
            .any(|(m, e)| (*m - n).length() < 1e-9 && (e - d).abs() < tol)
        {
            planes.push((n, d));
            if planes.len() > 4096 {
                return Effect::new(
                    true,
                    "more than 4096 distinct planes: not a convex enclosure, visibility rays cast",
                );
            }
        }
    }
    let used: Vec<DVec3> = scene
        .triangles
        .iter()
        .flat_map(|t| t.vertices.map(|v| scene.positions[v as usize]))
        .collect();
    for (n, d) in &planes {
        if let Some(p) = used.iter().find(|p| n.dot(**p) - d < -tol) {
            return Effect::new(
                true,
                format!(
                    "not a convex enclosure (vertex ({:.3}, {:.3}, {:.3}) lies behind a face): visibility rays cast",
                    p.x, p.y, p.z
                ),
            );
        }
    }
    Effect::new(
        false,
        format!(
            "the scene is a convex enclosure ({} face planes): nothing can occlude, no visibility rays",
            planes.len()
        ),
    )
}

/// Whether the scene emits light itself.
pub fn plan_emission(patches: &Patches) -> Effect {
    let emitters = patches
        .patches
        .iter()
        .filter(|p| p.emission.max_channel() > 0.0)
        .count();
    if emitters == 0 {
        Effect::new(
            false,
            "no emissive surface: light comes only from runtime lights",
        )
    } else {
        Effect::new(
            true,
            format!(
                "{emitters} emissive patches light the scene (their intensity may change at run time)"
            ),
        )
    }
}
