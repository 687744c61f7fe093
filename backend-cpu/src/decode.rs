//! Block decoders for the gather: a block's palette once, then 16 texels through its indices,
//! straight into two `f32x8` registers per channel.
//!
//! Every value is bit-identical to [`radiosity_core::BlockDecoder`] under
//! [`radiosity_core::DecodeMode::D3d10`]: the same integer palette rules, then the same per-tile
//! `LogScale::table()` (the unit tests compare the palettes with the core's over random blocks).

use wide::f32x8;

/// Per-tile decode data a kernel reads: the channel log tables and, for BC1, the palette
/// tables of the tile (see [`Bc1Palettes`]).
pub(crate) struct TileTables<'a> {
    pub(crate) log: [&'a [f32; 256]; 3],
    pub(crate) bc1: Option<&'a Bc1Palettes>,
    /// binary16 → f32 for every half (F16 on the baseline path only; else empty).
    pub(crate) f16: &'a [f32],
}

/// One storage format's block decoder: one plane of one block to two `f32x8` (block rows 0–1
/// and 2–3) per channel it fills.
pub(crate) trait Kernel: Sync {
    /// Bytes per block and plane.
    const BLOCK_BYTES: usize;
    /// Decodes plane `plane` of the block `raw` into `out[channel]`.
    fn decode<I: Isa>(raw: &[u8], t: &TileTables<'_>, plane: usize, out: &mut [[f32x8; 2]; 3]);
}

/// The instruction-set specific primitives the gather body is generic over.
pub(crate) trait Isa {
    /// 16 texels from a 4-entry palette and 2-bit indices (`bits`, texel `i` at bit `2i`).
    fn expand4(pal: &[f32; 4], bits: u32) -> [f32x8; 2];
    /// 16 texels from an 8-entry palette and 3-bit indices (texel `i` at bit `3i`).
    fn expand8(pal: &[f32; 8], bits: u64) -> [f32x8; 2];
    /// `a · b + c`.
    fn mul_add(a: f32x8, b: f32x8, c: f32x8) -> f32x8;
    /// The eight signed multiples `nibble − 8` of a block correction's code word, texel `i`
    /// at bits `4i`.
    #[inline(always)]
    fn multiples(word: u32) -> f32x8 {
        f32x8::from(core::array::from_fn::<f32, 8, _>(|i| {
            ((word >> (4 * i)) & 15) as f32 - 8.0
        }))
    }
    /// A whole BC4 block (`raw`) through its tile's log table.
    #[inline(always)]
    fn bc4(raw: &[u8; 8], table: &[f32; 256]) -> [f32x8; 2] {
        let pal = bc4_palette(raw).map(|q| table[usize::from(q)]);
        Self::expand8(&pal, u64::from_le_bytes(*raw) >> 16)
    }
    /// Eight log codes through a table. Scalar loads on every path: on this machine (Zen 5)
    /// `vgatherdps` measured slower (u8 gather 7.3 ms against 5.0–7.1 ms at n = 4096).
    #[inline(always)]
    fn lut8(table: &[f32; 256], codes: &[u8; 8]) -> f32x8 {
        f32x8::from(codes.map(|q| table[usize::from(q)]))
    }
    /// Eight little-endian binary16 values (`f16` is the 65536-entry conversion table the
    /// baseline uses).
    #[inline(always)]
    fn f16x8(raw: &[u8; 16], f16: &[f32]) -> f32x8 {
        f32x8::from(core::array::from_fn::<f32, 8, _>(|i| {
            f16[usize::from(u16::from_le_bytes([raw[2 * i], raw[2 * i + 1]]))]
        }))
    }
}

/// BC1: RGB log codes, 2-bit indices.
pub(crate) struct Bc1;
/// BC4: one channel of log codes, 3-bit indices.
pub(crate) struct Bc4;
/// Plain log codes.
pub(crate) struct U8;
/// binary16 values.
pub(crate) struct F16;
/// f32 values.
pub(crate) struct F32;

/// Whatever the build's target features give `wide` (SSE2 on plain x86-64).
pub(crate) struct Baseline;

impl Isa for Baseline {
    #[inline(always)]
    fn expand4(pal: &[f32; 4], bits: u32) -> [f32x8; 2] {
        core::array::from_fn(|h| {
            f32x8::from(core::array::from_fn::<f32, 8, _>(|i| {
                pal[((bits >> (2 * (8 * h + i))) & 3) as usize]
            }))
        })
    }
    #[inline(always)]
    fn expand8(pal: &[f32; 8], bits: u64) -> [f32x8; 2] {
        core::array::from_fn(|h| {
            f32x8::from(core::array::from_fn::<f32, 8, _>(|i| {
                pal[((bits >> (3 * (8 * h + i))) & 7) as usize]
            }))
        })
    }
    #[inline(always)]
    fn mul_add(a: f32x8, b: f32x8, c: f32x8) -> f32x8 {
        a.mul_add(b, c)
    }
}

/// AVX2 + FMA through `std::arch`: palette expansion with `vpermilps`/`vpermps` on indices
/// shifted into place by `vpsrlvd`, and `vfmadd`. Only called from `#[target_feature]`
/// functions that the dispatcher enters after detecting both features.
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx2;

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2 {
    use super::{Avx2, Isa};
    use radiosity_core::bytemuck::cast;
    use std::arch::x86_64::*;
    use wide::f32x8;

    /// The eight D3D10 palette codes of a BC4 block, one per 32-bit lane.
    ///
    /// Both modes, then a select: the mode is data, and a branch on it mispredicts. Eight
    /// values: ((7 − t)·r0 + t·r1) / 7 for entry 1 + t, with x / 7 = x·9363 >> 16 exactly for
    /// x ≤ 7·255. Six values: ((5 − t)·r0 + t·r1) / 5 (x / 5 = x·13108 >> 16 for x ≤ 5·255),
    /// then the constants 0 and 255. `vpmaddwd` forms r0·wa + r1·wb from 16-bit pairs,
    /// `vpmulhuw` the division.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn bc4_codes(raw: &[u8; 8]) -> __m256i {
        let eight = _mm256_set1_epi32(-i32::from(raw[0] > raw[1]));
        let pair = _mm256_set1_epi32(i32::from(raw[0]) | (i32::from(raw[1]) << 16));
        let w = |a: [i32; 8], b: [i32; 8]| {
            let v: [i32; 8] = core::array::from_fn(|i| a[i] | (b[i] << 16));
            // SAFETY: reads the 32 bytes of `v`.
            unsafe { _mm256_loadu_si256(v.as_ptr().cast()) }
        };
        let weights = _mm256_blendv_epi8(
            w([5, 0, 4, 3, 2, 1, 0, 0], [0, 5, 1, 2, 3, 4, 0, 0]),
            w([7, 0, 6, 5, 4, 3, 2, 1], [0, 7, 1, 2, 3, 4, 5, 6]),
            eight,
        );
        let recip = _mm256_blendv_epi8(_mm256_set1_epi32(13108), _mm256_set1_epi32(9363), eight);
        let q = _mm256_mulhi_epu16(_mm256_madd_epi16(pair, weights), recip);
        // Lane 7 of a six-value block is the constant 255.
        let six7 = _mm256_andnot_si256(eight, _mm256_setr_epi32(0, 0, 0, 0, 0, 0, 0, 255));
        _mm256_or_si256(q, six7)
    }

