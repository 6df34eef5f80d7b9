//! What the dynamics reports: time, energies, momentum, the state, the
//! displacements and orientational correlations, and the interval
//! sums of the collision virial and the pressure tensor.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::analysis::order::{legendre_p2, nematic_order};
use crate::edmd::motion::position_after;
use crate::space::PeriodicBox;
use crate::state::{Particle, StateError, System};

type V3 = Vector3<f64>;

use super::*;

/// A symmetric 3×3 tensor in the order HOOMD-blue gives its pressure
/// tensor: (xx, xy, xz, yy, yz, zz).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct SymmetricTensor(pub [f64; 6]);

impl SymmetricTensor {
    /// Adds `scale` times the symmetric part of a ⊗ b.
    #[inline]
    pub fn add_outer(&mut self, a: &V3, b: &V3, scale: f64) {
        let t = &mut self.0;
        t[0] += scale * a.x * b.x;
        t[1] += scale * 0.5 * (a.x * b.y + a.y * b.x);
        t[2] += scale * 0.5 * (a.x * b.z + a.z * b.x);
        t[3] += scale * a.y * b.y;
        t[4] += scale * 0.5 * (a.y * b.z + a.z * b.y);
        t[5] += scale * a.z * b.z;
    }

    /// Adds `scale` times `other`.
    #[inline]
    pub fn add_scaled(&mut self, other: &Self, scale: f64) {
        for (t, o) in self.0.iter_mut().zip(&other.0) {
            *t += scale * o;
        }
    }

    /// xx + yy + zz.
    #[inline]
    pub fn trace(&self) -> f64 {
        self.0[0] + self.0[3] + self.0[5]
    }
}

/// Counters and sums over the interval since the last sample (times on
/// the dynamics' own clock): what a frame records so that a resumed run's
/// first sample covers the same interval as the uninterrupted run's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    /// When the interval began.
    pub start: f64,
    /// Collisions in it.
    pub collisions: u64,
    /// Σ (r_B − r_A)·J over collisions, J the impulse on B.
    pub virial: f64,
    /// ∫ (translational kinetic energy) dt, up to `ke_since`.
    pub ke_integral: f64,
    /// See `ke_integral`.
    pub ke_since: f64,
    /// Impulse taken by the two walls of each axis.
    pub wall_impulse: [f64; 3],
    /// The sums the pressure tensor is made of; `None` in an interval
    /// resumed from a frame written before they were recorded (that
    /// interval reports no tensor).
    #[serde(default)]
    pub stress: Option<StressSums>,
}

impl Interval {
    /// An empty interval beginning at `start`.
    pub fn starting(start: f64) -> Self {
        Self {
            start,
            collisions: 0,
            virial: 0.0,
            ke_integral: 0.0,
            ke_since: start,
            wall_impulse: [0.0; 3],
            stress: Some(StressSums::default()),
        }
    }
}

impl Default for Interval {
    fn default() -> Self {
        Self::starting(0.0)
    }
}

/// The interval's sums of the pressure tensor
/// P V = ⟨Σ m v⊗v⟩ + Σ (r_B − r_A) ⊗ J / Δt (symmetric part).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct StressSums {
    /// ∫ Σ m v⊗v dt, up to the interval's `ke_since`.
    pub kinetic: SymmetricTensor,
    /// Σ over collisions of the symmetric part of (r_B − r_A) ⊗ J.
    pub virial: SymmetricTensor,
}

