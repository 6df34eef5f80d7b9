//! Metropolis Monte Carlo of hard particles, on the configuration of
//! [`crate::state`]: trial moves and sweeps (`moves.rs`), box moves
//! (`box_moves.rs`), step-size tuning (`tuning.rs`), the parallel sweeps
//! (`parallel/`), compression (`compress.rs`), the scale-distribution
//! pressure (`sdf.rs`) and bodies on springs to lattice sites
//! (`einstein.rs`).
//!
//! A move is accepted iff it creates no overlap (hard-particle Metropolis);
//! volume moves in ln V carry the NPT weight. Overlap tests go through the
//! geometry layer's pair dispatch only.

pub mod box_moves;
pub mod compress;
pub mod einstein;
pub mod einstein_orientation;
pub mod moves;
pub mod parallel;
pub mod sdf;
pub mod tuning;