    impl Isa for Avx2 {
        #[inline(always)]
        fn expand4(pal: &[f32; 4], bits: u32) -> [f32x8; 2] {
            // SAFETY: only reached inside `#[target_feature(enable = "avx2,fma,f16c")]` functions,
            // entered after runtime detection (see `block_row::dispatch`); the unaligned
            // load reads exactly the 16 bytes of `pal`.
            unsafe {
                let q = _mm_loadu_ps(pal.as_ptr()); // folds into an unaligned vbroadcastf128
                let p = _mm256_set_m128(q, q);
                let b = _mm256_set1_epi32(bits as i32);
                let lo = _mm256_srlv_epi32(b, _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14));
                let hi = _mm256_srlv_epi32(b, _mm256_setr_epi32(16, 18, 20, 22, 24, 26, 28, 30));
                // vpermilps uses the low two bits of each index, within each 128-bit half:
                // both halves hold the palette.
                [
                    cast(_mm256_permutevar_ps(p, lo)),
                    cast(_mm256_permutevar_ps(p, hi)),
                ]
            }
        }
        #[inline(always)]
        fn expand8(pal: &[f32; 8], bits: u64) -> [f32x8; 2] {
            // SAFETY: as in `expand4`; the load reads exactly the 32 bytes of `pal`.
            unsafe {
                let p = _mm256_loadu_ps(pal.as_ptr());
                let lo = _mm256_set1_epi32((bits & 0xff_ffff) as i32);
                let hi = _mm256_set1_epi32(((bits >> 24) & 0xff_ffff) as i32);
                let sh = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
                // vpermps uses the low three bits of each index.
                [
                    cast(_mm256_permutevar8x32_ps(p, _mm256_srlv_epi32(lo, sh))),
                    cast(_mm256_permutevar8x32_ps(p, _mm256_srlv_epi32(hi, sh))),
                ]
            }
        }
        #[inline(always)]
        fn mul_add(a: f32x8, b: f32x8, c: f32x8) -> f32x8 {
            // SAFETY: as in `expand4`.
            unsafe { cast(_mm256_fmadd_ps(cast(a), cast(b), cast(c))) }
        }
        #[inline(always)]
        fn multiples(word: u32) -> f32x8 {
            // SAFETY: as in `expand4`.
            unsafe {
                let w = _mm256_set1_epi32(word as i32);
                let sh = _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28);
                let nib = _mm256_and_si256(_mm256_srlv_epi32(w, sh), _mm256_set1_epi32(15));
                let m = _mm256_sub_epi32(nib, _mm256_set1_epi32(8));
                cast(_mm256_cvtepi32_ps(m))
            }
        }
        #[inline(always)]
        fn bc4(raw: &[u8; 8], table: &[f32; 256]) -> [f32x8; 2] {
            // SAFETY: as in `expand4`; the gather reads `table` at codes 0..=255 only (every
            // code is a truncated weighted mean of two bytes, or the constant 0 or 255).
            unsafe {
                let codes = bc4_codes(raw);
                let pal = _mm256_i32gather_ps::<4>(table.as_ptr(), codes);
                let bits = u64::from_le_bytes(*raw) >> 16;
                let lo = _mm256_set1_epi32((bits & 0xff_ffff) as i32);
                let hi = _mm256_set1_epi32(((bits >> 24) & 0xff_ffff) as i32);
                let sh = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
                [
                    cast(_mm256_permutevar8x32_ps(pal, _mm256_srlv_epi32(lo, sh))),
                    cast(_mm256_permutevar8x32_ps(pal, _mm256_srlv_epi32(hi, sh))),
                ]
            }
        }
        #[inline(always)]
        fn f16x8(raw: &[u8; 16], _f16: &[f32]) -> f32x8 {
            // SAFETY: as in `expand4` (the dispatcher also checked F16C); reads the 16 bytes
            // of `raw`.
            unsafe { cast(_mm256_cvtph_ps(_mm_loadu_si128(raw.as_ptr().cast()))) }
        }
    }
}

