//! AVX-512 block-row bodies: one 4×4 block per `zmm` register (16 lanes, texel `i` in lane
//! `i`).
//!
//! - BC1: a block costs one index shift, three palette broadcasts, three permutes and three
//!   fused multiply-adds; the endpoint arithmetic of 16 blocks at a time runs in vector
//!   registers instead of scalar code, a run ahead of its use.
//! - BC4 and u8: log codes become values through the two 16-entry factor tables of
//!   `LogScale::factors` held in registers (two `vpermps` and a multiply per 16 codes) instead
//!   of a 256-entry table look-up per code.
//!
//! f16 and f32 have no body here: [`crate::SimdPath::Avx512`] runs the AVX2 one for them (see
//! the crate docs). Every function is compiled with `avx512f` (plus the AVX2 set, which every
//! AVX-512 CPU has) and only entered after runtime detection.

use crate::block_row::{Ctx, RowBody, X4, finish_rows};
use crate::decode::{BC1_KEY_OFFSET, Bc1Palettes, bc1_channel_palette, bc1_keys, index_bits};
use radiosity_core::{Format, Rgb};
use std::arch::x86_64::*;

/// The `zmm` body of `format`: BC1, BC4 and u8 have one; f16 and f32 run the AVX2 body.
pub(crate) fn body(format: Format) -> Option<RowBody> {
    match format {
        Format::Bc1 => Some(bc1_block_row),
        Format::Bc4 => Some(bc4_block_row),
        Format::U8 => Some(u8_block_row),
        Format::F16 | Format::F32 => None,
    }
}

/// Blocks whose endpoint keys are computed together.
const GROUP: usize = 16;

/// Block row `r` of a BC1 matrix (output rows `4r..4r + out.len()`).
///
/// # Safety
/// The CPU must support AVX-512F, AVX2, FMA and F16C (`SimdPath::Avx512::is_available`).
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
pub(crate) unsafe fn bc1_block_row(ctx: &Ctx<'_, '_>, x4: &[X4], r: usize, out: &mut [Rgb]) {
    let m = ctx.matrix;
    let l = &m.layout;
    let blocks: &[u8] = &m.blocks;
    let row = 4 * r;
    let tps = l.tiles_per_side();
    let ty = row / l.tile_size();
    let mut acc = [_mm512_setzero_ps(); 3];
    for tile in &ctx.tiles[ty * tps..(ty + 1) * tps] {
        let br = (row - tile.row0) / 4;
        let bw = tile.blocks_wide();
        let start = l.block_offset(tile, 0, br, 0);
        let raw = &blocks[start..start + bw * 8];
        let xs = &x4[tile.col0 / 4 * 3..(tile.col0 / 4 + bw) * 3];
        match ctx.bc1.get(tile.index).and_then(Option::as_ref) {
            Some(pal) => bc1_segment(raw, xs, pal, &mut acc),
            None => {
                let log = [0, 1, 2].map(|c| &ctx.tables[l.scale_index(tile.index, c)]);
                for (b, x) in raw.chunks_exact(8).zip(xs.chunks_exact(3)) {
                    let b: &[u8; 8] = b.try_into().expect("8-byte block");
                    let keys = bc1_keys(b);
                    let pal: [[f32; 4]; 3] = core::array::from_fn(|ch| {
                        bc1_channel_palette(ch, keys[ch]).map(|q| log[ch][q as usize])
                    });
                    bc1_block(&pal.each_ref(), index_bits(b), x, &mut acc);
                }
            }
        }
    }
    finish_rows::<crate::decode::Avx2>(ctx, row, acc.map(row_sums), out);
}

/// Block row `r` of a u8 matrix (output rows `4r..4r + out.len()`): each block and plane
/// through [`log16`].
///
/// # Safety
/// The CPU must support AVX-512F, AVX2, FMA and F16C (`SimdPath::Avx512::is_available`).
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
pub(crate) unsafe fn u8_block_row(ctx: &Ctx<'_, '_>, x4: &[X4], r: usize, out: &mut [Rgb]) {
    planar_block_row::<16>(ctx, x4, r, out, |raw, f| log16(raw, f));
}

