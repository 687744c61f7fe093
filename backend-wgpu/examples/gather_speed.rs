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

use radiosity_backend_wgpu::{
    Adapter, DecodePath, GpuError, GpuOptions, WgpuGather, choose_adapter,
};
use radiosity_core::{
    BlockCorrections, DEFAULT_MAX_TILE, Format, Gather, LogScale, MatrixLayout, Rgb, SparseRows,
    TransferMatrix,
};
use std::borrow::Cow;
use std::time::{Duration, Instant};

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
        let matrix = random_matrix(n, format, &mut next);
        for path in [DecodePath::Software, DecodePath::HardwareBc] {
            for &splits in &splits {
                let options = GpuOptions {
                    path,
                    column_splits: splits,
                    ..GpuOptions::default()
                };
                let splits = splits.map_or("auto".to_owned(), |s| s.to_string());
                match time_gather(&matrix, &adapter, &options) {
                    Ok(timing) => timing.print(&format!("{format} {path} splits={splits}")),
                    Err(e) => println!("{format} {path}: {e}"),
                }
            }
        }
    }
}

/// An `n`-patch, three-channel matrix of `format` whose blocks are the bytes of `next()`
/// (valid whatever they are: log codes through one scale per tile) and without a sparse part.
fn random_matrix(
    n: u32,
    format: Format,
    next: &mut impl FnMut() -> u64,
) -> TransferMatrix<'static> {
    let layout = MatrixLayout::new(n, 3, format, DEFAULT_MAX_TILE).expect("layout");
    let mut blocks = vec![0u8; layout.block_bytes() as usize];
    for chunk in blocks.chunks_mut(8) {
        chunk.copy_from_slice(&next().to_le_bytes()[..chunk.len()]);
    }
    TransferMatrix {
        layout,
        scales: Cow::Owned(vec![LogScale::new(1e-3, 6.9); layout.scale_count()]),
        blocks: Cow::Owned(blocks),
        sparse: SparseRows::empty(n as usize),
        corrections: BlockCorrections::empty(n as usize),
    }
}

/// One gather's figures over 21 frames, each list sorted.
struct Timing {
    /// Seconds per frame (upload of x, dispatches, readback of y).
    frames: Vec<f64>,
    /// Milliseconds of the kernels alone per frame (none without timestamps).
    kernels: Vec<f64>,
    /// Bytes a frame must move: the matrix, `x` and `y`.
    moved: f64,
    dispatches: usize,
    /// Building the gather (uploads, pipelines, the first gather).
    setup: Duration,
}

/// Builds a gather of `matrix` on `adapter` under `options` and times 21 frames.
fn time_gather(
    matrix: &TransferMatrix<'_>,
    adapter: &Adapter,
    options: &GpuOptions,
) -> Result<Timing, GpuError> {
    let n = matrix.layout.n();
    let x: Vec<Rgb> = (0..n).map(|i| Rgb::splat((i % 7) as f32)).collect();
    let mut y = vec![Rgb::ZERO; n];
    let t = Instant::now();
    let mut g = WgpuGather::on_adapter(matrix, adapter, options)?;
    let setup = t.elapsed();
    let mut frames = Vec::new();
    let mut kernels = Vec::new();
    for _ in 0..21 {
        let t = Instant::now();
        g.gather(&x, &mut y).expect("gather");
        frames.push(t.elapsed().as_secs_f64());
        kernels.extend(g.kernel_ms());
    }
    frames.sort_by(f64::total_cmp);
    kernels.sort_by(f64::total_cmp);
    Ok(Timing {
        frames,
        kernels,
        moved: matrix.bytes() as f64 + 24.0 * n as f64,
        dispatches: g.dispatches(),
        setup,
    })
}

impl Timing {
    /// One line: the median and fastest frame and kernels, and the bandwidth each implies.
    fn print(&self, what: &str) {
        let (times, moved) = (&self.frames, self.moved);
        let median = times[times.len() / 2];
        print!(
            "{what}: frame {:.3} ms (min {:.3}), {:.1} GB/s of {:.1} MB",
            median * 1e3,
            times[0] * 1e3,
            moved / median / 1e9,
            moved / 1e6,
        );
        if let Some(&k) = self.kernels.get(self.kernels.len() / 2) {
            print!(
                "; kernels {k:.3} ms (min {:.3}), {:.1} GB/s",
                self.kernels[0],
                moved / (k * 1e-3) / 1e9
            );
        }
        println!(
            "; {} dispatches, setup {:.0} ms",
            self.dispatches,
            self.setup.as_secs_f64() * 1e3
        );
    }
}
