//! Observables computed from the geometry layer, and the statistics of
//! the series a run logs.

pub mod averages;
pub mod order;
pub mod series;
pub mod virial;
