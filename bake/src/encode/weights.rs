//! Error weights: how much each entry's error matters ([`ErrorWeights`]), the encoder's
//! objective for the scene's own emitters and for lights added at run time.

use super::EncodeError;
use radiosity_core::Rgb;

/// How much each entry's error matters: the encoder's objective.
///
/// The runtime computes `y = M·x`, with `x = s·E + r`: the scene's own emitters `E` (scaled by
/// one factor at run time) plus light added at run time `r`. Model `r` as independent per
/// patch and channel with mean 0 and variance σ². The expected squared error of `y` is then
/// `σ²·Σ_ij ΔM_ij² + Σ_i (Σ_j ΔM_ij·E_j)²` per channel (with `s = 1`). [`ErrorWeights::for_emitters`]
/// takes σ² = the mean of `E_j²` over patches and channels, so the scene's own lighting and
/// lighting added later get equal total weight: a bake is judged both by its own emitters (the
/// report's `lighting_error`) and by runtime lights (the Frobenius norm). Without emitters
/// ([`ErrorWeights::uniform`]) the objective is the Frobenius norm.
///
/// The second term couples all entries of a row. Block fits and the sparse selection use its
/// diagonal, per-entry weights `σ² + E_j²` ([`ErrorWeights::weight`]), which would be exact if
/// the entries' errors were independent. They are not: a row sees all patches of a small light
/// almost alike, so their code errors come out alike and add up (measured on the Cornell box,
/// `‖ΔM·E‖²` was 3× its diagonal part). A last pass over the blocks of the emitting columns
/// therefore encodes each block row left to right with the exact objective, each block leaning
/// against the row errors of those before it (`refine::Coupling`): error diffusion. With one
/// scale factor for all emitters at run time, the cancellation holds for any `s`.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorWeights {
    /// Per column, the scene's own exitance per channel in units of σ (`E_j / σ`); empty when
    /// nothing emits (uniform weights).
    emission: Vec<[f32; 3]>,
}

impl ErrorWeights {
    /// Every entry alike: the Frobenius norm.
    pub fn uniform() -> Self {
        Self {
            emission: Vec::new(),
        }
    }

    /// The weights for a scene whose patches (matrix numbering) emit `emission`, with σ² =
    /// the mean of `E_j²` over patches and channels (see the type's doc); uniform when nothing
    /// emits.
    pub fn for_emitters(emission: &[Rgb]) -> Self {
        let n = emission.len();
        let sigma2 = emission
            .iter()
            .map(|e| (0..3).map(|k| f64::from(e.channel(k)).powi(2)).sum::<f64>())
            .sum::<f64>()
            / (3 * n.max(1)) as f64;
        if !(sigma2 > 0.0 && sigma2.is_finite()) {
            return Self::uniform();
        }
        let sigma = sigma2.sqrt();
        Self {
            emission: emission
                .iter()
                .map(|e| core::array::from_fn(|k| (f64::from(e.channel(k)) / sigma) as f32))
                .collect(),
        }
    }

    /// Whether any column carries emission (the coupled pass then has work).
    pub(crate) fn has_emitters(&self) -> bool {
        self.emission.iter().any(|e| *e != [0.0; 3])
    }

    /// `E_j / σ` of column `col` (zero when uniform).
    #[inline]
    pub(super) fn emission(&self, col: usize) -> [f32; 3] {
        self.emission.get(col).copied().unwrap_or([0.0; 3])
    }

    /// Whether any of the four columns of column block `bc` (of `n`) emits: the blocks the
    /// coupled pass encodes along their rows.
    pub(super) fn emits_in_column_block(&self, bc: usize, n: usize) -> bool {
        (bc * 4..(bc * 4 + 4).min(n)).any(|c| self.emission(c) != [0.0; 3])
    }

    /// The diagonal weight of column `col`, matrix channel `ch`, in units of σ²: `1 + (E/σ)²`
    /// for a three-channel matrix; a grey matrix's entry multiplies all three exitance
    /// channels, so `3 + Σ_k (E_k/σ)²`. 1 everywhere for [`ErrorWeights::uniform`].
    #[inline]
    pub fn weight(&self, col: usize, ch: usize, channels: usize) -> f32 {
        if self.emission.is_empty() {
            return 1.0;
        }
        let e = self.emission(col);
        if channels == 1 {
            3.0 + e.iter().map(|v| v * v).sum::<f32>()
        } else {
            1.0 + e[ch] * e[ch]
        }
    }

    pub(super) fn check(&self, n: usize) -> Result<(), EncodeError> {
        if !self.emission.is_empty() && self.emission.len() != n {
            return Err(EncodeError::Params(
                "error weights need one emission per column",
            ));
        }
        if self
            .emission
            .iter()
            .flatten()
            .any(|w| !(w.is_finite() && *w >= 0.0))
        {
            return Err(EncodeError::Params(
                "error weights must be finite and non-negative",
            ));
        }
        Ok(())
    }
}
