//! AVX2 block-row bodies of their own: what `avx512.rs` does in a `zmm` register, in two `ymm`
//! halves (block rows 0–1 and 2–3).
//!
//! - BC1: the generic body (`block_row::generic` over `decode::Avx2`) spent a third of its
//!   instructions on each block's scalar endpoint arithmetic (c0, c1, the four-colour flag,
//!   three table keys), kept a branch on the channel count inside the block loop, and spilled
//!   accumulators. Here, as in the AVX-512 body, the keys of a run of blocks are computed
//!   first, eight blocks per register, and the block loop is left with one broadcast of the
//!   index bits, two `vpsrlvd`, three 16-byte palette broadcasts from the tile's table, six
//!   `vpermilps` and six `vfmadd` per block. BC1 always has three channels.
//! - BC4: the palette's eight log codes become values through the two 16-entry factor tables
//!   of `LogScale::factors` (each in two registers: two `vpermps` and a blend per factor, then
//!   a multiply) instead of a `vgatherdps` from the 256-entry table; bit-identical to the table
//!   (the same single rounding). One plane at a time, so that its four factor registers and
//!   two accumulators stay in registers. At 4098 patches on 2 threads (Zen 3, AVX2 only,
//!   `gather_file`, three runs of 101 alternating with the generic body): 10.7–13.3 ms
//!   against 14.2–15.0 ms.
//! - u8 has no body here: the same product form for its 16 codes per block measured 22 ms
//!   against 14 ms for the generic body's scalar look-ups (one thread; `vpermps` crosses
//!   128-bit lanes and is slow on Zen 3, and a u8 block needs eight of them per plane).
//!
//! The exitance is read as [`X4`] (16 bytes per column block and channel, broadcast to both
//! halves). Every function here is compiled with `avx2,fma,f16c` and only entered after
//! runtime detection ([`crate::SimdPath::Avx2Fma`]).

use crate::block_row::{Ctx, RowBody, X4, finish_rows};
use crate::decode::{BC1_KEY_OFFSET, Bc1Palettes, bc1_channel_palette, bc1_keys, index_bits};
use radiosity_core::bytemuck::cast;
use radiosity_core::{Format, Rgb};
use std::arch::x86_64::*;

/// Blocks whose keys one `ymm` register holds.
const GROUP: usize = 8;

/// Blocks keyed before any of them is multiplied (see `avx512::RUN`: a scalar key load right
/// behind the wider vector store that wrote it waits for the store).
const RUN: usize = crate::decode::KEY_RUN;

/// Two block rows of one channel: lanes 0–3 row 0 (or 2), lanes 4–7 row 1 (or 3).
type Acc = [[__m256; 2]; 3];

/// Block row `r` of a BC1 matrix (output rows `4r..4r + out.len()`).
///
/// # Safety
/// The CPU must support AVX2, FMA and F16C (`SimdPath::Avx2Fma::is_available`).
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn bc1_block_row(ctx: &Ctx<'_, '_>, x4: &[X4], r: usize, out: &mut [Rgb]) {
    let m = ctx.matrix;
    let l = &m.layout;
    let blocks: &[u8] = &m.blocks;
    let row = 4 * r;
    let tps = l.tiles_per_side();
    let ty = row / l.tile_size();
    let mut acc: Acc = [[_mm256_setzero_ps(); 2]; 3];
    for tile in &ctx.tiles[ty * tps..(ty + 1) * tps] {
        let br = (row - tile.row0) / 4;
        let bw = tile.blocks_wide();
        let start = l.block_offset(tile, 0, br, 0);
        let raw = &blocks[start..start + bw * 8];
        let xs = &x4[tile.col0 / 4 * 3..(tile.col0 / 4 + bw) * 3];
        match ctx.bc1.get(tile.index).and_then(Option::as_ref) {
            Some(pal) => segment(raw, xs, pal, &mut acc),
            None => {
                // A small tile has no palette tables: the same rules, per block.
                let log = [0, 1, 2].map(|c| &ctx.tables[l.scale_index(tile.index, c)]);
                for (b, x) in raw.chunks_exact(8).zip(xs.chunks_exact(3)) {
                    let b: &[u8; 8] = b.try_into().expect("8-byte block");
                    let keys = bc1_keys(b);
                    let pal: [[f32; 4]; 3] = core::array::from_fn(|ch| {
                        bc1_channel_palette(ch, keys[ch]).map(|q| log[ch][q as usize])
                    });
                    block(&pal.each_ref(), index_bits(b), x, &mut acc);
                }
            }
        }
    }
    finish_rows::<crate::decode::Avx2>(ctx, row, row_sums(&acc), out);
}

