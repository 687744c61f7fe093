//! Value-space refinement of BC1 and BC4 blocks.
//!
//! texpresso's cluster fit and the BC4 candidates fit 8-bit log codes: a wrong code costs the
//! same wherever it is. The gather adds up *values*, and a code step is a fixed *ratio*
//! (`e^(s/255)`, 2.7% at the default range), so the same code error costs ten times more on a
//! texel ten times larger. A block of a transfer matrix often spans a decade (a patch's near
//! and far neighbours side by side), and its largest texels then carry nearly all of its value
//! error. This module takes a code-space fit as the start and improves it as judged by the
//! weighted squared error in value space, `Σ w·(decode(q) − v)²`, under the reference decoder
//! (D3D10 rules and the tile's decode table), so the judgement is exact:
//!
//! 1. every index is re-picked as the palette entry nearest in value (weighted over channels
//!    for BC1);
//! 2. the endpoints are re-solved by weighted least squares on the codes with the chosen
//!    indices, each texel weighted by `w·v²` (the squared slope of value against code, up to
//!    a constant): the first-order value-space problem; rounded, re-indexed, kept if better;
//! 3. coordinate descent moves each endpoint component by ±1 while the error falls.
//!
//! Each step keeps the block only if its error falls, so the result is never worse than the
//! start in the weighted value-space error. All arithmetic is f32 in a fixed order: the result
//! is a pure function of the input.

mod coupled;
#[cfg(test)]
mod tests;

pub(crate) use coupled::{Coupling, refine_bc1_coupled, refine_bc4_coupled};

use radiosity_core::{Bc1Block, Bc4Block, DecodeMode};

/// What one block should hold.
pub(crate) struct BlockTarget<'a> {
    /// Exact value per channel and texel (row-major); ignored where the weight is 0.
    pub values: [[f32; 16]; 3],
    /// Weight of the squared value error per channel and texel: 0 for texels beyond the last
    /// patch and for sparse texels whose exact value is unknown.
    pub weights: [[f32; 16]; 3],
    /// Texels whose error counts (in the matrix and not in the sparse list). The others still
    /// get the index nearest their value (when their weight is not 0), so that the block decodes
    /// as close to a sparse entry as it can: the sparse selection reads that value.
    pub fit: u32,
    /// Decode table (code → value) per channel; only the channels the format stores are read.
    pub tables: [&'a [f32; 256]; 3],
    /// The codes the fit targets, per channel and texel.
    pub codes: [[u8; 16]; 3],
}

/// Largest number of coordinate-descent sweeps; each sweep tries ±1 on every endpoint
/// component. Measured on the Cornell box, almost every block stops after one or two.
const MAX_SWEEPS: usize = 4;

/// Least-squares rounds (solve, round, re-index); the second rarely changes anything.
const LS_ROUNDS: usize = 2;

/// A BC1 block as refined: endpoints, index bits and the weighted error over `fit`.
#[derive(Clone, Copy)]
struct Bc1State {
    c0: u16,
    c1: u16,
    bits: u32,
    err: f32,
}

/// The decoded palette values `[entry][channel]` of the BC1 endpoint words `c0`, `c1` (D3D10
/// rules, the block's tables) and how many entries a texel may use: 4, or 3 in three-colour
/// mode (index 3 is transparent black, see `guard_bc1`).
fn bc1_palette_values(c0: u16, c1: u16, t: &BlockTarget<'_>) -> ([[f32; 3]; 4], usize) {
    let [a, b] = [c0.to_le_bytes(), c1.to_le_bytes()];
    let block = Bc1Block([a[0], a[1], b[0], b[1], 0, 0, 0, 0]);
    let palette = block.palette(DecodeMode::D3d10);
    let usable = if block.is_four_colour() { 4 } else { 3 };
    let mut pv = [[0f32; 3]; 4];
    for k in 0..usable {
        for ch in 0..3 {
            pv[k][ch] = t.tables[ch][usize::from(palette[k][ch])];
        }
    }
    (pv, usable)
}

