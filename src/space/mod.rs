//! Space: the periodic simulation box (cell and neighbour lists will live
//! here too). Depends on nothing but nalgebra.

pub mod periodic_box;

pub use periodic_box::PeriodicBox;
