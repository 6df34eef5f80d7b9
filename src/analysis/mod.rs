//! Observables computed from the geometry layer.

pub mod order;
pub mod virial;