/// Row sums of the accumulators (`[channel][row]`): lanes `4q..4q + 4` of each half belong
/// to one row, summed as `(s0 + s1) + (s2 + s3)` like the other bodies.
#[inline(always)]
fn row_sums(acc: &Acc) -> [[f32; 4]; 3] {
    core::array::from_fn(|k| {
        let halves: [[f32; 8]; 2] = [cast(acc[k][0]), cast(acc[k][1])];
        core::array::from_fn(|i| {
            let (s, q) = (&halves[i / 2], 4 * (i % 2));
            (s[q] + s[q + 1]) + (s[q + 2] + s[q + 3])
        })
    })
}

/// The `ymm` body of `format`, if it has one: BC1 and BC4 (u8, f16 and f32 run the generic
/// AVX2 body).
pub(crate) fn body(format: Format) -> Option<RowBody> {
    match format {
        Format::Bc1 => Some(bc1_block_row),
        Format::Bc4 => Some(bc4_block_row),
        Format::U8 | Format::F16 | Format::F32 => None,
    }
}

/// A tile's `LogScale::factors` for one plane in registers: high 0–7, high 8–15, low 0–7,
/// low 8–15.
type Factors = [__m256; 4];

/// Block row `r` of a BC4 matrix (output rows `4r..4r + out.len()`).
///
/// # Safety
/// The CPU must support AVX2, FMA and F16C (`SimdPath::Avx2Fma::is_available`).
#[target_feature(enable = "avx2,fma,f16c")]
pub(crate) unsafe fn bc4_block_row(ctx: &Ctx<'_, '_>, x4: &[X4], r: usize, out: &mut [Rgb]) {
    planar_block_row::<8>(ctx, x4, r, out, |raw, f| bc4_16(raw, f));
}

/// The body of a one-plane-per-channel log format (BC4 here): `decode` turns one block of one
/// plane (`B` bytes) into its 16 values (two halves) through the plane's factor tables.
#[inline(always)]
fn planar_block_row<const B: usize>(
    ctx: &Ctx<'_, '_>,
    x4: &[X4],
    r: usize,
    out: &mut [Rgb],
    decode: impl Fn(&[u8; B], &Factors) -> [__m256; 2],
) {
    let m = ctx.matrix;
    let l = &m.layout;
    let blocks: &[u8] = &m.blocks;
    let planes = l.planes();
    let row = 4 * r;
    let tps = l.tiles_per_side();
    let ty = row / l.tile_size();
    // SAFETY (every intrinsic below): only reached from `bc4_block_row`, whose callers
    // checked AVX2, FMA and F16C.
    unsafe {
        let mut acc: Acc = [[_mm256_setzero_ps(); 2]; 3];
        for tile in &ctx.tiles[ty * tps..(ty + 1) * tps] {
            let br = (row - tile.row0) / 4;
            let bw = tile.blocks_wide();
            let xs = &x4[tile.col0 / 4 * 3..(tile.col0 / 4 + bw) * 3];
            // One plane at a time: its four factor registers and two accumulators stay in
            // registers (all three planes at once spilled, and lost to the table look-ups).
            for p in 0..planes {
                let start = l.block_offset(tile, p, br, 0);
                let row = &blocks[start..start + bw * B];
                let (high, low) = &ctx.factors[l.scale_index(tile.index, p)];
                // Each load reads 32 of the 64 bytes of a `[f32; 16]`.
                let f = [
                    _mm256_loadu_ps(high.as_ptr()),
                    _mm256_loadu_ps(high[8..].as_ptr()),
                    _mm256_loadu_ps(low.as_ptr()),
                    _mm256_loadu_ps(low[8..].as_ptr()),
                ];
                let blocks = row.chunks_exact(B).zip(xs.chunks_exact(3));
                if planes == 1 {
                    for (raw, x) in blocks {
                        let v = decode(raw.try_into().expect("one block"), &f);
                        for k in 0..3 {
                            // The load reads the 16 bytes of `x[k]`.
                            let x = _mm256_broadcast_ps(&*x[k].0.as_ptr().cast::<__m128>());
                            for h in 0..2 {
                                acc[k][h] = _mm256_fmadd_ps(v[h], x, acc[k][h]);
                            }
                        }
                    }
                } else {
                    for (raw, x) in blocks {
                        let v = decode(raw.try_into().expect("one block"), &f);
                        // The load reads the 16 bytes of `x[p]`.
                        let x = _mm256_broadcast_ps(&*x[p].0.as_ptr().cast::<__m128>());
                        for h in 0..2 {
                            acc[p][h] = _mm256_fmadd_ps(v[h], x, acc[p][h]);
                        }
                    }
                }
            }
        }
        finish_rows::<crate::decode::Avx2>(ctx, row, row_sums(&acc), out);
    }
}

