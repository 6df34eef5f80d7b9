//! Building the dynamics: from a state, from its parts or from a dump,
//! and the first predictions of every event.

use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;

use crate::edmd::calendar::Calendar;
use crate::edmd::motion::position_after;
use crate::edmd::predict::Predictor;
use crate::geometry::pair::contact_sum;
use crate::space::{CellList, NeighbourLists, PeriodicBox};
use crate::state::sizes::species_at_largest;
use crate::state::{Species, System};

type V3 = Vector3<f64>;

use super::*;

impl Dynamics {
    /// Dynamics from an MC state with Maxwell–Boltzmann velocities at the
    /// temperature of `options`, zero total momentum, and the kinetic energy
    /// set exactly to dof · kT / 2.
    pub fn from_state<R: Rng>(
        system: &System,
        options: &DynamicsOptions,
        rng: &mut R,
    ) -> Result<Self, EdmdError> {
        let t = options.temperature;
        if !(t.is_finite() && t > 0.0) {
            return Err(EdmdError::BadTemperature(t));
        }
        let n = system.len();
        if n < 2 {
            return Err(EdmdError::TooFewParticles(n));
        }
        let species = system.species().to_vec();
        let mut kinds = kinds_for(&species, options)?;
        let own = body_kinds(&mut kinds, (&species, options), system);
        let mut bodies: Vec<Body> = system
            .particles()
            .iter()
            .zip(&own)
            .map(|(p, &own)| {
                let kind = &kinds[own as usize];
                let gauss = |rng: &mut R| {
                    V3::new(
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                    )
                };
                let velocity = gauss(rng) * (t * kind.inverse_mass).sqrt();
                // Equipartition about each principal axis, then to the lab.
                // The spin no collision changes starts at zero: it would
                // keep its draw for ever.
                let angular_velocity = if kind.rotates {
                    p.orientation
                        * kind.exchanged_spin(
                            gauss(rng).component_mul(&kind.moments.map(|i| (t / i).sqrt())),
                        )
                } else {
                    V3::zeros()
                };
                Body {
                    position: p.position,
                    velocity,
                    time: 0.0,
                    orientation: p.orientation,
                    angular_velocity,
                    species: p.species,
                    kind: own,
                    horizon: f64::INFINITY,
                }
            })
            .collect();
        // Zero total momentum, then the exact kinetic energy.
        let total_mass: f64 = bodies
            .iter()
            .map(|b| 1.0 / kinds[b.kind as usize].inverse_mass)
            .sum();
        let momentum: V3 = bodies
            .iter()
            .map(|b| b.velocity / kinds[b.kind as usize].inverse_mass)
            .sum();
        let drift = momentum / total_mass;
        let rotations = exchanged_rotations(&bodies, &kinds);
        let dof = degrees_of_freedom(system.periodic_box(), n, rotations);
        for b in &mut bodies {
            b.velocity -= drift;
        }
        let energy: f64 = bodies.iter().map(|b| body_energy(b, &kinds)).sum();
        let scale = (0.5 * dof * t / energy).sqrt();
        for b in &mut bodies {
            b.velocity *= scale;
            b.angular_velocity *= scale;
        }
        Self::assemble(system, species, kinds, bodies, options, 0.0, None)
    }

    /// The dynamics of `system` with the velocities given, its bodies
    /// growing (Lubachevsky–Stillinger) so that each one's linear size is
    /// its size in `system` times 1 + `rate` t, up to the time
    /// ([`Dynamics::growth_ends`]) at which it is 1 + `margin` times that:
    /// the dynamics is built for bodies of that size (cells and neighbour
    /// regions), so it must not be run past it. Moments of inertia are
    /// those of the largest bodies.
    pub fn growing(
        system: &System,
        velocities: &[(V3, V3)],
        options: &DynamicsOptions,
        rate: f64,
        margin: f64,
    ) -> Result<Self, EdmdError> {
        if !(rate.is_finite() && rate > 0.0 && margin.is_finite() && margin > 0.0) {
            return Err(EdmdError::BadGrowth { rate, margin });
        }
        let n = system.len();
        if n < 2 {
            return Err(EdmdError::TooFewParticles(n));
        }
        let largest = 1.0 + margin;
        let species = scaled_species(system.species(), largest);
        let mut kinds = kinds_for(&species, options)?;
        let bodies = bodies_moving(system, velocities, (&species, options), &mut kinds)?;
        let growth = Growth {
            scale: 1.0 / largest,
            rate: rate / largest,
        };
        Self::assemble(system, species, kinds, bodies, options, 0.0, Some(growth))
    }

