//! What `radiosity bench`, `radiosity report` and the criterion benches (`benches/`) measure
//! with: the peer baselines a gather is compared against (each a [`radiosity_core::Gather`]),
//! this machine's roofline (memory bandwidth and multiply-add rate) and the timing helpers
//! (medians, interleaved rounds); and the charts `radiosity report` draws ([`plots`]).

pub mod peers;
pub mod plots;
pub mod roofline;
pub mod timing;
