//! Times the GPU gather on a large synthetic matrix: the measurement for a real GPU.
//!
//! `cargo run --release -p radiosity-backend-wgpu --example gather_speed -- [N] [FORMAT…] [splits=S,…]`
//! (default: 16384 patches, bc1 and bc4, three channels), on the best adapter
//! (`WGPU_BACKEND=vulkan` etc. restricts the search). Blocks are random but valid (log codes
//! 1–255 through one scale per tile): the gather's cost does not depend on their content, and
//! encoding 16M real BC1 blocks would take minutes. For each decode path it prints the median
//! of 21 frames (upload of x, dispatches, readback of y), the median GPU time of the kernels
//! alone (timestamps, where the adapter has them), and the bytes they must move divided by
//! each; compare with the device's memory bandwidth (H100 SXM: 3.35 TB/s; 50% of it is the
//! issue's target for BC1).

use radiosity_backend_wgpu::{DecodePath, GpuOptions, WgpuGather, choose_adapter};
use radiosity_core::{
    BlockCorrections, DEFAULT_MAX_TILE, Format, Gather, LogScale, MatrixLayout, Rgb, SparseRows,
    TransferMatrix,
};
use std::borrow::Cow;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: u32 = args.first().and_then(|a| a.parse().ok()).unwrap_or(16384);
    let formats: Vec<Format> = args
        .iter()
        .filter_map(|a| Format::from_name(a))
        .collect::<Vec<_>>();
    // `splits=1,4,16` times each column-split count (default: the gather's own choice).
    let splits: Vec<Option<u32>> = args
        .iter()
        .find_map(|a| a.strip_prefix("splits="))
        .map_or(vec![None], |list| {
            list.split(',').map(|s| s.parse().ok()).collect()
        });
    let formats = if formats.is_empty() {
        vec![Format::Bc1, Format::Bc4]
    } else {
        formats
    };
    let adapter = match choose_adapter(&Default::default()) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    println!("adapter: {}, n = {n}", adapter.info);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for format in formats {
        let layout = MatrixLayout::new(n, 3, format, DEFAULT_MAX_TILE).expect("layout");
        let mut blocks = vec![0u8; layout.block_bytes() as usize];
        for chunk in blocks.chunks_mut(8) {
            chunk.copy_from_slice(&next().to_le_bytes()[..chunk.len()]);
        }
        let matrix = TransferMatrix {
            layout,
            scales: Cow::Owned(vec![LogScale::new(1e-3, 6.9); layout.scale_count()]),
            blocks: Cow::Owned(blocks),
            sparse: SparseRows::empty(n as usize),
            corrections: BlockCorrections::empty(n as usize),
        };
        let x: Vec<Rgb> = (0..n).map(|i| Rgb::splat((i % 7) as f32)).collect();
        let mut y = vec![Rgb::ZERO; n as usize];
        let moved = matrix.bytes() as f64 + 24.0 * f64::from(n);
        for path in [DecodePath::Software, DecodePath::HardwareBc] {
            for &splits in &splits {
                let options = GpuOptions {
                    path,
                    column_splits: splits,
                    ..GpuOptions::default()
                };
                let t = Instant::now();
                let mut g = match WgpuGather::on_adapter(&matrix, &adapter, &options) {
                    Ok(g) => g,
                    Err(e) => {
                        println!("{format} {path}: {e}");
                        continue;
                    }
                };
                let setup = t.elapsed();
                let mut times = Vec::new();
                let mut kernel = Vec::new();
                for _ in 0..21 {
                    let t = Instant::now();
                    g.gather(&x, &mut y).expect("gather");
                    times.push(t.elapsed().as_secs_f64());
                    kernel.extend(g.kernel_ms());
                }
                times.sort_by(f64::total_cmp);
                kernel.sort_by(f64::total_cmp);
                let median = times[times.len() / 2];
                let splits = splits.map_or("auto".to_owned(), |s| s.to_string());
                print!(
                    "{format} {path} splits={splits}: frame {:.3} ms (min {:.3}), {:.1} GB/s of {:.1} MB",
                    median * 1e3,
                    times[0] * 1e3,
                    moved / median / 1e9,
                    moved / 1e6,
                );
                if let Some(&k) = kernel.get(kernel.len() / 2) {
                    print!(
                        "; kernels {k:.3} ms (min {:.3}), {:.1} GB/s",
                        kernel[0],
                        moved / (k * 1e-3) / 1e9
                    );
                }
                println!(
                    "; {} dispatches, setup {:.0} ms",
                    g.dispatches(),
                    setup.as_secs_f64() * 1e3
                );
            }
        }
    }
}
