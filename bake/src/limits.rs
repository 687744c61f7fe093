//! How many patches a bake can take, checked before anything is loaded: the dense n × n
//! matrices the bake holds at its peak against the machine's physical memory, and a ceiling no
//! machine passes.

use crate::BakeError;
use crate::pipeline::SystemsChoice;
use crate::transfer::BounceSpec;

/// Largest patch target of a bake into one matrix on any machine. A target is hit within
/// +10%, and the matrix's n² entries must stay countable in 32 bits (the sparse rows' offsets
/// are `u32`): 1.1 · 58 000 = 63 800 patches, 4.07e9 entries < 2³².
pub const MAX_PATCHES: usize = 58_000;

/// Largest patch target of a level cut into systems (`--systems`): the level's patch indices
/// and its coupling's entry count stay within `u32` with room to spare; memory refuses far
/// sooner on most machines ([`level_peak_bytes`]).
pub const MAX_LEVEL_PATCHES: usize = 1 << 20;

/// Bytes per patch of a level at its peak, over its largest system's dense transfer: the
/// ray-cast rows' counts, their transpose and pooled rows, the f64 rows the burial and
/// closure correct, the f32 live rows they leave, the mesh and the coupling. MEASURED on the
/// city of `scripts/city.py` (`docs/decisions/systems.md`, about 600 entries a row at 4096
/// rays a patch): 2.56 GB peak RSS at 70 479 patches (36 kB a patch), 5.71 GB at 122 270
/// (47 kB: the coupling grows as more of the exchange crosses between more systems).
const LEVEL_BYTES_PER_PATCH: f64 = 48_000.0;

/// How far over its target a bake may land (the simplification hits it within ±10%).
const OVERSHOOT: f64 = 1.1;

/// Bytes per matrix entry (per pair of patches) at the bake's peak when the transfer solves all
/// bounces by LU (`--bounces auto` or `inf`), over the scene's own memory. Counted from the
/// code: the transfer's second channel holds F (8), `I − G` factored in place (8), the
/// solution (8) and the first channel's f32 plane (4), 28 in all, and auto's short series
/// (K ≤ 2) F, the f32 planes, `I + G` and `M` (8 each), 32; the form factors hold their f32
/// matrix and f64 upper triangle (12), the encode the f32 RGB matrix and its block scores
/// (16), the measure the matrix and its decoded copy (24). MEASURED peak RSS minus the
/// scene's 11 MB (`radiosity bake` of the Cornell box, 2-core x86 VM, `docs/figures.md`):
/// 30.4 bytes per entry at 4098 patches (510 MB; this estimate says 650 MB for `--patches
/// 4096`), the rest over the count being faer's and rayon's working memory.
const PEAK_BYTES_PER_ENTRY: f64 = 32.0;

/// Bytes per matrix entry at the peak of a bake with a finite `--bounces K`: the series sums
/// by doubling, F, the f32 planes, G, its power, the sum and their product (8 each) = 48.
const SERIES_PEAK_BYTES_PER_ENTRY: f64 = 48.0;

/// Bytes per matrix entry at the peak of a bake under `bounces`.
fn bytes_per_entry(bounces: BounceSpec) -> f64 {
    match bounces {
        BounceSpec::Fixed(k) if k > 2 => SERIES_PEAK_BYTES_PER_ENTRY,
        _ => PEAK_BYTES_PER_ENTRY,
    }
}

/// Estimated peak memory in bytes of a bake aimed at `patches` patches under `bounces`.
pub(crate) fn bake_peak_bytes(patches: usize, bounces: BounceSpec) -> f64 {
    let n = patches as f64 * OVERSHOOT;
    bytes_per_entry(bounces) * n * n
}

/// The largest patch target whose estimated peak fits in `memory` bytes (at most
/// [`MAX_PATCHES`]), rounded down to a hundred.
pub(crate) fn largest_fitting(memory: u64, bounces: BounceSpec) -> usize {
    let n = (memory as f64 / bytes_per_entry(bounces)).sqrt() / OVERSHOOT;
    ((n as usize) / 100 * 100).clamp(1, MAX_PATCHES)
}

