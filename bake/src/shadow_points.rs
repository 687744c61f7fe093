//! Direct-light points where shadows fall: a patch whose points do not all see out the same way
//! gets more of them.
//!
//! The runtime samples a light's direct irradiance on a patch at its direct-light points
//! ([`direct_points`]), one shadow ray each per frame. Four points decide well enough how much
//! of an open patch is lit, but not of one a shadow edge crosses: a pavilion's plinth under
//! the roof, sunlit between the columns' shadows, came out ±40–60% per object from four points
//! a patch (`docs/decisions/shadow-points.md`). The light's direction is not known at bake
//! time, so the test asks of every direction at once: from [`PROBE_POINTS`] points of the patch
//! and [`PROBE_DIRECTIONS`] cosine-weighted directions about its normal, does some direction
//! light some points and not others (a ray that leaves the scene against one that meets
//! something, or a point whose own face turns away)? Such a patch gets `shadowed` points, the
//! others keep `min`. The probe costs 256 rays a patch, once.

use crate::effect_plan::Effect;
use crate::geometry::Occluders;
use crate::patch::Patches;
use crate::patch::points::cosine_at;
use crate::simplify::runtime_mesh::direct_points;
use rayon::prelude::*;

/// Direct-light points a patch that shadows may cross has by default.
pub const SHADOW_POINTS: u32 = 32;

/// Points of a patch the probe looks out from.
const PROBE_POINTS: u32 = 16;

/// Directions the probe looks in: a `PROBE_GRID × PROBE_GRID` grid of the unit square mapped
/// to cosine-weighted directions about the patch's normal (the weight a directional light's
/// irradiance carries).
const PROBE_GRID: u32 = 4;

/// Directions of the probe.
pub const PROBE_DIRECTIONS: u32 = PROBE_GRID * PROBE_GRID;

/// The number of direct-light points of each patch (simplification order): `shadowed` where a
/// shadow may cross it ([`crosses`]), `min` elsewhere; and the effect that says how many.
pub(crate) fn direct_point_counts(
    patches: &Patches,
    occ: &Occluders,
    objects: &[u32],
    min: u32,
    shadowed: u32,
) -> (Vec<u32>, Effect) {
    let n = patches.len();
    if shadowed <= min {
        return (
            vec![min; n],
            Effect::new(
                false,
                format!(
                    "--shadow-points {shadowed} is not above --direct-points {min}: every patch has {min} direct-light points"
                ),
            ),
        );
    }
    let raised: Vec<bool> = (0..n)
        .into_par_iter()
        .map(|i| crosses(patches, i, occ, objects))
        .collect();
    let count = raised.iter().filter(|&&r| r).count();
    let total: f64 = patches.patches.iter().map(|p| p.area).sum();
    let area: f64 = (0..n)
        .filter(|&i| raised[i])
        .map(|i| patches.patches[i].area)
        .sum();
    let share = if total > 0.0 { area / total } else { 0.0 };
    let counts: Vec<u32> = raised
        .iter()
        .map(|&r| if r { shadowed } else { min })
        .collect();
    let why = if count == 0 {
        format!(
            "no patch's points see out differently in any of {PROBE_DIRECTIONS} directions: every patch has {min} direct-light points"
        )
    } else {
        format!(
            "{count} of {n} patches ({share:.3} of the area) have points that see out differently in some of {PROBE_DIRECTIONS} directions (a shadow may cross them): {shadowed} direct-light points each, {min} elsewhere"
        )
    };
    (counts, Effect::new(count > 0, why))
}

/// Whether some direction about patch `i`'s normal lights some of its probe points and not
/// others: the ray from one leaves the scene and from another meets something, or one
/// point's face turns away from the direction (a column's facets around a bend), or two rays
/// meet different objects, one at less than [`NEAR_SHARE`] of the other's distance (a light
/// between the two in that direction lights one point and not the other: the floor under a
/// table's edge in a closed room, whose rays never leave). `objects`: the object of each
/// scene triangle.
fn crosses(patches: &Patches, i: usize, occ: &Occluders, objects: &[u32]) -> bool {
    let points = direct_points(patches.pieces_of(i), PROBE_POINTS);
    if points.len() < 2 {
        return false;
    }
    let normal = patches.patches[i].normal;
    // As the runtime's shadow ray for a directional light: a segment past the scene's far side.
    let far = 2.0 * occ.extent();
    let g = f64::from(PROBE_GRID);
    for a in 0..PROBE_GRID {
        for b in 0..PROBE_GRID {
            let d = cosine_at(normal, (f64::from(a) + 0.5) / g, (f64::from(b) + 0.5) / g);
            let (mut lit, mut dark) = (false, false);
            // The nearest and farthest hits: (distance, object).
            let (mut near, mut farthest) = ((f64::INFINITY, 0), (0.0, 0));
            for p in &points {
                if p.normal.dot(d) <= 0.0 {
                    dark = true;
                } else if occ
                    .segment_visible(p.position, p.position + d * (far + p.position.length()))
                {
                    lit = true;
                } else {
                    dark = true;
                    if let Some(h) = occ.closest_hit_from_surface(p.position, d, 2.0 * far) {
                        let o = objects.get(h.triangle as usize).copied().unwrap_or(0);
                        if h.distance < near.0 {
                            near = (h.distance, o);
                        }
                        if h.distance > farthest.0 {
                            farthest = (h.distance, o);
                        }
                    }
                }
                if lit && dark {
                    return true;
                }
            }
            if near.1 != farthest.1 && near.0 < NEAR_SHARE * farthest.0 {
                return true;
            }
        }
    }
    false
}

