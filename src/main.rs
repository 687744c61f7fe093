//! The `radiosity` command line (DESIGN.md, "Command line").
fn main() {}
