//! Axis-aligned boxes: whether a ray crosses one (the rebake's test of which rays may meet
//! what changed).

use glam::DVec3;

/// Whether the ray `x + t·d`, `t` in `[0, far]`, crosses the box `[lo, hi]`.
pub fn crosses(x: DVec3, d: DVec3, far: f64, (lo, hi): (DVec3, DVec3)) -> bool {
    let (mut t0, mut t1) = (0.0f64, far);
    for a in 0..3 {
        let inv = 1.0 / d[a];
        let (mut ta, mut tb) = ((lo[a] - x[a]) * inv, (hi[a] - x[a]) * inv);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        // NaN (a zero direction on an axis with x on a face) keeps the ray: conservative.
        t0 = if ta > t0 { ta } else { t0 };
        t1 = if tb < t1 { tb } else { t1 };
        if t0 > t1 {
            return false;
        }
    }
    true
}
