//! Verlet lists for Monte Carlo moves of spheres: each sphere lists the
//! spheres whose reference centres lie within their contact distance plus
//! a skin of its own reference centre. While every centre stays within
//! half the skin of its reference, a sphere at a trial centre within half
//! the skin of its reference can only touch spheres on its list (the two
//! half-skins make up the skin), about a tenth of the slots the 27 cells
//! around it hold. A sphere that ends a move farther out takes its new
//! centre as reference and is relisted (and struck from, or added to, the
//! others' lists), through cells of its own over the reference centres,
//! as wide as the largest contact distance plus the skin: the moves' own
//! cells stay as wide as the interaction range.

use nalgebra::Vector3;

use super::{NeighbourLists, PackedCells, PeriodicBox};

type V3 = Vector3<f64>;

/// Per-sphere neighbour lists with a skin (see the module docs).
#[derive(Debug, Clone)]
pub struct SphereLists {
    skin: f64,
    /// Reference centres (in the box).
    reference: Vec<V3>,
    /// The reference centres binned, to relist from.
    references: PackedCells,
    radii: Vec<f64>,
    /// Symmetric: j is on i's list iff i is on j's.
    lists: NeighbourLists,
}

impl SphereLists {
    /// Lists for spheres at `positions` (in the box) with `radii`.
    pub fn new(box_: &PeriodicBox, positions: &[V3], radii: &[f64], skin: f64) -> Self {
        let n = positions.len();
        let largest = radii.iter().copied().fold(0.0, f64::max);
        let mut this = Self {
            skin,
            reference: positions.to_vec(),
            references: PackedCells::new(box_, 2.0 * largest + skin, positions, radii),
            radii: radii.to_vec(),
            lists: NeighbourLists::new(n, 16),
        };
        for i in 0..n {
            this.link_neighbours(i, |j| j > i);
        }
        this
    }

    /// Links sphere `i` with every sphere j ≠ i with `wanted(j)` whose
    /// reference lies within the contact distance plus the skin of i's
    /// reference (the reference cells are that wide).
    fn link_neighbours(&mut self, i: usize, wanted: impl Fn(usize) -> bool) {
        let Self {
            skin,
            reference,
            references,
            radii,
            lists,
        } = self;
        references.any_near(&reference[i], |j, d| {
            if j != i && wanted(j) {
                let reach = radii[i] + radii[j] + *skin;
                if d.norm_squared() <= reach * reach {
                    lists.link(i, j);
                }
            }
            false
        });
    }

    /// Whether sphere `i` at `centre` (in the box) touches a listed sphere
    /// j at `positions[j]` with `keep(j)`; `None` if `centre` is more than
    /// half the skin from i's reference, where the list does not reach.
    #[inline]
    pub fn overlaps(
        &self,
        i: usize,
        centre: &V3,
        positions: &[V3],
        box_: &PeriodicBox,
        keep: impl Fn(usize) -> bool,
    ) -> Option<bool> {
        let half = 0.5 * self.skin;
        let drift = box_.minimum_image_near(&(centre - self.reference[i]));
        if drift.norm_squared() > half * half {
            return None;
        }
        let ri = self.radii[i];
        Some(self.lists.of(i).iter().any(|&j| {
            let j = j as usize;
            let d = box_.minimum_image_near(&(positions[j] - centre));
            let reach = ri + self.radii[j];
            d.norm_squared() <= reach * reach && keep(j)
        }))
    }

    /// Records that sphere `i` now sits at `centre` (in the box):
    /// relisted if it left half the skin around its reference.
    pub fn moved(&mut self, i: usize, centre: &V3, box_: &PeriodicBox) {
        let half = 0.5 * self.skin;
        let drift = box_.minimum_image_near(&(centre - self.reference[i]));
        if drift.norm_squared() <= half * half {
            return;
        }
        self.lists.unlink_all(i);
        self.reference[i] = *centre;
        self.references.update(i, centre);
        self.link_neighbours(i, |_| true);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Random walks of spheres (overlaps allowed: the lists do not care):
    /// after every step the overlap answer from the lists (where they
    /// reach) equals the all-pairs answer, and every list is exactly the
    /// set its definition says.
    #[test]
    fn lists_answer_as_all_pairs_through_random_walks() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let box_ = PeriodicBox::new(V3::new(6.0, 7.0, 8.0)).unwrap();
        let n = 120;
        let radii: Vec<f64> = (0..n)
            .map(|i| if i % 3 == 0 { 0.25 } else { 0.5 })
            .collect();
        let mut positions: Vec<V3> = (0..n)
            .map(|_| {
                box_.wrap(&V3::new(
                    rng.gen_range(-3.0..3.0),
                    rng.gen_range(-3.5..3.5),
                    rng.gen_range(-4.0..4.0),
                ))
            })
            .collect();
        let skin = 0.3;
        let mut lists = SphereLists::new(&box_, &positions, &radii, skin);
        let mut answered = 0;
        for step in 0..20_000 {
            let i = rng.gen_range(0..n);
            let trial = box_.wrap(&(positions[i] + V3::from_fn(|_, _| rng.gen_range(-0.15..0.15))));
            let all_pairs = (0..n).any(|j| {
                j != i && {
                    let d = box_.minimum_image(&(positions[j] - trial));
                    d.norm() <= radii[i] + radii[j]
                }
            });
            if let Some(answer) = lists.overlaps(i, &trial, &positions, &box_, |j| j != i) {
                assert_eq!(answer, all_pairs, "step {step}, sphere {i}");
                answered += 1;
            }
            positions[i] = trial;
            lists.moved(i, &trial, &box_);
            if step % 1000 == 0 {
                for a in 0..n {
                    let mut listed: Vec<u32> = lists.lists.of(a).to_vec();
                    listed.sort_unstable();
                    let expected: Vec<u32> = (0..n)
                        .filter(|&b| {
                            b != a && {
                                let d =
                                    box_.minimum_image(&(lists.reference[b] - lists.reference[a]));
                                d.norm() <= radii[a] + radii[b] + skin
                            }
                        })
                        .map(|b| b as u32)
                        .collect();
                    assert_eq!(listed, expected, "list of {a} at step {step}");
                }
            }
        }
        assert!(answered > 5_000, "{answered} answered by the lists");
    }
}
