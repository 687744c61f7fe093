//! Systems: a level's patches cut into pieces, each with its own multi-bounce transfer, passing
//! light to each other through the rows of the form factors between them
//! (`docs/decisions/systems.md`).
//!
//! The patches are numbered so that each system's are one range. For system `s`, with the
//! level's first exitance `x = E + ρ∘H_d`, its own transfer `M_ss = (I − F_ss·C_s)⁻¹·F_ss` and
//! the others' exitance `B_t`, the irradiance the others give it is `g_s = Σ_{t≠s} F_st·B_t`
//! ([`Coupling`]), and exactly
//!
//! ```text
//! y_s = g_s + M_ss · (x_s + ρ_s ∘ g_s)
//! ```
//!
//! since `(I − F_ss·C_s)⁻¹ = I + M_ss·C_s`. [`Systems::update`] applies it to one system with
//! the exitance the others have now; updating the systems in turn is block Gauss–Seidel on
//! `I − F·C`, which converges to the one-matrix answer `y = M·x` whatever the cut (a regular
//! splitting of a non-singular M-matrix when every row of `F·C` sums below one).

use crate::{Gather, GatherError, Rgb};
use alloc::borrow::Cow;
use alloc::vec;
use alloc::vec::Vec;
use core::ops::Range;

/// The form factors from each patch to the patches of other systems, in compressed sparse
/// rows over the level's patches: `F_ij` for `i` and `j` in different systems.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Coupling<'a> {
    /// Row `i`'s entries are `row_ptr[i]..row_ptr[i + 1]` (`patches + 1` values).
    pub row_ptr: Cow<'a, [u32]>,
    /// Column of each entry: a patch of another system.
    pub cols: Cow<'a, [u32]>,
    /// `F_ij` of each entry.
    pub values: Cow<'a, [f32]>,
}

impl Coupling<'_> {
    /// Whether these rows fit a level whose systems are `ranges` (tiling `0..n` in order):
    /// `n + 1` increasing offsets from 0 to the entry count, a column and a finite
    /// non-negative value each entry, every column a patch of the level outside its row's
    /// own system.
    pub fn fits(&self, ranges: &[Range<usize>]) -> bool {
        let n = ranges.last().map_or(0, |r| r.end);
        let c = self;
        let rows_ok = c.row_ptr.len() == n + 1
            && c.row_ptr.first() == Some(&0)
            && c.row_ptr.windows(2).all(|w| w[0] <= w[1])
            && c.row_ptr[n] as usize == c.cols.len()
            && c.cols.len() == c.values.len()
            && c.values.iter().all(|v| v.is_finite() && *v >= 0.0);
        rows_ok
            && ranges.iter().all(|r| {
                let (a, b) = (c.row_ptr[r.start] as usize, c.row_ptr[r.end] as usize);
                c.cols[a..b]
                    .iter()
                    .all(|&j| (j as usize) < n && !r.contains(&(j as usize)))
            })
    }

    /// Entries.
    pub fn nnz(&self) -> usize {
        self.cols.len()
    }

    /// Copies every borrowed part.
    pub fn into_owned(self) -> Coupling<'static> {
        Coupling {
            row_ptr: Cow::Owned(self.row_ptr.into_owned()),
            cols: Cow::Owned(self.cols.into_owned()),
            values: Cow::Owned(self.values.into_owned()),
        }
    }

    /// `out[k] = Σ_j F_ij · exitance[j]` for the rows `i = rows.start + k`.
    ///
    /// # Panics
    /// If `rows` or a column lies outside the level, or `out` is not `rows.len()` long.
    pub fn incoming(&self, rows: Range<usize>, exitance: &[Rgb], out: &mut [Rgb]) {
        assert_eq!(out.len(), rows.len(), "one output a row");
        for (o, i) in out.iter_mut().zip(rows) {
            let r = self.row_ptr[i] as usize..self.row_ptr[i + 1] as usize;
            let mut acc = Rgb::ZERO;
            for (&j, &f) in self.cols[r.clone()].iter().zip(&self.values[r]) {
                acc += exitance[j as usize] * f;
            }
            *o = acc;
        }
    }
}

/// Why [`Systems::new`] refused its parts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SystemsError {
    /// The ranges do not tile `0..patches` in order, or a gather's size is not its range's.
    Ranges,
    /// The coupling's rows, columns or values do not fit the level, or a column lies in its
    /// row's own system.
    Coupling,
    /// Not one reflectance per patch.
    Reflectance,
}

impl core::fmt::Display for SystemsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            SystemsError::Ranges => {
                "system ranges do not tile the level or do not match their matrices"
            }
            SystemsError::Coupling => "coupling rows do not fit the level's systems",
            SystemsError::Reflectance => "not one reflectance per patch",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for SystemsError {}

