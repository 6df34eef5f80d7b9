//! What the dynamics reports: time, energies, momentum, the state, the
//! displacements and orientational correlations, and the interval
//! sums of the collision virial.

use nalgebra::Vector3;

use crate::analysis::order::{legendre_p2, nematic_order};
use crate::edmd::motion::position_after;
use crate::space::PeriodicBox;
use crate::state::{Particle, StateError, System};

type V3 = Vector3<f64>;

use super::*;

impl Dynamics {
    /// Simulated time.
    pub fn time(&self) -> f64 {
        self.origin + self.now
    }

    /// Collisions so far.
    pub fn collisions(&self) -> u64 {
        self.collisions
    }

    /// What the collision searches have cost so far (distance
    /// evaluations and solver iterations), and what did not go the first
    /// way; counted on through frames ([`Dynamics::resynchronize`]).
    pub fn solver_work(&self) -> crate::edmd::SolverWork {
        self.predictor.work()
    }

    /// Counts the solver's work on from `work` (zero at a stage's start,
    /// a frame's counts when resumed from it).
    pub fn continue_solver_work(&mut self, work: crate::edmd::SolverWork) {
        self.predictor.continue_work(work);
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// Always false: the dynamics has bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// The box.
    pub fn periodic_box(&self) -> &PeriodicBox {
        &self.box_
    }

    /// Total kinetic energy, translational plus rotational.
    pub fn kinetic_energy(&self) -> f64 {
        self.bodies
            .iter()
            .map(|b| body_energy(b, &self.kinds))
            .sum()
    }

    /// Replaces every body's velocity and angular velocity (lab frame), as
    /// of the current time (restoring a saved state, or preparing one out
    /// of equilibrium); angular velocities of bodies that do not rotate must
    /// be zero. All events are predicted again.
    pub fn set_velocities(&mut self, velocities: &[(V3, V3)]) -> Result<(), EdmdError> {
        if velocities.len() != self.bodies.len()
            || velocities.iter().enumerate().any(|(i, (v, w))| {
                !(v.iter().all(|x| x.is_finite()) && w.iter().all(|x| x.is_finite()))
                    || (!self.kinds[self.bodies[i].species as usize].rotates && *w != V3::zeros())
            })
        {
            return Err(EdmdError::BadVelocities(self.bodies.len()));
        }
        for i in 0..self.bodies.len() {
            self.advance(i);
        }
        self.accumulate_kinetic();
        for (b, (v, w)) in self.bodies.iter_mut().zip(velocities) {
            b.velocity = *v;
            b.angular_velocity = *w;
        }
        self.kinetic_translational = self
            .bodies
            .iter()
            .map(|b| 0.5 * b.velocity.norm_squared() / self.kinds[b.species as usize].inverse_mass)
            .sum();
        for i in 0..self.bodies.len() {
            self.calendar.invalidate(i);
        }
        self.schedule_everything()
    }

    /// Translational kinetic energy.
    pub fn translational_kinetic_energy(&self) -> f64 {
        self.kinetic_translational
    }

    /// Total momentum.
    pub fn momentum(&self) -> V3 {
        self.bodies
            .iter()
            .map(|b| b.velocity / self.kinds[b.species as usize].inverse_mass)
            .sum()
    }

    /// Degrees of freedom (translations, rotations, minus the three of the
    /// fixed total momentum).
    pub fn degrees_of_freedom(&self) -> f64 {
        self.degrees_of_freedom
    }

    /// The particles at the current time, positions wrapped into the box.
    pub fn particles(&self) -> Vec<Particle> {
        particles_at(&self.box_, &self.kinds, &self.bodies, self.now)
    }

    /// The unwrapped centres and lab-frame molecular axes now.
    pub(super) fn trajectory_points(&self) -> impl Iterator<Item = (V3, Option<V3>)> + '_ {
        self.bodies.iter().zip(&self.images).map(|(b, image)| {
            let dt = self.now - b.time;
            let centre = position_after(&b.position, &b.velocity, dt) + image;
            let axis = self.molecular_axes[b.species as usize].map(|u| {
                self.kinds[b.species as usize]
                    .spin(&b.orientation, &b.angular_velocity)
                    .orientation_after(&b.orientation, dt)
                    * u
            });
            (centre, axis)
        })
    }

    /// Makes the current time the origin of the mean-squared displacement
    /// and the orientational correlation.
    pub fn set_reference(&mut self) {
        self.reference = self.trajectory_points().collect();
    }

    /// ⟨|r(t) − r(0)|²⟩ over the bodies, r unwrapped, since the reference
    /// time (the start, or the last [`Dynamics::set_reference`]).
    pub fn mean_squared_displacement(&self) -> f64 {
        let sum: f64 = self
            .trajectory_points()
            .zip(&self.reference)
            .map(|((r, _), (r0, _))| (r - r0).norm_squared())
            .sum();
        sum / self.bodies.len() as f64
    }

    /// C₂(t) = ⟨P₂(u(0)·u(t))⟩ of the molecular axes since the reference
    /// time; `None` without rotating anisotropic bodies.
    pub fn orientational_correlation(&self) -> Option<f64> {
        let (sum, count) = self
            .trajectory_points()
            .zip(&self.reference)
            .filter_map(|((_, u), (_, u0))| Some(legendre_p2(u?.dot(&(*u0)?))))
            .fold((0.0, 0usize), |(s, c), p| (s + p, c + 1));
        (count > 0).then(|| sum / count as f64)
    }