/// BC1 palettes of one tile, decoded to values ahead of time: per channel, indexed by
/// `(four-colour flag, endpoint 0, endpoint 1)` of that channel (5, 6, 5 bits), the four
/// palette values through the tile's table. One flat table of 2¹⁴ palettes (channel `ch` from
/// [`BC1_KEY_OFFSET`]`[ch]`; 12288 used, 256 KiB) so that a key masked to 14 bits is always in
/// bounds; a block then needs three 16-byte loads instead of its integer palette arithmetic
/// and twelve table look-ups.
#[derive(Debug)]
pub(crate) struct Bc1Palettes {
    entries: Box<[[f32; 4]; BC1_TABLE_LEN]>,
}

/// Palettes in a [`Bc1Palettes`] table (a power of two: keys are masked, not bounds-checked).
pub(crate) const BC1_TABLE_LEN: usize = 1 << 14;

/// Where each channel's palettes start in [`Bc1Palettes`]: red has 2¹¹ keys, green 2¹³, blue
/// 2¹¹.
pub(crate) const BC1_KEY_OFFSET: [usize; 3] = [0, 1 << 11, (1 << 11) + (1 << 13)];

const BITS: [u32; 3] = [5, 6, 5];

/// Tiles with fewer blocks than this decode BC1 palettes per block instead of building
/// [`Bc1Palettes`] (256 KiB): at this size the tables are at most half of the tile's block
/// bytes and cost under one palette per 5 blocks to build.
pub(crate) const BC1_TABLE_MIN_BLOCKS: usize = 65536;

