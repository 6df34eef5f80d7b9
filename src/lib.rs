//! hardbody: dense packings and dynamics of hard ellipsoids,
//! superellipsoids, cuboids and spheres.
//!
//! Layers, bottom to top: [`geometry`] (shapes, overlap, distance), [`space`]
//! (the periodic box), [`analysis`] (observables built on the geometry), and
//! the command line at the edge (`src/main.rs`).
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod geometry;
pub mod mc;
pub mod space;
