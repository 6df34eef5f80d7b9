//! Building a configuration, checking it, and what it reports.

use nalgebra::{Matrix3, Vector3};

use crate::geometry::Placed;
use crate::geometry::capsule::bounding_capsule;
use crate::space::PeriodicBox;

use super::*;

type V3 = Vector3<f64>;

impl System {
    /// A system, checked to be overlap-free and in a box large enough for
    /// the minimum image.
    pub fn new(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
    ) -> Result<Self, StateError> {
        Self::with_contacts(box_, species, particles, None, |_, _| false)
    }

    /// A system whose pairs may touch as the event-driven dynamics hands
    /// them on: [`System::with_contacts`], a pair let through where its
    /// signed distance, by the geometry layer's distance kernel (the one
    /// the predictions follow), is no deeper than `tolerance` times the
    /// smaller body's smallest half-extent. `sizes` as in
    /// [`System::with_sizes`].
    pub fn with_touching(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
        sizes: Option<Vec<f64>>,
        tolerance: f64,
    ) -> Result<Self, StateError> {
        let shape = |i: usize| {
            let shape = species[particles[i].species as usize].shape;
            match &sizes {
                Some(f) => shape.scaled(f[i]),
                None => shape,
            }
        };
        let touching = |i: usize, j: usize| {
            let (a, b) = (&particles[i], &particles[j]);
            let (sa, sb) = (shape(i), shape(j));
            let d = box_.minimum_image(&(b.position - a.position));
            let rel = crate::geometry::Relative::new(&d, &a.orientation, &b.orientation);
            let contact = crate::geometry::distance(
                &sa,
                &sb,
                &rel,
                &crate::geometry::DistanceOptions::default(),
                None,
            );
            let scale = sa.min_half_extent().min(sb.min_half_extent());
            contact.distance >= -tolerance * scale
        };
        Self::with_contacts(
            box_,
            species.clone(),
            particles.clone(),
            sizes.clone(),
            touching,
        )
    }

    /// As [`System::new`] (or [`System::with_sizes`] with `sizes`), except
    /// that pairs (i < j) for which `touching(i, j)` holds are let through
    /// where the overlap kernels count them as overlapping: a state of the
    /// event-driven dynamics holds the pair of its last collision touching
    /// to round-off, which another kernel's arithmetic may put either side
    /// of contact. A move of such a particle is then judged against its
    /// partner as usual (moves that part them are accepted).
    pub fn with_contacts(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
        sizes: Option<Vec<f64>>,
        touching: impl Fn(usize, usize) -> bool,
    ) -> Result<Self, StateError> {
        Self::assemble(box_, species, particles, sizes, touching)
    }

    /// A system of polydisperse spheres: body i is its species' sphere
    /// scaled by `sizes[i]` (HOOMD's per-particle diameter, relative to
    /// the species'), checked as [`System::new`] checks.
    pub fn with_sizes(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
        sizes: Vec<f64>,
    ) -> Result<Self, StateError> {
        Self::assemble(box_, species, particles, Some(sizes), |_, _| false)
    }