/// The machine's physical memory in bytes (`MemTotal` of `/proc/meminfo`), where known.
pub fn physical_memory() -> Option<u64> {
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

/// Estimated peak memory in bytes of a level aimed at `patches` patches cut into systems as
/// `systems` says: its sparse form factors ([`LEVEL_BYTES_PER_PATCH`]) and the dense
/// transfer of its largest system (a tenth over the even share, as the cut lands).
pub(crate) fn level_peak_bytes(patches: usize, systems: usize, bounces: BounceSpec) -> f64 {
    let n = patches as f64 * OVERSHOOT;
    let largest = n / systems.max(1) as f64 * OVERSHOOT;
    LEVEL_BYTES_PER_PATCH * n + bytes_per_entry(bounces) * largest * largest
}

/// Why a patch target is above [`MAX_LEVEL_PATCHES`], the most any bake takes (`None` when it
/// is not).
pub fn above_ceiling(patches: usize) -> Option<String> {
    (patches > MAX_LEVEL_PATCHES).then(|| {
        format!(
            "more than any bake can hold: at most {MAX_LEVEL_PATCHES} (patch indices and coupling entries are counted in 32 bits)"
        )
    })
}

/// Refuses a patch target above [`MAX_LEVEL_PATCHES`].
pub(crate) fn check_ceiling(patches: usize) -> Result<(), BakeError> {
    match above_ceiling(patches) {
        Some(why) => Err(BakeError::Flag(format!("--patches {patches} is {why}"))),
        None => Ok(()),
    }
}

/// The memory a bake may take at its peak.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// The machine's physical memory, where known.
    Machine(Option<u64>),
    /// Bytes given by `--memory-budget`.
    Given(f64),
}

impl Budget {
    fn bytes(self) -> Option<f64> {
        match self {
            Budget::Machine(m) => m.map(|m| m as f64),
            Budget::Given(b) => Some(b),
        }
    }

    /// What the budget is, for a refusal.
    fn name(self) -> String {
        match self {
            Budget::Machine(m) => format!(
                "this machine's {:.1} GB of memory",
                m.unwrap_or(0) as f64 / 1e9
            ),
            Budget::Given(b) => format!("the --memory-budget of {:.1} GB", b / 1e9),
        }
    }
}

/// [`check_patches_in`] under `budget`: the machine's memory or `--memory-budget`.
pub fn check_patches_within(
    patches: usize,
    budget: Budget,
    bounces: BounceSpec,
    systems: SystemsChoice,
) -> Result<(), BakeError> {
    check_patches_named(patches, budget, bounces, systems)
}

/// Refuses a patch target the bake cannot hold: above [`MAX_LEVEL_PATCHES`], above
/// [`MAX_PATCHES`] for one matrix, or whose estimated peak ([`bake_peak_bytes`], or
/// [`level_peak_bytes`] where `systems` cuts the target into systems) exceeds `memory` bytes
/// of physical memory (when known).
pub(crate) fn check_patches_in(
    patches: usize,
    memory: Option<u64>,
    bounces: BounceSpec,
    systems: SystemsChoice,
) -> Result<(), BakeError> {
    check_patches_named(patches, Budget::Machine(memory), bounces, systems)
}

/// [`check_patches_in`] against `budget`, named in the refusal.
fn check_patches_named(
    patches: usize,
    budget: Budget,
    bounces: BounceSpec,
    systems: SystemsChoice,
) -> Result<(), BakeError> {
    let memory = budget.bytes();
    check_ceiling(patches)?;
    if let Some(count) = systems.count_for(patches) {
        let peak = level_peak_bytes(patches, count, bounces);
        return match memory {
            Some(memory) if peak > memory => Err(BakeError::Flag(format!(
                "--patches {patches} in {count} systems needs about {:.1} GB at the bake's peak (sparse form factors of {:.0} kB a patch and the largest system's dense transfer), more than {}: cut it into more systems or aim at fewer patches",
                peak / 1e9,
                LEVEL_BYTES_PER_PATCH / 1e3,
                budget.name(),
            ))),
            _ => Ok(()),
        };
    }
    if patches > MAX_PATCHES {
        return Err(BakeError::Flag(format!(
            "--patches {patches} is more than one matrix can hold: at most {MAX_PATCHES} (a bake of n patches stores n² matrix entries, counted in 32 bits); cut the level into systems with --systems auto"
        )));
    }
    if let Some(memory) = memory {
        let peak = bake_peak_bytes(patches, bounces);
        if peak > memory {
            return Err(BakeError::Flag(format!(
                "--patches {patches} needs about {:.1} GB at the bake's peak (dense matrices of {} bytes per pair of up to {} patches), more than {}: at most {} patches fit, or cut the level into systems with --systems N",
                peak / 1e9,
                bytes_per_entry(bounces),
                (patches as f64 * OVERSHOOT).round(),
                budget.name(),
                largest_fitting(memory as u64, bounces)
            )));
        }
    }
    Ok(())
}

