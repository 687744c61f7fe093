//! Golden blocks: hand-made BC1/BC4 blocks whose texels were worked out by hand from the rules,
//! not by running any decoder.
//!
//! Provenance: D3D10 values from the block-compression rules in Microsoft's "Block Compression
//! (Direct3D 10)" documentation, with the integer (truncating) division texpresso and
//! texture2ddecoder use; Mesa values from the rules measured on llvmpipe/lavapipe 22.3
//! (`DecodeMode::Mesa`). Each entry shows its arithmetic.

use radiosity_core::{
    DecodeMode, decode_bc1_block, decode_bc1_block_with, decode_bc4_block, decode_bc4_block_with,
};

/// An opaque BC1 texel.
const fn rgb(r: u8, g: u8, b: u8) -> [u8; 4] {
    [r, g, b, 255]
}

#[test]
fn bc1_endpoint_order_selects_three_colour_mode() {
    // c0 = 0x001f (pure blue, b5 = 31 → 255), c1 = 0xf800 (pure red): c0 = 31 < c1 = 63488, so
    // this is a THREE-colour block despite "looking" four-colour: order matters, not colours.
    // Indices 0b11100100 in the first byte: texels 0..4 use 0, 1, 2, 3.
    let block = [0x1f, 0x00, 0x00, 0xf8, 0b1110_0100, 0, 0, 0];
    let d = decode_bc1_block(&block);
    // Midpoint: (255 + 0) / 2 = 127 for red and blue; index 3 is transparent black.
    assert_eq!(
        d[..4],
        [
            rgb(0, 0, 255),
            rgb(255, 0, 0),
            rgb(127, 0, 127),
            [0, 0, 0, 0]
        ]
    );
    // Mesa's midpoint rounds up: (255 + 0 + 1) >> 1 = 128.
    let m = decode_bc1_block_with(&block, DecodeMode::Mesa);
    assert_eq!(
        m[..4],
        [
            rgb(0, 0, 255),
            rgb(255, 0, 0),
            rgb(128, 0, 128),
            [0, 0, 0, 0]
        ]
    );
    // The remaining 12 texels have index 0.
    assert!(d[4..].iter().all(|t| *t == rgb(0, 0, 255)));
}

#[test]
fn bc1_four_colour_grey_ramp() {
    // c0 = 0xffff (white) > c1 = 0x0841 (r5 = 1, g6 = 2, b5 = 1 → 8, 8, 8).
    // c2 = (2·255 + 8) / 3 = 172 (518/3 = 172.67, truncated); c3 = (255 + 16) / 3 = 90.
    // Indices: row 0 = 0, 2, 3, 1 → byte 0b01_11_10_00.
    let block = [0xff, 0xff, 0x41, 0x08, 0b0111_1000, 0, 0, 0];
    let d = decode_bc1_block(&block);
    assert_eq!(
        d[..4],
        [
            rgb(255, 255, 255),
            rgb(172, 172, 172),
            rgb(90, 90, 90),
            rgb(8, 8, 8)
        ]
    );
    // Mesa: 255 + ((−247·85) >> 8) = 255 + ⌊−82.01⌋ = 172; 255 + ((−247·170) >> 8) = 255 − 165 = 90.
    let m = decode_bc1_block_with(&block, DecodeMode::Mesa);
    assert_eq!(m[..4], d[..4]);
}

#[test]
fn bc1_endpoint_expansion_by_bit_replication() {
    // c0 = 0b10000_100000_00001 (0x8401) → r = 132, g = 130, b = 8; c1 = 0 → black. Four-colour.
    // c2 = (264 + 0)/3, (260)/3, (16)/3 = 88, 86, 5; c3 = 44, 43, 2.
    let block = [0x01, 0x84, 0x00, 0x00, 0b1110_0100, 0, 0, 0];
    let d = decode_bc1_block(&block);
    assert_eq!(
        d[..4],
        [
            rgb(132, 130, 8),
            rgb(0, 0, 0),
            rgb(88, 86, 5),
            rgb(44, 43, 2)
        ]
    );
    // Mesa: 132 + ((−132·85) >> 8) = 132 + ⌊−43.83⌋ = 88; 130 − 44 = 86 (⌊−43.16⌋ = −44);
    // 8 + ⌊−2.66⌋ = 5; c3: 132 + ⌊−87.66⌋ = 44, 130 + ⌊−86.33⌋ = 43, 8 + ⌊−5.31⌋ = 2.
    assert_eq!(decode_bc1_block_with(&block, DecodeMode::Mesa)[..4], d[..4]);
}

