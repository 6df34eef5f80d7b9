//! What a member of a Monte Carlo team that shares one system of hard
//! spheres ([`crate::mc::parallel`]) may write of it: its own copies of
//! the headers of the slot storage a sphere's move touches (the centres,
//! the particles, the cells and the sphere lists), and the placement of
//! one sphere through them. Every other part of the system (the box, the
//! species, the rotations, the plan, the scalars) it can only read.

use std::mem::ManuallyDrop;

use nalgebra::Vector3;

use super::{Neighbours, Particle, System};
use crate::space::slots::Slots;
use crate::space::{PackedCells, PeriodicBox, SphereLists};

type V3 = Vector3<f64>;

/// Copies of the headers of the storage a sphere's move writes, the
/// storage itself the system's (never dropped from here). The cells and
/// lists panic rather than grow, which would move their storage from
/// under the other members.
pub(crate) struct SphereSlots {
    positions: Slots<V3>,
    particles: Slots<Particle>,
    cells: PackedCells,
    lists: Option<SphereLists>,
}

impl SphereSlots {
    /// The slots of `system`, a system of spheres on one grid of cells
    /// (None for any other).
    ///
    /// SAFETY: no one may change `system`'s header (its fields, as opposed
    /// to the elements of its slot storage) while the copy is used, and
    /// whoever holds it writes only elements no other thread touches
    /// meanwhile.
    pub(crate) unsafe fn of(system: &System) -> Option<ManuallyDrop<Self>> {
        let Neighbours::Cells(cells) = &system.cells else {
            return None;
        };
        if !system.all_spheres {
            return None;
        }
        // SAFETY: bitwise copies of headers whose storage stays the
        // system's: they are never dropped (ManuallyDrop), and the caller
        // keeps the header unchanged while they are used.
        let mut slots = ManuallyDrop::new(unsafe {
            Self {
                positions: std::ptr::read(&system.positions),
                particles: std::ptr::read(&system.particles),
                cells: std::ptr::read(cells),
                lists: std::ptr::read(&system.sphere_lists),
            }
        });
        slots.cells.fix_capacity();
        if let Some(lists) = &mut slots.lists {
            lists.fix_capacity();
        }
        Some(slots)
    }

    /// Places sphere `i`, now at `from`, at `position` in `box_` (wrapped
    /// into it), as [`System::place`] does for a sphere: its centre, its
    /// cell and its lists. Returns the squared length of the step.
    #[inline]
    pub(crate) fn place(&mut self, box_: &PeriodicBox, i: usize, from: &V3, position: V3) -> f64 {
        let position = box_.wrap_near(&position);
        let step = box_.minimum_image_near(&(position - from));
        self.particles[i].position = position;
        self.positions[i] = position;
        self.cells.update(i, &position);
        if let Some(lists) = &mut self.lists {
            lists.moved(i, &position, box_);
        }
        step.norm_squared()
    }
}
