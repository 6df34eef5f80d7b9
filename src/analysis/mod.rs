//! Observables of a configuration (order parameters, the excluded volume
//! by sampling) and the statistics of the series a run logs. Built on the
//! geometry layer only, so both drivers can measure with it.

pub mod contact_gap;
pub mod eos;
pub mod order;
pub mod packing;
pub mod series;
pub mod structure;
pub mod virial;
