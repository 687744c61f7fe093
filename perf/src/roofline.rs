//! This machine's two roofs, measured: memory bandwidth (a multi-threaded streaming read of a
//! buffer much larger than the caches) and multiply-add rate (independent FMA chains on every
//! rayon thread, 512-bit where the CPU has AVX-512F — as the BC1 gather then uses — else
//! 256-bit). A method's time bound is the larger of bytes ÷ bandwidth and
//! multiply-adds ÷ rate; its distance from the roofline is measured time ÷ bound.

use crate::peers::Cost;
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Instant;
use wide::f32x8;

/// The measured roofs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roofline {
    /// Streaming read bandwidth, bytes per second (best of the repetitions).
    pub bandwidth: f64,
    /// f32 multiply-adds per second over all threads (best of the repetitions).
    pub fma_rate: f64,
    /// What the FMA loop ran on: `"avx512f"` (512-bit FMA, the widest the gather kernels use),
    /// `"avx2+fma"` (256-bit) or `"baseline"` (`wide` as built: a separate multiply and add on
    /// SSE2).
    pub fma_path: &'static str,
    /// Size of the bandwidth buffer in bytes.
    pub buffer_bytes: usize,
    /// Threads used.
    pub threads: usize,
}

/// A method's roofline bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    /// Seconds the cost needs at best: the slower of moving its bytes and doing its FMAs.
    pub seconds: f64,
    /// The read bandwidth of a working set of the cost's size, bytes per second.
    pub bandwidth: f64,
    /// Which roof binds: `"memory"` or `"compute"`.
    pub limit: &'static str,
}

impl Roofline {
    /// Measures both roofs with a buffer of `buffer_bytes` (use several times the last-level
    /// cache; 256 MiB is 8× a 32 MiB L3) and `reps` repetitions of each measurement.
    pub fn measure(buffer_bytes: usize, reps: usize) -> Self {
        let (fma_rate, fma_path) = fma_rate(reps);
        Self {
            bandwidth: read_bandwidth(buffer_bytes, reps),
            fma_rate,
            fma_path,
            buffer_bytes,
            threads: rayon::current_num_threads(),
        }
    }

    /// The bound of a call that costs `cost` and is repeated (as a per-frame gather is): its
    /// bytes come from wherever a working set of that size lives between calls, so the memory
    /// roof is the streaming-read bandwidth measured on a buffer of `cost.bytes` (a cache
    /// level when it fits, never less than the large-buffer bandwidth). Measures, so it takes
    /// a few milliseconds.
    pub fn bound(&self, cost: Cost) -> Bound {
        let bytes = cost.bytes as usize;
        let bandwidth = if bytes >= self.buffer_bytes {
            self.bandwidth
        } else {
            read_bandwidth(bytes, 3).max(self.bandwidth)
        };
        self.bound_with(cost, bandwidth)
    }

    /// The bound of `cost` at a given memory bandwidth.
    pub fn bound_with(&self, cost: Cost, bandwidth: f64) -> Bound {
        let memory = cost.bytes as f64 / bandwidth;
        let compute = cost.fmas_f32 as f64 / self.fma_rate;
        Bound {
            seconds: memory.max(compute),
            bandwidth,
            limit: if memory >= compute {
                "memory"
            } else {
                "compute"
            },
        }
    }
}

/// Best streaming-read bandwidth over `reps` passes, bytes per second: every rayon thread sums
/// its share of a buffer of `bytes` (first written, so its pages exist) with four independent
/// `f32x8` accumulators. A small buffer is read several times per pass (each thread its own
/// share again, as repeated gathers do) so that a pass lasts long enough to time.
pub fn read_bandwidth(bytes: usize, reps: usize) -> f64 {
    let lanes = (bytes / 32).max(1);
    let repeat = ((64 << 20) / (lanes * 32)).max(1);
    let buf: Vec<f32x8> = (0..lanes)
        .into_par_iter()
        .map(|i| f32x8::splat((i % 7) as f32))
        .collect();
    let threads = rayon::current_num_threads().max(1);
    let chunk = lanes.div_ceil(threads * 4).max(1);
    let mut best = 0f64;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let s: f32 = buf
            .par_chunks(chunk)
            .map(|c| {
                let mut acc = [f32x8::ZERO; 4];
                let (quads, rest) = c.split_at(c.len() / 4 * 4);
                for _ in 0..repeat {
                    for q in quads.chunks_exact(4) {
                        for k in 0..4 {
                            acc[k] += q[k];
                        }
                    }
                    for v in rest {
                        acc[0] += *v;
                    }
                    acc = black_box(acc);
                }
                (acc[0] + acc[1] + acc[2] + acc[3]).reduce_add()
            })
            .sum();
        let dt = t.elapsed().as_secs_f64();
        black_box(s);
        best = best.max((lanes * 32 * repeat) as f64 / dt);
    }
    best
}

/// Chains per step of each kernel: 10 independent 8- or 16-lane chains (enough to cover a
/// 4-cycle FMA latency on two FMA ports).
const CHAINS: usize = 10;
const STEPS: usize = 1 << 22;

