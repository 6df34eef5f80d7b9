//! Box changes: a rescale that keeps the state overlap-free, and one that
//! allows overlaps (compression), with the restore that undoes it.

use nalgebra::Vector3;

use crate::space::PeriodicBox;

use super::*;

type V3 = Vector3<f64>;

impl System {
    /// The box of these edges (the tilts kept), if valid and at least
    /// twice the interaction range across each pair of faces.
    pub(super) fn box_with_lengths(&self, lengths: V3) -> Option<PeriodicBox> {
        let new_box = self.box_.with_lengths(lengths).ok()?;
        Self::check_box(&new_box, self.range).ok()?;
        Some(new_box)
    }

    /// Puts the system in `cell`, a cell of the lattice of `new_box`,
    /// every centre taken along with the box (the same fractional
    /// coordinates in `new_box`, then wrapped into `cell`; the neighbour
    /// structures are the caller's to renew).
    pub(super) fn scale_into(&mut self, new_box: PeriodicBox, cell: PeriodicBox) {
        let old_box = self.box_;
        self.box_ = cell;
        for (p, r) in self.particles.iter_mut().zip(&mut self.positions) {
            p.position = cell.wrap(&new_box.map_from(&old_box, &p.position));
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
        let old_box = self.box_;
        self.scale_into(new_box, new_box);
        self.capsule_lists = None;
        self.cells = self.neighbours_as_they_are();
        if let Some(mut lists) = self.sphere_lists.take()
            && lists.rescaled(&old_box, &self.box_, self.positions.as_slice())
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

    /// Rescales the box to `lengths` (its tilts kept) and the positions
    /// with it, if that creates no overlap and keeps the box at least twice
    /// the interaction range; returns whether it did.
    #[cfg(test)]
    pub(crate) fn try_rescale(&mut self, lengths: V3) -> bool {
        match self.box_with_lengths(lengths) {
            Some(new_box) => self.try_change_box(new_box),
            None => false,
        }
    }

    /// Changes the box to `new_box` (any edges and tilts, the same walls)
    /// and the positions with it (the same fractional coordinates), if that
    /// creates no overlap and keeps the box at least twice the interaction
    /// range across each pair of faces; returns whether it did. A box whose
    /// tilts pass half an edge is replaced by the same lattice's reduced
    /// cell ([`PeriodicBox::reduced`]), which the range is checked on: what
    /// is accepted depends on the lattice alone, not on its cell.
    pub(crate) fn try_change_box(&mut self, new_box: PeriodicBox) -> bool {
        let cell = new_box.reduced();
        if Self::check_box(&cell, self.range).is_err() {
            return false;
        }
        let old_box = self.box_;
        // Lists follow a box that keeps its cell; a new cell starts afresh.
        let same_cell = cell == new_box;
        // Only an isotropic expansion keeps convex bodies apart whatever
        // their shape (r ∉ A⊕(−B) ⇒ s·r ∉ A⊕(−B) for s ≥ 1); a map that
        // stretches every separation keeps spheres apart; anything else
        // (one edge grown, a shear) can bring bodies into contact.
        let stretch = new_box.smallest_stretch_from(&old_box);
        let may_touch =
            !new_box.expands_uniformly_from(&old_box) && (stretch < 1.0 || !self.only_spheres());
        // Most may_touch that fail make a listed pair overlap: the listed
        // pairs are measured on the scaled centres alone, before any cell
        // is rebuilt (the arithmetic of the centres scaled in place below,
        // so the same answer); below, only the strays are left to check.
        if may_touch
            && !self.ideal
            && !self.box_.has_walls()
            && same_cell
            && let Some(lists) = &self.sphere_lists
        {
            self.scaled.clear();
            (self.scaled).extend(
                self.positions
                    .iter()
                    .map(|r| new_box.wrap(&new_box.map_from(&old_box, r))),
            );
            if lists.listed_overlap_after_rescale(&old_box, &new_box, &self.scaled) {
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
        let old_positions = self.positions.clone();
        self.scale_into(new_box, cell);
        let new_cells = self.neighbours_as_they_are();
        let old_cells = std::mem::replace(&mut self.cells, new_cells);
        let overlaps =
            |i: usize| self.overlaps_at(i, &self.particles[i].position, &self.rotations[i]);
        // Sphere lists answered above for all but the centres that strayed
        // far from their references (walls aside).
        if may_touch
            && !self.ideal
            && match &lists {
                Some(lists) if !self.box_.has_walls() && same_cell => (lists)
                    .strays_after_rescale(&old_box, &self.box_, self.positions.as_slice())
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
            && same_cell
            && lists.rescaled(&old_box, &self.box_, self.positions.as_slice())
        {
            self.sphere_lists = Some(lists);
        }
        self.list_window = (0, 0.0);
        self.changed = true;
        true
    }

    /// Whether every species is a sphere.
    fn only_spheres(&self) -> bool {
        self.species.iter().all(|s| s.shape.is_sphere())
    }
}