#[test]
fn bc4_eight_value_mode() {
    // r0 = 200 > r1 = 60: eight values. t/7 steps: (6·200 + 60)/7 = 180, (5·200 + 120)/7 = 160,
    // (4·200 + 180)/7 = 140, (3·200 + 240)/7 = 120, (2·200 + 300)/7 = 100, (200 + 360)/7 = 80.
    // Indices 0..7 in texels 0..7, then texels 8..16 index 0. 3-bit indices packed LSB first:
    // 0 | 1<<3 | 2<<6 | 3<<9 | 4<<12 | 5<<15 | 6<<18 | 7<<21 = 0xfac688.
    let block = [200, 60, 0x88, 0xc6, 0xfa, 0, 0, 0];
    let d = decode_bc4_block(&block);
    assert_eq!(d[..8], [200, 60, 180, 160, 140, 120, 100, 80]);
    assert!(d[8..].iter().all(|v| *v == 200));
    // Mesa: 200 + ((−140·⌊255t/7⌋) >> 8): w = 36, 72, 109, 145, 182, 218 →
    // 200 + ⌊−19.69⌋ = 180, ⌊−39.38⌋ → 160, ⌊−59.61⌋ → 140, ⌊−79.30⌋ → 120, ⌊−99.53⌋ → 100,
    // ⌊−119.22⌋ → 80. Equal here; they differ elsewhere (see codec_differential).
    assert_eq!(decode_bc4_block_with(&block, DecodeMode::Mesa)[..8], d[..8]);
}

#[test]
fn bc4_six_value_mode_with_constants() {
    // r0 = 10 ≤ r1 = 110: six values and the constants. (4·10 + 110)/5 = 30, (30 + 220)/5 = 50,
    // (20 + 330)/5 = 70, (10 + 440)/5 = 90, then 0 and 255. Same packing as above.
    let block = [10, 110, 0x88, 0xc6, 0xfa, 0, 0, 0];
    assert_eq!(
        decode_bc4_block(&block)[..8],
        [10, 110, 30, 50, 70, 90, 0, 255]
    );
    // Mesa: 10 + ((100·⌊255t/5⌋) >> 8): w = 51, 102, 153, 204 → 10 + 19, 10 + 39, 10 + 59,
    // 10 + 79 = 29, 49, 69, 89: one below D3D10 each.
    assert_eq!(
        decode_bc4_block_with(&block, DecodeMode::Mesa)[..8],
        [10, 110, 29, 49, 69, 89, 0, 255]
    );
}

#[test]
fn surfaces_clip_partial_blocks() {
    // A 5×3 BC4 surface has 2×1 blocks; the second block's first column becomes column 4.
    let block_a = [7, 7, 0, 0, 0, 0, 0, 0];
    let block_b = [9, 9, 0, 0, 0, 0, 0, 0];
    let data = [block_a, block_b].concat();
    let out = radiosity_core::decode_bc4_surface(&data, 5, 3, DecodeMode::D3d10).unwrap();
    assert_eq!(out.len(), 15);
    assert_eq!(&out[..5], &[7, 7, 7, 7, 9]);
    assert!(radiosity_core::decode_bc4_surface(&data[..8], 5, 3, DecodeMode::D3d10).is_err());
    let rgba = radiosity_core::decode_bc1_surface(&[0u8; 16], 8, 4, DecodeMode::D3d10).unwrap();
    assert!(rgba.iter().all(|t| *t == [0, 0, 0, 255]));
}
