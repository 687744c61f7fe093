//! Which rules does this GPU's texture unit decode BC1/BC4 by?
//!
//! `cargo run --release -p radiosity-backend-wgpu --example bc_decoder [-- ADAPTER [DIR]]`
//!
//! With DIR it also writes what it read: `bc4.bin` and `bc1.bin`, for each block its 8 bytes
//! and then its palette as the texture unit returned it (BC4: 8 f32 for indices 0–7; BC1: 4
//! RGB f32 triples for indices 0–3), for study away from the GPU.
//!
//! Uploads every BC4 endpoint pair (256 × 256, both palette modes, every index) and 65 536
//! random BC1 blocks (both modes) as textures, reads every texel back through `textureLoad`
//! in a compute shader as the f32 the texture unit returns, and compares `255·t` with four
//! models of the palette: D3D10's integer rules ([`DecodeMode::D3d10`], what the encoder
//! assumes), Mesa's ([`DecodeMode::Mesa`]), the exact rational interpolation, and the exact
//! interpolation rounded to the nearest code. It prints, per format and model, how many texels
//! match within 1e-3 of a code, and the largest distance; and whether `⌊255·t + 1/14⌋`
//! recovers the D3D10 code everywhere (true when the decoder interpolates without rounding,
//! since D3D10's truncated thirds, fifths and sevenths all lie at least 1/7 below the next
//! integer). The gather runs a smaller check of the same kind
//! (`radiosity_backend_wgpu::texture_unit::texture_decode_model`) to decide whether its texture path
//! may be used.

use radiosity_backend_wgpu::texture_unit::{
    random_bc1_blocks, read_bc_texels, texel, texture_decode_model,
};
use radiosity_backend_wgpu::{AdapterChoice, choose_adapter};
use radiosity_core::{Bc1Block, Bc4Block, DecodeMode, expand_565};

fn main() {
    let choice = std::env::args()
        .nth(1)
        .map_or(AdapterChoice::Best, AdapterChoice::Name);
    let dump = std::env::args().nth(2).map(std::path::PathBuf::from);
    let adapter = choose_adapter(&choice).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(1)
    });
    println!("adapter: {}", adapter.info);
    if !adapter.info.bc {
        println!("no TEXTURE_COMPRESSION_BC: nothing to measure");
        return;
    }
    let bc4 = every_bc4_pair();
    // BC1: random endpoints, each row of texels using indices 0..3.
    let bc1 = random_bc1_blocks(65536);

    let t4 = read_bc_texels(&adapter, wgpu::TextureFormat::Bc4RUnorm, &bc4)
        .expect("texture unit texels");
    bc4_stats(&bc4, &t4).print("bc4");
    if let Some(dir) = &dump {
        // Texels 0–7 of each block hold indices 0–7.
        write_dump(&dir.join("bc4.bin"), &bc4, |k| {
            (0..8).map(|i| t4[texel(k, i)][0]).collect()
        });
    }

    let t1 = read_bc_texels(&adapter, wgpu::TextureFormat::Bc1RgbaUnorm, &bc1)
        .expect("texture unit texels");
    bc1_stats(&bc1, &t1).print("bc1");
    println!(
        "the gather's own check (what `auto` decides by): {:?}",
        texture_decode_model(&adapter)
    );
    if let Some(dir) = &dump {
        // Texels 0–3 of each block hold indices 0–3.
        write_dump(&dir.join("bc1.bin"), &bc1, |k| {
            (0..4).flat_map(|i| t1[texel(k, i)][..3].to_vec()).collect()
        });
    }
}

/// BC4 blocks of every endpoint pair (r0, r1), indices 0..7 twice over the 16 texels.
fn every_bc4_pair() -> Vec<u8> {
    let mut bc4 = Vec::with_capacity(65536 * 8);
    for r0 in 0..=255u8 {
        for r1 in 0..=255u8 {
            let mut idx = 0u64;
            for i in 0..16u64 {
                idx |= (i % 8) << (3 * i);
            }
            let mut b = [0u8; 8];
            b[0] = r0;
            b[1] = r1;
            b[2..].copy_from_slice(&idx.to_le_bytes()[..6]);
            bc4.extend_from_slice(&b);
        }
    }
    bc4
}