/// Best f32 multiply-add rate over `reps` runs on every rayon thread, and the path used.
pub fn fma_rate(reps: usize) -> (f64, &'static str) {
    let threads = rayon::current_num_threads().max(1);
    let (path, lanes) = if avx512_available() {
        ("avx512f", 16)
    } else if avx2_fma_available() {
        ("avx2+fma", 8)
    } else {
        ("baseline", 8)
    };
    let mut best = 0f64;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let s: f32 = (0..threads)
            .into_par_iter()
            .map(|i| fma_chains(STEPS, 1.0 + i as f32 * 1e-3))
            .sum();
        let dt = t.elapsed().as_secs_f64();
        black_box(s);
        best = best.max((threads * STEPS * CHAINS * lanes) as f64 / dt);
    }
    (best, path)
}

fn avx512_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn avx2_fma_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `steps` rounds of `CHAINS` independent `a = a·m + c` over 8 lanes (16 with AVX-512F);
/// returns a sum so the work cannot be dropped.
fn fma_chains(steps: usize, seed: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if avx512_available() {
        // SAFETY: the CPU has AVX-512F (checked just above), all that the function enables.
        return unsafe { fma_chains_avx512(steps, seed) };
    }
    #[cfg(target_arch = "x86_64")]
    if avx2_fma_available() {
        // SAFETY: the CPU has AVX2 and FMA (checked just above), all that the function enables.
        return unsafe { fma_chains_avx2(steps, seed) };
    }
    // The baseline: whatever `wide` compiles `mul_add` to on this target.
    let m = f32x8::splat(0.999_999);
    let c = f32x8::splat(1e-7);
    let mut acc = [f32x8::splat(seed); CHAINS];
    for _ in 0..steps {
        for a in acc.iter_mut() {
            *a = a.mul_add(m, c);
        }
        black_box(&mut acc);
    }
    acc.iter().map(|a| a.reduce_add()).sum()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn fma_chains_avx2(steps: usize, seed: f32) -> f32 {
    use std::arch::x86_64::*;
    let m = _mm256_set1_ps(0.999_999);
    let c = _mm256_set1_ps(1e-7);
    let mut acc = [_mm256_set1_ps(seed); CHAINS];
    for _ in 0..steps {
        for a in acc.iter_mut() {
            *a = _mm256_fmadd_ps(*a, m, c);
        }
    }
    let mut out = [0f32; 8];
    let mut sum = _mm256_setzero_ps();
    for a in acc {
        sum = _mm256_add_ps(sum, a);
    }
    // SAFETY: `out` holds 8 f32, the 32 bytes the unaligned store writes.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), sum) };
    out.iter().sum()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn fma_chains_avx512(steps: usize, seed: f32) -> f32 {
    use std::arch::x86_64::*;
    let m = _mm512_set1_ps(0.999_999);
    let c = _mm512_set1_ps(1e-7);
    let mut acc = [_mm512_set1_ps(seed); CHAINS];
    for _ in 0..steps {
        for a in acc.iter_mut() {
            *a = _mm512_fmadd_ps(*a, m, c);
        }
    }
    let mut sum = _mm512_setzero_ps();
    for a in acc {
        sum = _mm512_add_ps(sum, a);
    }
    _mm512_reduce_add_ps(sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roofs are finite and physically plausible: any machine this runs on reads more than
    /// 100 MB/s and does more than 10 M multiply-adds per second (even in a debug build), and
    /// none reads 10 TB/s or multiplies 100 T/s: a broken timer or a loop the compiler dropped
    /// would land outside. (8 MiB fits a large L3, so this is not the DRAM bandwidth.)
    #[test]
    fn roofs_are_plausible() {
        let r = Roofline::measure(8 << 20, 2);
        assert!(
            r.bandwidth > 1e8 && r.bandwidth < 1e13,
            "bandwidth {:e} B/s",
            r.bandwidth
        );
        assert!(
            r.fma_rate > 1e7 && r.fma_rate < 1e14,
            "FMA rate {:e}/s",
            r.fma_rate
        );
        // A gigabyte is beyond any cache: the large-buffer bandwidth binds.
        let cost = Cost {
            bytes: 1 << 30,
            fmas_f32: 1,
        };
        let b = r.bound(cost);
        assert_eq!(b.limit, "memory");
        assert_eq!(b.bandwidth, r.bandwidth);
        let t = (1u64 << 30) as f64 / r.bandwidth;
        assert!((b.seconds - t).abs() < 1e-12 * t, "{} vs {t}", b.seconds);
        // A kilobyte of data and a billion FMAs: compute binds, and a small working set reads
        // at least as fast as the large buffer.
        let b = r.bound(Cost {
            bytes: 1 << 10,
            fmas_f32: 1 << 30,
        });
        assert_eq!(b.limit, "compute");
        assert!(b.bandwidth >= r.bandwidth);
        let t = (1u64 << 30) as f64 / r.fma_rate;
        assert!((b.seconds - t).abs() < 1e-12 * t, "{} vs {t}", b.seconds);
    }
}