/// Block row `r` of a BC4 matrix (output rows `4r..4r + out.len()`): each block and plane
/// through [`bc4_16`].
///
/// # Safety
/// The CPU must support AVX-512F, AVX2, FMA and F16C (`SimdPath::Avx512::is_available`).
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
pub(crate) unsafe fn bc4_block_row(ctx: &Ctx<'_, '_>, x4: &[X4], r: usize, out: &mut [Rgb]) {
    planar_block_row::<8>(ctx, x4, r, out, |raw, f| bc4_16(raw, f));
}

/// The body of the one-plane-per-channel log formats: `decode` turns one block of one plane
/// (`B` bytes) into its 16 values through the plane's factor tables.
#[inline(always)]
fn planar_block_row<const B: usize>(
    ctx: &Ctx<'_, '_>,
    x4: &[X4],
    r: usize,
    out: &mut [Rgb],
    decode: impl Fn(&[u8; B], (__m512, __m512)) -> __m512,
) {
    let m = ctx.matrix;
    let l = &m.layout;
    let blocks: &[u8] = &m.blocks;
    let planes = l.planes();
    let row = 4 * r;
    let tps = l.tiles_per_side();
    let ty = row / l.tile_size();
    // SAFETY (every intrinsic below): only reached from `u8_block_row` / `bc4_block_row`, whose
    // callers checked AVX-512F, AVX2, FMA and F16C.
    unsafe {
        let mut acc = [_mm512_setzero_ps(); 3];
        for tile in &ctx.tiles[ty * tps..(ty + 1) * tps] {
            let br = (row - tile.row0) / 4;
            let bw = tile.blocks_wide();
            let mut rows: [&[u8]; 3] = [&[]; 3];
            let mut factors = [(_mm512_setzero_ps(), _mm512_setzero_ps()); 3];
            for p in 0..planes {
                let start = l.block_offset(tile, p, br, 0);
                rows[p] = &blocks[start..start + bw * B];
                let (high, low) = &ctx.factors[l.scale_index(tile.index, p)];
                // Each load reads the 64 bytes of a `[f32; 16]`.
                factors[p] = (
                    _mm512_loadu_ps(high.as_ptr()),
                    _mm512_loadu_ps(low.as_ptr()),
                );
            }
            let xs = &x4[tile.col0 / 4 * 3..(tile.col0 / 4 + bw) * 3];
            for (b, x) in xs.chunks_exact(3).enumerate() {
                // Each load reads the 16 bytes of `x[k]`.
                let x = [0, 1, 2].map(|k| _mm512_broadcast_f32x4(_mm_load_ps(x[k].0.as_ptr())));
                let block = |p: usize| -> &[u8; B] {
                    rows[p][B * b..B * (b + 1)].try_into().expect("one block")
                };
                if planes == 1 {
                    let v = decode(block(0), factors[0]);
                    for k in 0..3 {
                        acc[k] = _mm512_fmadd_ps(v, x[k], acc[k]);
                    }
                } else {
                    for k in 0..3 {
                        let v = decode(block(k), factors[k]);
                        acc[k] = _mm512_fmadd_ps(v, x[k], acc[k]);
                    }
                }
            }
        }
        finish_rows::<crate::decode::Avx2>(ctx, row, acc.map(row_sums), out);
    }
}

/// Log codes (one per 32-bit lane) to their values through the tile's `(high, low)` factor
/// tables (`LogScale::factors`): `high[(255 − q) >> 4] · low[(255 − q) & 15]`, 0 for code 0 —
/// the same single rounding as `LogScale::decode`, so bit-identical to the table.
#[inline]
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
fn log_values(q: __m512i, (high, low): (__m512, __m512)) -> __m512 {
    let d = _mm512_xor_si512(q, _mm512_set1_epi32(255));
    // vpermps uses the low four bits of each index.
    let h = _mm512_permutexvar_ps(_mm512_srli_epi32::<4>(d), high);
    let l = _mm512_permutexvar_ps(d, low);
    _mm512_maskz_mul_ps(_mm512_test_epi32_mask(q, q), h, l)
}

/// A BC4 block: its eight palette codes (`decode::avx2::bc4_codes`) to values in both halves
/// of a register, then the 16 texels through their 3-bit indices.
#[inline]
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
fn bc4_16(raw: &[u8; 8], factors: (__m512, __m512)) -> __m512 {
    let codes = crate::decode::avx2::bc4_codes(raw);
    // The palette in lanes 0–7 and again in 8–15, so that vpermps, which reads four index
    // bits, finds it whatever bit 3 of a shifted index holds.
    let pal = log_values(_mm512_broadcast_i64x4(codes), factors);
    let bits = u64::from_le_bytes(*raw) >> 16;
    let idx = _mm512_mask_set1_epi32(
        _mm512_set1_epi32((bits & 0xff_ffff) as i32),
        0xff00,
        ((bits >> 24) & 0xff_ffff) as i32,
    );
    let sh = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 0, 3, 6, 9, 12, 15, 18, 21);
    _mm512_permutexvar_ps(_mm512_srlv_epi32(idx, sh), pal)
}