    fn assemble(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
        sizes: Option<Vec<f64>>,
        touching: impl Fn(usize, usize) -> bool,
    ) -> Result<Self, StateError> {
        if particles.is_empty() {
            return Err(StateError::Empty);
        }
        for (i, p) in particles.iter().enumerate() {
            if p.species as usize >= species.len() {
                return Err(StateError::UnknownSpecies(i, p.species, species.len()));
            }
        }
        let species: Vec<Species> = species
            .into_iter()
            .map(|s| Species {
                rotation: s.rotation && !s.shape.is_sphere(),
                ..s
            })
            .collect();
        if let Some(sizes) = &sizes {
            check_sizes(&particles, sizes)?;
        }
        let size = |i: usize| sizes.as_ref().map_or(1.0, |s| s[i]);
        let body_radii: Vec<f64> = (particles.iter().enumerate())
            .map(|(i, p)| species[p.species as usize].shape.bounding_radius() * size(i))
            .collect();
        // A species' bounds are its largest body's, so that every range,
        // cell and prefilter sized by species holds for each of its bodies.
        let largest = match &sizes {
            Some(sizes) => super::sizes::largest_sizes(
                species.len(),
                particles.iter().map(|p| p.species),
                sizes,
            ),
            None => vec![1.0_f64; species.len()],
        };
        let radii: Vec<f64> = (species.iter().zip(&largest))
            .map(|(s, f)| s.shape.bounding_radius() * f)
            .collect();
        let max_radius = radii.iter().cloned().fold(0.0, f64::max);
        let range = 2.0 * max_radius;
        let particles: Vec<Particle> = particles
            .into_iter()
            .map(|p| Particle {
                position: box_.wrap(&p.position),
                ..p
            })
            .collect();
        let rotations: Vec<Matrix3<f64>> = particles
            .iter()
            .map(|p| p.orientation.to_rotation_matrix().into_inner())
            .collect();
        Self::check_box(&box_, range)?;
        let obb: Vec<V3> = (species.iter().zip(&largest))
            .map(|(s, f)| s.shape.obb_half_extents() * *f)
            .collect();
        let aabb: Vec<V3> = particles
            .iter()
            .zip(&rotations)
            .map(|(p, r)| aabb_half_extents(r, &obb[p.species as usize]))
            .collect();
        // A body at size 1 keeps its species' very shape.
        let body_shapes: Option<Vec<Shape>> = sizes.as_ref().map(|sizes| {
            (particles.iter().zip(sizes))
                .map(|(p, &f)| {
                    let shape = species[p.species as usize].shape;
                    if f == 1.0 { shape } else { shape.scaled(f) }
                })
                .collect()
        });
        let shape_of = |i: usize| match &body_shapes {
            Some(shapes) => shapes[i],
            None => species[particles[i].species as usize].shape,
        };
        let placed: Vec<Placed> = (rotations.iter().enumerate())
            .map(|(i, r)| Placed::new(&shape_of(i), r))
            .collect();
        let plan = NeighbourPlan::for_species(&species);
        let capsules = (species.iter().zip(&largest))
            .map(|(s, &f)| {
                let (axis, c) = bounding_capsule(&s.shape);
                let scaled = crate::geometry::capsule::Capsule {
                    half_length: c.half_length * f,
                    radius: c.radius * f,
                };
                (axis, if f == 1.0 { c } else { scaled })
            })
            .collect();
        let positions: Vec<V3> = particles.iter().map(|p| p.position).collect();
        let kinds: Vec<u16> = particles.iter().map(|p| p.species).collect();
        let all_spheres = species.iter().all(|s| s.shape.is_sphere());
        let cells = Neighbours::build(
            &plan,
            range,
            &box_,
            &positions,
            &aabb,
            &kinds,
            &radii,
            &body_radii,
        );
        let system = Self {
            box_,
            species,
            particles: particles.into(),
            rotations,
            radii,
            max_radius,
            body_radii,
            sizes,
            body_shapes,
            positions: positions.into(),
            obb,
            aabb,
            placed,
            cells,
            plan,
            range,
            all_spheres,
            sphere_lists: None,
            capsules,
            capsule_lists: None,
            list_window: (0, 0.0),
            scaled: Vec::new(),
            ideal: false,
            stamp: new_stamp(),
            changed: false,
        };
        if let Some(i) = system.first_wall_overlap() {
            return Err(StateError::WallOverlap(i));
        }
        // Through the neighbour structure: O(N), where the all-pairs check is
        // O(N²) (that one is for tests).
        for i in 0..system.len() {
            if system.overlaps_where_it_is(i) {
                let partners: Vec<usize> = system.partners_of(i).collect();
                match partners.iter().find(|&&j| !touching(i.min(j), i.max(j))) {
                    Some(&j) => return Err(StateError::Overlap(i.min(j), i.max(j))),
                    None if partners.is_empty() => return Err(StateError::Overlap(i, i)),
                    None => {} // Touching partners only.
                }
            }
        }
        Ok(system)
    }

