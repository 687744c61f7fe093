//! The `std` side of the core's systems ([`radiosity_core::systems`]): the coupling product
//! spread over threads.

use radiosity_core::Rgb;
use radiosity_core::systems::Coupling;
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
