//! Verlet lists for Monte Carlo moves of spheres: each sphere lists the
//! spheres whose reference centres lie within their contact distance plus
//! a skin of its own reference centre. While every centre stays within
//! half the skin of its reference, a sphere at a trial centre within half
//! the skin of its reference can only touch spheres on its list (the two
//! half-skins make up the skin), about a tenth of the slots the 27 cells
//! around it hold. A sphere that ends a move farther out takes its new
//! centre as reference and is relisted (and struck from, or added to, the
//! others' lists), through cells at least the contact range plus one and
//! a half skins wide.

use nalgebra::Vector3;

use super::{PackedCells, PeriodicBox};

type V3 = Vector3<f64>;

/// Per-sphere neighbour lists with a skin (see the module docs).
#[derive(Debug, Clone)]
pub struct SphereLists {
    skin: f64,
    /// Reference centres (in the box).
    reference: Vec<V3>,
    radii: Vec<f64>,
    /// Sphere-major: `lists[i · capacity + k]`, the first `counts[i]` used.
    lists: Vec<u32>,
    counts: Vec<u32>,
    capacity: usize,
}

impl SphereLists {
    /// Lists for spheres at `positions` (in the box) with `radii`, found
    /// through `cells`, which must be at least
    /// [`SphereLists::cell_width`] wide.
    pub fn new(
        box_: &PeriodicBox,
        cells: &PackedCells,
        positions: &[V3],
        radii: &[f64],
        skin: f64,
    ) -> Self {
        let n = positions.len();
        let mut lists = Self {
            skin,
            reference: positions.to_vec(),
            radii: radii.to_vec(),
            lists: Vec::new(),
            counts: vec![0; n],
            capacity: 16,
        };
        lists.relist_all(box_, cells);
        lists
    }

    /// The narrowest cells that can relist spheres of largest radius
    /// `max_radius` with `skin`.
    pub fn cell_width(max_radius: f64, skin: f64) -> f64 {
        2.0 * max_radius + 1.5 * skin
    }

    /// Lists every sphere afresh from the references (growing the
    /// capacity until every list fits).
    fn relist_all(&mut self, box_: &PeriodicBox, cells: &PackedCells) {
        let n = self.reference.len();
        'grow: loop {
            let cap = self.capacity;
            let mut found = vec![0; n * cap];
            for i in 0..n {
                let count = self.neighbours_of(i, box_, cells, |k, j| {
                    if k < cap {
                        found[i * cap + k] = j;
                    }
                });
                if count > cap {
                    self.capacity = count.next_power_of_two();
                    continue 'grow;
                }
                self.counts[i] = count as u32;
            }
            self.lists = found;
            return;
        }
    }

    /// Calls `put(k, j)` for the k-th sphere j ≠ i whose reference lies
    /// within the contact distance plus the skin of i's reference;
    /// returns how many there are. Spheres sit within half a skin of their
    /// references, so the cells around i's reference hold them all.
    fn neighbours_of(
        &self,
        i: usize,
        box_: &PeriodicBox,
        cells: &PackedCells,
        mut put: impl FnMut(usize, u32),
    ) -> usize {
        let centre = self.reference[i];
        let mut count = 0;
        cells.any_near(&centre, |j, _| {
            if j != i {
                let d = box_.minimum_image_near(&(self.reference[j] - centre));
                let reach = self.radii[i] + self.radii[j] + self.skin;
                if d.norm_squared() <= reach * reach {
                    put(count, j as u32);
                    count += 1;
                }
            }
            false
        });
        count
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
        let start = i * self.capacity;
        let list = &self.lists[start..start + self.counts[i] as usize];
        Some(list.iter().any(|&j| {
            let j = j as usize;
            let d = box_.minimum_image_near(&(positions[j] - centre));
            let reach = ri + self.radii[j];
            d.norm_squared() <= reach * reach && keep(j)
        }))
    }

    /// Records that sphere `i` now sits at `centre` (in the box; `cells`
    /// already updated): relisted if it left half the skin around its
    /// reference.
    pub fn moved(&mut self, i: usize, centre: &V3, box_: &PeriodicBox, cells: &PackedCells) {
        let half = 0.5 * self.skin;
        let drift = box_.minimum_image_near(&(centre - self.reference[i]));
        if drift.norm_squared() <= half * half {
            return;
        }
        // Struck from its old neighbours' lists.
        let cap = self.capacity;
        for k in 0..self.counts[i] as usize {
            let j = self.lists[i * cap + k] as usize;
            let list = &mut self.lists[j * cap..j * cap + self.counts[j] as usize];
            if let Some(at) = list.iter().position(|&m| m as usize == i) {
                let last = list.len() - 1;
                list.swap(at, last);
                self.counts[j] -= 1;
            }
        }
        self.reference[i] = *centre;
        let mut found = std::mem::take(&mut self.lists);
        let count = self.neighbours_of(i, box_, cells, |k, j| {
            if k < cap {
                found[i * cap + k] = j;
            }
        });
        self.lists = found;
        if count > cap {
            self.capacity = count.next_power_of_two();
            self.relist_all(box_, cells);
            return;
        }
        self.counts[i] = count as u32;
        // Added to its new neighbours' lists.
        for k in 0..count {
            let j = self.lists[i * cap + k] as usize;
            let c = self.counts[j] as usize;
            if c == cap {
                self.capacity *= 2;
                self.relist_all(box_, cells);
                return;
            }
            self.lists[j * cap + c] = i as u32;
            self.counts[j] += 1;
        }
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
        let width = SphereLists::cell_width(0.5, skin);
        let mut cells = PackedCells::new(&box_, width, &positions, &radii);
        let mut lists = SphereLists::new(&box_, &cells, &positions, &radii, skin);
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
            cells.update(i, &trial);
            lists.moved(i, &trial, &box_, &cells);
            if step % 1000 == 0 {
                for a in 0..n {
                    let mut listed: Vec<u32> = lists.lists
                        [a * lists.capacity..a * lists.capacity + lists.counts[a] as usize]
                        .to_vec();
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