    pub(super) fn check_box(box_: &PeriodicBox, range: f64) -> Result<(), StateError> {
        if box_.heights().min() < 2.0 * range {
            Err(StateError::BoxTooSmall {
                lengths: box_.lengths().into(),
                range,
            })
        } else {
            Ok(())
        }
    }

    /// The largest centre–centre distance at which two particles can
    /// touch (twice the largest bounding radius): the box edges must stay
    /// at least twice this for the minimum image to be unique.
    pub fn interaction_range(&self) -> f64 {
        self.range
    }

    /// Switches overlap tests off (an ideal gas of the same particles), for
    /// checking the volume-move statistics.
    pub fn set_ideal(&mut self, ideal: bool) {
        self.changed = true;
        self.ideal = ideal;
    }

    /// The box.
    pub fn periodic_box(&self) -> &PeriodicBox {
        &self.box_
    }

    /// The particles.
    pub fn particles(&self) -> &[Particle] {
        self.particles.as_slice()
    }

    /// The species.
    pub fn species(&self) -> &[Species] {
        &self.species
    }

    /// An identity of the state: a system and a clone of it have the same
    /// stamp until either changes (a stamp asked for after any move placed
    /// or box rescaled is a fresh one). Replicas kept for parallel sweeps
    /// are reused while the system's stamp is the one they were
    /// synchronised at.
    pub fn stamp(&mut self) -> u64 {
        if self.changed {
            self.stamp = new_stamp();
            self.changed = false;
        }
        self.stamp
    }

    /// The neighbour structure it uses, and why.
    pub fn plan(&self) -> &NeighbourPlan {
        &self.plan
    }

    /// Whether sphere moves are answered by Verlet lists now (built once
    /// the box has stayed put long enough; see [`NeighbourPlan::sphere_skin`]).
    pub fn uses_sphere_lists(&self) -> bool {
        self.sphere_lists.is_some()
    }

    /// Whether capsule Verlet lists answer most moves now (bodies on AABB
    /// cells, once the moves are short; see [`NeighbourPlan::capsule_pad`]).
    pub fn uses_capsule_lists(&self) -> bool {
        self.capsule_lists.is_some()
    }

    /// Whether candidates come from AABB cells (elongated or flat species)
    /// rather than range-wide cells.
    pub fn uses_aabb_cells(&self) -> bool {
        self.plan.aabb_cells
    }

    /// Whether each species has a grid of its own (size-asymmetric
    /// mixtures).
    pub fn uses_per_species_cells(&self) -> bool {
        self.plan.per_species
    }

