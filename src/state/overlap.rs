//! Overlap queries: one particle where it is or where a move would put
//! it, and the first overlap of the whole configuration.

use nalgebra::{Matrix3, Vector3};

use crate::geometry::{Placed, Relative, overlap, placed_overlap};

use super::*;

type V3 = Vector3<f64>;

impl System {
    /// Whether particle `i`, placed at `position` with rotation `rotation`,
    /// would overlap any other particle (periodic images included).
    pub fn overlaps_at(&self, i: usize, position: &V3, rotation: &Matrix3<f64>) -> bool {
        self.overlaps_at_except(i, position, rotation, |j| j == i)
    }

    /// Whether body `i` (its species' shape at its size) at `position`
    /// turned by `rotation` touches or crosses a hard wall.
    pub(super) fn touches_wall(&self, i: usize, position: &V3, rotation: &Matrix3<f64>) -> bool {
        let s = self.particles[i].species as usize;
        let (up, down) = self.species[s].shape.lab_extents(rotation);
        let size = self.size_of(i);
        self.box_.wall_gap(position, (&(up * size), &(down * size))) <= 0.0
    }

    /// The first particle touching or crossing a hard wall, if any.
    pub fn first_wall_overlap(&self) -> Option<usize> {
        (0..self.len()).find(|&i| self.touches_wall(i, &self.positions[i], &self.rotations[i]))
    }

    /// Whether particle `i` (its species), placed at `position` with
    /// `rotation`, overlaps particle `j` placed at `position_j` with
    /// `rotation_j`.
    pub(crate) fn pair_overlaps(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        j: usize,
        position_j: &V3,
        rotation_j: &Matrix3<f64>,
    ) -> bool {
        if self.ideal {
            return false;
        }
        let (si, sj) = (
            self.particles[i].species as usize,
            self.particles[j].species as usize,
        );
        // Both positions lie in the box: |d| < 3L/2.
        let d = self.box_.minimum_image_near(&(position_j - position));
        let reach = self.body_radii[i] + self.body_radii[j];
        if d.norm_squared() > reach * reach {
            return false;
        }
        let (shape_i, shape_j) = (self.body_shape(i), self.body_shape(j));
        if shape_i.is_sphere() && shape_j.is_sphere() {
            return true;
        }
        if self.plan.aabb_cells {
            // Disjoint AABBs, as the AABB cells would have told.
            let (hi, hj) = (
                aabb_half_extents(rotation, &self.obb[si]),
                aabb_half_extents(rotation_j, &self.obb[sj]),
            );
            if (0..3).any(|k| d[k].abs() > hi[k] + hj[k]) {
                return false;
            }
        }
        let (placed_i, placed_j) = (
            Placed::new(shape_i, rotation),
            Placed::new(shape_j, rotation_j),
        );
        if let Some(answer) = placed_overlap(&placed_i, &placed_j, &d) {
            return answer;
        }
        let rel = Relative {
            translation: rotation.tr_mul(&d),
            rotation: rotation.tr_mul(rotation_j),
        };
        overlap(shape_i, shape_j, &rel)
    }

    /// As [`System::overlaps_at`], for a trial move of particle `i`: where
    /// its capsule list finds the overlap, the partner goes to the front
    /// of the list, where the next trial of `i`, most likely overlapping
    /// it too, meets it first. (The order of a list changes no answer.)
    /// `rotation` `None` keeps the particle's own (a translation).
    pub(crate) fn trial_overlaps(
        &mut self,
        i: usize,
        position: &V3,
        rotation: Option<&Matrix3<f64>>,
    ) -> bool {
        let rotation = rotation.unwrap_or(&self.rotations[i]);
        if self.capsule_lists.is_none() {
            return self.overlaps_at(i, position, rotation);
        }
        let hit = std::cell::Cell::new(None);
        let overlaps = self.overlap_search(i, position, rotation, |j| j == i, &hit);
        if let (Some(at), Some(lists)) = (hit.get(), &mut self.capsule_lists) {
            lists.to_front(i, at);
        }
        overlaps
    }

    /// As [`System::overlaps_at`], ignoring every particle `j` for which
    /// `skip(j)` holds (the particle itself always among them).
    pub(crate) fn overlaps_at_except(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        skip: impl Fn(usize) -> bool,
    ) -> bool {
        self.overlap_search(i, position, rotation, skip, &std::cell::Cell::new(None))
    }

    /// As [`System::overlaps_at_except`]; where a capsule list finds the
    /// overlap, `hit` is set to the partner's place on the list.
    #[inline]
    pub(super) fn overlap_search(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        skip: impl Fn(usize) -> bool,
        hit: &std::cell::Cell<Option<usize>>,
    ) -> bool {
        // One instance per kind of box: the orthorhombic one's candidate
        // loops carry no tilt test per pair.
        if self.box_.is_tilted() {
            self.overlap_search_in::<true>(i, position, rotation, skip, hit)
        } else {
            self.overlap_search_in::<false>(i, position, rotation, skip, hit)
        }
    }