/// 16 u8 log codes to their values ([`log_values`]).
#[inline]
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
fn log16(codes: &[u8; 16], factors: (__m512, __m512)) -> __m512 {
    // SAFETY: the load reads the 16 bytes of `codes`.
    let q = _mm512_cvtepu8_epi32(unsafe { _mm_loadu_si128(codes.as_ptr().cast()) });
    log_values(q, factors)
}

/// One block: expand each channel's palette through the 2-bit indices, multiply-add against
/// the column block's exitance (broadcast to the four block rows).
#[inline]
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
fn bc1_block(pal: &[&[f32; 4]; 3], bits: i32, x: &[X4], acc: &mut [__m512; 3]) {
    let idx = _mm512_srlv_epi32(
        _mm512_set1_epi32(bits),
        _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30),
    );
    for ch in 0..3 {
        // SAFETY: the loads read exactly the 16 bytes of `pal[ch]` and of `x[ch]`; the
        // caller's target features cover these instructions.
        unsafe {
            // vpermilps uses the low two bits of each index within each 128-bit lane: every
            // lane holds the palette.
            let p = _mm512_broadcast_f32x4(_mm_loadu_ps(pal[ch].as_ptr()));
            let v = _mm512_permutevar_ps(p, idx);
            let x = _mm512_broadcast_f32x4(_mm_load_ps(x[ch].0.as_ptr()));
            acc[ch] = _mm512_fmadd_ps(v, x, acc[ch]);
        }
    }
}

/// Blocks whose keys are computed before any of them is multiplied: the key stores then
/// reach the cache long before the block loop loads them (a load right behind a wider vector
/// store to the same place waits for the store instead of forwarding from it).
const RUN: usize = crate::decode::KEY_RUN;

/// A run of BC1 blocks of one tile with palette tables: the keys of up to [`RUN`] blocks
/// first, 16 at a time in vector registers, then each block through [`bc1_block`].
#[inline]
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
fn bc1_segment(raw: &[u8], xs: &[X4], pal: &Bc1Palettes, acc: &mut [__m512; 3]) {
    let mut keys = [[0u32; RUN]; 3];
    // Two accumulators per channel, even and odd blocks, so that consecutive blocks do not
    // wait on each other's multiply-add.
    let mut odd = [_mm512_setzero_ps(); 3];
    for (run, xs) in raw.chunks(8 * RUN).zip(xs.chunks(3 * RUN)) {
        let full = run.len() / (8 * GROUP) * GROUP;
        for (g, chunk) in run.chunks_exact(8 * GROUP).enumerate() {
            let chunk: &[u8; 8 * GROUP] = chunk.try_into().expect("a group of blocks");
            group_keys(chunk, &mut keys, g * GROUP);
        }
        for (b, block) in run.chunks_exact(8).enumerate().skip(full) {
            let k = bc1_keys(block.try_into().expect("8-byte block"));
            for ch in 0..3 {
                keys[ch][b] = (BC1_KEY_OFFSET[ch] + k[ch]) as u32;
            }
        }
        let mut pairs = run.chunks_exact(16).zip(xs.chunks_exact(6));
        for (b, (pair, x)) in pairs.by_ref().enumerate() {
            let (b0, b1) = (2 * b, 2 * b + 1);
            let p = [0, 1, 2].map(|ch| pal.flat(keys[ch][b0] as usize));
            bc1_block(
                &p,
                index_bits(pair[..8].try_into().expect("8 bytes")),
                &x[..3],
                acc,
            );
            let p = [0, 1, 2].map(|ch| pal.flat(keys[ch][b1] as usize));
            bc1_block(
                &p,
                index_bits(pair[8..].try_into().expect("8 bytes")),
                &x[3..],
                &mut odd,
            );
        }
        if run.len() % 16 != 0 {
            let b = run.len() / 8 - 1;
            let p = [0, 1, 2].map(|ch| pal.flat(keys[ch][b] as usize));
            let last = run[8 * b..].try_into().expect("8 bytes");
            bc1_block(&p, index_bits(last), &xs[3 * b..], acc);
        }
    }
    for ch in 0..3 {
        acc[ch] = _mm512_add_ps(acc[ch], odd[ch]);
    }
}

