//! The `spatial` order: patches grouped by orientation (dominant normal axis and sign, six
//! groups), then along a space-filling curve over their centres.
//!
//! Patches that are close and face the same way see nearly the same scene, so their rows (and
//! columns) of M are alike; a curve keeps such patches consecutive, which is what a 4×4 block
//! needs. Grouping by orientation first keeps a wall's patches apart from those of the box side
//! right in front of it, whose rows differ completely. Hilbert is the default: unlike Morton it
//! has no long jumps, so more aligned groups of four are compact.

use radiosity_core::Patch;

/// Which space-filling curve orders the centres within an orientation group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Curve {
    /// 3-D Hilbert curve (Skilling 2004): consecutive cells always share a face.
    Hilbert,
    /// 3-D Morton (Z-order): bit interleaving; cheaper, with jumps at power-of-two boundaries.
    /// No order picks it (Hilbert is the default, module doc); it stays as the comparison.
    #[expect(dead_code, reason = "kept as the comparison; no order constructs it")]
    Morton,
}

/// Bits per axis of the curve grid: 2^16 cells per side, far finer than any patch spacing.
const BITS: u32 = 16;

/// Orientation group of a normal: `2·axis + (component < 0)` for its largest component.
pub fn orientation(normal: [f32; 3]) -> u8 {
    let a = normal.map(f32::abs);
    let axis = if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    };
    2 * axis as u8 + u8::from(normal[axis] < 0.0)
}

/// The permutation (`perm[new] = old`) sorting patches by orientation group, then by `curve`
/// over their centres in the bounding cube of all centres. Ties (equal keys) keep the given
/// order, so the result is deterministic.
pub(crate) fn spatial_order(patches: &[Patch], curve: Curve) -> Vec<u32> {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in patches {
        for k in 0..3 {
            lo[k] = lo[k].min(p.centre[k]);
            hi[k] = hi[k].max(p.centre[k]);
        }
    }
    // A cube, not a box: the curve's locality is isotropic only on a cubic grid.
    let side = (0..3).map(|k| hi[k] - lo[k]).fold(0f32, f32::max);
    let cells = (1u32 << BITS) as f32;
    let scale = if side > 0.0 {
        (cells - 1.0) / side
    } else {
        0.0
    };
    let keys: Vec<u64> = patches
        .iter()
        .map(|p| {
            let cell: [u32; 3] = core::array::from_fn(|k| {
                // Finite centres give values in [0, cells − 1]; the cast saturates otherwise.
                ((p.centre[k] - lo[k]) * scale) as u32
            });
            let along = match curve {
                Curve::Hilbert => hilbert_3d(cell, BITS),
                Curve::Morton => morton_3d(cell, BITS),
            };
            u64::from(orientation(p.normal)) << (3 * BITS) | along
        })
        .collect();
    let mut perm: Vec<u32> = (0..patches.len() as u32).collect();
    perm.sort_by_key(|&i| keys[i as usize]); // stable
    perm
}

/// Position of cell `x` (each coordinate below `2^bits`, `3·bits ≤ 64`) along the 3-D Hilbert
/// curve. J. Skilling, "Programming the Hilbert curve", AIP Conf. Proc. 707 (2004): axes to
/// transposed index, then the transpose's bits interleaved, most significant first.
pub(crate) fn hilbert_3d(mut x: [u32; 3], bits: u32) -> u64 {
    debug_assert!(bits >= 1 && 3 * bits <= 64);
    let top = 1u32 << (bits - 1);
    // Inverse undo of the excess work.
    let mut q = top;
    while q > 1 {
        let p = q - 1;
        for i in 0..3 {
            if x[i] & q != 0 {
                x[0] ^= p;
            } else {
                let t = (x[0] ^ x[i]) & p;
                x[0] ^= t;
                x[i] ^= t;
            }
        }
        q >>= 1;
    }
    // Gray encode.
    for i in 1..3 {
        x[i] ^= x[i - 1];
    }
    let mut t = 0;
    let mut q = top;
    while q > 1 {
        if x[2] & q != 0 {
            t ^= q - 1;
        }
        q >>= 1;
    }
    for v in &mut x {
        *v ^= t;
    }
    interleave(x, bits)
}

/// Position of cell `x` along the 3-D Morton (Z-order) curve.
pub(crate) fn morton_3d(x: [u32; 3], bits: u32) -> u64 {
    interleave(x, bits)
}

/// Bits of `x[0]`, `x[1]`, `x[2]` interleaved from the most significant, `x[0]` first.
fn interleave(x: [u32; 3], bits: u32) -> u64 {
    let mut h = 0u64;
    for b in (0..bits).rev() {
        for v in x {
            h = h << 1 | u64::from((v >> b) & 1);
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_visits_every_cell_once_through_faces() {
        let bits = 3;
        let side = 1u32 << bits;
        let mut cells: Vec<(u64, [u32; 3])> = (0..side.pow(3))
            .map(|i| {
                let c = [i % side, i / side % side, i / side / side];
                (hilbert_3d(c, bits), c)
            })
            .collect();
        cells.sort_unstable();
        for (k, (h, _)) in cells.iter().enumerate() {
            assert_eq!(*h, k as u64, "indices are a bijection onto 0..512");
        }
        for w in cells.windows(2) {
            let d: u32 = (0..3).map(|k| w[0].1[k].abs_diff(w[1].1[k])).sum();
            assert_eq!(
                d, 1,
                "cells {:?} → {:?} are not face neighbours",
                w[0].1, w[1].1
            );
        }
    }

    #[test]
    fn orientation_groups() {
        assert_eq!(orientation([1.0, 0.0, 0.0]), 0);
        assert_eq!(orientation([-1.0, 0.2, 0.0]), 1);
        assert_eq!(orientation([0.0, 0.9, -0.3]), 2);
        assert_eq!(orientation([0.1, -0.9, 0.3]), 3);
        assert_eq!(orientation([0.0, 0.0, 1.0]), 4);
        assert_eq!(orientation([0.5, 0.0, -0.7]), 5);
    }
}
