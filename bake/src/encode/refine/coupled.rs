//! The coupled pass: blocks of the emitters' columns refined along each block row under the
//! exact row objective, each leaning against the row errors of the blocks before it
//! ([`Coupling`]).

use super::{BlockTarget, MAX_SWEEPS, bc1_order, bc1_palette_values, pack_565, unpack_565};
use radiosity_core::{Bc1Block, Bc4Block, DecodeMode};

/// The scene's own emitters in a block's objective. With `x = E + r` (see
/// [`super::ErrorWeights`]), the squared error of row `r`'s irradiance is
/// `σ²·Σ_j d_rj² + (Σ_j d_rj·E_j)²`: the second term couples every entry of a row, across
/// blocks. Rows of a transfer matrix see all patches of a small light almost alike, so their
/// code errors (one log step is 2.7%) come out alike too and add up instead of averaging out:
/// measured on the Cornell box, `‖ΔM·E‖²` was 3× the sum of the entries' own terms. Blocks are
/// therefore encoded along each block row in turn, each carrying the row sums `S` of the
/// errors of the blocks before it, and minimising
/// `σ²·Σ d² + Σ_r (S_r + Σ_c d_rc·E_c)²`: error diffusion, so a block leans against what the
/// blocks to its left got wrong.
pub(crate) struct Coupling {
    /// Weight of every squared entry error (`σ²`, summed over the exitance channels an entry
    /// multiplies: 1 for a three-channel matrix, 3 for a grey one), in the units of the
    /// emission terms.
    pub sigma2: f32,
    /// Whether the matrix is grey: its one channel multiplies all three exitance channels.
    pub grey: bool,
    /// `E` of the block's four columns, per exitance channel (0 beyond the matrix).
    pub emission: [[f32; 3]; 4],
    /// `S`: the emitter-weighted error carried into each of the block's four rows, per
    /// exitance channel.
    pub carried: [[f32; 3]; 4],
}

impl Coupling {
    /// The matrix channel that exitance channel `k` multiplies.
    #[inline]
    fn source(&self, k: usize) -> usize {
        if self.grey { 0 } else { k }
    }
}

/// Per texel and matrix channel, the decoded value of each palette entry (`pv[k][ch]`) for
/// the channels `chans` of one plane; `usable` entries.
struct Palette<'p> {
    values: &'p [[f32; 3]],
    chans: &'p [usize],
}

