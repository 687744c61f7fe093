//! Rows given to the discretisation from outside: a plan's shards ([`crate::plan`]) computed
//! every patch's burial survey and ray-cast hit counts, which the discretisation then takes in
//! place of its own.

use crate::BakeError;
use crate::form_factor::FormFactors;
use crate::form_factor::cast::{HitCounts, pool};
use crate::form_factor::matrix::{Exchange, sparse_exchange};
use crate::geometry::Occluders;
use crate::patch::Patches;

/// The burial surveys and hit counts of every patch, as the shards computed them: what
/// [`discretise`](super::discretise) takes in place of its own.
pub struct GivenRows {
    pub(crate) burial: Vec<Vec<u32>>,
    pub(crate) counts: Vec<HitCounts>,
    pub(crate) rays: u32,
}

impl GivenRows {
    /// The surveys and the pooled form factors of `patches`.
    #[allow(clippy::type_complexity)]
    pub(crate) fn exchange(
        self,
        patches: &Patches,
        occ: &Occluders,
    ) -> Result<(Vec<Vec<u32>>, (Exchange, FormFactors)), BakeError> {
        if self.counts.len() != patches.len() || self.burial.len() != patches.len() {
            return Err(BakeError::InvalidParams(format!(
                "the shards hold rows of {} patches, the scene under the plan has {}: they were made from another scene",
                self.counts.len(),
                patches.len()
            )));
        }
        let cover = crate::form_factor::coverage(patches, Some(occ));
        let s = pool(patches, &self.counts, self.rays, cover.as_deref());
        Ok((self.burial, sparse_exchange(s, patches)))
    }
}