/// Evaluates the BC1 block with endpoint words `c0`, `c1` (whose order sets the mode) and
/// each texel's best index in value space; three-colour blocks never use index 3
/// (transparent black, see `guard_bc1`).
fn bc1_eval(c0: u16, c1: u16, t: &BlockTarget<'_>) -> Bc1State {
    let (pv, usable) = bc1_palette_values(c0, c1, t);
    let mut bits = 0u32;
    let mut err = 0f32;
    for i in 0..16 {
        let w = [t.weights[0][i], t.weights[1][i], t.weights[2][i]];
        if w == [0.0; 3] {
            continue;
        }
        let v = [t.values[0][i], t.values[1][i], t.values[2][i]];
        let mut best = (f32::INFINITY, 0u32);
        for (k, p) in pv.iter().enumerate().take(usable) {
            let e = w[0] * (p[0] - v[0]).powi(2)
                + w[1] * (p[1] - v[1]).powi(2)
                + w[2] * (p[2] - v[2]).powi(2);
            if e < best.0 {
                best = (e, k as u32);
            }
        }
        bits |= best.1 << (2 * i);
        if t.fit & (1 << i) != 0 {
            err += best.0;
        }
    }
    Bc1State { c0, c1, bits, err }
}

/// Orders two endpoint words for the wanted mode: four-colour needs `c0 > c1` (`None` when
/// they are equal, which would be three-colour), three-colour `c0 ≤ c1`. Swapping the
/// endpoints of either mode gives the same palette set, so nothing is lost.
fn bc1_order(a: u16, b: u16, four: bool) -> Option<(u16, u16)> {
    match (four, a.cmp(&b)) {
        (true, core::cmp::Ordering::Equal) => None,
        (true, _) => Some((a.max(b), a.min(b))),
        (false, _) => Some((a.min(b), a.max(b))),
    }
}

fn unpack_565(c: u16) -> [i32; 3] {
    [
        i32::from(c >> 11),
        i32::from((c >> 5) & 63),
        i32::from(c & 31),
    ]
}

fn pack_565(c: [i32; 3]) -> u16 {
    ((c[0] as u16) << 11) | ((c[1] as u16) << 5) | c[2] as u16
}

/// Refines a BC1 block (a code-space fit, already guarded) in value space; see the module
/// doc. The result is in the same mode as `start` and never worse than it.
/// Returns the refined block and its weighted squared error over `fit`.
pub(crate) fn refine_bc1(start: Bc1Block, t: &BlockTarget<'_>) -> (Bc1Block, f32) {
    let four = start.is_four_colour();
    let mut best = bc1_eval(start.c0(), start.c1(), t);
    let try_pair = |best: &mut Bc1State, a: u16, b: u16| -> bool {
        match bc1_order(a, b, four) {
            Some((c0, c1)) if (c0, c1) != (best.c0, best.c1) => {
                let s = bc1_eval(c0, c1, t);
                if s.err < best.err {
                    *best = s;
                    return true;
                }
                false
            }
            _ => false,
        }
    };
    for _ in 0..LS_ROUNDS {
        match bc1_least_squares(&best, four, t) {
            Some((a, b)) if try_pair(&mut best, a, b) => {}
            _ => break,
        }
    }
    for _ in 0..MAX_SWEEPS {
        let mut moved = false;
        for end in 0..2 {
            for comp in 0..3 {
                for step in [-1, 1] {
                    let (mut e0, mut e1) = (unpack_565(best.c0), unpack_565(best.c1));
                    let e = if end == 0 { &mut e0 } else { &mut e1 };
                    let top = if comp == 1 { 63 } else { 31 };
                    e[comp] += step;
                    if !(0..=top).contains(&e[comp]) {
                        continue;
                    }
                    moved |= try_pair(&mut best, pack_565(e0), pack_565(e1));
                }
            }
        }
        if !moved {
            break;
        }
    }
    let [a, b] = [best.c0.to_le_bytes(), best.c1.to_le_bytes()];
    let i = best.bits.to_le_bytes();
    (
        Bc1Block([a[0], a[1], b[0], b[1], i[0], i[1], i[2], i[3]]),
        best.err,
    )
}

