//! Observables of a configuration (order parameters, the excluded volume
//! by sampling), the statistics of the series a run logs, and the
//! quadrature integrals over paths use. Built on the
//! geometry layer only, so both drivers can measure with it.

pub mod contact_gap;
pub mod eos;
pub mod order;
pub mod packing;
pub mod quadrature;
pub mod series;
pub mod structure;
pub mod virial;