    /// How many particles the neighbour structure hands to the overlap test
    /// for particle `i` where it is (itself included): the work of one
    /// trial move before the pair kernels.
    pub fn candidates_of(&self, i: usize) -> usize {
        let mut count = 0;
        let mut seen = |_: usize, _: &V3| {
            count += 1;
            false
        };
        let position = self.positions[i];
        let si = self.particles[i].species as usize;
        match &self.cells {
            Neighbours::Cells(cells) => {
                cells.any_near(&position, &mut seen);
            }
            Neighbours::Aabb(cells) => match &self.capsule_lists {
                // Itself included, as the cells count it.
                Some(lists) => count = lists.of(i).len() + 1,
                None => {
                    let h = aabb_half_extents(&self.rotations[i], &self.obb[si]);
                    cells.any_near(&position, &h, |j| seen(j, &position));
                }
            },
            Neighbours::PerSpecies(grids) => {
                for (sj, grid) in grids.iter().enumerate() {
                    grid.any_within(&position, self.radii[si] + self.radii[sj], &mut seen);
                }
            }
        }
        count
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Always false: a system has particles.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// φ = Σ vᵢ / V.
    pub fn packing_fraction(&self) -> f64 {
        let v: f64 = (0..self.len()).map(|i| self.body_volume(i)).sum();
        v / self.box_.volume()
    }

    /// Each body's size, the scale factor of its species' shape; `None`
    /// where every body has its species' size.
    pub fn sizes(&self) -> Option<&[f64]> {
        self.sizes.as_deref()
    }

    /// The size of body `i` (1 without sizes).
    pub fn size_of(&self, i: usize) -> f64 {
        self.sizes.as_ref().map_or(1.0, |s| s[i])
    }

    /// The shape of body `i`: its species' scaled by its size.
    pub fn shape_of(&self, i: usize) -> crate::geometry::Shape {
        *self.body_shape(i)
    }

    /// [`System::shape_of`], borrowed (the overlap tests' read).
    #[inline]
    pub(crate) fn body_shape(&self, i: usize) -> &crate::geometry::Shape {
        match &self.body_shapes {
            Some(shapes) => &shapes[i],
            None => &self.species[self.particles[i].species as usize].shape,
        }
    }

    /// The volume of body `i`.
    pub fn body_volume(&self, i: usize) -> f64 {
        let v = self.species[self.particles[i].species as usize]
            .shape
            .volume();
        v * self.size_of(i).powi(3)
    }

    /// The contact network of the bodies, pairs closer than
    /// `gap_tolerance` times the smaller one's smallest half-extent (see
    /// [`crate::analysis::packing::contact_network`]).
    pub fn contact_network(&self, gap_tolerance: f64) -> crate::analysis::packing::ContactNetwork {
        let (shapes, _, bodies) = self.packed();
        crate::analysis::packing::contact_network(&self.box_, &shapes, &bodies, gap_tolerance)
    }

    /// The contact network read at the gap the packing itself shows (see
    /// [`crate::analysis::contact_gap`]), at reduced pressure
    /// `reduced_pressure` where known; with the choice of the gap.
    pub fn read_contact_network(
        &self,
        reduced_pressure: Option<f64>,
    ) -> (
        crate::analysis::contact_gap::GapChoice,
        crate::analysis::packing::ContactNetwork,
    ) {
        let (shapes, turns, bodies) = self.packed();
        crate::analysis::contact_gap::read_contact_network(
            &self.box_,
            &shapes,
            &turns,
            &bodies,
            None,
            reduced_pressure,
        )
    }

    /// The shapes, whether each turns, and the bodies as the packing
    /// analysis takes them.
    fn packed(
        &self,
    ) -> (
        Vec<crate::geometry::Shape>,
        Vec<bool>,
        Vec<crate::analysis::packing::PackedBody>,
    ) {
        let shapes: Vec<_> = self.species.iter().map(|s| s.shape).collect();
        let turns: Vec<bool> = self.species.iter().map(|s| s.rotation).collect();
        let species_of: Vec<usize> = self.particles.iter().map(|p| p.species as usize).collect();
        let (shapes, turns, shape_of) = crate::analysis::packing::body_shapes(
            &shapes,
            &turns,
            &species_of,
            self.sizes.as_deref(),
        );
        let bodies = (self.particles.iter().zip(shape_of))
            .map(|(p, shape)| crate::analysis::packing::PackedBody {
                position: p.position,
                orientation: p.orientation,
                shape,
            })
            .collect();
        (shapes, turns, bodies)
    }
}

/// Sizes fit the particles: one finite positive factor each.
fn check_sizes(particles: &[Particle], sizes: &[f64]) -> Result<(), StateError> {
    if sizes.len() != particles.len() {
        return Err(StateError::SizesCount {
            sizes: sizes.len(),
            particles: particles.len(),
        });
    }
    if let Some(i) = sizes.iter().position(|f| !(f.is_finite() && *f > 0.0)) {
        return Err(StateError::BadSize(i, sizes[i]));
    }
    Ok(())
}