    #[inline(always)]
    fn overlap_search_in<const TILTED: bool>(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        skip: impl Fn(usize) -> bool,
        hit: &std::cell::Cell<Option<usize>>,
    ) -> bool {
        if self.ideal {
            return false;
        }
        let si = self.particles[i].species as usize;
        let shape_i = self.body_shape(i);
        let ri = self.body_radii[i];
        if self.box_.has_walls() && self.touches_wall(i, position, rotation) {
            return true;
        }
        if let (Neighbours::Cells(cells), true) = (&self.cells, self.all_spheres) {
            let centre = self.box_.wrap_near(position);
            if let Some(lists) = &self.sphere_lists
                && let Some(answer) =
                    lists.overlaps(i, &centre, &self.positions, &self.box_, |j| !skip(j))
            {
                return answer;
            }
            return cells.sphere_overlaps_where(&centre, ri, |j| !skip(j as usize));
        }
        // The largest reach any partner could have: most candidates fail
        // this before their species is even looked up.
        let reach_max = ri + self.max_radius;
        // A translation tests the particle's own rotation (the very matrix
        // `rotations[i]`), already placed.
        let placed_i = if std::ptr::eq(rotation, &self.rotations[i]) {
            self.placed[i]
        } else {
            Placed::new(shape_i, rotation)
        };
        let test = |j: usize, d: &V3| {
            let d2 = d.norm_squared();
            if d2 > reach_max * reach_max || skip(j) {
                return false;
            }
            let reach = ri + self.body_radii[j];
            if d2 > reach * reach {
                return false;
            }
            let shape_j = self.body_shape(j);
            if shape_i.is_sphere() && shape_j.is_sphere() {
                return true; // within the sum of radii
            }
            if let Some(answer) = placed_overlap(&placed_i, &self.placed[j], d) {
                return answer;
            }
            let rel = Relative {
                translation: rotation.tr_mul(d),
                rotation: rotation.tr_mul(&self.rotations[j]),
            };
            overlap(shape_i, shape_j, &rel)
        };
        match &self.cells {
            // At the position it would be stored at (a trial translation may
            // have left the box).
            Neighbours::Cells(cells) => cells.any_near(&self.box_.wrap_near(position), test),
            Neighbours::PerSpecies(grids) => {
                let at = self.box_.wrap_near(position);
                grids
                    .iter()
                    .enumerate()
                    .any(|(sj, grid)| grid.any_within(&at, ri + self.radii[sj], |j, d| test(j, d)))
            }
            Neighbours::Aabb(cells) => {
                // Both centres lie within half a box of the box: |d| < 3L/2.
                let separation = |j: usize| {
                    self.box_
                        .minimum_image_near_as::<TILTED>(&(self.positions[j] - position))
                };
                let h = aabb_half_extents(rotation, &self.obb[si]);
                let candidate = |j: usize| {
                    // Disjoint AABBs (the registry is coarser than them).
                    let d = separation(j);
                    let hj = &self.aabb[j];
                    if (0..3).any(|k| d[k].abs() > h[k] + hj[k]) {
                        return false;
                    }
                    test(j, &d)
                };
                let Some(lists) = &self.capsule_lists else {
                    return cells.any_near(position, &h, candidate);
                };
                let axis = rotation.column(self.capsules[si].0).into();
                if lists.reach(&self.box_, i, position, &axis) {
                    let at = lists.of(i).iter().position(|&j| candidate(j as usize));
                    hit.set(at);
                    return at.is_some();
                }
                // While the lists are on, their cells hold every body.
                lists.any_near(position, &h, candidate)
            }
        }
    }

    /// The first overlapping pair found through the neighbour structure
    /// (O(N): for systems too large for [`System::first_overlap_all_pairs`]);
    /// a body on a wall is paired with itself.
    pub fn first_overlap(&self) -> Option<(usize, usize)> {
        let i = (0..self.len()).find(|&i| self.overlaps_where_it_is(i))?;
        Some(match self.partners_of(i).next() {
            Some(j) => (i.min(j), i.max(j)),
            None => (i, i),
        })
    }

    /// The particles that particle `i` overlaps where it is, by testing
    /// every other one (for naming an overlap, not for moves).
    pub(super) fn partners_of(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (p, r) = (&self.positions[i], &self.rotations[i]);
        (0..self.len()).filter(move |&j| {
            j != i && self.pair_overlaps(i, p, r, j, &self.positions[j], &self.rotations[j])
        })
    }

    /// The first overlapping pair by testing all N(N−1)/2 pairs, without the
    /// cell list: the independent check that a state is overlap-free.
    pub fn first_overlap_all_pairs(&self) -> Option<(usize, usize)> {
        let n = self.particles.len();
        for i in 0..n {
            let pi = &self.particles[i];
            for j in i + 1..n {
                let pj = &self.particles[j];
                let d = self.box_.minimum_image(&(pj.position - pi.position));
                let reach = self.body_radii[i] + self.body_radii[j];
                if d.norm_squared() > reach * reach {
                    continue; // the pair kernels would reject it the same way
                }
                let rel = Relative::new(&d, &pi.orientation, &pj.orientation);
                if overlap(&self.shape_of(i), &self.shape_of(j), &rel) {
                    return Some((i, j));
                }
            }
        }
        None
    }
}