    /// The dynamics of `system` with velocities and angular velocities
    /// (lab frame) given, at simulated time `time` after `collisions`
    /// collisions: what a frame of a log holds. Building from the state
    /// [`Dynamics::resynchronize`] leaves gives the same dynamics bit for
    /// bit.
    pub fn from_parts(
        system: &System,
        velocities: &[(V3, V3)],
        options: &DynamicsOptions,
        time: f64,
        collisions: u64,
    ) -> Result<Self, EdmdError> {
        let n = system.len();
        if n < 2 {
            return Err(EdmdError::TooFewParticles(n));
        }
        let species = system.species().to_vec();
        let mut kinds = kinds_for(&species, options)?;
        let bodies = bodies_moving(system, velocities, (&species, options), &mut kinds)?;
        let mut dynamics = Self::assemble(system, species, kinds, bodies, options, 0.0, None)?;
        dynamics.origin = time;
        dynamics.collisions = collisions;
        dynamics.collisions_at_rebase = collisions;
        Ok(dynamics)
    }

    /// Every body's stored pose and time, and the clock: what
    /// [`Dynamics::from_dump`] rebuilds the predictions from, bit for bit.
    pub fn dump(&self) -> DynamicsDump {
        let triple = |v: &V3| [v.x, v.y, v.z];
        DynamicsDump {
            time_origin: self.origin,
            now: self.now,
            collisions: self.collisions,
            collisions_at_rebase: self.collisions_at_rebase,
            box_lengths: triple(&self.box_.lengths()),
            tilts: triple(&self.box_.tilts()),
            walls: self.box_.walls(),
            bodies: self
                .bodies
                .iter()
                .map(|b| {
                    let q = b.orientation.quaternion();
                    BodyDump {
                        species: b.species,
                        time: b.time,
                        position: triple(&b.position),
                        orientation: [q.w, q.i, q.j, q.k],
                        velocity: triple(&b.velocity),
                        angular_velocity: triple(&b.angular_velocity),
                    }
                })
                .collect(),
            growth: self.growth,
            sizes: self.sizes.clone(),
        }
    }