/// The texels `t4` the texture unit returned for the BC4 blocks `bc4`, against each model.
fn bc4_stats(bc4: &[u8], t4: &[[f32; 4]]) -> Stats {
    let mut s4 = Stats::default();
    for (k, block) in bc4.chunks_exact(8).enumerate() {
        let b = Bc4Block(block.try_into().unwrap());
        let (r0, r1) = (f64::from(block[0]), f64::from(block[1]));
        let d3d = b.palette(DecodeMode::D3d10);
        let mesa = b.palette(DecodeMode::Mesa);
        for i in 0..16 {
            let p = b.index(i) as usize;
            let exact = match (b.is_eight_value(), p) {
                (_, 0) => r0,
                (_, 1) => r1,
                (true, p) => ((8 - p) as f64 * r0 + (p - 1) as f64 * r1) / 7.0,
                (false, 6) => 0.0,
                (false, 7) => 255.0,
                (false, p) => ((6 - p) as f64 * r0 + (p - 1) as f64 * r1) / 5.0,
            };
            let got = f64::from(t4[texel(k, i)][0]) * 255.0;
            s4.add(got, f64::from(d3d[p]), f64::from(mesa[p]), exact);
        }
    }
    s4
}

/// The texels `t1` the texture unit returned for the BC1 blocks `bc1`, against each model
/// (every channel of every opaque texel).
fn bc1_stats(bc1: &[u8], t1: &[[f32; 4]]) -> Stats {
    let mut s1 = Stats::default();
    for (k, block) in bc1.chunks_exact(8).enumerate() {
        let b = Bc1Block(block.try_into().unwrap());
        let (e0, e1) = (expand_565(b.c0()), expand_565(b.c1()));
        let d3d = b.palette(DecodeMode::D3d10);
        let mesa = b.palette(DecodeMode::Mesa);
        for i in 0..16 {
            let p = b.index(i) as usize;
            if !b.is_four_colour() && p == 3 {
                continue; // transparent black: no interpolation to measure
            }
            for c in 0..3 {
                let (a, z) = (f64::from(e0[c]), f64::from(e1[c]));
                let exact = match (b.is_four_colour(), p) {
                    (_, 0) => a,
                    (_, 1) => z,
                    (true, 2) => (2.0 * a + z) / 3.0,
                    (true, _) => (a + 2.0 * z) / 3.0,
                    (false, _) => (a + z) / 2.0,
                };
                let got = f64::from(t1[texel(k, i)][c]) * 255.0;
                s1.add(got, f64::from(d3d[p][c]), f64::from(mesa[p][c]), exact);
            }
        }
    }
    s1
}

/// Each block's bytes followed by `palette(k)` as little-endian f32.
fn write_dump(path: &std::path::Path, blocks: &[u8], palette: impl Fn(usize) -> Vec<f32>) {
    let mut out = Vec::new();
    for (k, b) in blocks.chunks_exact(8).enumerate() {
        out.extend_from_slice(b);
        for v in palette(k) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(path, out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

#[derive(Default)]
struct Stats {
    n: usize,
    hits: [usize; 4],
    worst: [f64; 4],
    floor_ok: usize,
}

impl Stats {
    fn add(&mut self, got: f64, d3d: f64, mesa: f64, exact: f64) {
        self.n += 1;
        for (m, want) in [d3d, mesa, exact, exact.round()].into_iter().enumerate() {
            let d = (got - want).abs();
            self.hits[m] += usize::from(d < 1e-3);
            self.worst[m] = self.worst[m].max(d);
        }
        self.floor_ok += usize::from((got + 1.0 / 14.0).floor() == d3d);
    }

    fn print(&self, what: &str) {
        println!("{what}: {} texel channels", self.n);
        for (m, name) in ["d3d10", "mesa", "exact", "exact-rounded"]
            .iter()
            .enumerate()
        {
            println!(
                "  {name:14} matches {:6.2}%  largest distance {:.4} codes",
                100.0 * self.hits[m] as f64 / self.n as f64,
                self.worst[m]
            );
        }
        println!(
            "  floor(255·t + 1/14) == d3d10 code: {:.2}%",
            100.0 * self.floor_ok as f64 / self.n as f64
        );
    }
}