/// Weight of each endpoint in palette entry `k` (`(α, β)`: entry = α·e0 + β·e1) for BC1;
/// `None` for the transparent entry of three-colour mode.
fn bc1_mix(k: u32, four: bool) -> Option<(f32, f32)> {
    match (k, four) {
        (0, _) => Some((1.0, 0.0)),
        (1, _) => Some((0.0, 1.0)),
        (2, true) => Some((2.0 / 3.0, 1.0 / 3.0)),
        (3, true) => Some((1.0 / 3.0, 2.0 / 3.0)),
        (2, false) => Some((0.5, 0.5)),
        _ => None,
    }
}

/// The two endpoint codes `(x0, x1)` of channel `ch` minimising `Σ w·v²·(a·x0 + b·x1 − q)²`
/// over the fitted texels, where `mix(i)` gives texel `i`'s palette mix `(a, b)` of the two
/// endpoints (`None` for a constant entry, which no endpoint moves); `None` when the 2×2
/// system is singular (every texel on one palette entry).
fn weighted_endpoints(
    t: &BlockTarget<'_>,
    ch: usize,
    mix: impl Fn(usize) -> Option<(f32, f32)>,
) -> Option<(f32, f32)> {
    let (mut aa, mut ab, mut bb, mut aq, mut bq) = (0f32, 0f32, 0f32, 0f32, 0f32);
    for i in 0..16 {
        if t.fit & (1 << i) == 0 {
            continue;
        }
        let Some((a, b)) = mix(i) else {
            continue;
        };
        let v = t.values[ch][i];
        let w = t.weights[ch][i] * v * v;
        let q = f32::from(t.codes[ch][i]);
        aa += w * a * a;
        ab += w * a * b;
        bb += w * b * b;
        aq += w * a * q;
        bq += w * b * q;
    }
    let det = aa * bb - ab * ab;
    if !(det > 1e-6 * aa * bb) {
        return None;
    }
    Some(((bb * aq - ab * bq) / det, (aa * bq - ab * aq) / det))
}

/// Solves for the two endpoints (codes, per channel) that minimise `Σ w·v²·(α e0 + β e1 − q)²`
/// over the fitted texels with `state`'s indices, rounded to 565. `None` when a channel's
/// system is singular (every texel on one palette entry).
fn bc1_least_squares(state: &Bc1State, four: bool, t: &BlockTarget<'_>) -> Option<(u16, u16)> {
    let mut e = [[0i32; 3]; 2];
    for ch in 0..3 {
        let (x0, x1) = weighted_endpoints(t, ch, |i| bc1_mix((state.bits >> (2 * i)) & 3, four))?;
        let top = if ch == 1 { 63.0 } else { 31.0 };
        e[0][ch] = (x0 * top / 255.0).round().clamp(0.0, top) as i32;
        e[1][ch] = (x1 * top / 255.0).round().clamp(0.0, top) as i32;
    }
    Some((pack_565(e[0]), pack_565(e[1])))
}

/// A BC4 block as refined.
#[derive(Clone, Copy)]
struct Bc4State {
    r0: u8,
    r1: u8,
    bits: u64,
    err: f32,
}

