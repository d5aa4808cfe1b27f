//! The code of the tutorials in docs/, compiled, linted and run by the test suite:
//!
//! - [`route_a`] and [`route_b`] are the two complete filter crates of
//!   docs/adding-a-filter.md step 3 (Route A, an importance density for RB-PHD SLAM; Route B,
//!   a particle filter of one's own), each shown there whole; their tests build and step
//!   them in a planar world and in the radio world;
//! - every other ```` ```rust ```` block of docs/adding-a-filter.md and
//!   docs/adding-a-sensor-model.md shows an excerpt of a workspace file, named on the line
//!   `<!-- excerpt: PATH -->` before it.
//!
//! `tests/excerpts.rs` checks that each block's lines are in its file, in order (`// ...`
//! marks what a block leaves out), so that a page whose code no longer compiles, or no
//! longer is the code, fails `cargo test --workspace`.

pub mod route_a;
pub mod route_b;
