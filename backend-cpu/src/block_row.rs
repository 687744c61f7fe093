//! One block row (four matrix rows) of the gather: what every body reads ([`Ctx`], the
//! [`X4`] exitance layout), the generic body (decode each block, multiply-add against the
//! exitance, add the sparse corrections; compiled once per format and SIMD path) and the
//! finish the ISA-specific bodies of `avx2.rs` and `avx512.rs` share.

use crate::SimdPath;
use crate::decode::{Baseline, Bc1Palettes, Isa, Kernel, TileTables};
use radiosity_core::{Rgb, Tile, TransferMatrix};
use wide::f32x8;

/// The exitance of one column block and channel for a `zmm` body: its four columns, which the
/// body broadcasts to all four 128-bit lanes (one per block row). 16 bytes instead of 64: a
/// block row then streams 48 bytes of exitance per block, and the whole vector of a 4096-patch
/// matrix (48 KiB) stays near L1.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct X4(pub(crate) [f32; 4]);

impl X4 {
    pub(crate) const ZERO: X4 = X4([0.0; 4]);
}

/// A block-row body of its own (`avx512.rs`, `avx2.rs`): output rows `4r..4r + out.len()` from
/// the exitance in [`X4`] layout. Unsafe to call: the CPU must have the features its path needs.
#[cfg(target_arch = "x86_64")]
pub(crate) type RowBody = unsafe fn(&Ctx<'_, '_>, &[X4], usize, &mut [Rgb]);

/// What every block row reads.
pub(crate) struct Ctx<'a, 'm> {
    pub(crate) matrix: &'a TransferMatrix<'m>,
    pub(crate) tables: &'a [[f32; 256]],
    /// `LogScale::factors()` per tile and channel for the `zmm` log bodies (else empty).
    #[cfg_attr(
        not(target_arch = "x86_64"),
        expect(dead_code, reason = "only the x86-64 `zmm` bodies read it")
    )]
    pub(crate) factors: &'a [([f32; 16], [f32; 16])],
    /// BC1 palette tables per tile, `None` for small tiles (empty for other formats).
    pub(crate) bc1: &'a [Option<Bc1Palettes>],
    pub(crate) tiles: &'a [Tile],
    /// `decode::f16_table()` for F16 on the baseline path, else empty.
    pub(crate) f16: &'a [f32],
    pub(crate) xs: &'a [f32x8],
    /// The exitance as [`X4`] for the `zmm`/`ymm` bodies (then `xs` is empty), else empty.
    pub(crate) x4: &'a [X4],
    pub(crate) exitance: &'a [Rgb],
    /// `TransferMatrix::correction_tables()`: the block corrections' scales per channel.
    pub(crate) corrections: &'a [[f32; 256]; 3],
}

