//! Observables computed from the geometry layer.

pub mod virial;