    /// The dynamics a [`Dynamics::dump`] was taken from, with every event
    /// predicted again from the dumped stored poses: the events it had
    /// scheduled come back at the same times (to replay a failure). The
    /// species and options must be those of the dumped run.
    pub fn from_dump(
        species: &[Species],
        dump: &DynamicsDump,
        options: &DynamicsOptions,
    ) -> Result<Self, EdmdError> {
        let n = dump.bodies.len();
        if n < 2 {
            return Err(EdmdError::TooFewParticles(n));
        }
        let mut kinds = kinds_for(species, options)?;
        let bad = |why: String| EdmdError::BadDump(why);
        if !(dump.now.is_finite() && dump.time_origin.is_finite()) {
            return Err(bad(format!(
                "clock {} + {} is not finite",
                dump.time_origin, dump.now
            )));
        }
        let mut bodies = Vec::with_capacity(n);
        for (k, b) in dump.bodies.iter().enumerate() {
            let fields: [(&str, &[f64]); 4] = [
                ("position", &b.position),
                ("orientation", &b.orientation),
                ("velocity", &b.velocity),
                ("angular_velocity", &b.angular_velocity),
            ];
            if let Some((name, value)) = fields
                .iter()
                .find(|(_, v)| !v.iter().all(|x| x.is_finite()))
            {
                return Err(bad(format!("body {k}: {name} {value:?} is not finite")));
            }
            if !b.time.is_finite() || b.time > dump.now {
                return Err(bad(format!(
                    "body {k}: its time {} must be finite and at most now ({})",
                    b.time, dump.now
                )));
            }
            let Some(kind) = kinds.get(b.species as usize) else {
                return Err(bad(format!(
                    "body {k}: species {} of {}",
                    b.species,
                    kinds.len()
                )));
            };
            let [w, x, y, z] = b.orientation;
            let q = nalgebra::Quaternion::new(w, x, y, z);
            if (q.norm() - 1.0).abs() > 1e-9 {
                return Err(bad(format!(
                    "body {k}: orientation {:?} is not a unit quaternion",
                    b.orientation
                )));
            }
            let angular_velocity = V3::from(b.angular_velocity);
            if !kind.rotates && angular_velocity != V3::zeros() {
                return Err(EdmdError::BadVelocities(n));
            }
            bodies.push(Body {
                position: V3::from(b.position),
                velocity: V3::from(b.velocity),
                time: b.time,
                // As stored, to the bit (renormalising would move it).
                orientation: UnitQuaternion::new_unchecked(q),
                angular_velocity,
                species: b.species,
                kind: u32::from(b.species),
                horizon: f64::INFINITY,
            });
        }
        let box_ = PeriodicBox::triclinic(V3::from(dump.box_lengths), V3::from(dump.tilts))
            .and_then(|b| b.with_walls(dump.walls))
            .map_err(|e| bad(format!("box: {e}")))?;
        if let Some(g) = dump.growth {
            let scale = g.at(dump.now);
            if !(g.rate.is_finite() && g.rate > 0.0 && scale > 0.0 && scale <= 1.0) {
                return Err(bad(format!(
                    "growth at rate {} to scale {scale} now: not a growth a dynamics runs",
                    g.rate
                )));
            }
        }
        if let Some(sizes) = &dump.sizes
            && sizes.len() != n
        {
            return Err(bad(format!("{} sizes for {n} bodies", sizes.len())));
        }
        let own = own_kinds(
            &mut kinds,
            (species, options),
            dump.sizes.as_deref(),
            &bodies,
        );
        for (b, own) in bodies.iter_mut().zip(own) {
            b.kind = own;
        }
        let particles = particles_at(&box_, &kinds, &bodies, dump.now);
        // Growing bodies have their size now in the state; the dynamics
        // keeps the largest shapes.
        let now_species = scaled_species(species, dump.growth.map_or(1.0, |g| g.at(dump.now)));
        // The dumped state is the dynamics' own, its failure included (a
        // pair overlapping where a contact was missed): it is replayed, not
        // judged again.
        let sizes = dump.sizes.clone();
        let system = System::with_contacts(box_, now_species, particles, sizes, |_, _| true)?;
        let mut dynamics = Self::assemble(
            &system,
            species.to_vec(),
            kinds,
            bodies,
            options,
            dump.now,
            dump.growth,
        )?;
        dynamics.origin = dump.time_origin;
        dynamics.collisions = dump.collisions;
        dynamics.collisions_at_rebase = dump.collisions_at_rebase.min(dump.collisions);
        Ok(dynamics)
    }