/// Block row `r` (output rows `4r..4r + out.len()`) on the chosen path.
#[inline]
pub(crate) fn dispatch<K: Kernel>(ctx: &Ctx<'_, '_>, simd: SimdPath, r: usize, out: &mut [Rgb]) {
    match simd {
        #[cfg(target_arch = "x86_64")]
        SimdPath::Avx2Fma | SimdPath::Avx512 => {
            // SAFETY: `CpuGather` only holds `SimdPath::Avx2Fma` or `Avx512` after
            // `is_available` saw (at least) AVX2, FMA and F16C on this CPU (`SimdPath::detect` /
            // `CpuGather::with_path`).
            unsafe { generic_avx2::<K>(ctx, r, out) }
        }
        _ => generic::<K, Baseline>(ctx, r, out),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,f16c")]
fn generic_avx2<K: Kernel>(ctx: &Ctx<'_, '_>, r: usize, out: &mut [Rgb]) {
    generic::<K, crate::decode::Avx2>(ctx, r, out);
}

#[inline(always)]
fn generic<K: Kernel, I: Isa>(ctx: &Ctx<'_, '_>, r: usize, out: &mut [Rgb]) {
    let m = ctx.matrix;
    let blocks: &[u8] = &m.blocks;
    let l = &m.layout;
    let (ch, planes) = (l.channels(), l.planes());
    let grey = ch == 1;
    let row = 4 * r;
    let tps = l.tiles_per_side();
    let ty = row / l.tile_size();
    let mut acc = [[f32x8::ZERO; 2]; 3];
    let mut vals = [[f32x8::ZERO; 2]; 3];
    let zero = [0f32; 256];
    for tile in &ctx.tiles[ty * tps..(ty + 1) * tps] {
        let br = (row - tile.row0) / 4;
        let mut t = TileTables {
            log: [&zero; 3],
            bc1: ctx.bc1.get(tile.index).and_then(Option::as_ref),
            f16: ctx.f16,
        };
        if !ctx.tables.is_empty() {
            for c in 0..ch {
                t.log[c] = &ctx.tables[l.scale_index(tile.index, c)];
            }
        }
        let bw = tile.blocks_wide();
        let xs = &ctx.xs[tile.col0 / 4 * 3..(tile.col0 / 4 + bw) * 3];
        // Each plane's block row is contiguous: `bw` blocks.
        let mut rows: [&[u8]; 3] = [&[]; 3];
        for p in 0..planes {
            let start = l.block_offset(tile, p, br, 0);
            rows[p] = &blocks[start..start + bw * K::BLOCK_BYTES];
        }
        for (bc, x) in xs.chunks_exact(3).enumerate() {
            for p in 0..planes {
                let raw = &rows[p][bc * K::BLOCK_BYTES..(bc + 1) * K::BLOCK_BYTES];
                K::decode::<I>(raw, &t, p, &mut vals);
            }
            for k in 0..3 {
                let v = &vals[if grey { 0 } else { k }];
                acc[k][0] = I::mul_add(v[0], x[k], acc[k][0]);
                acc[k][1] = I::mul_add(v[1], x[k], acc[k][1]);
            }
        }
    }
    let sums: [[f32; 8]; 6] = [
        acc[0][0].to_array(),
        acc[0][1].to_array(),
        acc[1][0].to_array(),
        acc[1][1].to_array(),
        acc[2][0].to_array(),
        acc[2][1].to_array(),
    ];
    let rows: [[f32; 4]; 3] = core::array::from_fn(|k| {
        core::array::from_fn(|i| {
            let (h, q) = (i / 2, (i % 2) * 4);
            let s = &sums[2 * k + h][q..q + 4];
            (s[0] + s[1]) + (s[2] + s[3])
        })
    });
    finish_rows::<I>(ctx, row, rows, out);
}

/// Writes output rows `row..row + out.len()` from the blocks' row sums (`sums[channel][i]`
/// for row `row + i`) plus the block row's block corrections, in column order, plus each row's
/// sparse corrections, in column order.
#[inline(always)]
pub(crate) fn finish_rows<I: Isa>(
    ctx: &Ctx<'_, '_>,
    row: usize,
    mut sums: [[f32; 4]; 3],
    out: &mut [Rgb],
) {
    let m = ctx.matrix;
    let ch = m.layout.channels();
    let grey = ch == 1;
    if !m.corrections.is_empty() {
        add_corrections::<I>(ctx, row, &mut sums);
    }
    for (i, y) in out.iter_mut().enumerate() {
        let mut v = [sums[0][i], sums[1][i], sums[2][i]];
        for (c, s) in m.sparse.row(row + i, ch) {
            let x = ctx.exitance[c].to_array();
            for k in 0..3 {
                v[k] += s[if grey { 0 } else { k }] * x[k];
            }
        }
        *y = Rgb::from_array(v);
    }
}

/// Adds the block corrections of the block row starting at `row` to its row sums, eight
/// texels (two rows of a block) per `f32x8`, against the block's four columns of exitance
/// repeated twice: the layout of the generic body's accumulators. A good order corrects a few
/// per cent of the blocks (2.5% on the Cornell box), so this stays a small share of a gather.
#[inline(always)]
fn add_corrections<I: Isa>(ctx: &Ctx<'_, '_>, row: usize, sums: &mut [[f32; 4]; 3]) {
    let m = ctx.matrix;
    let c = &m.corrections;
    let ch = m.layout.channels();
    let mut acc = [[f32x8::ZERO; 2]; 3];
    // The exitance of column block `bc`, channel `k`, as the body's layout holds it.
    let x = |bc: usize, k: usize| -> f32x8 {
        match ctx.xs.get(bc * 3 + k) {
            Some(x) => *x,
            None => {
                let q = ctx.x4[bc * 3 + k].0;
                f32x8::from([q[0], q[1], q[2], q[3], q[0], q[1], q[2], q[3]])
            }
        }
    };
    for (bc, index) in c.row(row / 4) {
        for k in 0..ch {
            let s = f32x8::splat(ctx.corrections[k][usize::from(c.exponents[index * ch + k])]);
            let words = &c.codes[(index * ch + k) * 2..][..2];
            let lo = I::multiples(words[0]) * s;
            let hi = I::multiples(words[1]) * s;
            if ch == 1 {
                for (kk, a) in acc.iter_mut().enumerate() {
                    let x = x(bc, kk);
                    a[0] = I::mul_add(lo, x, a[0]);
                    a[1] = I::mul_add(hi, x, a[1]);
                }
            } else {
                let x = x(bc, k);
                acc[k][0] = I::mul_add(lo, x, acc[k][0]);
                acc[k][1] = I::mul_add(hi, x, acc[k][1]);
            }
        }
    }
    for (sum, a) in sums.iter_mut().zip(&acc) {
        let (lo, hi) = (a[0].to_array(), a[1].to_array());
        sum[0] += (lo[0] + lo[1]) + (lo[2] + lo[3]);
        sum[1] += (lo[4] + lo[5]) + (lo[6] + lo[7]);
        sum[2] += (hi[0] + hi[1]) + (hi[2] + hi[3]);
        sum[3] += (hi[4] + hi[5]) + (hi[6] + hi[7]);
    }
}
