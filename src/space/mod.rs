//! Space: the periodic simulation box and cell lists. Depends on nothing but
//! nalgebra.

pub mod aabb_cells;
pub mod cell_list;
pub mod periodic_box;

pub use aabb_cells::AabbCells;
pub use cell_list::CellList;
pub use periodic_box::PeriodicBox;