/// Observables over the interval since the previous sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Simulated time.
    pub time: f64,
    /// Collisions since the start of the run.
    pub collisions: u64,
    /// Collisions in the interval.
    pub interval_collisions: u64,
    /// βP from the collision virial over the interval:
    /// P V = ⅔⟨K_trans⟩ + Σ r_AB·J / (3 Δt), β = 1/kT.
    pub pressure: Option<f64>,
    /// βP_αβ from the same sums (`pressure` is a third of its trace);
    /// `None` with walls, or over an interval resumed from a frame that
    /// did not record the tensor's sums.
    pub pressure_tensor: Option<SymmetricTensor>,
    /// kT = 2K / dof.
    pub temperature: f64,
    /// φ.
    pub packing_fraction: f64,
    /// S₂ of the molecular axes of the rotating anisotropic bodies; `None`
    /// if there are none.
    pub nematic_order: Option<f64>,
}

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
                    || (!self.kinds[self.bodies[i].kind as usize].rotates && *w != V3::zeros())
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
        self.kinetic = kinetic_tensor(&self.bodies, &self.kinds);
        for i in 0..self.bodies.len() {
            self.calendar.invalidate(i);
        }
        self.schedule_everything()
    }

    /// Translational kinetic energy.
    pub fn translational_kinetic_energy(&self) -> f64 {
        0.5 * self.kinetic.trace()
    }

    /// Total momentum.
    pub fn momentum(&self) -> V3 {
        self.bodies
            .iter()
            .map(|b| b.velocity / self.kinds[b.kind as usize].inverse_mass)
            .sum()
    }

    /// Degrees of freedom (translations, the rotations collisions exchange,
    /// minus the three of the fixed total momentum): a body of revolution
    /// turns with two, a sphere with none (see [`Dynamics::temperature`]).
    pub fn degrees_of_freedom(&self) -> f64 {
        self.degrees_of_freedom
    }

    /// kT: twice the kinetic energy of the degrees of freedom over their
    /// number. The spin of a body of revolution about its axis (of a
    /// sphere, all its spin) is left out: no collision changes it, so it
    /// keeps whatever it started with and is no part of the equilibrium.
    pub fn temperature(&self) -> f64 {
        let frozen: f64 = (self.bodies.iter())
            .map(|b| self.kinds[b.kind as usize].frozen_energy(&b.orientation, &b.angular_velocity))
            .sum();
        2.0 * (self.kinetic_energy() - frozen) / self.degrees_of_freedom
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
                self.kinds[b.kind as usize]
                    .spin(&b.orientation, &b.angular_velocity)
                    .orientation_after(dt)
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

    /// Velocities and angular velocities (lab frame) at the current time:
    /// a body that is not a spherical top turns its ω with it between
    /// events (L is what stays).
    pub fn velocities(&self) -> Vec<(V3, V3)> {
        (0..self.bodies.len())
            .map(|i| (self.bodies[i].velocity, self.angular_velocity_now(i)))
            .collect()
    }

    /// Body `i`'s lab angular velocity now.
    fn angular_velocity_now(&self, i: usize) -> V3 {
        let b = &self.bodies[i];
        let dt = self.now - b.time;
        if dt == 0.0 || b.angular_velocity == V3::zeros() {
            return b.angular_velocity;
        }
        let top = self.top(i);
        top.angular_velocity(&top.orientation_after(dt))
    }

    /// The current state as an MC system: building it checks, independently
    /// of the predictions, that no two bodies overlap. Growing bodies have
    /// their size now.
    pub fn to_system(&self) -> Result<System, StateError> {
        let tolerance = self.predictor.contact_tolerance();
        System::with_touching(
            self.box_,
            self.species_now(),
            self.particles(),
            self.sizes.clone(),
            tolerance,
        )
    }

    /// Polydisperse spheres: each body's size relative to its species'
    /// shape, as the state it was built from gave them.
    pub fn sizes(&self) -> Option<&[f64]> {
        self.sizes.as_deref()
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

    /// The shell of the neighbour lists the dynamics built, or `None`
    /// where it runs on cells alone.
    pub fn neighbour_shell(&self) -> Option<f64> {
        self.neighbours.as_ref().map(|n| n.shell)
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
        let kt = self.temperature();
        let pressure_tensor = iv
            .stress
            .filter(|_| dt > 0.0 && !self.box_.has_walls())
            .map(|sums| {
                let mut p = SymmetricTensor::default();
                let to_beta_p = 1.0 / (dt * self.box_.volume() * kt);
                p.add_scaled(&sums.kinetic, to_beta_p);
                p.add_scaled(&sums.virial, to_beta_p);
                p
            });
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
        self.interval = Interval::starting(self.now);
        Sample {
            time: self.time(),
            collisions: self.collisions,
            interval_collisions: iv.collisions,
            pressure,
            pressure_tensor,
            temperature: kt,
            packing_fraction: self.packing_fraction * self.scale_now().powi(3),
            nematic_order: self.nematic_order(),
        }
    }

    #[inline(always)]
    pub(super) fn accumulate_kinetic(&mut self) {
        let iv = &mut self.interval;
        let dt = self.now - iv.ke_since;
        iv.ke_integral += 0.5 * self.kinetic.trace() * dt;
        if let Some(sums) = &mut iv.stress {
            sums.kinetic.add_scaled(&self.kinetic, dt);
        }
        iv.ke_since = self.now;
    }

    /// An impulse changes velocities: `impulse` on one body (B) of
    /// velocity `velocity_gap` before, or on B and its opposite on A with
    /// `velocity_gap` = v_B − v_A before; `inverse_masses` = Σ 1/m of the
    /// bodies it acts on. Σ m v⊗v changes by 2 sym(w ⊗ J) with
    /// w = velocity_gap + ½ J Σ 1/m (momentum conservation; no velocity
    /// read back). Brings the kinetic integral up to now first.
    #[inline(always)]
    pub(super) fn kinetic_impulse(&mut self, velocity_gap: &V3, impulse: &V3, inverse_masses: f64) {
        self.accumulate_kinetic();
        let w = velocity_gap + impulse * (0.5 * inverse_masses);
        self.kinetic.add_outer(&w, impulse, 2.0);
    }

    /// A collision's contribution to the virial: `separation` = r_B − r_A
    /// (the image in which they touch), `impulse` the impulse on B.
    pub(super) fn add_virial(&mut self, separation: &V3, impulse: &V3) {
        let iv = &mut self.interval;
        iv.virial += separation.dot(impulse);
        if let Some(sums) = &mut iv.stress {
            sums.virial.add_outer(separation, impulse, 1.0);
        }
    }
}

/// Σ m v⊗v over the bodies.
pub(super) fn kinetic_tensor(bodies: &[Body], kinds: &[Kind]) -> SymmetricTensor {
    let mut t = SymmetricTensor::default();
    for b in bodies {
        t.add_outer(
            &b.velocity,
            &b.velocity,
            1.0 / kinds[b.kind as usize].inverse_mass,
        );
    }
    t
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

/// Degrees of freedom of `n` bodies whose collisions exchange `rotations`
/// rotational ones: total momentum is conserved (and zero) along each
/// periodic axis only; walls exchange momentum with the bodies.
pub(super) fn degrees_of_freedom(box_: &PeriodicBox, n: usize, rotations: usize) -> f64 {
    let periodic = box_.walls().iter().filter(|&&w| !w).count();
    (3 * n - periodic + rotations) as f64
}

/// Kinetic energy of one body (spherical top).
pub(super) fn body_energy(b: &Body, kinds: &[Kind]) -> f64 {
    let k = &kinds[b.kind as usize];
    let rot = k.rotational_energy(&b.orientation, &b.angular_velocity);
    0.5 * b.velocity.norm_squared() / k.inverse_mass + rot
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_interval_from_an_older_frame_reports_no_tensor() {
        let old = r#"{"start":0.0,"collisions":3,"virial":1.5,"ke_integral":2.0,"ke_since":1.0,"wall_impulse":[0.0,0.0,0.0]}"#;
        let interval: Interval = serde_json::from_str(old).unwrap();
        assert_eq!(interval.stress, None);
        assert!(Interval::starting(1.0).stress.is_some());
    }

    #[test]
    fn the_outer_product_is_symmetrized_with_the_dot_product_as_trace() {
        let (a, b) = (V3::new(1.0, 2.0, 3.0), V3::new(-0.5, 0.25, 4.0));
        let mut t = SymmetricTensor::default();
        t.add_outer(&a, &b, 2.0);
        assert_eq!(t.trace(), 2.0 * a.dot(&b));
        assert_eq!(t.0[1], a.x * b.y + a.y * b.x);
        assert_eq!(t.0[4], a.y * b.z + a.z * b.y);
    }
}
