//! The `std` side of the core's systems ([`radiosity_core::systems`]): the coupling product
//! spread over threads, and [`Level`]: a level file's systems built into gathers and lit to
//! the steady state.

use radiosity_core::systems::{Coupling, Systems, SystemsError};
use radiosity_core::{Gather, GatherError, RadFile, Rgb};
use rayon::prelude::*;
use std::ops::Range;

/// [`Coupling::incoming`] over rayon's threads, in chunks of 256 rows: the same sums in the
/// same order per row, so the same values bit for bit. For
/// [`radiosity_core::systems::Systems::set_incoming`].
pub fn parallel_incoming(c: &Coupling<'_>, rows: Range<usize>, exitance: &[Rgb], out: &mut [Rgb]) {
    const CHUNK: usize = 256;
    assert_eq!(out.len(), rows.len(), "one output a row");
    out.par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(k, chunk)| {
            let start = rows.start + k * CHUNK;
            c.incoming(start..start + chunk.len(), exitance, chunk);
        });
}

/// Why [`Level::new`] could not light a level file.
#[derive(Debug)]
pub enum LevelError<E> {
    /// The file is a one-matrix `.rad` file, not a level (no SYSTEMS section).
    NotALevel,
    /// The file is a level's head only: its systems' files are not loaded.
    NotLoaded,
    /// System `s`'s own file could not be parsed or does not belong to the level.
    System(usize, radiosity_core::RadError),
    /// The constructor refused system `s`'s gather.
    Gather(usize, E),
    /// The gathers, the coupling or the reflectance do not fit the level.
    Systems(SystemsError),
}

impl<E: std::fmt::Display> std::fmt::Display for LevelError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LevelError::NotALevel => {
                f.write_str("this .rad file has no systems (a one-matrix file, not a level)")
            }
            LevelError::NotLoaded => {
                f.write_str("only the level's head is loaded, not its systems' files")
            }
            LevelError::System(s, e) => write!(f, "system {s} of the level: {e}"),
            LevelError::Gather(s, e) => write!(f, "system {s}'s gather: {e}"),
            LevelError::Systems(e) => write!(f, "level: {e}"),
        }
    }
}

impl<E: std::fmt::Debug + std::fmt::Display> std::error::Error for LevelError<E> {}

/// A level file (`.rad` version 3, its transfer split into systems) ready to light: one
/// gather per system, built by the caller from that system's own `.rad` file, lit block by
/// block through the core's [`Systems`] (block Gauss–Seidel over the systems with the
/// coupling between them). The patches are the level's, in the level's numbering.
pub struct Level<G> {
    systems: Systems<G>,
    name: String,
    reflectance: Vec<Rgb>,
    frames: usize,
    change: f32,
}