    /// Advances every body to now and predicts every event again from that
    /// state, as [`Dynamics::from_parts`] would from a frame written now:
    /// a run that does this at each frame and a run resumed from any of
    /// those frames follow the same trajectory bit for bit. Observables
    /// (the interval's sums, MSD and C₂ references) carry over.
    pub fn resynchronize(&mut self) -> Result<(), EdmdError> {
        let system = self.to_system()?;
        let unwrapped: Vec<V3> = self.trajectory_points().map(|(r, _)| r).collect();
        let mut next = Self::from_parts(
            &system,
            &self.velocities(),
            &self.options,
            self.time(),
            self.collisions,
        )?;
        next.interval = Interval {
            start: self.interval.start - self.now,
            ke_since: self.interval.ke_since - self.now,
            ..self.interval
        };
        for ((image, r), b) in next.images.iter_mut().zip(&unwrapped).zip(&next.bodies) {
            *image = r - b.position;
        }
        next.predictor.continue_work(self.predictor.work());
        next.reference = std::mem::take(&mut self.reference);
        next.trace = self.trace.take();
        *self = next;
        Ok(())
    }

    /// Everything but the velocities: cells, calendar, first predictions,
    /// with the clock at `now` (the bodies' stored times are at most it),
    /// the bodies growing as `growth` says (`system` then holds them at
    /// their size now).
    pub(super) fn assemble(
        system: &System,
        species: Vec<Species>,
        mut kinds: Vec<Kind>,
        bodies: Vec<Body>,
        options: &DynamicsOptions,
        now: f64,
        growth: Option<Growth>,
    ) -> Result<Self, EdmdError> {
        let n = bodies.len();
        let sizes = system.sizes().map(<[f64]>::to_vec);
        let ns = species.len();
        let spheres_only = species.iter().all(|s| s.shape.is_sphere());
        // What the neighbour structures must hold: each species' largest
        // body.
        let largest: Vec<Shape> = match &sizes {
            Some(sizes) => species_at_largest(&species, bodies.iter().map(|b| b.species), sizes)
                .into_iter()
                .map(|s| s.shape)
                .collect(),
            None => kinds[..ns].iter().map(|k| k.shape).collect(),
        };
        let body_radii = match &sizes {
            Some(sizes) if spheres_only => {
                for (kind, shape) in kinds.iter_mut().zip(&largest) {
                    kind.shape = *shape;
                }
                (bodies.iter().zip(sizes))
                    .map(|(b, f)| species[b.species as usize].shape.bounding_radius() * f)
                    .collect()
            }
            // Each body's kind is at its size.
            Some(_) => bodies
                .iter()
                .map(|b| kinds[b.kind as usize].shape.bounding_radius())
                .collect(),
            None => Vec::new(),
        };
        let rotations = exchanged_rotations(&bodies, &kinds);
        let dof = degrees_of_freedom(system.periodic_box(), n, rotations);
        let rotating = kinds.iter().any(|k| k.rotates);
        let contact_sums: Vec<Option<f64>> = (0..ns * ns)
            .map(|k| contact_sum(&species[k / ns].shape, &species[k % ns].shape))
            .collect();
        let box_ = *system.periodic_box();
        if let Some(shell) = options.neighbour_shell
            && !(shell.is_finite() && shell > 0.0)
        {
            return Err(EdmdError::BadShell(shell));
        }
        let shell = options.neighbour_shell.unwrap_or(0.0);
        // Spheres keep spheres; any other system gets oriented boxes.
        let box_regions = options.neighbour_shell.is_some() && !spheres_only;
        let box_half: Vec<V3> = largest
            .iter()
            .map(|shape| shape.obb_half_extents().add_scalar(shell))
            .collect();
        let reach: Vec<f64> = if box_regions {
            box_half.iter().map(|h| h.norm()).collect()
        } else {
            largest
                .iter()
                .map(|shape| shape.bounding_radius() + shell)
                .collect()
        };
        let range = 2.0 * reach.iter().copied().fold(0.0, f64::max);
        // Where the bodies are now (their stored poses, at a fresh start).
        let poses: Vec<(V3, UnitQuaternion<f64>)> = bodies
            .iter()
            .map(|b| {
                if b.time == now {
                    return (b.position, b.orientation);
                }
                let (r, q) = body_pose(&kinds, b, now);
                (box_.wrap(&r), q)
            })
            .collect();
        let positions: Vec<V3> = poses.iter().map(|(r, _)| *r).collect();
        // Per body: what brings the stored position into the image of the
        // cell it is in now (whole lattice vectors).
        let cell_shifts: Vec<V3> = bodies
            .iter()
            .zip(&positions)
            .map(|(b, r)| {
                let moved = position_after(&b.position, &b.velocity, now - b.time);
                -box_.image_shift(&(r - moved))
            })
            .collect();
        let cells = CellList::new(&box_, range, &positions);
        let cell_lengths = cells.cell_lengths();
        let neighbours = match options.neighbour_shell {
            Some(shell) => {
                let regions = if box_regions {
                    let axes = poses
                        .iter()
                        .map(|(_, q)| q.to_rotation_matrix().into_inner())
                        .collect();
                    Regions::Boxes {
                        half: box_half,
                        axes,
                    }
                } else {
                    Regions::Spheres
                };
                let body_reach = match regions {
                    Regions::Spheres => body_radii.iter().map(|r| r + shell).collect(),
                    Regions::Boxes { .. } => Vec::new(),
                };
                let mut spheres = NeighbourSpheres {
                    shell,
                    reach,
                    body_reach,
                    centres: positions,
                    regions,
                    lists: NeighbourLists::new(n, 16),
                    marks: Marks::new(n),
                };
                for i in 0..n {
                    link_overlapping(i, true, &box_, &cells, &bodies, &mut spheres);
                }
                Some(spheres)
            }
            None => None,
        };
        let kinetic = kinetic_tensor(&bodies, &kinds);
        // Along an axis of fewer than four cells, a pair's separation can
        // pass from one periodic image to the next before either body
        // leaves its cell: such pairs are searched in each image they can
        // reach (`image_steps`), until their next crossings. Neighbour
        // regions (at most `range` across, the cells at least as wide)
        // overlap in one image only unless the axis holds a single cell.
        let fewest = if options.neighbour_shell.is_some() {
            2
        } else {
            4
        };
        let narrow = cells.dims().map(|n| n < fewest);
        let closed_form = contact_sums.iter().all(Option::is_some) && !narrow.contains(&true);
        let mut dynamics = Self {
            box_,
            closed_form,
            narrow,
            contact_sums,
            sizes,
            body_radii,
            cells,
            cell_lengths,
            neighbours,
            candidates: Vec::new(),
            around: Box::new([0; AROUND]),
            cell_shifts,
            calendar: Calendar::new(n),
            predictor: Predictor::new(options.predictor),
            now,
            origin: 0.0,
            collisions_at_rebase: 0,
            collisions: 0,
            interval: Interval::default(),
            kinetic,
            degrees_of_freedom: dof,
            // At the species' sizes.
            packing_fraction: system.packing_fraction() / growth.map_or(1.0, |g| g.at(now)).powi(3),
            rotating,
            options: options.clone(),
            trace: None,
            deferred: Vec::new(),
            found: std::collections::HashMap::new(),
            molecular_axes: Vec::new(),
            images: vec![V3::zeros(); n],
            reference: Vec::new(),
            events_at_now: 0,
            futile: (0, 0, 0),
            species,
            kinds,
            bodies,
            tops: Vec::new(),
            crossing_times: vec![f64::INFINITY; n],
            growth,
        };
        dynamics.molecular_axes = dynamics.species.iter().map(Species::order_axis).collect();
        dynamics.set_reference();
        dynamics.schedule_everything()?;
        Ok(dynamics)
    }