/// [`check_patches_in`] this machine's physical memory.
pub fn check_patches(
    patches: usize,
    bounces: BounceSpec,
    systems: SystemsChoice,
) -> Result<(), BakeError> {
    check_patches_in(patches, physical_memory(), bounces, systems)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_estimate_grows_as_the_square_and_names_what_fits() {
        let auto = BounceSpec::default();
        // 2048 patches aimed at: up to 2253 in the matrix, 32 bytes each pair: 0.16 GB.
        let a = bake_peak_bytes(2048, auto);
        assert!((0.15e9..0.17e9).contains(&a), "{a}");
        assert!((bake_peak_bytes(4096, auto) / a - 4.0).abs() < 1e-9);
        // The doubling series holds more.
        assert!(bake_peak_bytes(2048, BounceSpec::Fixed(3)) > a * 1.4);
        assert_eq!(bake_peak_bytes(2048, BounceSpec::Fixed(2)), a);
        let gb23 = 23_000_000_000;
        let fit = largest_fitting(gb23, auto);
        assert!(bake_peak_bytes(fit, auto) <= gb23 as f64);
        assert!(bake_peak_bytes(fit + 200, auto) > gb23 as f64, "{fit}");
        // A 16384-patch bake fits a 23 GB machine (it did not at 68 bytes a pair).
        assert!(fit >= 16_384, "{fit}");
        let off = SystemsChoice::Off;
        check_patches_in(fit, Some(gb23), auto, off).unwrap();
        let err = check_patches_in(50_000, Some(gb23), auto, off)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("--patches 50000")
                && err.contains("needs about 96.8 GB")
                && err.contains(&format!("at most {fit} patches")),
            "{err}"
        );
        let series = largest_fitting(gb23, BounceSpec::Fixed(5));
        assert!(series < fit, "{series} vs {fit}");
        let err = check_patches_in(10_000_000, None, auto, off)
            .unwrap_err()
            .to_string();
        assert!(err.contains("at most 1048576"), "{err}");
        let err = check_patches_in(60_000, None, auto, off)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("at most 58000") && err.contains("--systems auto"),
            "{err}"
        );
        check_patches_in(50_000, None, auto, off).unwrap();
    }

    #[test]
    fn a_level_is_estimated_by_its_sparse_rows_and_largest_system() {
        let auto = BounceSpec::default();
        let gb8 = 8_000_000_000;
        // 65 536 patches in systems of 2048: 3.5 GB for the level, 0.2 GB for the largest
        // system's transfer; the same patches in one matrix would need 166 GB.
        let level = level_peak_bytes(65_536, 32, auto);
        assert!((3.0e9..4.5e9).contains(&level), "{level}");
        check_patches_in(65_536, Some(gb8), auto, SystemsChoice::Auto).unwrap();
        assert!(check_patches_in(65_536, Some(gb8), auto, SystemsChoice::Off).is_err());
        // Two systems of 32k patches each need a dense 36k² transfer: refused, with the cure.
        let err = check_patches_in(65_536, Some(gb8), auto, SystemsChoice::Count(2))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("in 2 systems") && err.contains("more systems"),
            "{err}"
        );
        // Below auto's threshold a target is one matrix, estimated as one.
        check_patches_in(4096, Some(gb8), auto, SystemsChoice::Auto).unwrap();
    }

    #[test]
    fn reads_this_machines_memory() {
        if cfg!(target_os = "linux") {
            assert!(physical_memory().is_some_and(|m| m > 1 << 26));
        }
    }
}
