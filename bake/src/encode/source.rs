//! One block of a whole matrix ([`Source`]): its target under the error weights, its encode
//! and score for the error-driven selection, and the coupled pass along a block row.

use super::blocks::{empty_target, encode_target};
use super::refine::{self, BlockTarget, Coupling};
use super::{EncodeParams, ErrorWeights, block_texels};
use radiosity_core::{Bc1Block, BlockDecoder, Format, LogScale, MatrixLayout};

/// What encoding one block of a whole matrix needs.
pub(super) struct Source<'a> {
    pub(super) layout: &'a MatrixLayout,
    pub(super) params: &'a EncodeParams,
    pub(super) dense: &'a [f32],
    pub(super) weights: &'a ErrorWeights,
    pub(super) scales: &'a [LogScale],
    pub(super) tables: Vec<[f32; 256]>,
    pub(super) decoder: BlockDecoder,
}

impl Source<'_> {
    /// Encodes global block `b` (every plane, `out` holds them in turn) with the texels in
    /// `sparse` left to the sparse list. With `score`, also writes each texel's weighted
    /// squared error as decoded (for sparse texels: what the block decodes there), 0 beyond
    /// the last patch.
    /// `thorough`: a second BC1 start ([`EncodeParams::bc1_retry`]).
    pub(super) fn encode(
        &self,
        b: usize,
        sparse: u16,
        out: &mut [u8],
        score: Option<&mut [f32; 16]>,
        thorough: bool,
    ) {
        let l = self.layout;
        let channels = l.channels();
        let bb = self.params.format.block_bytes();
        let (target, tile) = self.target(b, sparse);
        let mut decoded = [[0f32; 16]; 3];
        for plane in 0..l.planes() {
            let raw = &mut out[plane * bb..(plane + 1) * bb];
            encode_target(self.params, plane, &target, raw, thorough);
            if score.is_some() {
                self.decoder.decode_plane(l, tile, plane, raw, &mut decoded);
            }
        }
        if let Some(score) = score {
            for i in 0..16 {
                score[i] = (0..channels)
                    .map(|ch| {
                        target.weights[ch][i] * (decoded[ch][i] - target.values[ch][i]).powi(2)
                    })
                    .sum();
            }
        }
    }

    /// What global block `b` should hold with the texels in `sparse` left to the sparse list,
    /// and its tile's index.
    pub(super) fn target(&self, b: usize, sparse: u16) -> (BlockTarget<'_>, usize) {
        let l = self.layout;
        let (n, channels) = (l.n(), l.channels());
        let side = l.padded() / 4;
        let (tile, _, _) = l.locate(b / side * 4, b % side * 4);
        let mut target = empty_target();
        let log = self.params.format.is_log();
        if log {
            for ch in 0..channels {
                target.tables[ch] = &self.tables[l.scale_index(tile.index, ch)];
            }
        }
        for (i, r, c) in block_texels(b, side, n) {
            let e = (r * n + c) * channels;
            for ch in 0..channels {
                target.values[ch][i] = self.dense[e + ch];
                target.weights[ch][i] = self.weights.weight(c, ch, channels);
            }
            if sparse & (1 << i) == 0 {
                target.fit |= 1 << i;
                if log {
                    for ch in 0..channels {
                        let s = self.scales[l.scale_index(tile.index, ch)];
                        target.codes[ch][i] = s.encode(target.values[ch][i]);
                    }
                }
            }
        }
        (target, tile.index)
    }

    /// The coupled pass over block row `block_row` (`out`: its blocks, planes together):
    /// each block with an emitting column, left to right, is refined under [`Coupling`]
    /// with the emitter-weighted row errors of the blocks before it, then its own errors are
    /// added to them. BC1 and BC4 only.
    pub(super) fn couple_row(&self, block_row: usize, masks: &[u16], out: &mut [u8], search: bool) {
        let l = self.layout;
        let (n, channels) = (l.n(), l.channels());
        let side = l.padded() / 4;
        let bb = self.params.format.block_bytes();
        let per_block = l.planes() * bb;
        let grey = channels == 1;
        let mut carried = [[0f32; 3]; 4];
        for bc in 0..side {
            let b = block_row * side + bc;
            let emission: [[f32; 3]; 4] = core::array::from_fn(|c| {
                let col = bc * 4 + c;
                if col < n {
                    self.weights.emission(col)
                } else {
                    [0.0; 3]
                }
            });
            if emission == [[0.0; 3]; 4] {
                continue;
            }
            let (target, tile) = self.target(b, masks[b]);
            if (0..channels).all(|ch| target.codes[ch] == [0; 16]) {
                continue;
            }
            let cp = Coupling {
                sigma2: if grey { 3.0 } else { 1.0 },
                grey,
                emission,
                carried,
            };
            let raw = &mut out[bc * per_block..(bc + 1) * per_block];
            let mut decoded = [[0f32; 16]; 3];
            for plane in 0..l.planes() {
                let r = &mut raw[plane * bb..(plane + 1) * bb];
                let start: [u8; 8] = (&*r).try_into().expect("8-byte block");
                let refined = match self.params.format {
                    Format::Bc1 => {
                        refine::refine_bc1_coupled(Bc1Block(start), &target, &cp, search).0
                    }
                    _ => refine::refine_bc4_coupled(start, &target, plane, &cp, search),
                };
                r.copy_from_slice(&refined);
                self.decoder.decode_plane(l, tile, plane, r, &mut decoded);
            }
            for i in 0..16 {
                if target.fit & (1 << i) == 0 {
                    continue;
                }
                for k in 0..3 {
                    let ch = if grey { 0 } else { k };
                    carried[i / 4][k] +=
                        (decoded[ch][i] - target.values[ch][i]) * emission[i % 4][k];
                }
            }
        }
    }

    /// Texels of global block `b` that must stay in the sparse list whatever their score: a
    /// value above its tile's `v_max` in some channel (the scales come from the first sparse
    /// set, whose entries may exceed them, and a block cannot decode above `v_max`).
    pub(super) fn must_stay_sparse(&self, b: usize) -> u16 {
        let l = self.layout;
        let (n, channels) = (l.n(), l.channels());
        let side = l.padded() / 4;
        block_texels(b, side, n).fold(0u16, |m, (i, r, c)| {
            let (tile, _, _) = l.locate(r, c);
            let e = (r * n + c) * channels;
            let above = (0..channels)
                .any(|ch| self.dense[e + ch] > self.scales[l.scale_index(tile.index, ch)].v_max);
            if above { m | 1 << i } else { m }
        })
    }
}
