//! `decode_blocks`: the BC1 and BC4 decoders under both decode rules, against each other and
//! the reference decoders.

use radiosity_core::{
    DecodeMode, decode_bc1_block, decode_bc1_block_with, decode_bc4_block, decode_bc4_block_with,
};

/// Largest difference between the [`DecodeMode::Mesa`] and [`DecodeMode::D3d10`] palettes on an
/// interpolated BC1 entry, per channel. Both round `e0 + (e1 − e0)·k` for k = 1/3, 2/3 (four
/// colours) or 1/2 (three colours): D3D10 with the exact fraction, Mesa with 85/256, 170/256
/// (off by at most 255·|1/3 − 85/256| < 0.34 and 255·|2/3 − 170/256| < 0.67 before flooring) or
/// with a rounded instead of a truncated midpoint, so the floors differ by at most 1. The replay
/// test checks this bound exhaustively over every pair of 8-bit endpoints and that it is reached.
pub const BC1_MESA_MAX_DIFF: u8 = 1;

/// The same bound for BC4, per palette entry `t`: the six-value mode (`r0 ≤ r1`, weights
/// `⌊255t/5⌋/256`) stays within 1, but the eight-value mode's weights `⌊255t/7⌋/256` fall short
/// of `t/7` by up to 0.0056 for t = 6 (218/256 against 6/7), 1.4 codes at a 255 span, so after
/// both floors the two modes differ by up to **2** (reached at t = 4 and t = 6; checked
/// exhaustively by the replay test). The endpoints and the constants 0 and 255 are equal.
pub fn bc4_mesa_max_diff(eight_value: bool, t: usize) -> u8 {
    match (eight_value, t) {
        (true, 4 | 6) => 2,
        _ => 1,
    }
}

/// Decodes each 8-byte chunk of `data` as a BC1 and as a BC4 block and compares with texpresso's
/// decoder (exact, RGBA for BC1; the R channel for BC4, texpresso splats it to G and B), then
/// compares the [`DecodeMode::Mesa`] palettes with the D3D10 ones within the documented bounds.
pub fn check_decode_blocks(data: &[u8]) {
    for chunk in data.chunks_exact(8) {
        let block: &[u8; 8] = chunk.try_into().expect("chunks_exact(8)");
        check_bc1_block(block);
        check_bc4_block(block);
    }
}

fn check_bc1_block(block: &[u8; 8]) {
    let ours = decode_bc1_block(block);
    let theirs = texpresso::Format::Bc1.decompress_block(block);
    // texpresso's three-colour index 3 is [0, 0, 0, 0], as ours: compare all four channels.
    assert_eq!(ours, theirs, "BC1 block {block:02x?}: ours vs texpresso");

    let four = u16::from_le_bytes([block[0], block[1]]) > u16::from_le_bytes([block[2], block[3]]);
    let d3d = radiosity_core::Bc1Block(*block).palette(DecodeMode::D3d10);
    let mesa = radiosity_core::Bc1Block(*block).palette(DecodeMode::Mesa);
    assert_eq!(d3d[..2], mesa[..2], "BC1 {block:02x?}: endpoints differ");
    for k in 2..4 {
        for ch in 0..4 {
            let diff = d3d[k][ch].abs_diff(mesa[k][ch]);
            let bound = if ch == 3 || (k == 3 && !four) {
                0 // alpha, and three-colour transparent black, are exact
            } else {
                BC1_MESA_MAX_DIFF
            };
            assert!(
                diff <= bound,
                "BC1 {block:02x?}: palette[{k}][{ch}] D3D10 {} vs Mesa {} differ by {diff} > {bound}",
                d3d[k][ch],
                mesa[k][ch]
            );
        }
    }
    // The texels are the palette looked up by index in both modes.
    let texels = decode_bc1_block_with(block, DecodeMode::Mesa);
    let b = radiosity_core::Bc1Block(*block);
    for (i, t) in texels.iter().enumerate() {
        assert_eq!(
            *t,
            mesa[b.index(i) as usize],
            "BC1 {block:02x?} Mesa texel {i}"
        );
    }
}

fn check_bc4_block(block: &[u8; 8]) {
    let ours = decode_bc4_block(block);
    let theirs = texpresso::Format::Bc4.decompress_block(block);
    for i in 0..16 {
        assert_eq!(
            ours[i], theirs[i][0],
            "BC4 block {block:02x?} texel {i}: ours {} vs texpresso {}",
            ours[i], theirs[i][0]
        );
    }

    let b = radiosity_core::Bc4Block(*block);
    let eight = b.is_eight_value();
    let d3d = b.palette(DecodeMode::D3d10);
    let mesa = b.palette(DecodeMode::Mesa);
    assert_eq!(d3d[..2], mesa[..2], "BC4 {block:02x?}: endpoints differ");
    if !eight {
        assert_eq!((mesa[6], mesa[7]), (0, 255), "BC4 {block:02x?}: constants");
        assert_eq!(d3d[6..], mesa[6..], "BC4 {block:02x?}: constants differ");
    }
    let steps = if eight { 7 } else { 5 };
    for t in 1..steps {
        let diff = d3d[1 + t].abs_diff(mesa[1 + t]);
        let bound = bc4_mesa_max_diff(eight, t);
        assert!(
            diff <= bound,
            "BC4 {block:02x?}: palette[{}] D3D10 {} vs Mesa {} differ by {diff} > {bound}",
            1 + t,
            d3d[1 + t],
            mesa[1 + t]
        );
    }
    let texels = decode_bc4_block_with(block, DecodeMode::Mesa);
    for (i, t) in texels.iter().enumerate() {
        assert_eq!(
            *t,
            mesa[b.index(i) as usize],
            "BC4 {block:02x?} Mesa texel {i}"
        );
    }
}