impl<G: Gather> Level<G> {
    /// The level of `file`: `make(s, system_file)` builds system `s`'s gather from its own
    /// one-system `.rad` file (patches: the level's [`LevelSystems::range`]`(s)`, in order);
    /// the reflectance is the level's patches'. The coupling product runs over rayon's
    /// threads ([`parallel_incoming`]). No light yet.
    ///
    /// [`LevelSystems::range`]: radiosity_core::container::LevelSystems::range
    pub fn new<E>(
        file: &RadFile<'_>,
        mut make: impl FnMut(usize, &RadFile<'_>) -> Result<G, E>,
    ) -> Result<Self, LevelError<E>> {
        let sys = file.systems.as_ref().ok_or(LevelError::NotALevel)?;
        if !sys.is_loaded() {
            return Err(LevelError::NotLoaded);
        }
        if sys.n() != file.n() {
            return Err(LevelError::Systems(SystemsError::Ranges));
        }
        let mut gathers = Vec::with_capacity(sys.count());
        for s in 0..sys.count() {
            let one = sys.system(file, s).map_err(|e| LevelError::System(s, e))?;
            gathers.push(make(s, &one).map_err(|e| LevelError::Gather(s, e))?);
        }
        let reflectance: Vec<Rgb> = file.patches.iter().map(|p| p.reflectance).collect();
        let name = format!("{}-systems", gathers.first().map_or("", |g: &G| g.name()));
        let mut systems = Systems::new(
            gathers,
            sys.ranges(),
            sys.coupling.clone().into_owned(),
            reflectance.clone(),
        )
        .map_err(LevelError::Systems)?;
        systems.set_incoming(parallel_incoming);
        Ok(Self {
            systems,
            name,
            reflectance,
            frames: 0,
            change: f32::INFINITY,
        })
    }

    /// Lights the level for the first exitance `first` (`E + ρ∘H_d` per patch, the input a
    /// one-matrix gather takes) until the relative change of the exitance in a frame
    /// (`Σ|ΔB| / Σ|B|` over patches and channels, every system updated once) is at most
    /// `tolerance`, or `max_frames` frames. Returns the frames taken; [`Self::change`] is the
    /// last frame's relative change (not below `tolerance` when `max_frames` ran out). A
    /// `tolerance` that is negative or NaN is never met: `max_frames` frames.
    pub fn steady(
        &mut self,
        first: &[Rgb],
        tolerance: f32,
        max_frames: usize,
    ) -> Result<usize, GatherError> {
        let mut frames = 0;
        while frames < max_frames {
            let change = self.systems.frame(first)?;
            frames += 1;
            self.frames += 1;
            let total: f32 = first
                .iter()
                .zip(self.systems.gathered())
                .zip(&self.reflectance)
                .map(|((&x, &y), &rho)| {
                    let b = x + rho * y;
                    b.r.abs() + b.g.abs() + b.b.abs()
                })
                .sum();
            self.change = radiosity_core::systems::relative_change(change, total);
            if !change.is_finite() {
                let g = self.systems.gathered();
                let index = g
                    .iter()
                    .position(|v| !(v.r.is_finite() && v.g.is_finite() && v.b.is_finite()))
                    .unwrap_or(0);
                return Err(GatherError::NonFinite { index });
            }
            if self.change <= tolerance {
                break;
            }
        }
        Ok(frames)
    }

    /// The gathered irradiance `y` per patch of the level (as a one-matrix gather gives it:
    /// the total irradiance is `H_d + y`).
    pub fn gathered(&self) -> &[Rgb] {
        self.systems.gathered()
    }

    /// The relative change of the exitance in the last frame ([`Self::steady`]); infinite
    /// before any frame.
    pub fn change(&self) -> f32 {
        self.change
    }

    /// Frames lit since the level was built.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Systems of the level.
    pub fn count(&self) -> usize {
        self.systems.len()
    }

    /// Patches of the level.
    pub fn patches(&self) -> usize {
        self.reflectance.len()
    }

    /// The core's systems, for a frame under a budget ([`Systems::update_within`]) or a
    /// system's priority.
    pub fn systems_mut(&mut self) -> &mut Systems<G> {
        &mut self.systems
    }

    /// Patch `i` reflects `rho` from now on, in the light between systems and in the steady
    /// state's measure ([`Systems::set_reflectance`]; the system's own gather must carry the
    /// edit). `false` (nothing changed) for a patch past the level or a bad reflectance.
    pub fn set_reflectance(&mut self, i: usize, rho: Rgb) -> bool {
        let ok = self.systems.set_reflectance(i, rho);
        if ok {
            self.reflectance[i] = rho;
        }
        ok
    }

    /// The core's systems.
    pub fn systems(&self) -> &Systems<G> {
        &self.systems
    }
}

/// The relative change of the exitance [`Level::steady`] stops at when a level serves as a
/// [`Gather`]: `radiosity solve`'s tolerance.
pub const STEADY_TOLERANCE: f32 = 1e-4;
/// The most frames one [`Gather::gather`] of a level runs.
pub const STEADY_MAX_FRAMES: usize = 100;

/// A level is a gather: `gather(x, y)` lights it from the light it holds to the steady state
/// ([`STEADY_TOLERANCE`], at most [`STEADY_MAX_FRAMES`] frames; a few after the light
/// changes, one when nothing did), `y` the gathered irradiance, the one-matrix `M·x` within
/// that tolerance. So every user of a `Gather` (a frame of the runtime, `render`) lights a
/// level. Its name is the first system's gather's and `-systems` (`cpu-bc1-systems`).
impl<G: Gather> Gather for Level<G> {
    fn name(&self) -> &str {
        &self.name
    }

    fn patches(&self) -> usize {
        self.reflectance.len()
    }

    fn gather(&mut self, exitance: &[Rgb], irradiance: &mut [Rgb]) -> Result<(), GatherError> {
        radiosity_core::check_gather_args(self.reflectance.len(), exitance, irradiance)?;
        self.steady(exitance, STEADY_TOLERANCE, STEADY_MAX_FRAMES)?;
        irradiance.copy_from_slice(self.systems.gathered());
        Ok(())
    }
}