/// The D3D10 palette codes of one BC1 channel for `key` = (four-colour flag, endpoint 0,
/// endpoint 1) in 1 + 2·w bits (w = 5, 6, 5 for R, G, B).
#[inline(always)]
pub(crate) fn bc1_channel_palette(ch: usize, key: usize) -> [u32; 4] {
    let w = BITS[ch];
    let key = key as u32;
    let expand = |v: u32| (v << (8 - w)) | (v >> (2 * w - 8));
    let four = key >> (2 * w) != 0;
    let mask = (1 << w) - 1;
    let (a, b) = (expand((key >> w) & mask), expand(key & mask));
    let (p2, p3) = if four {
        ((2 * a + b) / 3, (a + 2 * b) / 3)
    } else {
        ((a + b) / 2, 0)
    };
    [a, b, p2, p3]
}

impl Bc1Palettes {
    pub(crate) fn new(tables: [&[f32; 256]; 3]) -> Self {
        let mut entries: Box<[[f32; 4]; BC1_TABLE_LEN]> = vec![[0f32; 4]; BC1_TABLE_LEN]
            .into_boxed_slice()
            .try_into()
            .expect("BC1_TABLE_LEN entries");
        for ch in 0..3 {
            for key in 0..2usize << (2 * BITS[ch]) {
                entries[BC1_KEY_OFFSET[ch] + key] =
                    bc1_channel_palette(ch, key).map(|q| tables[ch][q as usize]);
            }
        }
        Self { entries }
    }

    /// The palette of channel `ch` for `key`.
    #[inline(always)]
    pub(crate) fn get(&self, ch: usize, key: usize) -> &[f32; 4] {
        self.flat(BC1_KEY_OFFSET[ch] + key)
    }

    /// The palette at `key` = [`BC1_KEY_OFFSET`]`[ch]` + the channel's key (masked into range).
    #[inline(always)]
    pub(crate) fn flat(&self, key: usize) -> &[f32; 4] {
        &self.entries[key & (BC1_TABLE_LEN - 1)]
    }
}

/// The per-channel palette keys of a BC1 block: (four-colour flag, endpoint 0, endpoint 1),
/// as [`Bc1Palettes`] indexes them.
#[inline(always)]
pub(crate) fn bc1_keys(raw: &[u8; 8]) -> [usize; 3] {
    let c0 = usize::from(u16::from_le_bytes([raw[0], raw[1]]));
    let c1 = usize::from(u16::from_le_bytes([raw[2], raw[3]]));
    let four = usize::from(c0 > c1);
    [
        (four << 10) | ((c0 >> 11) << 5) | (c1 >> 11),
        (four << 12) | (((c0 >> 5) & 0x3f) << 6) | ((c1 >> 5) & 0x3f),
        (four << 10) | ((c0 & 0x1f) << 5) | (c1 & 0x1f),
    ]
}

/// The block's 2-bit indices, texel `i` at bit `2i`.
#[inline(always)]
pub(crate) fn index_bits(raw: &[u8; 8]) -> i32 {
    i32::from_le_bytes([raw[4], raw[5], raw[6], raw[7]])
}

impl Kernel for Bc1 {
    const BLOCK_BYTES: usize = 8;
    #[inline(always)]
    fn decode<I: Isa>(raw: &[u8], t: &TileTables<'_>, _plane: usize, out: &mut [[f32x8; 2]; 3]) {
        let raw: &[u8; 8] = raw.try_into().expect("8-byte block");
        let keys = bc1_keys(raw);
        let bits = index_bits(raw) as u32;
        match t.bc1 {
            Some(pal) => {
                for ch in 0..3 {
                    out[ch] = I::expand4(pal.get(ch, keys[ch]), bits);
                }
            }
            None => {
                // A small tile has no palette tables: the same rules, per block.
                for ch in 0..3 {
                    let pal = bc1_channel_palette(ch, keys[ch]).map(|q| t.log[ch][q as usize]);
                    out[ch] = I::expand4(&pal, bits);
                }
            }
        }
    }
}

impl Kernel for Bc4 {
    const BLOCK_BYTES: usize = 8;
    #[inline(always)]
    fn decode<I: Isa>(raw: &[u8], t: &TileTables<'_>, plane: usize, out: &mut [[f32x8; 2]; 3]) {
        let raw: &[u8; 8] = raw.try_into().expect("8-byte block");
        out[plane] = I::bc4(raw, t.log[plane]);
    }
}

