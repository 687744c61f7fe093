//! Criterion benches live in `benches/benches/`; this library holds what they share with
//! `radiosity bench`: the peer baselines (each a [`radiosity_core::Gather`]), the roofline
//! measurement and the timing helpers.

pub mod peers;
pub mod roofline;
pub mod timing;
