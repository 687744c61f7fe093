//! Criterion benches live in `benches/benches/`; this library holds their shared inputs.
