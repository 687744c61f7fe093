//! How many patches a bake can take, checked before anything is loaded: the dense n × n
//! matrices the bake holds at its peak against the machine's physical memory, and a ceiling no
//! machine passes.

use anyhow::bail;

/// Largest patch target on any machine. A target is hit within +10%, and the matrix's n²
/// entries must stay countable in 32 bits (the sparse rows' offsets are `u32`): 1.1 · 58 000
/// = 63 800 patches, 4.07e9 entries < 2³².
pub(crate) const MAX_PATCHES: usize = 58_000;

/// How far over its target a bake may land (the simplification hits it within ±10%).
const OVERSHOOT: f64 = 1.1;

/// Bytes per matrix entry (per pair of patches) at the bake's peak, the transfer stage:
/// F as f64 (8, kept by the discretised system) and its faer copy (8), the f32 RGB output
/// (12), and per channel ρ-scaled F (8) with either the LU path's `I − G` (8), its factors
/// (8) and the solution (8), or the series path's sum, power and product work (3 × 8) and its
/// result (8). The series is the larger: 8 + 8 + 12 + 8 + 24 + 8 = 68. Later stages (order,
/// encode, measure: f32 RGB copies, 12 each) stay below it.
const PEAK_BYTES_PER_ENTRY: f64 = 68.0;

/// Estimated peak memory in bytes of a bake aimed at `patches` patches.
pub(crate) fn bake_peak_bytes(patches: usize) -> f64 {
    let n = patches as f64 * OVERSHOOT;
    PEAK_BYTES_PER_ENTRY * n * n
}

/// The largest patch target whose estimated peak fits in `memory` bytes (at most
/// [`MAX_PATCHES`]), rounded down to a hundred.
pub(crate) fn largest_fitting(memory: u64) -> usize {
    let n = (memory as f64 / PEAK_BYTES_PER_ENTRY).sqrt() / OVERSHOOT;
    ((n as usize) / 100 * 100).clamp(1, MAX_PATCHES)
}

/// The machine's physical memory in bytes (`MemTotal` of `/proc/meminfo`), where known.
pub(crate) fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line
        .trim_start_matches("MemTotal:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    kib.checked_mul(1024)
}

/// Why a patch target is above [`MAX_PATCHES`] (`None` when it is not).
pub(crate) fn above_ceiling(patches: usize) -> Option<String> {
    (patches > MAX_PATCHES).then(|| {
        format!(
            "more than any bake can hold: at most {MAX_PATCHES} (a bake of n patches stores n² matrix entries, counted in 32 bits)"
        )
    })
}

/// Refuses a patch target above [`MAX_PATCHES`].
pub(crate) fn check_ceiling(patches: usize) -> anyhow::Result<()> {
    match above_ceiling(patches) {
        Some(why) => bail!("--patches {patches} is {why}"),
        None => Ok(()),
    }
}

/// Refuses a patch target the bake cannot hold: above [`MAX_PATCHES`], or whose estimated
/// peak ([`bake_peak_bytes`]) exceeds `memory` bytes of physical memory (when known).
pub(crate) fn check_patches_in(patches: usize, memory: Option<u64>) -> anyhow::Result<()> {
    check_ceiling(patches)?;
    if let Some(memory) = memory {
        let peak = bake_peak_bytes(patches);
        if peak > memory as f64 {
            bail!(
                "--patches {patches} needs about {:.1} GB at the bake's peak (dense matrices of {PEAK_BYTES_PER_ENTRY} bytes per pair of up to {} patches), more than this machine's {:.1} GB of memory: at most {} patches fit",
                peak / 1e9,
                (patches as f64 * OVERSHOOT).round(),
                memory as f64 / 1e9,
                largest_fitting(memory)
            );
        }
    }
    Ok(())
}

/// [`check_patches_in`] this machine's physical memory.
pub(crate) fn check_patches(patches: usize) -> anyhow::Result<()> {
    check_patches_in(patches, physical_memory())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_grows_as_the_square_and_names_what_fits() {
        // 2048 patches: about 0.35 GB; 4096: four times that.
        let a = bake_peak_bytes(2048);
        assert!((0.3e9..0.4e9).contains(&a), "{a}");
        assert!((bake_peak_bytes(4096) / a - 4.0).abs() < 1e-9);
        let gb23 = 23_000_000_000;
        let fit = largest_fitting(gb23);
        assert!(bake_peak_bytes(fit) <= gb23 as f64);
        assert!(bake_peak_bytes(fit + 200) > gb23 as f64, "{fit}");
        check_patches_in(fit, Some(gb23)).unwrap();
        let err = check_patches_in(50_000, Some(gb23))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("--patches 50000") && err.contains(&format!("at most {fit} patches")),
            "{err}"
        );
        let err = check_patches_in(10_000_000, None).unwrap_err().to_string();
        assert!(err.contains("at most 58000"), "{err}");
        check_patches_in(50_000, None).unwrap();
    }

    #[test]
    fn reads_this_machines_memory() {
        if cfg!(target_os = "linux") {
            assert!(physical_memory().is_some_and(|m| m > 1 << 26));
        }
    }
}