impl Kernel for U8 {
    const BLOCK_BYTES: usize = 16;
    #[inline(always)]
    fn decode<I: Isa>(raw: &[u8], t: &TileTables<'_>, plane: usize, out: &mut [[f32x8; 2]; 3]) {
        let table = t.log[plane];
        out[plane] = core::array::from_fn(|h| {
            I::lut8(table, raw[8 * h..8 * h + 8].try_into().expect("8 codes"))
        });
    }
}

impl Kernel for F16 {
    const BLOCK_BYTES: usize = 32;
    #[inline(always)]
    fn decode<I: Isa>(raw: &[u8], t: &TileTables<'_>, plane: usize, out: &mut [[f32x8; 2]; 3]) {
        out[plane] = core::array::from_fn(|h| {
            I::f16x8(
                raw[16 * h..16 * h + 16].try_into().expect("8 halves"),
                t.f16,
            )
        });
    }
}

impl Kernel for F32 {
    const BLOCK_BYTES: usize = 64;
    #[inline(always)]
    fn decode<I: Isa>(raw: &[u8], _t: &TileTables<'_>, plane: usize, out: &mut [[f32x8; 2]; 3]) {
        out[plane] = core::array::from_fn(|h| {
            f32x8::from(radiosity_core::bytemuck::pod_read_unaligned::<[f32; 8]>(
                &raw[32 * h..32 * h + 32],
            ))
        });
    }
}

#[cfg(test)]
fn expand_565(c: u32) -> [u32; 3] {
    let (r, g, b) = ((c >> 11) & 0x1f, (c >> 5) & 0x3f, c & 0x1f);
    [
        (r << 3) | (r >> 2),
        (g << 2) | (g >> 4),
        (b << 3) | (b >> 2),
    ]
}

/// BC1 palette codes under the D3D10 rules, `[channel][entry]` (for the tests: the gather uses
/// [`Bc1Palettes`], built by the same rules).
#[cfg(test)]
fn bc1_palette(raw: &[u8; 8]) -> [[u8; 4]; 3] {
    let c0 = u32::from(u16::from_le_bytes([raw[0], raw[1]]));
    let c1 = u32::from(u16::from_le_bytes([raw[2], raw[3]]));
    let (e0, e1) = (expand_565(c0), expand_565(c1));
    let four = c0 > c1;
    core::array::from_fn(|ch| {
        let (a, b) = (e0[ch], e1[ch]);
        let (p2, p3) = if four {
            ((2 * a + b) / 3, (a + 2 * b) / 3)
        } else {
            ((a + b) / 2, 0)
        };
        [a as u8, b as u8, p2 as u8, p3 as u8]
    })
}

/// BC4 palette codes under the D3D10 rules.
#[inline(always)]
pub(crate) fn bc4_palette(raw: &[u8; 8]) -> [u8; 8] {
    let (r0, r1) = (u32::from(raw[0]), u32::from(raw[1]));
    let mut p = [0u8; 8];
    p[0] = raw[0];
    p[1] = raw[1];
    if r0 > r1 {
        for t in 1..7 {
            p[1 + t as usize] = (((7 - t) * r0 + t * r1) / 7) as u8;
        }
    } else {
        for t in 1..5 {
            p[1 + t as usize] = (((5 - t) * r0 + t * r1) / 5) as u8;
        }
        p[6] = 0;
        p[7] = 255;
    }
    p
}

/// binary16 → f32 for all 65536 halves (the baseline path's f16 decoder; 256 KiB).
pub(crate) fn f16_table() -> Vec<f32> {
    (0..=u16::MAX)
        .map(radiosity_core::half::f16_to_f32)
        .collect()
}

/// Blocks whose keys a vector body computes before multiplying any of them (`avx512.rs` and
/// `avx2.rs`: 8 groups of 16 and 16 groups of 8).
#[cfg(target_arch = "x86_64")]
pub(crate) const KEY_RUN: usize = 128;

