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
pub use neighbour_list::{Marks, NeighbourLists};
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

/// Calls `f(i, j, d)` once for every pair i < j of `centres` (in the
/// box) closer than `cutoff`, with `d` the minimum-image separation from
/// i to j: by cells, so in time linear in the number of centres at a fixed
/// density.
pub fn pairs_within(
    box_: &PeriodicBox,
    centres: &[Vector3<f64>],
    cutoff: f64,
    mut f: impl FnMut(usize, usize, Vector3<f64>),
) {
    let cells = CellList::new(box_, cutoff, centres);
    cells.for_each_near_pair(|i, j| {
        let d = box_.minimum_image(&(centres[j] - centres[i]));
        if d.norm_squared() < cutoff * cutoff {
            f(i, j, d);
        }
    });
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

    /// The pairs by cells are the pairs by brute force, with the same
    /// separations: periodic and walled boxes, cutoffs from a small one to
    /// just under half the shortest edge.
    #[test]
    fn pairs_within_finds_every_pair_brute_force_finds() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        for (edges, walls) in [
            ([6.0, 6.0, 6.0], [false; 3]),
            ([9.0, 4.0, 5.0], [false, false, true]),
        ] {
            let box_ = PeriodicBox::new(Vector3::from(edges))
                .unwrap()
                .with_walls(walls)
                .unwrap();
            let centres: Vec<Vector3<f64>> = (0..300)
                .map(|_| Vector3::from(edges.map(|l| l * (rng.r#gen::<f64>() - 0.5))))
                .collect();
            for cutoff in [0.7, 1.3, 1.95] {
                let mut by_cells = Vec::new();
                pairs_within(&box_, &centres, cutoff, |i, j, d| by_cells.push((i, j, d)));
                by_cells.sort_by_key(|p| (p.0, p.1));
                let mut brute = Vec::new();
                for i in 0..centres.len() {
                    for j in i + 1..centres.len() {
                        let d = box_.minimum_image(&(centres[j] - centres[i]));
                        if d.norm() < cutoff {
                            brute.push((i, j, d));
                        }
                    }
                }
                assert!(!brute.is_empty());
                assert_eq!(by_cells, brute, "{edges:?} {cutoff}");
            }
        }
    }
}