/// Evaluates the BC4 block with endpoints `r0`, `r1` on channel `ch` of `t`, each texel on
/// the palette entry nearest its value.
fn bc4_eval(r0: u8, r1: u8, t: &BlockTarget<'_>, ch: usize) -> Bc4State {
    let palette = Bc4Block([r0, r1, 0, 0, 0, 0, 0, 0]).palette(DecodeMode::D3d10);
    let table = t.tables[ch];
    let pv: [f32; 8] = core::array::from_fn(|k| table[usize::from(palette[k])]);
    let mut bits = 0u64;
    let mut err = 0f32;
    for i in 0..16 {
        let w = t.weights[ch][i];
        if w == 0.0 {
            continue;
        }
        let v = t.values[ch][i];
        let mut best = (f32::INFINITY, 0u64);
        for (k, p) in pv.iter().enumerate() {
            let e = (p - v).powi(2);
            if e < best.0 {
                best = (e, k as u64);
            }
        }
        bits |= best.1 << (3 * i);
        if t.fit & (1 << i) != 0 {
            err += w * best.0;
        }
    }
    Bc4State { r0, r1, bits, err }
}

/// `(α, β)` of BC4 palette entry `k` (entry = α·r0 + β·r1), `None` for the constants 0 and
/// 255 of six-value mode.
fn bc4_mix(k: u64, eight: bool) -> Option<(f32, f32)> {
    let steps = if eight { 7.0 } else { 5.0 };
    match k {
        0 => Some((1.0, 0.0)),
        1 => Some((0.0, 1.0)),
        6 | 7 if !eight => None,
        _ => {
            let t = (k - 1) as f32;
            Some(((steps - t) / steps, t / steps))
        }
    }
}

/// Refines BC4 candidates (endpoint pairs, each in its own mode) in value space on channel
/// `ch`: the best candidate by value-space error, then least squares and ±1 descent in its
/// mode. Never worse than the best candidate.
pub(crate) fn refine_bc4(candidates: &[(u8, u8)], t: &BlockTarget<'_>, ch: usize) -> [u8; 8] {
    let mut best = candidates
        .iter()
        .map(|&(r0, r1)| bc4_eval(r0, r1, t, ch))
        .min_by(|a, b| a.err.total_cmp(&b.err))
        .expect("at least one candidate");
    let eight = best.r0 > best.r1;
    let order = |a: i32, b: i32| -> Option<(u8, u8)> {
        let (a, b) = (a.clamp(0, 255) as u8, b.clamp(0, 255) as u8);
        match (eight, a.cmp(&b)) {
            (true, core::cmp::Ordering::Equal) => None,
            (true, _) => Some((a.max(b), a.min(b))),
            (false, _) => Some((a.min(b), a.max(b))),
        }
    };
    let try_pair = |best: &mut Bc4State, a: i32, b: i32| -> bool {
        match order(a, b) {
            Some((r0, r1)) if (r0, r1) != (best.r0, best.r1) => {
                let s = bc4_eval(r0, r1, t, ch);
                if s.err < best.err {
                    *best = s;
                    return true;
                }
                false
            }
            _ => false,
        }
    };
    for _ in 0..LS_ROUNDS {
        let bits = best.bits;
        let Some((x0, x1)) = weighted_endpoints(t, ch, |i| bc4_mix((bits >> (3 * i)) & 7, eight))
        else {
            break;
        };
        let (x0, x1) = (x0.round() as i32, x1.round() as i32);
        if !try_pair(&mut best, x0, x1) {
            break;
        }
    }
    for _ in 0..MAX_SWEEPS {
        let mut moved = false;
        for end in 0..2 {
            for step in [-1, 1] {
                let (mut a, mut b) = (i32::from(best.r0), i32::from(best.r1));
                if end == 0 {
                    a += step;
                } else {
                    b += step;
                }
                if (0..=255).contains(&a) && (0..=255).contains(&b) {
                    moved |= try_pair(&mut best, a, b);
                }
            }
        }
        if !moved {
            break;
        }
    }
    let mut out = [0u8; 8];
    out[0] = best.r0;
    out[1] = best.r1;
    out[2..].copy_from_slice(&best.bits.to_le_bytes()[..6]);
    out
}
