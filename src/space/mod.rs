//! Space: the periodic simulation box, cell lists and neighbour lists.
//! Depends on nalgebra and, for the capsule lists, the geometry layer's
//! segment distance.

pub mod aabb_cells;
pub mod capsule_lists;
pub mod cell_list;
pub mod neighbour_list;
pub mod packed_cells;
pub mod periodic_box;
pub mod slots;
pub mod sphere_lists;

pub use aabb_cells::AabbCells;
pub use capsule_lists::CapsuleLists;
pub use cell_list::CellList;
pub use neighbour_list::NeighbourLists;
pub use packed_cells::PackedCells;
pub use periodic_box::PeriodicBox;
pub use sphere_lists::SphereLists;

use nalgebra::Vector3;

/// Cells per axis for cells at least `width` wide in a box of edges
/// `lengths`, holding `count` particles: as many as fit, but no more than
/// about four per particle (small bodies in a large box would otherwise ask
/// for billions of empty cells); wider cells stay correct, only slower.
pub(crate) fn cell_grid(lengths: &Vector3<f64>, width: f64, count: usize) -> [usize; 3] {
    let cap = (4 * count).max(64) as f64;
    let mut width = width;
    loop {
        let dims = [0, 1, 2].map(|k| ((lengths[k] / width).floor() as usize).max(1));
        if (dims[0] as f64) * (dims[1] as f64) * (dims[2] as f64) <= cap {
            return dims;
        }
        width *= 1.25;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_grid_is_capped_but_never_narrower_than_asked() {
        let l = Vector3::new(5.0, 5.0, 5.0);
        assert_eq!(cell_grid(&l, 1.0, 1000), [5, 5, 5]);
        let dims = cell_grid(&l, 0.004, 64);
        assert!(dims.iter().product::<usize>() <= 256, "{dims:?}");
        assert!(dims.iter().all(|&d| 5.0 / d as f64 >= 0.004));
    }
}