    /// Predicts every crossing and every pair collision from scratch.
    pub(super) fn schedule_everything(&mut self) -> Result<(), EdmdError> {
        self.calendar.clear();
        // The horizons belong to the predictions dropped: a search cut at
        // one would miss what the new ones find beyond it.
        for b in &mut self.bodies {
            b.horizon = f64::INFINITY;
        }
        if !self.closed_form {
            self.tops = self
                .bodies
                .iter()
                .map(|b| body_spin(&self.kinds, b))
                .collect();
        }
        for i in 0..self.bodies.len() {
            self.schedule_crossing(i);
        }
        for i in 0..self.bodies.len() {
            self.schedule_collisions(i, None, true)?;
        }
        Ok(())
    }
}

/// Links body `i` to every body whose neighbour region overlaps its own:
/// its list becomes exactly those (`after`: links only those of higher
/// index, to a list built in order of index, for the first build).
pub(super) fn link_overlapping(
    i: usize,
    after: bool,
    box_: &PeriodicBox,
    cells: &CellList,
    bodies: &[Body],
    spheres: &mut NeighbourSpheres,
) {
    let cell = cells.cell_of(i);
    let images = cells.neighbour_images(cell);
    let overlapping = |into: &mut [u32]| match &images {
        // Each neighbour cell's members brought next to i's by whole
        // lattice vectors, where the box is three cells wide or more.
        // Cells wholly out of reach are skipped.
        Some(images) => {
            let l = box_.lengths();
            let reach = &spheres.reach;
            // Room for rounding: only cells no member of which can pass.
            let limit = 1.000_001
                * (reach[bodies[i].species as usize] + reach.iter().copied().fold(0.0, f64::max));
            let within = cells.neighbours_within(cell, &spheres.centres[i], limit);
            let around = images
                .iter()
                .enumerate()
                .filter(|&(k, _)| within & (1 << k) != 0)
                .map(|(_, &(nc, wrap))| {
                    let image = box_.shear(&V3::from_fn(|k, _| f64::from(wrap[k]) * l[k]));
                    (cells.members(nc as usize), image)
                });
            overlapping_in(i, after, around, spheres, bodies, |d| d, into)
        }
        // Else the minimum image of each (centres are wrapped into the
        // box: its near form, without a rounding call).
        None => {
            let around = cells
                .neighbour_cells(cell)
                .into_iter()
                .map(|nc| (cells.members(nc as usize), V3::zeros()));
            let image = |d: V3| box_.minimum_image_near(&d);
            overlapping_in(i, after, around, spheres, bodies, image, into)
        }
    };
    let mut near = [0u32; 64];
    let mut more;
    let near = match overlapping(&mut near) {
        Some(count) => &mut near[..count],
        None => {
            // More than fit (a crowd of small bodies around a large one):
            // room for every candidate.
            let candidates = cells.neighbour_cells(cell).into_iter();
            more = vec![0u32; candidates.map(|nc| cells.members(nc as usize).len()).sum()];
            let count = overlapping(&mut more).expect("room for every candidate");
            &mut more[..count]
        }
    };
    let near = keep_box_overlaps(i, near, box_, bodies, spheres);
    if !after {
        if matches!(spheres.regions, Regions::Spheres) {
            spheres.lists.relink(i, near, &mut spheres.marks);
            return;
        }
        // A body's search meets its partners in its list's order, and
        // what a run of bodies logs depends on it (pinned to the bit by
        // the reference states): each neighbour drops `i` and lists it
        // again last.
        spheres.lists.unlink_all(i);
    }
    for &j in near {
        spheres.lists.link(i, j as usize);
    }
}