    /// S₂ of the molecular axes now.
    pub fn nematic_order(&self) -> Option<f64> {
        nematic_order(self.trajectory_points().filter_map(|(_, u)| u))
    }

    /// Velocities and angular velocities (lab frame) at the current time.
    pub fn velocities(&self) -> Vec<(V3, V3)> {
        self.bodies
            .iter()
            .map(|b| (b.velocity, b.angular_velocity))
            .collect()
    }

    /// The current state as an MC system: building it checks, independently
    /// of the predictions, that no two bodies overlap. Growing bodies have
    /// their size now.
    pub fn to_system(&self) -> Result<System, StateError> {
        let tolerance = self.predictor.contact_tolerance();
        System::with_touching(self.box_, self.species_now(), self.particles(), tolerance)
    }

    /// The species the dynamics was built with: for growing bodies, the
    /// largest they become ([`Dynamics::species_now`] has their size now).
    /// With [`Dynamics::dump`] and [`Dynamics::options`], what
    /// [`Dynamics::from_dump`] replays a run from.
    pub fn species(&self) -> &[Species] {
        &self.species
    }

    /// The options the dynamics runs with.
    pub fn options(&self) -> &DynamicsOptions {
        &self.options
    }

    /// The species with the bodies' shapes now (scaled, if they grow).
    pub fn species_now(&self) -> Vec<Species> {
        scaled_species(&self.species, self.scale_now())
    }

    /// The bodies' scale now relative to their species' shapes (1 unless
    /// they grow).
    #[inline]
    pub(super) fn scale_now(&self) -> f64 {
        self.growth.map_or(1.0, |g| g.at(self.now))
    }

    /// When growing bodies reach the size the dynamics was built for (the
    /// end of [`Dynamics::growing`]'s margin), on the simulated clock;
    /// `None` if they do not grow. The dynamics must not run past it.
    pub fn growth_ends(&self) -> Option<f64> {
        self.growth.map(|g| self.origin + g.ends())
    }

    /// Starts (or stops) recording every collision: time, and the pair as
    /// (lower index, higher index). For comparing trajectories.
    pub fn record_collisions(&mut self, on: bool) {
        self.trace = on.then(Vec::new);
    }

    /// The collisions recorded since the last call.
    pub fn take_collisions(&mut self) -> Vec<(f64, u32, u32)> {
        self.trace.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// The sums since the last sample.
    pub fn interval(&self) -> Interval {
        self.interval
    }

    /// Continues the sums of an interval recorded by [`Dynamics::interval`]
    /// at the same state (a resumed run).
    pub fn continue_interval(&mut self, interval: Interval) {
        self.interval = interval;
    }

    /// Observables over the interval since the previous sample (or the
    /// start), and a new interval begins.
    pub fn sample(&mut self) -> Sample {
        self.accumulate_kinetic();
        let iv = self.interval;
        let dt = self.now - iv.start;
        let kt = 2.0 * self.kinetic_energy() / self.degrees_of_freedom;
        let pressure = (dt > 0.0).then(|| {
            if self.box_.has_walls() {
                // The force per area the walls take, over the walled axes.
                let walls = self.box_.walls();
                let l = self.box_.lengths();
                let (sum, count) = (0..3).filter(|&k| walls[k]).fold((0.0, 0.0), |(s, c), k| {
                    let area = self.box_.volume() / l[k];
                    (s + iv.wall_impulse[k] / (2.0 * dt * area), c + 1.0)
                });
                sum / count / kt
            } else {
                let pv = (2.0 / 3.0) * iv.ke_integral / dt + iv.virial / (3.0 * dt);
                pv / (self.box_.volume() * kt)
            }
        });
        self.interval = Interval {
            start: self.now,
            ke_since: self.now,
            ..Interval::default()
        };
        Sample {
            time: self.time(),
            collisions: self.collisions,
            interval_collisions: iv.collisions,
            pressure,
            temperature: kt,
            packing_fraction: self.packing_fraction * self.scale_now().powi(3),
            nematic_order: self.nematic_order(),
        }
    }

    pub(super) fn accumulate_kinetic(&mut self) {
        let iv = &mut self.interval;
        iv.ke_integral += self.kinetic_translational * (self.now - iv.ke_since);
        iv.ke_since = self.now;
    }
}

/// The bodies as particles at time `now`, centres wrapped into the box.
pub(super) fn particles_at(
    box_: &PeriodicBox,
    kinds: &[Kind],
    bodies: &[Body],
    now: f64,
) -> Vec<Particle> {
    bodies
        .iter()
        .map(|b| {
            let (r, q) = body_pose(kinds, b, now);
            Particle {
                position: box_.wrap(&r),
                orientation: q,
                species: b.species,
            }
        })
        .collect()
}

/// Degrees of freedom of `n` bodies, `rotors` of them turning: total
/// momentum is conserved (and zero) along each periodic axis only; walls
/// exchange momentum with the bodies.
pub(super) fn degrees_of_freedom(box_: &PeriodicBox, n: usize, rotors: usize) -> f64 {
    let periodic = box_.walls().iter().filter(|&&w| !w).count();
    (3 * n - periodic + 3 * rotors) as f64
}

/// Kinetic energy of one body (spherical top).
pub(super) fn body_energy(b: &Body, kinds: &[Kind]) -> f64 {
    let k = &kinds[b.species as usize];
    let rot = k.rotational_energy(&b.orientation, &b.angular_velocity);
    0.5 * b.velocity.norm_squared() / k.inverse_mass + rot
}