/// Log codes (one per 32-bit lane) to their values through the tile's factor tables
/// (`LogScale::factors`): `high[(255 − q) >> 4] · low[(255 − q) & 15]`, 0 for code 0 — the
/// same single rounding as `LogScale::decode`, so bit-identical to the table.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn log_values(q: __m256i, f: &Factors) -> __m256 {
    let d = _mm256_xor_si256(q, _mm256_set1_epi32(255));
    let a = _mm256_srli_epi32::<4>(d);
    // vpermps uses the low three bits of each index; bit 3 picks the table's half through
    // the sign bit that blendv reads (bit 3 of `a` is bit 7 of `d`).
    let h = _mm256_blendv_ps(
        _mm256_permutevar8x32_ps(f[0], a),
        _mm256_permutevar8x32_ps(f[1], a),
        _mm256_castsi256_ps(_mm256_slli_epi32::<24>(d)),
    );
    let l = _mm256_blendv_ps(
        _mm256_permutevar8x32_ps(f[2], d),
        _mm256_permutevar8x32_ps(f[3], d),
        _mm256_castsi256_ps(_mm256_slli_epi32::<28>(d)),
    );
    let zero = _mm256_castsi256_ps(_mm256_cmpeq_epi32(q, _mm256_setzero_si256()));
    _mm256_andnot_ps(zero, _mm256_mul_ps(h, l))
}

/// A BC4 block: its eight palette codes (`decode::avx2::bc4_codes`) to values, then the 16
/// texels through their 3-bit indices.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn bc4_16(raw: &[u8; 8], f: &Factors) -> [__m256; 2] {
    let pal = log_values(crate::decode::avx2::bc4_codes(raw), f);
    let bits = u64::from_le_bytes(*raw) >> 16;
    let lo = _mm256_set1_epi32((bits & 0xff_ffff) as i32);
    let hi = _mm256_set1_epi32(((bits >> 24) & 0xff_ffff) as i32);
    let sh = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
    // vpermps uses the low three bits of each index.
    [
        _mm256_permutevar8x32_ps(pal, _mm256_srlv_epi32(lo, sh)),
        _mm256_permutevar8x32_ps(pal, _mm256_srlv_epi32(hi, sh)),
    ]
}