/// [`bc1_keys`] of 16 consecutive blocks plus each channel's [`BC1_KEY_OFFSET`] (keys into
/// [`Bc1Palettes::flat`]), in vector registers.
#[inline]
#[target_feature(enable = "avx512f,avx2,fma,f16c")]
fn group_keys(chunk: &[u8; 8 * GROUP], keys: &mut [[u32; RUN]; 3], at: usize) {
    // SAFETY: the loads read the 128 bytes of `chunk`, the stores write 64 bytes of each
    // `keys[ch]` (a checked sub-slice); the caller's target features cover these instructions.
    unsafe {
        let a = _mm512_loadu_si512(chunk.as_ptr().cast());
        let b = _mm512_loadu_si512(chunk.as_ptr().add(64).cast());
        // The low dword of each block (c0 | c1 << 16): dwords 0, 2, …, 30 of a:b.
        let even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
        let lo = _mm512_permutex2var_epi32(a, even, b);
        let c0 = _mm512_and_si512(lo, _mm512_set1_epi32(0xffff));
        let c1 = _mm512_srli_epi32::<16>(lo);
        let four = _mm512_maskz_mov_epi32(_mm512_cmpgt_epu32_mask(c0, c1), _mm512_set1_epi32(1));
        let m5 = _mm512_set1_epi32(0x1f);
        let m6 = _mm512_set1_epi32(0x3f);
        let red = _mm512_or_si512(
            _mm512_or_si512(
                _mm512_slli_epi32::<10>(four),
                _mm512_slli_epi32::<5>(_mm512_srli_epi32::<11>(c0)),
            ),
            _mm512_srli_epi32::<11>(c1),
        );
        let green = _mm512_or_si512(
            _mm512_or_si512(
                _mm512_slli_epi32::<12>(four),
                _mm512_slli_epi32::<6>(_mm512_and_si512(_mm512_srli_epi32::<5>(c0), m6)),
            ),
            _mm512_and_si512(_mm512_srli_epi32::<5>(c1), m6),
        );
        let blue = _mm512_or_si512(
            _mm512_or_si512(
                _mm512_slli_epi32::<10>(four),
                _mm512_slli_epi32::<5>(_mm512_and_si512(c0, m5)),
            ),
            _mm512_and_si512(c1, m5),
        );
        for ((k, v), off) in keys.iter_mut().zip([red, green, blue]).zip(BC1_KEY_OFFSET) {
            let v = _mm512_add_epi32(v, _mm512_set1_epi32(off as i32));
            let k: &mut [u32; GROUP] = (&mut k[at..at + GROUP]).try_into().expect("a group");
            _mm512_storeu_si512(k.as_mut_ptr().cast(), v);
        }
    }
}

/// Row sums of a `zmm` accumulator: lanes `4q..4q + 4` belong to block row `q`, summed as
/// `(s0 + s1) + (s2 + s3)` like the AVX2 body.
#[inline(always)]
fn row_sums(acc: __m512) -> [f32; 4] {
    // SAFETY: __m512 and [f32; 16] have the same size and every bit pattern is valid.
    let s: [f32; 16] = unsafe { core::mem::transmute(acc) };
    core::array::from_fn(|q| (s[4 * q] + s[4 * q + 1]) + (s[4 * q + 2] + s[4 * q + 3]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[target_feature(enable = "avx512f,avx2,fma,f16c")]
    fn keys_of(chunk: &[u8; 8 * GROUP]) -> [[u32; RUN]; 3] {
        let mut keys = [[u32::MAX; RUN]; 3];
        group_keys(chunk, &mut keys, RUN - GROUP);
        keys
    }

    /// The vector key arithmetic gives the scalar keys (`decode::check_group_keys`).
    #[test]
    fn group_keys_match_the_scalar_keys() {
        if !crate::SimdPath::Avx512.is_available() {
            return;
        }
        crate::decode::check_group_keys(GROUP, |chunk| {
            // SAFETY: the features were detected above.
            unsafe { keys_of(chunk.try_into().expect("one group")) }
        });
    }
}