/// How a level computes `g = F_cross · B` over some rows ([`Coupling::incoming`]'s
/// signature): the core's runs on one thread; a `std` caller may hand a parallel one to
/// [`Systems::set_incoming`] (`radiosity_runtime::systems::parallel_incoming`).
pub type Incoming = fn(&Coupling<'_>, Range<usize>, &[Rgb], &mut [Rgb]);

/// A level lit system by system: each system's gather, the coupling between them and the
/// light as it stands (exitance `B = x + ρ∘y` and gathered irradiance `y` per patch).
pub struct Systems<G> {
    gathers: Vec<G>,
    ranges: Vec<Range<usize>>,
    coupling: Coupling<'static>,
    reflectance: Vec<Rgb>,
    /// The first exitance the light was last updated with, per patch.
    first: Vec<Rgb>,
    gathered: Vec<Rgb>,
    exitance: Vec<Rgb>,
    /// `weights[s·S + t]`: `Σ F_ij` over `i` in `s`, `j` in `t`: how much of a change of
    /// `t`'s exitance reaches `s` ([`Self::update_within`]).
    weights: Vec<f32>,
    /// Each system's estimate of how far its light lags its inputs.
    need: Vec<f32>,
    /// Each system's weight in [`Self::update_within`]'s choice (1: as any other).
    priority: Vec<f32>,
    /// The coupling product.
    incoming: Incoming,
}

impl<G: Gather> Systems<G> {
    /// The level of `gathers` (system `s`'s transfer over the patches `ranges[s]`, which tile
    /// `0..n` in order), `coupling` between them and each patch's `reflectance`; no light yet.
    pub fn new(
        gathers: Vec<G>,
        ranges: Vec<Range<usize>>,
        coupling: Coupling<'static>,
        reflectance: Vec<Rgb>,
    ) -> Result<Self, SystemsError> {
        let n = ranges.last().map_or(0, |r| r.end);
        let tiled = ranges.first().is_none_or(|r| r.start == 0)
            && ranges.windows(2).all(|w| w[0].end == w[1].start)
            && ranges.iter().all(|r| r.start <= r.end)
            && gathers.len() == ranges.len()
            && gathers
                .iter()
                .zip(&ranges)
                .all(|(g, r)| g.patches() == r.len());
        if !tiled {
            return Err(SystemsError::Ranges);
        }
        if reflectance.len() != n {
            return Err(SystemsError::Reflectance);
        }
        if !coupling.fits(&ranges) {
            return Err(SystemsError::Coupling);
        }
        let system_of = |i: usize| ranges.partition_point(|r| r.end <= i);
        let c = &coupling;
        let count = ranges.len();
        let mut weights = vec![0.0f32; count * count];
        for (s, r) in ranges.iter().enumerate() {
            for i in r.clone() {
                let e = c.row_ptr[i] as usize..c.row_ptr[i + 1] as usize;
                for (&j, &f) in c.cols[e.clone()].iter().zip(&c.values[e]) {
                    weights[s * count + system_of(j as usize)] += f;
                }
            }
        }
        Ok(Self {
            gathers,
            ranges,
            coupling,
            reflectance,
            first: vec![Rgb::ZERO; n],
            gathered: vec![Rgb::ZERO; n],
            exitance: vec![Rgb::ZERO; n],
            weights,
            need: vec![0.0; count],
            priority: vec![1.0; count],
            incoming: |c, rows, b, out| c.incoming(rows, b, out),
        })
    }

    /// Computes the coupling product with `f` from now on (same values: each row's sum in
    /// the same order, only spread over threads).
    pub fn set_incoming(&mut self, f: Incoming) {
        self.incoming = f;
    }

    /// How much system `s` matters now (the camera is near it: more; far: less), as a
    /// factor of its need in [`Self::update_within`]'s choice; 0 leaves it until nothing else
    /// needs an update. Not finite or negative: refused, the weight kept.
    pub fn set_priority(&mut self, s: usize, weight: f32) -> bool {
        let ok = weight.is_finite() && weight >= 0.0;
        if ok {
            self.priority[s] = weight;
        }
        ok
    }

    /// Patch `i` reflects `rho` from now on (a reflectance edit at run time: the systems'
    /// own transfers must carry the same edit, `crate::EditedGather`). Refused (`false`, the
    /// reflectance kept) for a patch past the level or a reflectance not finite and ≥ 0.
    pub fn set_reflectance(&mut self, i: usize, rho: Rgb) -> bool {
        let ok = i < self.reflectance.len()
            && rho.is_finite()
            && rho.to_array().iter().all(|c| *c >= 0.0);
        if ok {
            self.reflectance[i] = rho;
        }
        ok
    }

    /// Each system's estimate of how far its light lags its inputs: the change of its first
    /// exitance and of the light reaching it from the others since its last update
    /// (`Σ |Δ|` over its patches and channels, the others' through the coupling's sums).
    pub fn need(&self) -> &[f32] {
        &self.need
    }

    /// Updates systems most in need first (need × priority, [`Self::set_priority`]) while
    /// `budget()` allows another and some system needs one: the frame under a time budget
    /// (`budget` asks the clock) or a count. A change of `first` is taken into every
    /// system's need before the first choice. Returns the systems updated, in order.
    pub fn update_within(
        &mut self,
        first: &[Rgb],
        budget: &mut dyn FnMut() -> bool,
    ) -> Result<Vec<usize>, GatherError> {
        self.check_first(first)?;
        for (s, r) in self.ranges.iter().enumerate() {
            for i in r.clone() {
                let d = first[i] - self.first[i];
                self.need[s] += d.r.abs() + d.g.abs() + d.b.abs();
            }
        }
        // Counted once: a system left waiting keeps its need, not the change again.
        self.first.copy_from_slice(first);
        let mut done = Vec::new();
        loop {
            let pick = (0..self.ranges.len())
                .filter(|&s| self.need[s] > 0.0)
                .max_by(|&a, &b| {
                    let key = |s: usize| (self.need[s] * self.priority[s], self.need[s]);
                    key(a)
                        .partial_cmp(&key(b))
                        .unwrap_or(core::cmp::Ordering::Equal)
                });
            let Some(s) = pick else { break };
            if !budget() {
                break;
            }
            self.update(s, first)?;
            done.push(s);
        }
        Ok(done)
    }

    /// Systems.
    pub fn len(&self) -> usize {
        self.ranges.len()
    }

    /// Whether the level has no system.
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// The patches of system `s`.
    pub fn range(&self, s: usize) -> Range<usize> {
        self.ranges[s].clone()
    }

    /// The gathered irradiance `y` per patch as it stands.
    pub fn gathered(&self) -> &[Rgb] {
        &self.gathered
    }

    /// Whether `first` has one entry per patch of the level.
    fn check_first(&self, first: &[Rgb]) -> Result<(), GatherError> {
        let n = self.first.len();
        if first.len() == n {
            Ok(())
        } else {
            Err(GatherError::Length {
                expected: n,
                exitance: first.len(),
                irradiance: n,
            })
        }
    }

    /// Updates system `s` for the first exitance `first` (the whole level's, `E + ρ∘H_d`)
    /// with the other systems' exitance as it stands: `y_s = g_s + M_ss·(x_s + ρ_s∘g_s)`.
    /// Returns how much the system's exitance changed, `Σ |ΔB|` over its patches and channels.
    pub fn update(&mut self, s: usize, first: &[Rgb]) -> Result<f32, GatherError> {
        self.check_first(first)?;
        let r = self.ranges[s].clone();
        self.first[r.clone()].copy_from_slice(&first[r.clone()]);
        let mut g = vec![Rgb::ZERO; r.len()];
        (self.incoming)(&self.coupling, r.clone(), &self.exitance, &mut g);
        let x: Vec<Rgb> = (0..r.len())
            .map(|k| first[r.start + k] + self.reflectance[r.start + k] * g[k])
            .collect();
        let mut y = vec![Rgb::ZERO; r.len()];
        self.gathers[s].gather(&x, &mut y)?;
        let mut change = 0.0;
        for k in 0..r.len() {
            let i = r.start + k;
            self.gathered[i] = g[k] + y[k];
            let b = first[i] + self.reflectance[i] * self.gathered[i];
            let d = b - self.exitance[i];
            change += d.r.abs() + d.g.abs() + d.b.abs();
            self.exitance[i] = b;
        }
        // The others now lag this change by the light it sends them (the coupling's sum
        // from this system to each, times its mean change a patch).
        let count = self.ranges.len();
        let mean = if r.is_empty() {
            0.0
        } else {
            change / r.len() as f32
        };
        for t in 0..count {
            if t != s {
                self.need[t] += self.weights[t * count + s] * mean;
            }
        }
        self.need[s] = 0.0;
        Ok(change)
    }

    /// Updates every system once, in order (block Gauss–Seidel: each sees the exitance the
    /// ones before it have just taken). Returns the total change of the exitance. Each
    /// system's need ([`Self::need`]) after it is what the ones after it changed.
    pub fn frame(&mut self, first: &[Rgb]) -> Result<f32, GatherError> {
        let mut change = 0.0;
        for s in 0..self.ranges.len() {
            change += self.update(s, first)?;
        }
        Ok(change)
    }
}

/// The relative change of a level's frame, `change / total` (`Σ|ΔB|` over `Σ|B|`, patches
/// and channels): 0 when nothing changed, infinite when something changed in a level with no
/// light. What `steady` loops compare with their tolerance.
pub fn relative_change(change: f32, total: f32) -> f32 {
    if change == 0.0 {
        0.0
    } else if total > 0.0 {
        change / total
    } else {
        f32::INFINITY
    }
}