/// One block: each channel's palette expanded through the 2-bit indices, multiplied into the
/// accumulators against the column block's exitance (its four columns in both halves).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn block(pal: &[&[f32; 4]; 3], bits: i32, x: &[X4], acc: &mut Acc) {
    let b = _mm256_set1_epi32(bits);
    let lo = _mm256_srlv_epi32(b, _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14));
    let hi = _mm256_srlv_epi32(b, _mm256_setr_epi32(16, 18, 20, 22, 24, 26, 28, 30));
    for ch in 0..3 {
        // SAFETY: the loads read exactly the 16 bytes of `pal[ch]` (unaligned: a palette is
        // only 4-byte aligned; it folds into one `vbroadcastf128`) and of `x[ch]` (an `X4`,
        // 16-byte aligned); the caller's target features cover these instructions.
        let (p, x) = unsafe {
            let q = _mm_loadu_ps(pal[ch].as_ptr());
            (
                _mm256_set_m128(q, q),
                _mm256_broadcast_ps(&*x[ch].0.as_ptr().cast::<__m128>()),
            )
        };
        // vpermilps uses the low two bits of each index within each 128-bit half: both
        // halves hold the palette.
        acc[ch][0] = _mm256_fmadd_ps(_mm256_permutevar_ps(p, lo), x, acc[ch][0]);
        acc[ch][1] = _mm256_fmadd_ps(_mm256_permutevar_ps(p, hi), x, acc[ch][1]);
    }
}

/// A run of BC1 blocks of one tile with palette tables: the keys of up to [`RUN`] blocks
/// first, eight at a time in vector registers, then each block through [`block`].
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn segment(raw: &[u8], xs: &[X4], pal: &Bc1Palettes, acc: &mut Acc) {
    let mut keys = [[0u32; RUN]; 3];
    for (run, xs) in raw.chunks(8 * RUN).zip(xs.chunks(3 * RUN)) {
        let full = run.len() / (8 * GROUP) * GROUP;
        for (g, chunk) in run.chunks_exact(8 * GROUP).enumerate() {
            group_keys(
                chunk.try_into().expect("a group of blocks"),
                &mut keys,
                g * GROUP,
            );
        }
        for (b, block) in run.chunks_exact(8).enumerate().skip(full) {
            let k = bc1_keys(block.try_into().expect("8-byte block"));
            for ch in 0..3 {
                keys[ch][b] = (BC1_KEY_OFFSET[ch] + k[ch]) as u32;
            }
        }
        for (b, (raw, x)) in run.chunks_exact(8).zip(xs.chunks_exact(3)).enumerate() {
            let p = [0, 1, 2].map(|ch| pal.flat(keys[ch][b] as usize));
            block(&p, index_bits(raw.try_into().expect("8 bytes")), x, acc);
        }
    }
}