/// Checks a vector body's key arithmetic for one group of `group` blocks: `keys_of(chunk)`
/// keys the group's 8·`group` bytes into the last `group` slots of a run filled with
/// `u32::MAX`. Every key must be the scalar [`bc1_keys`] plus its channel's
/// [`BC1_KEY_OFFSET`], including equal endpoints (three-colour mode) and c0 < c1, and nothing
/// outside the group may be written.
#[cfg(all(test, target_arch = "x86_64"))]
pub(crate) fn check_group_keys(group: usize, keys_of: impl Fn(&[u8]) -> [[u32; KEY_RUN]; 3]) {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    for round in 0..4000 {
        let mut chunk: Vec<u8> = (0..8 * group)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                s as u8
            })
            .collect();
        if round % 3 == 0 {
            for b in (0..group).step_by(2) {
                chunk[8 * b + 2] = chunk[8 * b];
                chunk[8 * b + 3] = chunk[8 * b + 1];
            }
        }
        let keys = keys_of(&chunk);
        for b in 0..group {
            let want = bc1_keys(chunk[8 * b..8 * b + 8].try_into().unwrap());
            for ch in 0..3 {
                assert_eq!(
                    keys[ch][KEY_RUN - group + b] as usize,
                    BC1_KEY_OFFSET[ch] + want[ch],
                    "block {b} channel {ch} of {chunk:?}"
                );
                assert!(keys[ch][..KEY_RUN - group].iter().all(|k| *k == u32::MAX));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use radiosity_core::{Bc1Block, Bc4Block, DecodeMode};

    /// SplitMix64, enough for random blocks.
    fn next(s: &mut u64) -> u64 {
        *s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = *s;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    #[test]
    fn palettes_match_the_core_decoder() {
        let tabs: [[f32; 256]; 3] =
            core::array::from_fn(|c| core::array::from_fn(|q| (q * (c + 1)) as f32 + 0.5));
        let luts = Bc1Palettes::new([&tabs[0], &tabs[1], &tabs[2]]);
        let mut s = 1u64;
        for k in 0..200_000u64 {
            let mut raw = next(&mut s).to_le_bytes();
            if k % 4 == 0 {
                // Equal BC1 endpoints (three-colour mode); BC4 sees r0 == r1.
                raw[1] = raw[0];
                raw[2] = raw[0];
                raw[3] = raw[0];
            }
            let core = Bc1Block(raw).palette(DecodeMode::D3d10);
            let ours = bc1_palette(&raw);
            for ch in 0..3 {
                for e in 0..4 {
                    assert_eq!(ours[ch][e], core[e][ch], "bc1 {raw:?} entry {e} ch {ch}");
                }
            }
            assert_eq!(
                bc4_palette(&raw),
                Bc4Block(raw).palette(DecodeMode::D3d10),
                "bc4 {raw:?}"
            );
            // The per-tile palette tables hold the table values of the core's palette codes.
            let c0 = usize::from(u16::from_le_bytes([raw[0], raw[1]]));
            let c1 = usize::from(u16::from_le_bytes([raw[2], raw[3]]));
            let four = usize::from(c0 > c1);
            let keys = [
                (four << 10) | ((c0 >> 11) << 5) | (c1 >> 11),
                (four << 12) | (((c0 >> 5) & 0x3f) << 6) | ((c1 >> 5) & 0x3f),
                (four << 10) | ((c0 & 0x1f) << 5) | (c1 & 0x1f),
            ];
            for ch in 0..3 {
                let want: [f32; 4] = core::array::from_fn(|e| tabs[ch][usize::from(core[e][ch])]);
                assert_eq!(luts.get(ch, keys[ch]), &want, "bc1 table {raw:?} ch {ch}");
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,f16c")]
    fn avx2_bc4(raw: &[u8; 8], table: &[f32; 256]) -> [[f32; 8]; 2] {
        Avx2::bc4(raw, table).map(|v| v.to_array())
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_bc4_matches_the_baseline() {
        if !crate::SimdPath::Avx2Fma.is_available() {
            return;
        }
        let table: [f32; 256] = core::array::from_fn(|q| q as f32 * 1.5 + 0.25);
        let mut s = 7u64;
        for k in 0..100_000u64 {
            let mut raw = next(&mut s).to_le_bytes();
            if k % 8 == 0 {
                raw[1] = raw[0];
            }
            let want = Baseline::bc4(&raw, &table).map(|v| v.to_array());
            // SAFETY: AVX2, FMA and F16C were detected above.
            let got = unsafe { avx2_bc4(&raw, &table) };
            assert_eq!(got, want, "{raw:?}");
        }
    }
}
