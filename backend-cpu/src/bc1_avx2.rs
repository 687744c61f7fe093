//! The AVX2 body for BC1: what `avx512.rs` does for a `zmm` register, in two `ymm` halves.
//!
//! The generic body (`kernel::block_row` over `decode::Avx2`) spent a third of its instructions
//! on each block's scalar endpoint arithmetic (c0, c1, the four-colour flag, three table keys),
//! kept a branch on the channel count inside the block loop, and spilled accumulators. Here, as
//! in the AVX-512 body, the keys of a run of blocks are computed first, eight blocks per `ymm`
//! register, and the block loop is left with one broadcast of the index bits, two `vpsrlvd`,
//! three 16-byte palette broadcasts from the tile's table, six `vpermilps` and six `vfmadd`
//! (two block rows per register) per block. BC1 always has three channels.
//!
//! Every function here is compiled with `avx2,fma,f16c` and only entered after runtime
//! detection ([`crate::SimdPath::Avx2Fma`]).

use crate::decode::{BC1_KEY_OFFSET, Bc1Palettes, bc1_channel_palette, bc1_keys, index_bits};
use crate::kernel::{Ctx, X4, finish_rows};
use radiosity_core::Rgb;
use radiosity_core::bytemuck::cast;
use std::arch::x86_64::*;

/// Blocks whose keys one `ymm` register holds.
const GROUP: usize = 8;

/// Blocks keyed before any of them is multiplied (see `avx512::RUN`: a scalar key load right
/// behind the wider vector store that wrote it waits for the store).
const RUN: usize = 16 * GROUP;

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
    let sums: [[f32; 4]; 3] = core::array::from_fn(|k| {
        let lo: [f32; 8] = cast(acc[k][0]);
        let hi: [f32; 8] = cast(acc[k][1]);
        core::array::from_fn(|i| {
            let s = if i < 2 { &lo } else { &hi };
            let q = 4 * (i % 2);
            (s[q] + s[q + 1]) + (s[q + 2] + s[q + 3])
        })
    });
    finish_rows(ctx, row, sums, out);
}

/// One block: each channel's palette expanded through the 2-bit indices, multiplied into the
/// accumulators against the column block's exitance (its four columns twice).
#[inline]
#[target_feature(enable = "avx2,fma,f16c")]
fn block(pal: &[&[f32; 4]; 3], bits: i32, x: &[X4], acc: &mut Acc) {
    let b = _mm256_set1_epi32(bits);
    let lo = _mm256_srlv_epi32(b, _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14));
    let hi = _mm256_srlv_epi32(b, _mm256_setr_epi32(16, 18, 20, 22, 24, 26, 28, 30));
    for ch in 0..3 {
        // SAFETY: the loads read exactly the 16 bytes of `pal[ch]` and of `x[ch]`; the
        // caller's target features cover these instructions.
        let (p, x) = unsafe {
            (
                _mm256_broadcast_ps(&*pal[ch].as_ptr().cast::<__m128>()),
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

    #[target_feature(enable = "avx2,fma,f16c")]
    fn keys_of(chunk: &[u8; 8 * GROUP]) -> [[u32; RUN]; 3] {
        let mut keys = [[u32::MAX; RUN]; 3];
        group_keys(chunk, &mut keys, RUN - GROUP);
        keys
    }

    /// The vector key arithmetic gives the scalar keys (plus each channel's offset) for every
    /// block of a group, including equal endpoints (three-colour mode) and c0 < c1, and
    /// writes nothing outside its group.
    #[test]
    fn group_keys_match_the_scalar_keys() {
        if !crate::SimdPath::Avx2Fma.is_available() {
            return;
        }
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for round in 0..4000 {
            let mut chunk: [u8; 8 * GROUP] = core::array::from_fn(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s as u8
            });
            if round % 3 == 0 {
                for b in (0..GROUP).step_by(2) {
                    chunk[8 * b + 2] = chunk[8 * b];
                    chunk[8 * b + 3] = chunk[8 * b + 1];
                }
            }
            // SAFETY: AVX2, FMA and F16C were detected above.
            let keys = unsafe { keys_of(&chunk) };
            for b in 0..GROUP {
                let want = bc1_keys(chunk[8 * b..8 * b + 8].try_into().unwrap());
                for ch in 0..3 {
                    assert_eq!(
                        keys[ch][RUN - GROUP + b] as usize,
                        BC1_KEY_OFFSET[ch] + want[ch],
                        "block {b} channel {ch} of {chunk:?}"
                    );
                    assert!(keys[ch][..RUN - GROUP].iter().all(|k| *k == u32::MAX));
                }
            }
        }
    }
}