/// [`bc1_keys`] of eight consecutive blocks plus each channel's [`BC1_KEY_OFFSET`] (keys into
/// [`Bc1Palettes::flat`]), in vector registers.
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn group_keys(chunk: &[u8; 8 * GROUP], keys: &mut [[u32; RUN]; 3], at: usize) {
    // SAFETY: the loads read the 64 bytes of `chunk`, the stores write 32 bytes of each
    // `keys[ch]` (a checked sub-slice); the caller's target features cover these instructions.
    unsafe {
        let a = _mm256_loadu_ps(chunk.as_ptr().cast());
        let b = _mm256_loadu_ps(chunk.as_ptr().add(32).cast());
        // The low dword of each block (c0 | c1 << 16): per 128-bit half a0 a2 b0 b2 | a4 a6
        // b4 b6, i.e. blocks 0 1 4 5 | 2 3 6 7; the 64-bit permute puts them in order.
        let lo: __m256i =
            _mm256_permute4x64_epi64::<0b11_01_10_00>(_mm256_castps_si256(_mm256_shuffle_ps::<
                0b10_00_10_00,
            >(a, b)));
        let c0 = _mm256_and_si256(lo, _mm256_set1_epi32(0xffff));
        let c1 = _mm256_srli_epi32::<16>(lo);
        // Both are below 2¹⁶, so the signed comparison is the unsigned one.
        let four = _mm256_and_si256(_mm256_cmpgt_epi32(c0, c1), _mm256_set1_epi32(1));
        let m5 = _mm256_set1_epi32(0x1f);
        let m6 = _mm256_set1_epi32(0x3f);
        let red = _mm256_or_si256(
            _mm256_or_si256(
                _mm256_slli_epi32::<10>(four),
                _mm256_slli_epi32::<5>(_mm256_srli_epi32::<11>(c0)),
            ),
            _mm256_srli_epi32::<11>(c1),
        );
        let green = _mm256_or_si256(
            _mm256_or_si256(
                _mm256_slli_epi32::<12>(four),
                _mm256_slli_epi32::<6>(_mm256_and_si256(_mm256_srli_epi32::<5>(c0), m6)),
            ),
            _mm256_and_si256(_mm256_srli_epi32::<5>(c1), m6),
        );
        let blue = _mm256_or_si256(
            _mm256_or_si256(
                _mm256_slli_epi32::<10>(four),
                _mm256_slli_epi32::<5>(_mm256_and_si256(c0, m5)),
            ),
            _mm256_and_si256(c1, m5),
        );
        for ((k, v), off) in keys.iter_mut().zip([red, green, blue]).zip(BC1_KEY_OFFSET) {
            let v = _mm256_add_epi32(v, _mm256_set1_epi32(off as i32));
            let k: &mut [u32; GROUP] = (&mut k[at..at + GROUP]).try_into().expect("a group");
            _mm256_storeu_si256(k.as_mut_ptr().cast(), v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use radiosity_core::LogScale;

    #[target_feature(enable = "avx2,fma,f16c")]
    fn values_of(scale: &LogScale) -> [f32; 256] {
        let (high, low) = scale.factors();
        // SAFETY: each load reads 32 of the 64 bytes of a `[f32; 16]`.
        let f = unsafe {
            [
                _mm256_loadu_ps(high.as_ptr()),
                _mm256_loadu_ps(high[8..].as_ptr()),
                _mm256_loadu_ps(low.as_ptr()),
                _mm256_loadu_ps(low[8..].as_ptr()),
            ]
        };
        let mut out = [0f32; 256];
        for (q0, out) in (0..256).step_by(8).zip(out.chunks_exact_mut(8)) {
            let q = _mm256_setr_epi32(q0, q0 + 1, q0 + 2, q0 + 3, q0 + 4, q0 + 5, q0 + 6, q0 + 7);
            let v: [f32; 8] = cast(log_values(q, &f));
            out.copy_from_slice(&v);
        }
        out
    }

    /// The in-register product form gives the decode table bit for bit, code 0 (exact zero)
    /// and both halves of each factor table included.
    #[test]
    fn log_values_are_the_table() {
        if !crate::SimdPath::Avx2Fma.is_available() {
            return;
        }
        for (v_max, s) in [(0.5, 6.9), (1.0, 4.6), (3.7e-3, 11.5), (0.31, 0.7)] {
            let scale = LogScale::new(v_max, s);
            // SAFETY: AVX2, FMA and F16C were detected above.
            let got = unsafe { values_of(&scale) };
            let want = scale.table();
            for q in 0..256 {
                assert_eq!(got[q].to_bits(), want[q].to_bits(), "code {q} of {scale:?}");
            }
        }
    }

    #[target_feature(enable = "avx2,fma,f16c")]
    fn keys_of(chunk: &[u8; 8 * GROUP]) -> [[u32; RUN]; 3] {
        let mut keys = [[u32::MAX; RUN]; 3];
        group_keys(chunk, &mut keys, RUN - GROUP);
        keys
    }

    /// The vector key arithmetic gives the scalar keys (`decode::check_group_keys`).
    #[test]
    fn group_keys_match_the_scalar_keys() {
        if !crate::SimdPath::Avx2Fma.is_available() {
            return;
        }
        crate::decode::check_group_keys(GROUP, |chunk| {
            // SAFETY: the features were detected above.
            unsafe { keys_of(chunk.try_into().expect("one group")) }
        });
    }
}