/// [`overlapping_into`] with the contact distance of each pair: one for
/// one species, without reading the second cache line of every
/// candidate's body for its species.
#[inline(always)]
fn overlapping_in<'a>(
    i: usize,
    after: bool,
    cells: impl Iterator<Item = (&'a [u32], V3)>,
    spheres: &NeighbourSpheres,
    bodies: &[Body],
    image: impl Fn(V3) -> V3,
    into: &mut [u32],
) -> Option<usize> {
    let reach = &spheres.reach;
    let reach_i = reach[bodies[i].species as usize];
    let centres = &spheres.centres;
    if let Some(own) = spheres.body_reach.get(i) {
        let body_reach = &spheres.body_reach;
        let contact = |j: usize| own + body_reach[j];
        overlapping_into(i, after, cells, centres, image, contact, into)
    } else if reach.len() == 1 {
        let contact = reach_i + reach[0];
        overlapping_into(i, after, cells, centres, image, |_| contact, into)
    } else {
        let contact = |j: usize| reach_i + reach[bodies[j].species as usize];
        overlapping_into(i, after, cells, centres, image, contact, into)
    }
}

/// The bodies among the members of `cells` whose neighbour spheres
/// (centred at `centres`) overlap body `i`'s, `contact(j)` apart at most,
/// in `into`, and how many; `None` if they do not fit. Each cell comes
/// with the shift that brings its members next to `i`, and `image` makes
/// a separation the shortest. Without a branch per candidate (a few in
/// ten are, at random: a branch on it would mispredict often).
#[inline(always)]
fn overlapping_into<'a>(
    i: usize,
    after: bool,
    cells: impl Iterator<Item = (&'a [u32], V3)>,
    centres: &[V3],
    image: impl Fn(V3) -> V3,
    contact: impl Fn(usize) -> f64,
    into: &mut [u32],
) -> Option<usize> {
    let centre = centres[i];
    let mut count = 0;
    for (members, shift) in cells {
        let from = centre - shift;
        for &j in members {
            let j = j as usize;
            let d = image(centres[j] - from);
            let contact = contact(j);
            let wanted = (j != i) & !(after & (j < i));
            *into.get_mut(count)? = j as u32;
            count += usize::from(wanted & (d.norm_squared() <= contact * contact));
        }
    }
    Some(count)
}

