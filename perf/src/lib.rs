//! What `radiosity bench`, `radiosity report` and the criterion benches (`benches/`) measure
//! with: the peer baselines a gather is compared against (each a [`radiosity_core::Gather`]),
//! this machine's roofline (memory bandwidth and multiply-add rate) and the timing helpers
//! (medians, interleaved rounds); the charts `radiosity report` draws ([`plots`]); the bench
//! ([`bench`](mod@bench)) and the report ([`report`]) themselves, each returning what it
//! measured for a front end to show; and the choice of a gather backend at run time
//! ([`backend`]), which every program that lights a file makes.

pub mod backend;
pub mod bench;
pub mod peers;
pub mod plots;
mod progress;
pub mod report;
pub mod roofline;
pub mod timing;

pub use progress::Progress;