/// The coupled objective of one plane with the given palette: indices start at each texel's
/// nearest entry under the diagonal weights, then single-texel changes are made while they
/// lower the objective. Returns the objective and the indices.
fn coupled_indices(pal: &Palette<'_>, t: &BlockTarget<'_>, cp: &Coupling) -> (f32, [u8; 16]) {
    let mut idx = [0u8; 16];
    let mut d = [[0f32; 3]; 16];
    for i in 0..16 {
        let mut best = (f32::INFINITY, 0u8);
        for (k, p) in pal.values.iter().enumerate() {
            let e: f32 = pal
                .chans
                .iter()
                .map(|&ch| t.weights[ch][i] * (p[ch] - t.values[ch][i]).powi(2))
                .sum();
            if e < best.0 {
                best = (e, k as u8);
            }
        }
        idx[i] = best.1;
        if t.fit & (1 << i) != 0 {
            for &ch in pal.chans {
                d[i][ch] = pal.values[usize::from(best.1)][ch] - t.values[ch][i];
            }
        }
    }
    let ks: &[usize] = if cp.grey { &[0, 1, 2] } else { pal.chans };
    let mut rows = cp.carried;
    for i in 0..16 {
        for &k in ks {
            rows[i / 4][k] += d[i][cp.source(k)] * cp.emission[i % 4][k];
        }
    }
    for _ in 0..MAX_SWEEPS {
        let mut changed = false;
        for i in 0..16 {
            if t.fit & (1 << i) == 0 {
                continue;
            }
            let (r, c) = (i / 4, i % 4);
            if cp.emission[c] == [0.0; 3] {
                continue; // no coupling: the diagonal choice is already optimal
            }
            let cur = usize::from(idx[i]);
            let mut best = (0f32, cur);
            for q in 0..pal.values.len() {
                if q == cur {
                    continue;
                }
                let mut delta = 0f32;
                let mut dd = [0f32; 3];
                for &ch in pal.chans {
                    dd[ch] = pal.values[q][ch] - pal.values[cur][ch];
                    delta += cp.sigma2 * (2.0 * d[i][ch] * dd[ch] + dd[ch] * dd[ch]);
                }
                for &k in ks {
                    let s = dd[cp.source(k)] * cp.emission[c][k];
                    delta += 2.0 * rows[r][k] * s + s * s;
                }
                if delta < best.0 {
                    best = (delta, q);
                }
            }
            if best.1 != cur {
                let q = best.1;
                for &ch in pal.chans {
                    d[i][ch] += pal.values[q][ch] - pal.values[cur][ch];
                }
                for &k in ks {
                    rows[r][k] += (pal.values[q][cp.source(k)] - pal.values[cur][cp.source(k)])
                        * cp.emission[c][k];
                }
                idx[i] = q as u8;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let mut j = 0f32;
    for i in 0..16 {
        for &ch in pal.chans {
            j += cp.sigma2 * d[i][ch] * d[i][ch];
        }
    }
    for row in &rows {
        for &k in ks {
            j += row[k] * row[k];
        }
    }
    (j, idx)
}

/// BC1 under the coupled objective ([`Coupling`]): `start`'s endpoints (the diagonal
/// refinement) with the coupled index choice, then, with `search`, ±1 coordinate descent on
/// the endpoints, each candidate with its own coupled index choice (≈ 7× the time; on the
/// Cornell box it takes the BC1 lighting error from 0.60% to 0.15%).
pub(crate) fn refine_bc1_coupled(
    start: Bc1Block,
    t: &BlockTarget<'_>,
    cp: &Coupling,
    search: bool,
) -> Bc1Block {
    let four = start.is_four_colour();
    let eval = |c0: u16, c1: u16| -> (f32, u32) {
        let (pv, usable) = bc1_palette_values(c0, c1, t);
        let pal = Palette {
            values: &pv[..usable],
            chans: &[0, 1, 2],
        };
        let (j, idx) = coupled_indices(&pal, t, cp);
        let bits = idx
            .iter()
            .enumerate()
            .fold(0u32, |m, (i, &k)| m | u32::from(k) << (2 * i));
        (j, bits)
    };
    let (mut c0, mut c1) = (start.c0(), start.c1());
    let (mut best, mut bits) = eval(c0, c1);
    for _ in 0..if search { MAX_SWEEPS } else { 0 } {
        let mut moved = false;
        for end in 0..2 {
            for comp in 0..3 {
                for step in [-1, 1] {
                    let (mut e0, mut e1) = (unpack_565(c0), unpack_565(c1));
                    let e = if end == 0 { &mut e0 } else { &mut e1 };
                    let top = if comp == 1 { 63 } else { 31 };
                    e[comp] += step;
                    if !(0..=top).contains(&e[comp]) {
                        continue;
                    }
                    let Some((a, b)) = bc1_order(pack_565(e0), pack_565(e1), four) else {
                        continue;
                    };
                    let (j, bb) = eval(a, b);
                    if j < best {
                        (best, bits, c0, c1, moved) = (j, bb, a, b, true);
                    }
                }
            }
        }
        if !moved {
            break;
        }
    }
    let [a, b] = [c0.to_le_bytes(), c1.to_le_bytes()];
    let i = bits.to_le_bytes();
    Bc1Block([a[0], a[1], b[0], b[1], i[0], i[1], i[2], i[3]])
}

/// BC4 plane `ch` under the coupled objective, as [`refine_bc1_coupled`] (the search takes the
/// Cornell box's BC4 lighting error from 0.031% to 0.023%).
pub(crate) fn refine_bc4_coupled(
    start: [u8; 8],
    t: &BlockTarget<'_>,
    ch: usize,
    cp: &Coupling,
    search: bool,
) -> [u8; 8] {
    let eight = start[0] > start[1];
    let chans = [ch];
    let eval = |r0: u8, r1: u8| -> (f32, u64) {
        let palette = Bc4Block([r0, r1, 0, 0, 0, 0, 0, 0]).palette(DecodeMode::D3d10);
        let mut pv = [[0f32; 3]; 8];
        for k in 0..8 {
            pv[k][ch] = t.tables[ch][usize::from(palette[k])];
        }
        let pal = Palette {
            values: &pv,
            chans: &chans,
        };
        let (j, idx) = coupled_indices(&pal, t, cp);
        let bits = idx
            .iter()
            .enumerate()
            .fold(0u64, |m, (i, &k)| m | u64::from(k) << (3 * i));
        (j, bits)
    };
    let (mut r0, mut r1) = (start[0], start[1]);
    let (mut best, mut bits) = eval(r0, r1);
    for _ in 0..if search { MAX_SWEEPS } else { 0 } {
        let mut moved = false;
        for end in 0..2 {
            for step in [-1i32, 1] {
                let (mut a, mut b) = (i32::from(r0), i32::from(r1));
                if end == 0 {
                    a += step;
                } else {
                    b += step;
                }
                if !((0..=255).contains(&a) && (0..=255).contains(&b)) {
                    continue;
                }
                let (a, b) = (a as u8, b as u8);
                let (a, b) = match (eight, a.cmp(&b)) {
                    (true, core::cmp::Ordering::Equal) => continue,
                    (true, _) => (a.max(b), a.min(b)),
                    (false, _) => (a.min(b), a.max(b)),
                };
                let (j, bb) = eval(a, b);
                if j < best {
                    (best, bits, r0, r1, moved) = (j, bb, a, b, true);
                }
            }
        }
        if !moved {
            break;
        }
    }
    let mut out = [0u8; 8];
    out[0] = r0;
    out[1] = r1;
    out[2..].copy_from_slice(&bits.to_le_bytes()[..6]);
    out
}
