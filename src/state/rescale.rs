//! Box changes: a rescale that keeps the state overlap-free, and one that
//! allows overlaps (compression), with the restore that undoes it.

use nalgebra::Vector3;

use crate::space::PeriodicBox;

use super::*;

type V3 = Vector3<f64>;

impl System {
    /// The box of these edges, if valid and at least twice the interaction
    /// range along each.
    pub(super) fn box_with_lengths(&self, lengths: V3) -> Option<PeriodicBox> {
        let new_box = self.box_.with_lengths(lengths).ok()?;
        Self::check_box(&new_box, self.range).ok()?;
        Some(new_box)
    }

    /// Puts the system in `new_box`, every centre scaled by `factor` (the
    /// neighbour structures are the caller's to renew).
    pub(super) fn scale_into(&mut self, new_box: PeriodicBox, factor: &V3) {
        self.box_ = new_box;
        for (p, r) in self.particles.iter_mut().zip(&mut self.positions) {
            p.position = new_box.wrap(&p.position.component_mul(factor));
            *r = p.position;
        }
    }

    /// Rescales the box to `lengths` and the centres with it, overlaps or
    /// not (a compression that lets the moves remove them); returns false,
    /// and changes nothing, where the box would be invalid or shorter than
    /// twice the interaction range.
    pub(crate) fn rescale_allowing_overlaps(&mut self, lengths: V3) -> bool {
        let Some(new_box) = self.box_with_lengths(lengths) else {
            return false;
        };
        let factor = lengths.component_div(&self.box_.lengths());
        self.scale_into(new_box, &factor);
        self.capsule_lists = None;
        self.cells = self.neighbours_as_they_are();
        if let Some(mut lists) = self.sphere_lists.take()
            && lists.rescaled(&self.box_, &factor, self.positions.as_slice())
        {
            self.sphere_lists = Some(lists);
        }
        self.list_window = (0, 0.0);
        self.changed = true;
        true
    }

    /// Puts the box and the particles back as `box_` and `particles` hold
    /// them (a state this system had, of the same species), checked to be
    /// overlap-free.
    pub(crate) fn restore(
        &mut self,
        box_: PeriodicBox,
        particles: &[Particle],
    ) -> Result<(), StateError> {
        let mut restored = System::new(box_, self.species.clone(), particles.to_vec())?;
        restored.ideal = self.ideal;
        *self = restored;
        Ok(())
    }

    /// Every particle that overlaps another or a wall, in index order,
    /// written to `out`.
    pub(crate) fn overlapping_particles(&self, out: &mut Vec<usize>) {
        out.clear();
        out.extend((0..self.len()).filter(|&i| self.overlaps_where_it_is(i)));
    }

    /// Whether particle `i` overlaps another or a wall where it is.
    pub(crate) fn overlaps_where_it_is(&self, i: usize) -> bool {
        self.overlaps_at(i, &self.positions[i], &self.rotations[i])
    }

    /// Rescales the box to `lengths` and the positions with it, if that
    /// creates no overlap and keeps the box at least twice the interaction
    /// range; returns whether it did.
    pub(crate) fn try_rescale(&mut self, lengths: V3) -> bool {
        let Some(new_box) = self.box_with_lengths(lengths) else {
            return false;
        };
        let old_lengths = self.box_.lengths();
        let factor = lengths.component_div(&old_lengths);
        let shrinks = factor.iter().any(|&f| f < 1.0);
        // Most shrinks that fail make a listed pair overlap: the listed
        // pairs are measured on the scaled centres alone, before any cell
        // is rebuilt (the arithmetic of the centres scaled in place below,
        // so the same answer); below, only the strays are left to check.
        if shrinks
            && !self.ideal
            && !self.box_.has_walls()
            && let Some(lists) = &self.sphere_lists
        {
            self.scaled.clear();
            (self.scaled).extend(
                self.positions
                    .iter()
                    .map(|r| new_box.wrap(&r.component_mul(&factor))),
            );
            if lists.listed_overlap_after_rescale(&new_box, &factor, &self.scaled) {
                return false;
            }
        }
        // Every centre moves: the trial is made in place, on new cells and
        // without lists; a refused change puts back the centres, the cells
        // and the lists it kept aside (a copy of the whole system per box
        // move, fresh pages each time, was a quarter of an NPT sweep of
        // 4000 spheres).
        let lists = self.sphere_lists.take();
        let capsule_lists = self.capsule_lists.take();
        let old_box = self.box_;
        let old_positions = self.positions.clone();
        self.scale_into(new_box, &factor);
        let new_cells = self.neighbours_as_they_are();
        let old_cells = std::mem::replace(&mut self.cells, new_cells);
        // Scaling all centres up cannot create an overlap of convex bodies
        // (r ∉ A⊕(−B) ⇒ s·r ∉ A⊕(−B) for s ≥ 1); only a shrink along some
        // axis needs checking.
        let overlaps =
            |i: usize| self.overlaps_at(i, &self.particles[i].position, &self.rotations[i]);
        // Sphere lists answered above for all but the centres that strayed
        // far from their references (walls aside).
        if shrinks
            && !self.ideal
            && match &lists {
                Some(lists) if !self.box_.has_walls() => (lists)
                    .strays_after_rescale(&self.box_, &factor, self.positions.as_slice())
                    .any(overlaps),
                _ => (0..self.len()).any(overlaps),
            }
        {
            self.box_ = old_box;
            for (p, r) in self.particles.iter_mut().zip(&old_positions) {
                p.position = *r;
            }
            self.positions = old_positions;
            self.cells = old_cells;
            self.sphere_lists = lists;
            self.capsule_lists = capsule_lists;
            return false;
        }
        // The sphere lists go with the box (scaled) while the gap they keep
        // allows; the capsule lists do not.
        if let Some(mut lists) = lists
            && lists.rescaled(&self.box_, &factor, self.positions.as_slice())
        {
            self.sphere_lists = Some(lists);
        }
        self.list_window = (0, 0.0);
        self.changed = true;
        true
    }
}