/// Two hits of one probe direction this far apart (the nearer at less than this share of the
/// farther's distance), on different objects, say that a light may stand between them.
const NEAR_SHARE: f64 = 0.5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use crate::simplify::{Resolution, VoxelParams, simplify};

    /// A 4 × 4 floor and, 1 above its −x half, a 2 × 4 roof (both sides).
    fn floor_and_roof() -> Scene {
        let obj = "\
o floor
v 0 0 0
v 4 0 0
v 4 0 4
v 0 0 4
f 1 4 3 2
o roof
v 0 1 0
v 2 1 0
v 2 1 4
v 0 1 4
f 5 8 7 6
f 5 6 7 8
";
        Scene::from_obj_str(std::path::Path::new("roof.obj"), obj).expect("scene")
    }

    /// The scene in 0.5 cells, and its direct-light point counts at 4 and 32.
    fn raised(scene: &Scene) -> (Patches, Vec<u32>, Effect) {
        let voxel = VoxelParams {
            resolution: Resolution::CellSize(0.5),
            ..VoxelParams::default()
        };
        let patches = simplify(scene, &voxel).expect("patches");
        let objects: Vec<u32> = scene.triangles.iter().map(|t| t.object).collect();
        let (counts, effect) = direct_point_counts(&patches, &scene.occluders(), &objects, 4, 32);
        (patches, counts, effect)
    }

    #[test]
    fn only_patches_a_shadow_can_cross_get_more_points() {
        let scene = floor_and_roof();
        let (patches, counts, effect) = raised(&scene);
        assert!(effect.on, "{}", effect.why);
        let mut raised_roof_top = 0;
        let mut under_the_edge = Vec::new();
        for (i, p) in patches.patches.iter().enumerate() {
            let c = p.centre;
            if p.normal.y > 0.5 && c.y > 0.5 {
                raised_roof_top += usize::from(counts[i] != 4);
            } else if p.normal.y > 0.5 && (c.x - 2.0).abs() < 0.5 {
                under_the_edge.push(counts[i]);
            }
        }
        // The roof's top sees the whole sky from every point: never raised.
        assert_eq!(raised_roof_top, 0);
        // The floor along the roof's edge (x = 2): rays tilted towards +x leave from its
        // points beyond the edge and meet the roof from those under it.
        assert!(
            !under_the_edge.is_empty() && under_the_edge.iter().all(|&c| c == 32),
            "{under_the_edge:?}"
        );
        // With no more points asked for shadows than the minimum, nothing changes.
        let objects: Vec<u32> = scene.triangles.iter().map(|t| t.object).collect();
        let (same, off) = direct_point_counts(&patches, &scene.occluders(), &objects, 4, 4);
        assert!(same.iter().all(|&c| c == 4) && !off.on);
    }

    #[test]
    fn closed_rooms_raise_points_where_a_light_inside_may_cast_a_shadow() {
        // An 8 × 3 × 8 closed room (faces inward) with a two-sided slab 1 above the floor's
        // x < 2 strip: no ray leaves, so only the hits' distances and objects can tell.
        // Tilted towards −x, rays from the floor along the slab's edge meet the slab (about
        // 1 away) from under it and the ceiling or the far wall (3 or more) from beside it: a
        // light between them lights one and not the other. The floor at x in [5, 6] sees the
        // ceiling and the walls, whose hits of one direction meet at the room's edges without
        // a jump: kept at 4.
        let obj = "\
o floor
v 0 0 0
v 8 0 0
v 8 0 8
v 0 0 8
f 1 4 3 2
o ceiling
v 0 3 0
v 8 3 0
v 8 3 8
v 0 3 8
f 5 6 7 8
o walls
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
o slab
v 0 1 0
v 2 1 0
v 2 1 8
v 0 1 8
f 9 12 11 10
f 9 10 11 12
";
        let scene = Scene::from_obj_str(std::path::Path::new("room.obj"), obj).expect("scene");
        let (patches, counts, effect) = raised(&scene);
        assert!(effect.on, "{}", effect.why);
        let (mut edge, mut open) = (Vec::new(), Vec::new());
        for (i, p) in patches.patches.iter().enumerate() {
            let c = p.centre;
            if p.normal.y < 0.5 || c.y > 0.5 || !(2.0..6.0).contains(&c.z) {
                continue;
            }
            if (c.x - 2.0).abs() < 0.5 {
                edge.push(counts[i]);
            } else if (5.0..6.0).contains(&c.x) {
                open.push(counts[i]);
            }
        }
        assert!(
            !edge.is_empty() && edge.iter().all(|&c| c == 32),
            "{edge:?}"
        );
        assert!(!open.is_empty() && open.iter().all(|&c| c == 4), "{open:?}");
    }
}