/// Those of `near` (bodies whose neighbour spheres overlap body `i`'s)
/// whose neighbour boxes, where there are boxes, overlap `i`'s too: moved
/// to the front of `near`, in their order.
fn keep_box_overlaps<'a>(
    i: usize,
    near: &'a mut [u32],
    box_: &PeriodicBox,
    bodies: &[Body],
    spheres: &NeighbourSpheres,
) -> &'a [u32] {
    let Regions::Boxes { half, axes } = &spheres.regions else {
        return near;
    };
    let si = bodies[i].species as usize;
    let mut kept = 0;
    for k in 0..near.len() {
        let j = near[k] as usize;
        let sj = bodies[j].species as usize;
        let d = box_.minimum_image_near(&(spheres.centres[j] - spheres.centres[i]));
        // The 15-axis test in i's box frame (De Michele eqs. 62–64).
        if crate::geometry::obb::boxes_overlap(
            &half[si],
            &half[sj],
            &axes[i].tr_mul(&axes[j]),
            &axes[i].tr_mul(&d),
        ) {
            near[kept] = j as u32;
            kept += 1;
        }
    }
    &near[..kept]
}

/// The bodies of `system` at rest in their stored poses at time 0, moving
/// with `velocities` (checked: finite, one pair per body, no spin for
/// bodies that do not turn).
fn bodies_moving(
    system: &System,
    velocities: &[(V3, V3)],
    species: (&[Species], &DynamicsOptions),
    kinds: &mut Vec<Kind>,
) -> Result<Vec<Body>, EdmdError> {
    let n = system.len();
    let own = body_kinds(kinds, species, system);
    if velocities.len() != n
        || velocities
            .iter()
            .zip(system.particles())
            .any(|((v, w), p)| {
                !(v.iter().all(|x| x.is_finite()) && w.iter().all(|x| x.is_finite()))
                    || (!kinds[p.species as usize].rotates && *w != V3::zeros())
            })
    {
        return Err(EdmdError::BadVelocities(n));
    }
    Ok(system
        .particles()
        .iter()
        .zip(velocities)
        .zip(own)
        .map(|((p, (v, w)), own)| Body {
            position: p.position,
            velocity: *v,
            time: 0.0,
            orientation: p.orientation,
            angular_velocity: *w,
            species: p.species,
            kind: own,
            horizon: f64::INFINITY,
        })
        .collect())
}
