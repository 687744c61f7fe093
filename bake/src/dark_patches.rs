//! Dark patches: a patch whose row of F is zero sees nothing. One buried whole under another
//! object is dropped from the matrix; the others (facing the void, such as a roof under the
//! sky) stay with a zero row, since direct light still reaches them. Hemisphere rays from them
//! ([`check_dark`]) check the zero rows.

use crate::effect_plan::Effect;
use crate::geometry::Occluders;
use crate::patch::Patches;
use crate::patch::points::{Owners, shares};
use rayon::prelude::*;
use serde::Serialize;

/// The `dark_patches` decision for a non-empty `dark` list, of which `kept` stay in the matrix
/// (the rest the burial test buried whole, [`expose`]), those checked by hemisphere rays
/// ([`check_dark`]); a kept dark patch whose rays land on patches also adds a warning to
/// `patches`.
pub(crate) fn dark_patches(
    patches: &mut Patches,
    occ: &Occluders,
    dark: &[usize],
    kept: &[usize],
    areas: &[f64],
    seed: u64,
) -> Effect {
    let buried = dark.len() - kept.len();
    let check = check_dark(patches, occ, kept, seed);
    let verdict = if check.seeing > 0 {
        let seeing_area: f64 = check.seeing_patches.iter().map(|&i| areas[i]).sum();
        patches.warnings.push(format!(
            "{} patches ({:.2}% of the area) pass on no bounced light though hemisphere rays from them reach other patches (up to {:.0}% of their rays, patch {}); their form factors found nothing: bake with `--form-factors fine`, or with more `--patches` so that they are not so small",
            check.seeing,
            100.0 * seeing_area / areas.iter().sum::<f64>(),
            100.0 * check.largest_share,
            check.worst_patch.unwrap_or(0)
        ));
        format!("; {} contradict it: see the warnings)", check.seeing)
    } else {
        format!(
            "): {} lie under or inside other objects (their rays meet back faces), {} face the void",
            check.covered,
            check.checked - check.covered
        )
    };
    // Hemisphere rays pass through a face they start on, so a patch lying face to face against
    // a part whose other side looks out of the room "faces the void" to them.
    let kept = kept.len();
    let dark_area: f64 = dark.iter().map(|&i| areas[i]).sum();
    Effect::new(
        true,
        format!(
            "{} of {} patches ({:.3} of the area) see nothing: {buried} buried whole (inside another object or face to face against one) are dropped from the matrix, {kept} stay with a zero row (direct light reaches them, they pass none on); hemisphere rays from {} of them land on a patch at most {:.3} of the time ({} rays each{verdict}",
            dark.len(),
            patches.len(),
            dark_area / areas.iter().sum::<f64>(),
            check.checked,
            check.largest_share,
            check.rays,
        ),
    )
}

/// Hemisphere rays per patch in [`check_dark`]: a patch that sends [`DARK_SHARE`] of its light
/// to other patches shows it in 13 rays on average, and a patch that truly sees nothing in none.
pub(crate) const DARK_CHECK_RAYS: u32 = 256;

/// At most this many dark patches are checked (spread evenly over them): 131 k rays.
pub(crate) const DARK_CHECK_MAX: usize = 512;

/// A dark patch whose hemisphere rays land on patches at least this often contradicts its zero
/// row of F: the bake warns.
pub(crate) const DARK_SHARE: f64 = 0.05;

/// What hemisphere rays say of the patches whose row of F is zero (which the bake drops).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DarkCheck {
    /// Patches checked: every dark patch, or [`DARK_CHECK_MAX`] of them spread evenly.
    pub checked: usize,
    /// Rays per patch.
    pub rays: u32,
    /// The largest share of rays that landed on a patch's front face.
    pub largest_share: f64,
    /// Patch of `largest_share` (`None` when nothing was checked).
    pub worst_patch: Option<usize>,
    /// Patches whose share reached [`DARK_SHARE`].
    pub seeing: usize,
    /// Those patches (of the ones checked).
    #[serde(skip)]
    pub seeing_patches: Vec<usize>,
    /// Patches whose rays mostly meet back faces first: covered by or inside other objects
    /// (a floor under a block).
    pub covered: usize,
}

/// Casts [`DARK_CHECK_RAYS`] hemisphere rays from each of the `dark` patches (those whose row
/// of F is zero) and reports how many of them land on patches. A patch facing out of a room
/// sends every ray into the void, one covered by another object (a floor under a block) into
/// that object's back faces, and both confirm their zero rows; a patch whose rays land on
/// other patches lost its light to a fault in the form factors, and with it the light it would
/// have passed on.
pub fn check_dark(patches: &Patches, occ: &Occluders, dark: &[usize], seed: u64) -> DarkCheck {
    let picked: Vec<usize> = if dark.len() > DARK_CHECK_MAX {
        (0..DARK_CHECK_MAX)
            .map(|k| dark[k * dark.len() / DARK_CHECK_MAX])
            .collect()
    } else {
        dark.to_vec()
    };
    let owners = Owners::new(patches);
    let (shares, back): (Vec<f64>, Vec<f64>) = picked
        .par_iter()
        .map(|&i| shares(patches, &owners, occ, i, DARK_CHECK_RAYS, seed))
        .unzip();
    let seeing_patches: Vec<usize> = picked
        .iter()
        .zip(&shares)
        .filter(|(_, s)| **s >= DARK_SHARE)
        .map(|(&i, _)| i)
        .collect();
    let worst = shares
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(k, &s)| (picked[k], s));
    DarkCheck {
        checked: picked.len(),
        rays: DARK_CHECK_RAYS,
        largest_share: worst.map_or(0.0, |w| w.1),
        worst_patch: worst.map(|w| w.0),
        seeing: seeing_patches.len(),
        seeing_patches,
        covered: back.iter().filter(|&&b| b > 0.5).count(),
    }
}
