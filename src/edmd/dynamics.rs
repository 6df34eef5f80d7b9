//! The event loop (De Michele Sec. 2.7): bodies move freely and lazily
//! (each keeps the time its stored pose belongs to), the calendar yields the
//! next collision or cell crossing, and only the bodies involved are
//! advanced, changed and re-predicted.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;

use super::calendar::{Calendar, EventKind};
use super::collision::{Kinetics, collide, collide_patch, collide_spheres};
use super::motion::{Spin, position_after};
use super::predict::{Found, Predictor, PredictorOptions, Progress};
use crate::analysis::order::{legendre_p2, nematic_order};
use crate::geometry::pair::contact_sum;
use crate::geometry::roots::{brent_minimize, narrow_sign_change};
use crate::geometry::{Relative, Shape, WarmStart};
use crate::space::{CellList, NeighbourLists, PeriodicBox};
use crate::state::{Particle, Species, StateError, System};

type V3 = Vector3<f64>;

/// What can go wrong setting up or running the dynamics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EdmdError {
    /// The temperature is not a positive finite number.
    #[error("temperature must be finite and > 0, got {0}")]
    BadTemperature(f64),
    /// A mass is not a positive finite number, or the masses do not match
    /// the species.
    #[error("masses must be one finite value > 0 per species ({species} species), got {masses:?}")]
    BadMasses {
        /// Species count.
        species: usize,
        /// What was given.
        masses: Vec<f64>,
    },
    /// Fewer than two particles: no degrees of freedom once the total
    /// momentum is removed.
    #[error("dynamics needs at least two particles, got {0}")]
    TooFewParticles(usize),
    /// The starting state is not a valid hard-body state.
    #[error("invalid starting state: {0}")]
    State(#[from] StateError),
    /// A pair predicted to touch does not: the prediction or the motion is
    /// wrong. Reported with the pair, the time and the distance found.
    #[error(
        "collision of particles {i} and {j} at t = {time}: their distance is {distance:e}, not 0 (predicted contact missed)"
    )]
    ContactMismatch {
        /// First particle.
        i: usize,
        /// Second particle.
        j: usize,
        /// Simulated time.
        time: f64,
        /// Signed distance at the predicted contact.
        distance: f64,
    },
    /// Events keep coming at one instant: a pair caught in a contact that
    /// the collision rule cannot resolve (a bug, reported rather than
    /// looped on).
    #[error(
        "{events} events at t = {time} without time advancing (last: particles {i} and {j}): the dynamics is stuck"
    )]
    Stalled {
        /// Simulated time.
        time: f64,
        /// Events at that time.
        events: u64,
        /// The last event's particles.
        i: usize,
        /// See `i`.
        j: usize,
    },
    /// True inertia was asked for a body that is not a body of revolution
    /// (its free rotation has no closed form here).
    #[error(
        "species {species}: true inertia needs a body of revolution (two equal principal moments), got {moments:?}"
    )]
    NotATop {
        /// The species.
        species: String,
        /// Its principal moments.
        moments: [f64; 3],
    },
    /// Velocities given for a different number of bodies, not finite, or
    /// spinning a body that does not rotate.
    #[error(
        "velocities must be finite, one pair per body ({0} bodies), and zero spin for bodies that do not rotate"
    )]
    BadVelocities(usize),
    /// A neighbour shell that is not a finite length > 0 (with a zero
    /// shell every body would rebuild its list at every instant).
    #[error("the neighbour shell must be a finite length > 0, got {0}")]
    BadShell(f64),
    /// A dump that cannot be a dynamics state.
    #[error("invalid dump: {0}")]
    BadDump(String),
    /// The distance solver failed at a collision or a prediction.
    #[error("distance of particles {i} and {j} at t = {time} could not be computed: {why}")]
    Solver {
        /// First particle.
        i: usize,
        /// Second particle.
        j: usize,
        /// Simulated time.
        time: f64,
        /// The solver's report.
        why: String,
    },
}

/// Settings of a dynamics run.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsOptions {
    /// kT of the Maxwell–Boltzmann start; the kinetic energy is set to
    /// exactly (dof/2) kT.
    pub temperature: f64,
    /// Mass per species (empty: all 1).
    pub masses: Vec<f64>,
    /// Collision prediction for non-spherical pairs.
    pub predictor: PredictorOptions,
    /// Rotate bodies of revolution as symmetric tops with their true
    /// principal moments; otherwise every body is a spherical top with the
    /// mean moment (De Michele's choice, eqs. 4–6).
    pub true_inertia: bool,
    /// Neighbour lists (Donev et al.; De Michele Sec. 3.3): each body gets
    /// a neighbour region fixed where the body was when it was built, and
    /// collisions are predicted only between bodies whose regions overlap;
    /// a region is rebuilt when its body is about to leave it. Systems of
    /// spheres use the bounding sphere grown by this shell (rebuilt when the
    /// centre has moved by the shell); any other system the paper's
    /// oriented boxes, the body's bounding box grown by the shell on every
    /// face (rebuilt when the turning body is about to poke out of a face).
    /// `None`: cells with cell-crossing events.
    pub neighbour_shell: Option<f64>,
}

impl Default for DynamicsOptions {
    fn default() -> Self {
        Self {
            temperature: 1.0,
            masses: Vec::new(),
            predictor: PredictorOptions::default(),
            true_inertia: false,
            neighbour_shell: None,
        }
    }
}

/// Below this packing fraction hard spheres run faster with cells.
pub const SPHERE_LISTS_FROM: f64 = 0.45;

/// The neighbour structure a scene gets unless it names one, at packing
/// fraction `packing_fraction`: for spheres, cells below φ = 0.45 and
/// lists (bounding spheres) with a shell of a quarter of the diameter
/// above; for every other system, oriented-box lists with a shell of a
/// tenth of the thinnest body's thickness (twice its smallest half-extent)
/// times the square root of the largest elongation (longest over shortest
/// half-extent): long and flat bodies rebuild their boxes often, and
/// since the support-plane searches made each pair cheap, a wider shell
/// pays for them.
/// Measured (`hardbody bench edmd-shell`, `edmd-density`,
/// `edmd-elongation`, one core; docs/ACCURACY.md): hard spheres N = 4000
/// at φ = 0.5, 2.48–2.50 µs per collision at shells 0.2–0.3 against 3.39
/// with cells; at φ = 0.4 no better than cells within the noise; at
/// φ = 0.3 cells win (2.98 against 3.96 at best). Bodies at φ = 0.5 with
/// box lists (`bench edmd`, 2026-11-21 after the support-plane searches),
/// thickness 1: prolate 2:1 38.7 µs at 0.1, 45.6 at 0.2, 54.8 at 0.5;
/// oblate 1:2 35.8 at 0.1, 41.0 at 0.05, 49.0 at 0.25; cubes 72.5 at 0.087,
/// 81.2 at 0.17. Aligned needles and plates (side by side, one core):
/// needles 10:1 at φ = 0.3 86 µs at shell 0.1 and 71 at 0.25, at φ = 0.5
/// 71 and 69; plates 1:10 (thickness 0.1) at φ = 0.3 54 at 0.01 and 44 at
/// 0.025; prolate 2:1 at φ = 0.5 39 at 0.1 and 40 at 0.25.
pub fn automatic_neighbour_shell(species: &[Species], packing_fraction: f64) -> Option<f64> {
    if species.iter().all(|s| s.shape.is_sphere()) {
        let diameter = species
            .iter()
            .map(|s| 2.0 * s.shape.bounding_radius())
            .fold(f64::INFINITY, f64::min);
        (packing_fraction >= SPHERE_LISTS_FROM).then_some(0.25 * diameter)
    } else {
        let thickness = species
            .iter()
            .map(|s| 2.0 * s.shape.min_half_extent())
            .fold(f64::INFINITY, f64::min);
        let elongation = species
            .iter()
            .map(|s| {
                let h = s.shape.obb_half_extents();
                h.max() / h.min()
            })
            .fold(1.0, f64::max);
        Some(0.1 * thickness * elongation.sqrt())
    }
}

/// The neighbour regions of [`DynamicsOptions::neighbour_shell`]: spheres,
/// or oriented boxes.
#[derive(Debug, Clone)]
struct NeighbourSpheres {
    shell: f64,
    /// Per species: the largest distance from the centre to a point of the
    /// region (bounding radius + shell for spheres, the box's half-diagonal
    /// for boxes).
    reach: Vec<f64>,
    /// Where each body's region is centred (its centre when it was built,
    /// wrapped into the box).
    centres: Vec<V3>,
    /// Oriented boxes: per species the half-extents (the body's bounding
    /// box grown by the shell), per body the box axes (the body's axes when
    /// it was built). `None`: spheres.
    boxes: Option<(Vec<V3>, Vec<Matrix3<f64>>)>,
    lists: NeighbourLists,
}

/// A box region stops being trusted when its body is this fraction of the
/// shell from a face (the escape search stops there, never past the face).
const BOX_ESCAPE_MARGIN: f64 = 0.02;

/// A body's motion since its last event.
///
/// The first cache line holds all that a closed-form (sphere) search reads
/// of a partner: position, velocity, time and horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
struct Body {
    /// Centre at `time` (wrapped into the box at cell crossings only).
    position: V3,
    velocity: V3,
    /// The time the stored pose belongs to.
    time: f64,
    /// Where its last collision search stopped: its crossing time or the
    /// earliest collision it found, whichever is first (any later
    /// collision of this body will be invalidated by that event). If that
    /// collision is invalidated by the partner instead, the search is
    /// renewed from there.
    horizon: f64,
    orientation: UnitQuaternion<f64>,
    /// Lab frame.
    angular_velocity: V3,
    species: u16,
}

// Two cache lines, the first all a sphere search reads of a partner.
const _: () = assert!(std::mem::size_of::<Body>() == 128);

/// Per species: what the dynamics needs to know.
#[derive(Debug, Clone, PartialEq)]
struct Kind {
    shape: Shape,
    inverse_mass: f64,
    /// Whether the species turns.
    rotates: bool,
    /// Principal moments of inertia along the body axes: all equal (the
    /// mean of the body's) for a spherical top, the body's own for a
    /// symmetric top.
    moments: V3,
    /// The body axis of the symmetric top (the odd moment).
    top_axis: usize,
}

impl Kind {
    /// The free rotation of a body of this kind with orientation `q` and
    /// lab angular velocity `omega` (zero for kinds that do not turn).
    #[inline]
    fn spin(&self, q: &UnitQuaternion<f64>, omega: &V3) -> Spin {
        if !self.rotates {
            return Spin::constant(V3::zeros());
        }
        let k = self.top_axis;
        let (i1, i3) = (self.moments[(k + 1) % 3], self.moments[k]);
        if i1 == i3 {
            return Spin::constant(*omega);
        }
        let axis = V3::ith(k, 1.0);
        let e3 = q * axis;
        let w3 = omega.dot(&e3);
        Spin {
            lab: omega + e3 * ((i3 / i1 - 1.0) * w3),
            body: axis * (w3 * (1.0 - i3 / i1)),
        }
    }

    /// I⁻¹ in the lab frame at orientation `q`.
    fn inverse_inertia(&self, q: &UnitQuaternion<f64>) -> Matrix3<f64> {
        if !self.rotates {
            return Matrix3::zeros();
        }
        let r = q.to_rotation_matrix().into_inner();
        r * Matrix3::from_diagonal(&self.moments.map(|m| 1.0 / m)) * r.transpose()
    }

    /// ½ ω·I ω.
    fn rotational_energy(&self, q: &UnitQuaternion<f64>, omega: &V3) -> f64 {
        if !self.rotates {
            return 0.0;
        }
        let body = q.inverse_transform_vector(omega);
        0.5 * body.component_mul(&body).dot(&self.moments)
    }
}

/// Counters and sums over the interval since the last sample (times on
/// the dynamics' own clock): what a frame records so that a resumed run's
/// first sample covers the same interval as the uninterrupted run's.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Interval {
    /// When the interval began.
    pub start: f64,
    /// Collisions in it.
    pub collisions: u64,
    /// Σ (r_B − r_A)·J n̂ over collisions.
    pub virial: f64,
    /// ∫ (translational kinetic energy) dt, up to `ke_since`.
    pub ke_integral: f64,
    /// See `ke_integral`.
    pub ke_since: f64,
    /// Impulse taken by the two walls of each axis.
    pub wall_impulse: [f64; 3],
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
    /// kT = 2K / dof.
    pub temperature: f64,
    /// φ.
    pub packing_fraction: f64,
    /// S₂ of the molecular axes of the rotating anisotropic bodies; `None`
    /// if there are none.
    pub nematic_order: Option<f64>,
}

/// One body as the dynamics stores it: the pose at its own time (not the
/// common time), and its velocities.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodyDump {
    /// Species index.
    pub species: u16,
    /// The time the pose belongs to (relative to `time_origin`).
    pub time: f64,
    /// Centre at `time`.
    pub position: [f64; 3],
    /// [w, x, y, z] at `time`.
    pub orientation: [f64; 4],
    /// Velocity.
    pub velocity: [f64; 3],
    /// Angular velocity, lab frame, at `time`.
    pub angular_velocity: [f64; 3],
}

/// Everything the predictions depend on, to the bit: each body's stored
/// pose and time (they differ from body to body between events), the
/// clock and the box. Written when a run fails so that the failure can be
/// replayed: [`Dynamics::from_dump`] predicts every event again from the
/// same stored poses, and predictions are canonical (a function of the
/// two stored poses alone; see `closed_form`), so the failing event comes
/// back.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DynamicsDump {
    /// Absolute time of `now` = 0.
    pub time_origin: f64,
    /// The clock, relative to `time_origin`.
    pub now: f64,
    /// Collisions so far.
    pub collisions: u64,
    /// Collisions at the last rebase (the next comes 32 N collisions
    /// after it).
    pub collisions_at_rebase: u64,
    /// Box edges.
    pub box_lengths: [f64; 3],
    /// Hard walls per axis.
    pub walls: [bool; 3],
    /// Per body.
    pub bodies: Vec<BodyDump>,
}

/// Event-driven molecular dynamics of hard bodies in a periodic box.
#[derive(Debug, Clone)]
pub struct Dynamics {
    box_: PeriodicBox,
    species: Vec<Species>,
    kinds: Vec<Kind>,
    /// Closed-form contact distance per species pair (spheres), else None.
    contact_sums: Vec<Option<f64>>,
    /// Every pair in closed form (spheres only): a contact time is exact
    /// whenever it is found, so searches need no horizon, and a body that
    /// crosses into a cell searches only the layer of cells it now
    /// neighbours (Smallenburg's scheme); otherwise a crossing renews the
    /// whole search, which stopped at it.
    ///
    /// Every prediction, closed form or searched, is canonical: a body's
    /// stored pose changes only at its collisions and wall bounces
    /// (wrapped into the box there) and at rebases (at a collision), never
    /// at crossings or list rebuilds, and a pair is solved from the later
    /// of its two stored poses (searches: with the lower index as A, on a
    /// step grid the horizon does not cut, resumed with their solver
    /// state; see `predict_pair`); so the predicted times, and the
    /// trajectory, do not depend on when searches run or on the neighbour
    /// structure.
    closed_form: bool,
    bodies: Vec<Body>,
    /// Per body: when it next leaves its cell or neighbour region (its
    /// events after that are invalidated there anyway, so none later is
    /// scheduled). Beside `bodies`, which keep a sphere search's reads in
    /// one cache line.
    crossing_times: Vec<f64>,
    /// Cells over the bodies' centres (with crossing events), or with
    /// neighbour lists over their neighbour spheres' centres (updated when
    /// a sphere is rebuilt, to find the spheres it overlaps).
    cells: CellList,
    cell_lengths: V3,
    /// Neighbour lists, when the options ask for them.
    neighbours: Option<NeighbourSpheres>,
    /// Scratch: the bodies a search looks at.
    candidates: Vec<u32>,
    /// Per body, with cells and closed-form pairs: what to add to the
    /// stored position to put it in its cell's image (the pose is kept
    /// through periodic crossings; see `closed_form`).
    cell_shifts: Vec<V3>,
    calendar: Calendar,
    predictor: Predictor,
    /// Time since `origin`.
    now: f64,
    /// Absolute time of `now` = 0 (moved forward at rebases).
    origin: f64,
    /// Collisions at the last rebase.
    collisions_at_rebase: u64,
    collisions: u64,
    interval: Interval,
    /// Translational kinetic energy (changes only at collisions).
    kinetic_translational: f64,
    degrees_of_freedom: f64,
    packing_fraction: f64,
    /// Whether any body rotates (else orientations are never touched).
    rotating: bool,
    /// Per species: the body axis S₂ and C₂ follow (rotating anisotropic
    /// species only).
    molecular_axes: Vec<Option<V3>>,
    /// Per body: the box lengths it has been wrapped by (unwrapped centre =
    /// centre + image).
    images: Vec<V3>,
    /// Per body: unwrapped centre and lab-frame molecular axis at the
    /// reference time of the MSD and C₂.
    reference: Vec<(V3, Option<V3>)>,
    /// The distance solver's state at each scheduled collision's predicted
    /// contact, by (first, second) body: the collision starts from it.
    found: std::collections::HashMap<(u32, u32), WarmStart>,
    /// Scratch: searches put off until the cheap ones are done (partner,
    /// the time it got to, where to resume it).
    deferred: Vec<(u32, f64, Progress)>,
    /// Events processed at the current instant (a guard against loops).
    events_at_now: u64,
    /// The options it was built with (to rebuild itself).
    options: DynamicsOptions,
    /// Every collision (time, lower index, higher index) while on.
    trace: Option<Vec<(f64, u32, u32)>>,
}

/// The outcome of a search for a body's next wall contact.
#[derive(Debug, Clone, Copy, PartialEq)]
enum WallContact {
    /// It touches the wall normal to `axis` (+L/2 if `up`) at `time`.
    At { time: f64, axis: usize, up: bool },
    /// No contact before the end of the search.
    None,
    /// The search stopped here without deciding.
    SearchedTo(f64),
}

/// How a pair's search ended (times absolute).
#[derive(Debug, Clone, Copy)]
enum PairSearch {
    /// A contact at this time, with the solver state there.
    Contact(f64, Option<WarmStart>),
    /// None before the horizon.
    Apart,
    /// Out of budget at this time; the progress to resume from is in the
    /// caller's slot.
    Unfinished(f64),
}

/// Steps a pair's contact search may take before it is put off behind the
/// other pairs of the same body.
const CHEAP_SEARCH: u32 = 16;

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
        let kinds = kinds_for(&species, options)?;
        let mut bodies: Vec<Body> = system
            .particles()
            .iter()
            .map(|p| {
                let kind = &kinds[p.species as usize];
                let gauss = |rng: &mut R| {
                    V3::new(
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                        rng.sample(StandardNormal),
                    )
                };
                let velocity = gauss(rng) * (t * kind.inverse_mass).sqrt();
                // Equipartition about each principal axis, then to the lab.
                let angular_velocity = if kind.rotates {
                    p.orientation * gauss(rng).component_mul(&kind.moments.map(|i| (t / i).sqrt()))
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
                    horizon: f64::INFINITY,
                }
            })
            .collect();
        // Zero total momentum, then the exact kinetic energy.
        let total_mass: f64 = bodies
            .iter()
            .map(|b| 1.0 / kinds[b.species as usize].inverse_mass)
            .sum();
        let momentum: V3 = bodies
            .iter()
            .map(|b| b.velocity / kinds[b.species as usize].inverse_mass)
            .sum();
        let drift = momentum / total_mass;
        let rotors = kinds_rotating(&bodies, &kinds);
        let dof = degrees_of_freedom(system.periodic_box(), n, rotors);
        for b in &mut bodies {
            b.velocity -= drift;
        }
        let energy: f64 = bodies.iter().map(|b| body_energy(b, &kinds)).sum();
        let scale = (0.5 * dof * t / energy).sqrt();
        for b in &mut bodies {
            b.velocity *= scale;
            b.angular_velocity *= scale;
        }
        Self::assemble(system, species, kinds, bodies, options, 0.0)
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
        let kinds = kinds_for(&species, options)?;
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
        let bodies: Vec<Body> = system
            .particles()
            .iter()
            .zip(velocities)
            .map(|(p, (v, w))| Body {
                position: p.position,
                velocity: *v,
                time: 0.0,
                orientation: p.orientation,
                angular_velocity: *w,
                species: p.species,
                horizon: f64::INFINITY,
            })
            .collect();
        let mut dynamics = Self::assemble(system, species, kinds, bodies, options, 0.0)?;
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
        let kinds = kinds_for(species, options)?;
        let bad = |why: String| EdmdError::BadDump(why);
        if !(dump.now.is_finite() && dump.time_origin.is_finite()) {
            return Err(bad(format!(
                "clock {} + {} is not finite",
                dump.time_origin, dump.now
            )));
        }
        let mut bodies = Vec::with_capacity(n);
        for (k, b) in dump.bodies.iter().enumerate() {
            let finite = b
                .position
                .iter()
                .chain(&b.orientation)
                .chain(&b.velocity)
                .chain(&b.angular_velocity)
                .all(|x| x.is_finite());
            if !finite || !b.time.is_finite() || b.time > dump.now {
                return Err(bad(format!(
                    "body {k}: values must be finite and its time at most now ({})",
                    dump.now
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
                horizon: f64::INFINITY,
            });
        }
        let box_ = PeriodicBox::new(V3::from(dump.box_lengths))
            .map_err(|e| bad(format!("box: {e}")))?
            .with_walls(dump.walls);
        let particles = particles_at(&box_, &kinds, &bodies, dump.now);
        let tolerance = Predictor::new(options.predictor).contact_tolerance();
        let system = system_of(box_, species, particles, tolerance)?;
        let mut dynamics =
            Self::assemble(&system, species.to_vec(), kinds, bodies, options, dump.now)?;
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
    /// with the clock at `now` (the bodies' stored times are at most it).
    fn assemble(
        system: &System,
        species: Vec<Species>,
        kinds: Vec<Kind>,
        bodies: Vec<Body>,
        options: &DynamicsOptions,
        now: f64,
    ) -> Result<Self, EdmdError> {
        let n = bodies.len();
        let rotors = kinds_rotating(&bodies, &kinds);
        let dof = degrees_of_freedom(system.periodic_box(), n, rotors);
        let rotating = rotors > 0;
        let ns = species.len();
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
        let box_regions =
            options.neighbour_shell.is_some() && kinds.iter().any(|k| !k.shape.is_sphere());
        let box_half: Vec<V3> = kinds
            .iter()
            .map(|k| k.shape.obb_half_extents().add_scalar(shell))
            .collect();
        let reach: Vec<f64> = if box_regions {
            box_half.iter().map(|h| h.norm()).collect()
        } else {
            kinds
                .iter()
                .map(|k| k.shape.bounding_radius() + shell)
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
        // Per body: the stored position in the image of the cell it is in
        // now (whole box lengths).
        let cell_shifts: Vec<V3> = bodies
            .iter()
            .zip(&positions)
            .map(|(b, r)| {
                let moved = position_after(&b.position, &b.velocity, now - b.time);
                let l = box_.lengths();
                V3::from_fn(|k, _| ((r[k] - moved[k]) / l[k]).round() * l[k])
            })
            .collect();
        let cells = CellList::new(box_.lengths(), range, &positions);
        let cell_lengths = cells.cell_lengths();
        let neighbours = match options.neighbour_shell {
            Some(shell) => {
                let boxes = box_regions.then(|| {
                    let axes = poses
                        .iter()
                        .map(|(_, q)| q.to_rotation_matrix().into_inner())
                        .collect();
                    (box_half, axes)
                });
                let mut spheres = NeighbourSpheres {
                    shell,
                    reach,
                    centres: positions,
                    boxes,
                    lists: NeighbourLists::new(n, 16),
                };
                for i in 0..n {
                    link_overlapping(i, true, &box_, &cells, &bodies, &mut spheres);
                }
                Some(spheres)
            }
            None => None,
        };
        let kinetic_translational = bodies
            .iter()
            .map(|b| 0.5 * b.velocity.norm_squared() / kinds[b.species as usize].inverse_mass)
            .sum();
        let closed_form = contact_sums.iter().all(Option::is_some);
        let mut dynamics = Self {
            box_,
            closed_form,
            contact_sums,
            cells,
            cell_lengths,
            neighbours,
            candidates: Vec::new(),
            cell_shifts,
            calendar: Calendar::new(n),
            predictor: Predictor::new(options.predictor),
            now,
            origin: 0.0,
            collisions_at_rebase: 0,
            collisions: 0,
            interval: Interval::default(),
            kinetic_translational,
            degrees_of_freedom: dof,
            packing_fraction: system.packing_fraction(),
            rotating,
            options: options.clone(),
            trace: None,
            deferred: Vec::new(),
            found: std::collections::HashMap::new(),
            molecular_axes: Vec::new(),
            images: vec![V3::zeros(); n],
            reference: Vec::new(),
            events_at_now: 0,
            species,
            kinds,
            bodies,
            crossing_times: vec![f64::INFINITY; n],
        };
        dynamics.molecular_axes = dynamics.species.iter().map(Species::order_axis).collect();
        dynamics.set_reference();
        dynamics.schedule_everything()?;
        Ok(dynamics)
    }

    /// Predicts every crossing and every pair collision from scratch.
    fn schedule_everything(&mut self) -> Result<(), EdmdError> {
        self.calendar.clear();
        // The horizons belong to the predictions dropped: a search cut at
        // one would miss what the new ones find beyond it.
        for b in &mut self.bodies {
            b.horizon = f64::INFINITY;
        }
        for i in 0..self.bodies.len() {
            self.schedule_crossing(i);
        }
        for i in 0..self.bodies.len() {
            self.schedule_collisions(i, None, true)?;
        }
        Ok(())
    }

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
    pub fn solver_work(&self) -> super::SolverWork {
        self.predictor.work()
    }

    /// Counts the solver's work on from `work` (zero at a stage's start,
    /// a frame's counts when resumed from it).
    pub fn continue_solver_work(&mut self, work: super::SolverWork) {
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
    fn trajectory_points(&self) -> impl Iterator<Item = (V3, Option<V3>)> + '_ {
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
    /// of the predictions, that no two bodies overlap.
    pub fn to_system(&self) -> Result<System, StateError> {
        let tolerance = self.predictor.contact_tolerance();
        system_of(self.box_, &self.species, self.particles(), tolerance)
    }

    /// Runs until the simulated time reaches `t_end` (bodies are then
    /// advanced to it).
    pub fn run_until(&mut self, t_end: f64) -> Result<(), EdmdError> {
        while let Some(e) = self.calendar.peek() {
            // Relative to the origin, which a rebase moves.
            if e.time > t_end - self.origin {
                break;
            }
            self.process_next()?;
        }
        self.advance_clock(t_end - self.origin);
        Ok(())
    }

    /// Runs `count` more collisions.
    pub fn run_collisions(&mut self, count: u64) -> Result<(), EdmdError> {
        let target = self.collisions + count;
        while self.collisions < target {
            if !self.process_next()? {
                break;
            }
        }
        Ok(())
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
            packing_fraction: self.packing_fraction,
            nematic_order: self.nematic_order(),
        }
    }

    fn accumulate_kinetic(&mut self) {
        let iv = &mut self.interval;
        iv.ke_integral += self.kinetic_translational * (self.now - iv.ke_since);
        iv.ke_since = self.now;
    }

    /// Moves the clock to `now` (no event in between).
    fn advance_clock(&mut self, now: f64) {
        if now > self.now {
            self.now = now;
        }
    }

    /// Processes the next event; false if the calendar is empty (nothing
    /// moves).
    fn process_next(&mut self) -> Result<bool, EdmdError> {
        let Some(e) = self.calendar.pop() else {
            return Ok(false);
        };
        if e.time > self.now {
            self.now = e.time;
            self.events_at_now = 0;
        } else {
            self.events_at_now += 1;
            // Every body may meet every neighbour at one instant in a
            // lattice; far more than that is a loop.
            if self.events_at_now > 100 * self.bodies.len() as u64 + 1000 {
                return Err(EdmdError::Stalled {
                    time: self.time(),
                    events: self.events_at_now,
                    i: e.i as usize,
                    j: e.j as usize,
                });
            }
        }
        match e.kind {
            EventKind::Collision if !self.calendar.partner_current(&e) => {
                // The partner changed: no collision; but if this was where
                // the first body's search stopped, it goes on from here.
                let i = e.i as usize;
                if e.time == self.bodies[i].horizon {
                    self.schedule_collisions(i, None, false)?;
                }
            }
            EventKind::Collision => self.collide(e.i as usize, e.j as usize)?,
            EventKind::CellCrossing { axis, up } => self.cross(e.i as usize, axis as usize, up)?,
            EventKind::Escape => self.escape(e.i as usize)?,
            EventKind::Wall { axis, up } => self.hit_wall(e.i as usize, axis as usize, up)?,
            EventKind::WallSearch => {
                let i = e.i as usize;
                self.calendar.invalidate(i);
                self.schedule_crossing(i);
                self.schedule_collisions(i, None, false)?;
            }
        }
        // At a collision (an instant both neighbour structures share; see
        // `closed_form`).
        let due = self.collisions - self.collisions_at_rebase > 32 * self.bodies.len() as u64
            && matches!(e.kind, EventKind::Collision);
        if due {
            self.rebase()?;
        }
        Ok(true)
    }

    /// Advances body `i` to the current time.
    #[inline]
    fn advance(&mut self, i: usize) {
        let now = self.now;
        let rotating = self.rotating;
        let b = &mut self.bodies[i];
        let dt = now - b.time;
        if dt != 0.0 {
            b.position = position_after(&b.position, &b.velocity, dt);
            if rotating && b.angular_velocity != V3::zeros() {
                let spin = self.kinds[b.species as usize].spin(&b.orientation, &b.angular_velocity);
                b.orientation = spin.orientation_after(&b.orientation, dt);
                b.angular_velocity = spin.angular_velocity(&b.orientation);
            }
            b.time = now;
        }
    }

    /// Moves the time origin to now, so that event times stay small and
    /// keep their precision over long runs.
    fn rebase(&mut self) -> Result<(), EdmdError> {
        for i in 0..self.bodies.len() {
            self.advance(i);
        }
        self.accumulate_kinetic();
        let shift = self.now;
        for b in &mut self.bodies {
            b.time = 0.0;
            b.horizon -= shift;
        }
        for t in &mut self.crossing_times {
            *t -= shift;
        }
        self.calendar.shift_times(shift);
        self.interval.start -= shift;
        self.interval.ke_since -= shift;
        self.origin += shift;
        self.now = 0.0;
        self.collisions_at_rebase = self.collisions;
        // Every prediction again from the new poses: an event predicted
        // before and shifted can differ in its last bit from the same event
        // predicted after (see `closed_form`).
        self.schedule_everything()?;
        Ok(())
    }

    fn collide(&mut self, i: usize, j: usize) -> Result<(), EdmdError> {
        // The body of lower index first, whichever body's search found the
        // pair: the same bits for the same collision (see `closed_form`).
        let (i, j) = (i.min(j), i.max(j));
        // A collision that fails leaves both bodies as they were, so that a
        // dump taken then replays it (see `DynamicsDump`). Two spheres are
        // checked before anything changes; bodies are kept aside.
        let spheres = self.contact_sums[self.pair_index(i, j)].is_some();
        let kept = (!spheres)
            .then(|| [i, j].map(|k| (self.bodies[k], self.cell_shifts[k], self.images[k])));
        let impulse = match self.impulse_at_contact(i, j) {
            Ok(impulse) => impulse,
            Err(e) => {
                for (k, (body, shift, image)) in [i, j].into_iter().zip(kept.into_iter().flatten())
                {
                    (self.bodies[k], self.cell_shifts[k], self.images[k]) = (body, shift, image);
                }
                return Err(e);
            }
        };
        self.interval.virial += impulse;
        self.interval.collisions += 1;
        self.collisions += 1;
        if let Some(trace) = self.trace.as_mut() {
            trace.push((self.origin + self.now, i.min(j) as u32, i.max(j) as u32));
        }
        self.calendar.invalidate(i);
        self.calendar.invalidate(j);
        self.schedule_crossing(i);
        self.schedule_crossing(j);
        self.schedule_collisions(i, Some(j), false)?;
        self.schedule_collisions(j, Some(i), false)?;
        // The pair itself last, within both horizons: a pair that has just
        // touched stays within ε_d for a while, where the search is slow.
        // Found, it is `i`'s earliest collision, in place of the one its
        // search found: `i`'s horizon, so that if `j` changes first, `i`'s
        // search is renewed there (see `process_next`).
        // Two spheres that have just collided recede for ever on their
        // straight lines (|d + Δv t|² grows once d·Δv > 0): nothing to search.
        if spheres {
            return Ok(());
        }
        let horizon = self.bodies[i].horizon.min(self.bodies[j].horizon);
        if let PairSearch::Contact(t, warm) =
            self.predict_pair(i, j, horizon, u32::MAX, None, &mut None)?
        {
            self.bodies[i].horizon = t;
            schedule_collision(&mut self.calendar, &mut self.found, t, i, j, warm);
        }
        Ok(())
    }

    /// Advances bodies `i` < `j` to now, where they touch, and applies the
    /// impulse; returns (r_B − r_A)·J n̂ for the virial. Changes nothing
    /// but the two bodies, and their velocities only if it succeeds.
    fn impulse_at_contact(&mut self, i: usize, j: usize) -> Result<f64, EdmdError> {
        let (si, sj) = (self.species_of(i), self.species_of(j));
        let sphere_contact = self.contact_sums[self.pair_index(i, j)];
        // The separation now, from the positions `advance` will store (to
        // the bit), before either body is touched.
        let now = |k: usize| {
            let b = &self.bodies[k];
            position_after(&b.position, &b.velocity, self.now - b.time)
        };
        let d = self.box_.minimum_image(&(now(j) - now(i)));
        if let Some(sigma) = sphere_contact {
            // Two spheres touch now.
            let gap = d.norm() - sigma;
            if gap.abs() > 1e-9 * sigma {
                return Err(EdmdError::ContactMismatch {
                    i,
                    j,
                    time: self.time(),
                    distance: gap,
                });
            }
        }
        self.advance(i);
        self.advance(j);
        // New stored poses: wrapped into the box here, and only here;
        // with cells, in the image of the body's cell.
        for k in [i, j] {
            let p = self.bodies[k].position;
            let wrapped = match self.neighbours {
                Some(_) => self.box_.wrap(&p),
                None => {
                    let l = self.box_.lengths();
                    let c = self.cells.coords_of(self.cells.cell_of(k));
                    let centre = V3::from_fn(|a, _| {
                        -0.5 * l[a] + (c[a] as f64 + 0.5) * self.cell_lengths[a]
                    });
                    p + self.box_.image_shift(&(p - centre))
                }
            };
            self.images[k] += p - wrapped;
            self.bodies[k].position = wrapped;
            self.cell_shifts[k] = V3::zeros();
        }
        let impulse = if sphere_contact.is_some() {
            let len = d.norm();
            let normal = d / len;
            let (mi, mj) = (self.kinds[si].inverse_mass, self.kinds[sj].inverse_mass);
            let (a, b) = pair_mut(&mut self.bodies, i, j);
            let ke_before = 0.5 * (a.velocity.norm_squared() / mi + b.velocity.norm_squared() / mj);
            let jn = collide_spheres(&mut a.velocity, &mut b.velocity, mi, mj, &normal);
            let ke_after = 0.5 * (a.velocity.norm_squared() / mi + b.velocity.norm_squared() / mj);
            self.accumulate_kinetic();
            self.kinetic_translational += ke_after - ke_before;
            jn * len
        } else {
            self.collide_bodies(i, j, &d)?
        };
        Ok(impulse)
    }

    /// The collision of two bodies with at least one non-sphere: contact
    /// point and normal from the distance kernel, impulse from
    /// [`collide`]. Returns (r_B − r_A)·J n̂ for the virial.
    fn collide_bodies(&mut self, i: usize, j: usize, d: &V3) -> Result<f64, EdmdError> {
        let (bi, bj) = (self.bodies[i], self.bodies[j]);
        let (ki, kj) = (
            &self.kinds[bi.species as usize],
            &self.kinds[bj.species as usize],
        );
        let rel = Relative::new(d, &bi.orientation, &bj.orientation);
        let warm = self.found.remove(&(i as u32, j as u32));
        let contact = self
            .predictor
            .contact_from(&ki.shape, &kj.shape, &rel, warm.as_ref());
        if !contact.distance.is_finite() {
            return Err(EdmdError::Solver {
                i,
                j,
                time: self.time(),
                why: format!("{:?}", contact.status),
            });
        }
        let scale = ki.shape.min_half_extent().min(kj.shape.min_half_extent());
        if contact.distance.abs() > self.predictor.contact_tolerance() * scale {
            return Err(EdmdError::ContactMismatch {
                i,
                j,
                time: self.time(),
                distance: contact.distance,
            });
        }
        let lab = |c: &crate::geometry::Contact| {
            let normal = bi.orientation * c.normal;
            let arm_a = bi.orientation * (0.5 * (c.point_a + c.point_b));
            let closing = normal.dot(
                &(bi.velocity + bi.angular_velocity.cross(&arm_a)
                    - bj.velocity
                    - bj.angular_velocity.cross(&(arm_a - d))),
            );
            (normal, arm_a, closing)
        };
        let kinetics = |b: &Body, k: &Kind| Kinetics {
            velocity: b.velocity,
            angular_velocity: b.angular_velocity,
            inverse_mass: k.inverse_mass,
            inverse_inertia: k.inverse_inertia(&b.orientation),
        };
        // A face or an edge lying on a face: the impact acts on all the
        // corners of the shared region at once (see `collide_patch`).
        let patch = crate::geometry::pair::contact_patch(
            &ki.shape,
            &kj.shape,
            &rel,
            &contact.normal,
            self.predictor.contact_tolerance() * scale,
        );
        if patch.points().len() >= 2 {
            let normal = bi.orientation * contact.normal;
            let mut arms = [(V3::zeros(), V3::zeros()); 8];
            for (arm, p) in arms.iter_mut().zip(patch.points()) {
                let arm_a = bi.orientation * p;
                *arm = (arm_a, arm_a - d);
            }
            let mut ka = kinetics(&bi, ki);
            let mut kb = kinetics(&bj, kj);
            let jn = collide_patch(&mut ka, &mut kb, &arms[..patch.points().len()], &normal);
            return Ok(self.apply_impulse(i, j, ka, kb, jn * d.dot(&normal)));
        }
        let (mut normal, mut arm_a, closing) = lab(&contact);
        if closing <= 0.0 {
            // Touching, but not where the bodies close in: at a contact
            // within round-off of a second one (a box face about to meet a
            // vertex beside the one touching), the pair overlaps an instant
            // later at the other. Take the contact from there.
            let (spin_i, spin_j) = (
                ki.spin(&bi.orientation, &bi.angular_velocity),
                kj.spin(&bj.orientation, &bj.angular_velocity),
            );
            let rate = (bj.velocity - bi.velocity).norm()
                + bi.angular_velocity.norm() * ki.shape.moment_arm()
                + bj.angular_velocity.norm() * kj.shape.moment_arm();
            let mut delta =
                self.predictor.contact_tolerance() * scale / rate.max(f64::MIN_POSITIVE);
            for _ in 0..40 {
                let later = Relative::new(
                    &(d + (bj.velocity - bi.velocity) * delta),
                    &spin_i.orientation_after(&bi.orientation, delta),
                    &spin_j.orientation_after(&bj.orientation, delta),
                );
                let ahead = self.predictor.contact(&ki.shape, &kj.shape, &later);
                if ahead.distance < 0.0 {
                    let (n, a, c) = lab(&ahead);
                    if c > 0.0 {
                        (normal, arm_a) = (n, a);
                    }
                    break;
                }
                delta *= 2.0;
            }
        }
        let arm_b = arm_a - d;
        let mut ka = kinetics(&bi, ki);
        let mut kb = kinetics(&bj, kj);
        let jn = collide(&mut ka, &mut kb, &arm_a, &arm_b, &normal);
        Ok(self.apply_impulse(i, j, ka, kb, jn * d.dot(&normal)))
    }

    /// Stores bodies `i` and `j`'s velocities after a collision (`ka`,
    /// `kb`) and the change of the translational kinetic energy; passes
    /// the virial term through.
    fn apply_impulse(
        &mut self,
        i: usize,
        j: usize,
        ka: Kinetics,
        kb: Kinetics,
        virial: f64,
    ) -> f64 {
        let ke_before = 0.5
            * (self.bodies[i].velocity.norm_squared() / ka.inverse_mass
                + self.bodies[j].velocity.norm_squared() / kb.inverse_mass);
        let ke_after = 0.5
            * (ka.velocity.norm_squared() / ka.inverse_mass
                + kb.velocity.norm_squared() / kb.inverse_mass);
        self.accumulate_kinetic();
        self.kinetic_translational += ke_after - ke_before;
        for (idx, k) in [(i, ka), (j, kb)] {
            self.bodies[idx].velocity = k.velocity;
            self.bodies[idx].angular_velocity = k.angular_velocity;
        }
        virial
    }

    fn cross(&mut self, i: usize, axis: usize, up: bool) -> Result<(), EdmdError> {
        // The stored pose stays (see `closed_form`): a periodic crossing
        // moves `cell_shifts`, not the pose.
        let dims = self.cells.dims();
        let mut c = self.cells.coords_of(self.cells.cell_of(i));
        let l = self.box_.lengths()[axis];
        let mut shift = 0.0;
        if up {
            c[axis] += 1;
            if c[axis] == dims[axis] {
                c[axis] = 0;
                shift = -l;
            }
        } else if c[axis] == 0 {
            c[axis] = dims[axis] - 1;
            shift = l;
        } else {
            c[axis] -= 1;
        }
        if shift != 0.0 {
            self.cell_shifts[i][axis] += shift;
        }
        let cell = self.cells.index_of(c);
        self.cells.move_to(i, cell);
        if self.closed_form {
            // The trajectory is unchanged and its events stand; only the
            // bodies in the layer of cells ahead are new neighbours.
            self.schedule_crossing(i);
            let mut layer = c;
            layer[axis] = if up {
                (c[axis] + 1) % dims[axis]
            } else {
                (c[axis] + dims[axis] - 1) % dims[axis]
            };
            return self.schedule_collisions_in_layer(i, layer, axis);
        }
        self.calendar.invalidate(i);
        self.schedule_crossing(i);
        self.schedule_collisions(i, None, false)
    }

    /// Body `i` has moved the shell from its neighbour sphere's centre: the
    /// sphere is rebuilt around it, and `i` searches its new list.
    fn escape(&mut self, i: usize) -> Result<(), EdmdError> {
        // The stored pose stays (see `closed_form`).
        let (centre, orientation) = self.pose_at(i, self.now);
        let wrapped = self.box_.wrap(&centre);
        self.cells.update(i, &wrapped);
        let spheres = self
            .neighbours
            .as_mut()
            .expect("escapes come with neighbour lists");
        spheres.centres[i] = wrapped;
        if let Some((_, axes)) = &mut spheres.boxes {
            axes[i] = orientation.to_rotation_matrix().into_inner();
        }
        spheres.lists.unlink_all(i);
        link_overlapping(i, false, &self.box_, &self.cells, &self.bodies, spheres);
        if self.closed_form {
            prefetch_bodies(&self.bodies, spheres.lists.of(i));
            // Its trajectory and its events stand; only earlier contacts
            // with its new neighbours are scheduled.
            self.schedule_crossing(i);
            let spheres = self.neighbours.as_ref().expect("just rebuilt");
            let earliest = self.earliest_closed_form_listed(
                i,
                spheres.lists.of(i),
                |_| true,
                self.bodies[i].horizon,
            );
            self.schedule_earliest(i, earliest);
            return Ok(());
        }
        self.calendar.invalidate(i);
        self.schedule_crossing(i);
        self.schedule_collisions(i, None, false)
    }

    /// Closed-form pairs only: schedules body `i`'s collisions with the
    /// bodies in the 3×3 cells around `layer` across `axis` (its new
    /// neighbours after a crossing), if earlier than its earliest one.
    fn schedule_collisions_in_layer(
        &mut self,
        i: usize,
        layer: [usize; 3],
        axis: usize,
    ) -> Result<(), EdmdError> {
        let dims = self.cells.dims();
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let cells = &self.cells;
        let layer_cells = [dims[a] - 1, 0, 1].into_iter().flat_map(|da| {
            [dims[b] - 1, 0, 1].into_iter().map(move |db| {
                let mut c = layer;
                c[a] = (c[a] + da) % dims[a];
                c[b] = (c[b] + db) % dims[b];
                cells.index_of(c)
            })
        });
        let earliest = self.earliest_closed_form_in_cells(
            i,
            layer_cells.map(|c| cells.members(c)),
            |j| j != i,
            self.bodies[i].horizon,
        );
        self.schedule_earliest(i, earliest);
        Ok(())
    }

    /// Schedules body `i`'s next cell crossing, or with neighbour lists its
    /// escape from its neighbour sphere (`i` at its own time), or its wall
    /// contact if that comes first.
    fn schedule_crossing(&mut self, i: usize) {
        let b = &self.bodies[i];
        if let Some(spheres) = &self.neighbours {
            if spheres.boxes.is_some() {
                let t = self.box_escape_time(i);
                self.schedule_neighbourhood_event(i, t, EventKind::Escape);
                return;
            }
            // Against a sphere shrunk by a relative 1e-9: rounding never
            // takes a body out of its sphere unseen.
            let now = position_after(&b.position, &b.velocity, self.now - b.time);
            let dt = escape_time(
                &self.box_.minimum_image(&(now - spheres.centres[i])),
                &b.velocity,
                spheres.shell * (1.0 - 1e-9),
            );
            self.schedule_neighbourhood_event(i, self.now + dt, EventKind::Escape);
            return;
        }
        let c = self.cells.coords_of(self.cells.cell_of(i));
        let half = self.box_.lengths() * 0.5;
        let mut best = (f64::INFINITY, 0u8, false);
        for k in 0..3 {
            let v = b.velocity[k];
            if v == 0.0 {
                continue;
            }
            let lower = -half[k] + c[k] as f64 * self.cell_lengths[k];
            let (face, up) = if v > 0.0 {
                (lower + self.cell_lengths[k], true)
            } else {
                (lower, false)
            };
            // The stored position in the image of its cell (they differ
            // when the pose is kept through a periodic crossing).
            let x = b.position[k] + self.cell_shifts[i][k];
            let t = ((face - x) / v).max(0.0);
            if t < best.0 {
                best = (t, k as u8, up);
            }
        }
        let time = b.time + best.0;
        self.schedule_neighbourhood_event(
            i,
            time,
            EventKind::CellCrossing {
                axis: best.1,
                up: best.2,
            },
        );
    }

    /// Schedules `kind` (a crossing or an escape) for body `i` at `time`,
    /// or its wall contact if that comes first.
    fn schedule_neighbourhood_event(&mut self, i: usize, time: f64, kind: EventKind) {
        if self.box_.has_walls() {
            match self.wall_contact(i, time) {
                WallContact::At { time: t, axis, up } => {
                    self.crossing_times[i] = t;
                    self.calendar.schedule(
                        t,
                        EventKind::Wall {
                            axis: axis as u8,
                            up,
                        },
                        i,
                        i,
                    );
                    return;
                }
                WallContact::SearchedTo(t) if t < time => {
                    self.crossing_times[i] = t;
                    self.calendar.schedule(t, EventKind::WallSearch, i, i);
                    return;
                }
                _ => {}
            }
        }
        self.crossing_times[i] = time;
        if time.is_finite() {
            self.calendar.schedule(time, kind, i, i);
        }
    }

    /// Body `i`'s centre and orientation at time `t`, by free motion from
    /// its stored pose.
    fn pose_at(&self, i: usize, t: f64) -> (V3, UnitQuaternion<f64>) {
        body_pose(&self.kinds, &self.bodies[i], t)
    }

    /// The gap between body `i` at time `t` and the faces of its neighbour
    /// box: min over the box axes uₖ of Hₖ − |(r − c)·uₖ| − hₖ, with H the
    /// box's half-extents, c its centre and hₖ the body's extent along uₖ.
    fn box_gap_at(&self, i: usize, t: f64) -> f64 {
        let spheres = self.neighbours.as_ref().expect("box regions");
        let (half, axes) = spheres.boxes.as_ref().expect("box regions");
        let b = &self.bodies[i];
        let kind = &self.kinds[b.species as usize];
        let (r, q) = self.pose_at(i, t);
        let axes = &axes[i];
        let h = kind
            .shape
            .lab_half_extents(&axes.tr_mul(&q.to_rotation_matrix().into_inner()));
        let offset = axes.tr_mul(&self.box_.minimum_image(&(r - spheres.centres[i])));
        let half = &half[b.species as usize];
        (0..3)
            .map(|k| half[k] - offset[k].abs() - h[k])
            .fold(f64::INFINITY, f64::min)
    }

    /// When body `i`'s neighbour box stops being trusted: the gap to its
    /// faces cannot close faster than |v·uₖ| + |ω| × moment arm, so steps
    /// of gap / rate never pass a face (conservative advancement); the
    /// search stops within [`BOX_ESCAPE_MARGIN`] of the shell, or after 64
    /// steps (an early rebuild costs a search, never a collision).
    fn box_escape_time(&self, i: usize) -> f64 {
        let spheres = self.neighbours.as_ref().expect("box regions");
        let (_, axes) = spheres.boxes.as_ref().expect("box regions");
        let b = &self.bodies[i];
        let kind = &self.kinds[b.species as usize];
        let along = axes[i].tr_mul(&b.velocity).abs().max();
        let rate = along + b.angular_velocity.norm() * kind.shape.moment_arm();
        if rate == 0.0 {
            return f64::INFINITY;
        }
        let margin = BOX_ESCAPE_MARGIN * spheres.shell;
        let mut t = self.now;
        for _ in 0..64 {
            let gap = self.box_gap_at(i, t);
            if gap <= margin {
                break;
            }
            t += gap / rate;
        }
        t
    }

    /// The gap between body `i` at absolute time `t` (relative to the
    /// origin) and the nearest wall: min over walled axes of
    /// L/2 − |rₖ| − hₖ(R), with the axis and side.
    fn wall_gap_at(&self, i: usize, t: f64) -> (f64, usize, bool) {
        let b = &self.bodies[i];
        let kind = &self.kinds[b.species as usize];
        let (r, q) = self.pose_at(i, t);
        let h = kind
            .shape
            .lab_half_extents(&q.to_rotation_matrix().into_inner());
        let half = self.box_.lengths() * 0.5;
        let walls = self.box_.walls();
        (0..3)
            .filter(|&k| walls[k])
            .map(|k| (half[k] - r[k].abs() - h[k], k, r[k] > 0.0))
            .fold(
                (f64::INFINITY, 0, true),
                |m, x| if x.0 < m.0 { x } else { m },
            )
    }

    /// Body `i`'s next wall contact before `t_end`: in closed form for a
    /// body that does not turn; otherwise by bracketing the gap with steps
    /// it cannot close faster than (|v| + |ω| × moment arm), a search for
    /// grazing minima below ε_d, and the safeguarded root finder. Gives up
    /// after a fixed number of steps (to be renewed from there).
    fn wall_contact(&self, i: usize, t_end: f64) -> WallContact {
        let b = &self.bodies[i];
        let kind = &self.kinds[b.species as usize];
        let half = self.box_.lengths() * 0.5;
        let walls = self.box_.walls();
        if !kind.rotates || b.angular_velocity == V3::zeros() {
            let h = kind
                .shape
                .lab_half_extents(&b.orientation.to_rotation_matrix().into_inner());
            let mut best = WallContact::None;
            let mut best_t = t_end;
            for k in (0..3).filter(|&k| walls[k]) {
                let v = b.velocity[k];
                if v == 0.0 {
                    continue;
                }
                let up = v > 0.0;
                let gap = half[k] - h[k] - if up { b.position[k] } else { -b.position[k] };
                let t = b.time + (gap / v.abs()).max(0.0);
                if t < best_t {
                    best_t = t;
                    best = WallContact::At {
                        time: t,
                        axis: k,
                        up,
                    };
                }
            }
            return best;
        }
        let opts = self.predictor.options();
        let scale = kind.shape.min_half_extent();
        let tol = opts.contact_tolerance * scale;
        let eps = opts.grazing_threshold * scale;
        let speed = (0..3)
            .filter(|&k| walls[k])
            .map(|k| b.velocity[k].abs())
            .fold(0.0, f64::max);
        let rate = speed + b.angular_velocity.norm() * kind.shape.moment_arm();
        let gap = |t: f64| self.wall_gap_at(i, t).0;
        let contact = |lo: f64| {
            let (_, axis, up) = self.wall_gap_at(i, lo);
            WallContact::At { time: lo, axis, up }
        };
        // From now: the pose is kept through the events that renew this
        // search (see `closed_form`), and the body is clear of the walls
        // up to now (a search that stopped renews itself from there).
        let start = self.now.max(b.time);
        let (mut t, mut g) = (start, gap(start));
        for _ in 0..64 {
            let t1 = (t + g.max(eps) / rate).min(t_end);
            let g1 = gap(t1);
            if g1 < 0.0 {
                if g <= 0.0 {
                    return contact(t);
                }
                let (lo, ..) = narrow_sign_change(gap, (t, g), (t1, g1), tol, 200);
                return contact(lo);
            }
            if g.min(g1) < eps {
                // A grazing approach: is there a dip below zero in between?
                let (x, gx, _) = brent_minimize(gap, t, t1, 1e-12 * (t1 - t).max(1e-300), 60);
                if gx < 0.0 && g > 0.0 {
                    let (lo, ..) = narrow_sign_change(gap, (t, g), (x, gx), tol, 200);
                    return contact(lo);
                }
            }
            if t1 >= t_end {
                return WallContact::None;
            }
            (t, g) = (t1, g1);
        }
        WallContact::SearchedTo(t)
    }

    /// Body `i` meets the wall normal to `axis` (at +L/2 if `up`): an
    /// elastic impulse against an immovable wall at the body's extreme
    /// point (collision::collide with an infinite-mass partner).
    fn hit_wall(&mut self, i: usize, axis: usize, up: bool) -> Result<(), EdmdError> {
        self.advance(i);
        let b = self.bodies[i];
        let kind = &self.kinds[b.species as usize];
        let normal = V3::ith(axis, if up { 1.0 } else { -1.0 });
        let arm = b.orientation
            * kind
                .shape
                .support(&b.orientation.inverse_transform_vector(&normal));
        let gap = 0.5 * self.box_.lengths()[axis] - (b.position[axis] + arm[axis]) * normal[axis];
        let scale = kind.shape.min_half_extent();
        if gap.abs() > 1e3 * self.predictor.contact_tolerance() * scale {
            return Err(EdmdError::ContactMismatch {
                i,
                j: i,
                time: self.time(),
                distance: gap,
            });
        }
        let mut body = Kinetics {
            velocity: b.velocity,
            angular_velocity: b.angular_velocity,
            inverse_mass: kind.inverse_mass,
            inverse_inertia: kind.inverse_inertia(&b.orientation),
        };
        let mut wall = Kinetics {
            velocity: V3::zeros(),
            angular_velocity: V3::zeros(),
            inverse_mass: 0.0,
            inverse_inertia: Matrix3::zeros(),
        };
        let ke_before = 0.5 * body.velocity.norm_squared() / kind.inverse_mass;
        let j = collide(&mut body, &mut wall, &arm, &V3::zeros(), &normal);
        let ke_after = 0.5 * body.velocity.norm_squared() / kind.inverse_mass;
        self.accumulate_kinetic();
        self.kinetic_translational += ke_after - ke_before;
        self.interval.wall_impulse[axis] += j;
        self.bodies[i].velocity = body.velocity;
        self.bodies[i].angular_velocity = body.angular_velocity;
        self.calendar.invalidate(i);
        self.schedule_crossing(i);
        self.schedule_collisions(i, None, false)
    }

    /// Predicts and schedules the collisions of body `i` (at the current
    /// time) with the bodies in the cells around it, except `skip`; with
    /// `once`, only with bodies of larger index (the initial sweep over all
    /// pairs). Each search stops at the earliest event found so far for `i`
    /// (its horizon): a later collision of `i` would be invalidated by it.
    fn schedule_collisions(
        &mut self,
        i: usize,
        skip: Option<usize>,
        once: bool,
    ) -> Result<(), EdmdError> {
        let keep = |j: usize| j != i && Some(j) != skip && !(once && j < i);
        if self.closed_form {
            // Every search is one closed-form solve, exact whenever it is
            // done: no horizon, none deferred.
            let earliest = match &self.neighbours {
                Some(spheres) => {
                    prefetch_bodies(&self.bodies, spheres.lists.of(i));
                    self.earliest_closed_form_listed(i, spheres.lists.of(i), keep, f64::INFINITY)
                }
                None => {
                    let cells = &self.cells;
                    let around = cells.neighbour_cells(cells.cell_of(i));
                    self.earliest_closed_form_in_cells(
                        i,
                        around.iter().map(|&nc| cells.members(nc as usize)),
                        keep,
                        f64::INFINITY,
                    )
                }
            };
            self.bodies[i].horizon = f64::INFINITY;
            self.schedule_earliest(i, earliest);
            return Ok(());
        }
        let mut horizon_i = self.crossing_times[i];
        // Searches that need many steps (pairs lingering close together)
        // wait until the cheap ones have shortened the horizon.
        let mut deferred = std::mem::take(&mut self.deferred);
        deferred.clear();
        // Only the earliest contact found is scheduled: a later one would be
        // invalidated by it, or, if its partner changes first, found again
        // when the search is renewed from there (see `process_next`).
        let mut earliest = None;
        let mut candidates = std::mem::take(&mut self.candidates);
        candidates.clear();
        match &self.neighbours {
            Some(spheres) => candidates.extend_from_slice(spheres.lists.of(i)),
            None => {
                for &nc in self.cells.neighbour_cells(self.cells.cell_of(i)) {
                    candidates.extend_from_slice(self.cells.members(nc as usize));
                }
            }
        }
        // Where a search out of budget leaves its progress.
        let mut stopped = None;
        for &j in &candidates {
            let j = j as usize;
            if !keep(j) {
                continue;
            }
            // Past j's own horizon, j's first event will have changed it
            // or renewed its search (which covers this pair).
            let horizon = horizon_i.min(self.bodies[j].horizon);
            match self.predict_pair(i, j, horizon, CHEAP_SEARCH, None, &mut stopped)? {
                PairSearch::Contact(t, warm) => {
                    earliest = Some((t, j, warm));
                    horizon_i = t;
                }
                PairSearch::Apart => {}
                PairSearch::Unfinished(t) => {
                    deferred.push((j as u32, t, stopped.take().expect("stopped")))
                }
            }
        }
        self.candidates = candidates;
        // The put-off searches race: the least advanced one takes the next
        // few steps, so that the first contact among them is found before
        // any of them searches past it (it becomes everyone's horizon). A
        // search resumes with its solver state: the same steps as if it
        // had not stopped (see `predict_pair`).
        while !deferred.is_empty() {
            let (k, &(j, _, progress)) = deferred
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.1.total_cmp(&b.1.1))
                .expect("not empty");
            let j = j as usize;
            let horizon = horizon_i.min(self.bodies[j].horizon);
            match self.predict_pair(i, j, horizon, CHEAP_SEARCH, Some(&progress), &mut stopped)? {
                PairSearch::Contact(t, warm) => {
                    earliest = Some((t, j, warm));
                    horizon_i = t;
                    deferred.swap_remove(k);
                }
                PairSearch::Apart => {
                    deferred.swap_remove(k);
                }
                PairSearch::Unfinished(t) => {
                    deferred[k] = (j as u32, t, stopped.take().expect("stopped"))
                }
            }
        }
        self.deferred = deferred;
        self.bodies[i].horizon = horizon_i;
        if let Some((t, j, warm)) = earliest {
            schedule_collision(&mut self.calendar, &mut self.found, t, i, j, warm);
        }
        Ok(())
    }

    /// Closed-form pairs: the earliest contact of body `i` (at the current
    /// time) with one of `others` before `horizon` and before the other's
    /// own horizon (past it, the other's first event changes it or renews
    /// its search, which covers the pair).
    fn earliest_closed_form(
        &self,
        i: usize,
        others: impl Iterator<Item = usize>,
        mut horizon: f64,
    ) -> Option<(f64, usize)> {
        let mut earliest = None;
        for j in others {
            // +∞ for pairs that never meet: no branch on whether they do.
            let t = self.closed_form_contact(i, j);
            if t < horizon.min(self.bodies[j].horizon) {
                earliest = Some((t, j));
                horizon = t;
            }
        }
        earliest
    }

    /// [`Dynamics::earliest_closed_form`] over a neighbour list, the
    /// partners `keep` lets through: four contact times are computed side
    /// by side, so that the square roots and divisions of four run at once
    /// instead of one after the other (their latency was a quarter of a
    /// sphere run with lists). The same result to the bit, the partners
    /// taken in the list's order (which of equal times wins).
    #[inline(always)]
    fn earliest_closed_form_listed(
        &self,
        i: usize,
        list: &[u32],
        keep: impl Fn(usize) -> bool,
        mut horizon: f64,
    ) -> Option<(f64, usize)> {
        let mut earliest = None;
        let lanes = list.chunks_exact(LANES);
        let tail = lanes.remainder();
        for lanes in lanes {
            let lanes: [usize; LANES] = std::array::from_fn(|k| lanes[k] as usize);
            let times = self.closed_form_contacts(i, &lanes);
            for (&t, &j) in times.iter().zip(&lanes) {
                if keep(j) && t < horizon.min(self.bodies[j].horizon) {
                    earliest = Some((t, j));
                    horizon = t;
                }
            }
        }
        // The rest one by one (padding them into a batch was no faster).
        let rest = tail.iter().map(|&j| j as usize).filter(|&j| keep(j));
        self.earliest_closed_form(i, rest, horizon).or(earliest)
    }

    /// [`Dynamics::earliest_closed_form_listed`] over the members of
    /// `cells` that `keep` lets through, gathered into a small array first
    /// (and prefetched); more than fit are searched one at a time.
    #[inline(always)]
    fn earliest_closed_form_in_cells<'a>(
        &self,
        i: usize,
        cells: impl Iterator<Item = &'a [u32]> + Clone,
        keep: impl Fn(usize) -> bool,
        horizon: f64,
    ) -> Option<(f64, usize)> {
        let mut near = [0u32; GATHERED];
        match gather(cells.clone(), &mut near) {
            Some(count) => {
                prefetch_bodies(&self.bodies, &near[..count]);
                self.earliest_closed_form_listed(i, &near[..count], keep, horizon)
            }
            None => {
                let near = cells.flatten().map(|&j| j as usize);
                self.earliest_closed_form(i, near.filter(|&j| keep(j)), horizon)
            }
        }
    }

    /// [`Dynamics::closed_form_contact`] of body `i` with each of `others`,
    /// to the bit, computed side by side.
    #[inline(always)]
    fn closed_form_contacts(&self, i: usize, others: &[usize; LANES]) -> [f64; LANES] {
        let bi = &self.bodies[i];
        // Structure of arrays, one lane per partner, so that the compiler
        // computes the lanes in vector registers.
        let mut d = [[0.0; LANES]; 3];
        let mut dv = [[0.0; LANES]; 3];
        let mut t0 = [0.0; LANES];
        let mut sigma = [0.0; LANES];
        for (k, &j) in others.iter().enumerate() {
            let bj = &self.bodies[j];
            // A species pair that never touches: NaN, which meets nothing.
            sigma[k] = self.contact_sums[self.pair_index(i, j)].unwrap_or(f64::NAN);
            // Both bodies brought to the later of their times (the one
            // already there moves by zero: the same bits as moving only the
            // other, as `closed_form_contact` does).
            t0[k] = bi.time.max(bj.time);
            let ri = position_after(&bi.position, &bi.velocity, t0[k] - bi.time);
            let rj = position_after(&bj.position, &bj.velocity, t0[k] - bj.time);
            for a in 0..3 {
                d[a][k] = rj[a] - ri[a];
                dv[a][k] = bj.velocity[a] - bi.velocity[a];
            }
        }
        let mut times = [0.0; LANES];
        for k in 0..LANES {
            // The image nearest now (as `closed_form_contact`), and the
            // products in the order of nalgebra's (from zero, x, y, z).
            let dt = self.now - t0[k];
            let (mut b, mut dd, mut v2) = (0.0, 0.0, 0.0);
            for a in 0..3 {
                let x = d[a][k] + self.box_.image_shift_along(a, d[a][k] + dv[a][k] * dt);
                b += x * dv[a][k];
                dd += x * x;
                v2 += dv[a][k] * dv[a][k];
            }
            let t = crate::geometry::pair::sphere_contact_time_from_products(b, dd, v2, sigma[k]);
            times[k] = (t0[k] + t).max(self.now); // t0 + ∞ stays ∞
        }
        times
    }

    /// Schedules the contact found by [`Dynamics::earliest_closed_form`],
    /// which becomes body `i`'s horizon.
    fn schedule_earliest(&mut self, i: usize, earliest: Option<(f64, usize)>) {
        if let Some((t, j)) = earliest {
            self.bodies[i].horizon = t;
            self.calendar.schedule(t, EventKind::Collision, i, j);
        }
    }

    /// Where the species pair of bodies `i` and `j` sits in
    /// `contact_sums`.
    #[inline]
    fn pair_index(&self, i: usize, j: usize) -> usize {
        self.species_of(i) * self.kinds.len() + self.species_of(j)
    }

    /// Body `k`'s species; with one species, without reading the body's
    /// second cache line, which spheres need for nothing else.
    #[inline]
    fn species_of(&self, k: usize) -> usize {
        if self.kinds.len() == 1 {
            0
        } else {
            self.bodies[k].species as usize
        }
    }

    /// The contact time of two spheres, `i` at the current time (absolute,
    /// +∞ if they never touch).
    #[inline(always)]
    fn closed_form_contact(&self, i: usize, j: usize) -> f64 {
        let (bi, bj) = (&self.bodies[i], &self.bodies[j]);
        let Some(sigma) = self.contact_sums[self.pair_index(i, j)] else {
            return f64::INFINITY;
        };
        // From the later of the two stored poses, whenever the search runs:
        // the same bits for the same poses (see `closed_form`).
        // The image is the one nearest now (bodies that have flown far
        // since t0 may have been nearer in another then); neighbours are
        // far closer than half a box, so every search picks the same one.
        let dv = bj.velocity - bi.velocity;
        let (t0, raw) = if bi.time >= bj.time {
            let rj = position_after(&bj.position, &bj.velocity, bi.time - bj.time);
            (bi.time, rj - bi.position)
        } else {
            let ri = position_after(&bi.position, &bi.velocity, bj.time - bi.time);
            (bj.time, bj.position - ri)
        };
        let d = raw + self.box_.image_shift(&(raw + dv * (self.now - t0)));
        (t0 + crate::geometry::pair::sphere_contact_time_or_never(&d, &dv, sigma)).max(self.now)
    }

    /// The contact time of bodies `i` and `j` if it comes before
    /// `horizon`, with about `budget` steps (else how far the search got,
    /// to resume it from there with `resume`). Canonical (see
    /// `closed_form`): searched from the later of the two stored poses, the
    /// body of lower index as A, on a step grid the horizon does not cut,
    /// and resumed with its solver state; so the time found is a function
    /// of the two stored poses alone, whenever and from whichever body the
    /// search runs.
    fn predict_pair(
        &self,
        i: usize,
        j: usize,
        horizon: f64,
        budget: u32,
        resume: Option<&Progress>,
        stopped: &mut Option<Progress>,
    ) -> Result<PairSearch, EdmdError> {
        let (a, b) = (i.min(j), i.max(j));
        let (ba, bb) = (&self.bodies[a], &self.bodies[b]);
        let t0 = ba.time.max(bb.time);
        let ra = position_after(&ba.position, &ba.velocity, t0 - ba.time);
        let rb = position_after(&bb.position, &bb.velocity, t0 - bb.time);
        let dv = bb.velocity - ba.velocity;
        // The image nearest now (as for closed-form pairs).
        let raw = rb - ra;
        let d = raw + self.box_.image_shift(&(raw + dv * (self.now - t0)));
        let pair = ba.species as usize * self.kinds.len() + bb.species as usize;
        let found = if let Some(sigma) = self.contact_sums[pair] {
            match crate::geometry::pair::sphere_contact_time(&d, &dv, sigma) {
                Some(t) => Found::Contact(t),
                None => Found::Apart,
            }
        } else {
            let (ka, kb) = (
                &self.kinds[ba.species as usize],
                &self.kinds[bb.species as usize],
            );
            // A free rotation's two parts are constants of the motion.
            let (spin_a, spin_b) = (body_spin(&self.kinds, ba), body_spin(&self.kinds, bb));
            // The stored orientations, each turned on from its own time
            // inside the search (one rotation per step, none to bring it
            // to t0 first).
            self.predictor
                .search_into(
                    (&ka.shape, &ba.orientation, &spin_a),
                    (&kb.shape, &bb.orientation, &spin_b),
                    (t0 - ba.time, t0 - bb.time),
                    &d,
                    &dv,
                    resume,
                    horizon - t0,
                    budget,
                    stopped,
                )
                .map_err(|why| EdmdError::Solver {
                    i,
                    j,
                    time: self.time(),
                    why,
                })?
        };
        let warm = self.predictor.take_found();
        Ok(match found {
            // Not before now (rounding at a contact found right now).
            Found::Contact(t) if t0 + t < horizon => {
                PairSearch::Contact((t0 + t).max(self.now), warm)
            }
            Found::Contact(_) | Found::Apart => PairSearch::Apart,
            Found::Stopped(t) => PairSearch::Unfinished(t0 + t),
        })
    }
}

/// When a centre `d` from its neighbour sphere's centre (inside: |d| <
/// `shell`), moving at `v`, is `shell` from it.
fn escape_time(d: &V3, v: &V3, shell: f64) -> f64 {
    let a = v.norm_squared();
    let c = d.norm_squared() - shell * shell;
    if a == 0.0 {
        return f64::INFINITY;
    }
    if c >= 0.0 {
        return 0.0;
    }
    let b = d.dot(v);
    let root = (b * b - a * c).sqrt();
    // The positive root, without cancellation.
    if b > 0.0 {
        -c / (b + root)
    } else {
        (root - b) / a
    }
}

/// Links body `i` to every body whose neighbour sphere overlaps its own
/// (`after`: only bodies with a higher index, for the first build).
fn link_overlapping(
    i: usize,
    after: bool,
    box_: &PeriodicBox,
    cells: &CellList,
    bodies: &[Body],
    spheres: &mut NeighbourSpheres,
) {
    let centre = spheres.centres[i];
    let si = bodies[i].species as usize;
    let reach = spheres.reach[si];
    // The bodies whose spheres overlap i's are gathered without a branch
    // per candidate (a few in ten of the cells' members are, at random: a
    // branch on it mispredicts often), then linked.
    let mut near = [0u32; 64];
    let mut count = 0;
    // One species: its reach, without reading the second cache line of
    // every candidate's body for its species.
    let one_kind = spheres.reach.len() == 1;
    for &nc in cells.neighbour_cells(cells.cell_of(i)) {
        for &j in cells.members(nc as usize) {
            let sj = if one_kind {
                0
            } else {
                bodies[j as usize].species as usize
            };
            // Centres are wrapped into the box: the near form of the minimum
            // image (no rounding call) and squared lengths serve the many
            // candidates of long bodies' wide cells.
            let d = box_.minimum_image_near(&(spheres.centres[j as usize] - centre));
            let contact = reach + spheres.reach[sj];
            let wanted = (j as usize != i) & !(after & ((j as usize) < i));
            near[count] = j;
            count += (wanted & (d.norm_squared() <= contact * contact)) as usize;
            if count == near.len() {
                link_near(i, &near, box_, bodies, spheres);
                count = 0;
            }
        }
    }
    link_near(i, &near[..count], box_, bodies, spheres);
}

/// Links body `i` to each of `near` (bodies whose neighbour spheres
/// overlap its own) whose neighbour box, where there are boxes, overlaps
/// its own.
fn link_near(
    i: usize,
    near: &[u32],
    box_: &PeriodicBox,
    bodies: &[Body],
    spheres: &mut NeighbourSpheres,
) {
    let si = bodies[i].species as usize;
    for &j in near {
        let j = j as usize;
        if let Some((half, axes)) = &spheres.boxes {
            let sj = bodies[j].species as usize;
            let d = box_.minimum_image_near(&(spheres.centres[j] - spheres.centres[i]));
            // The 15-axis test in i's box frame (De Michele eqs. 62–64).
            let apart = !crate::geometry::obb::boxes_overlap(
                &half[si],
                &half[sj],
                &axes[i].tr_mul(&axes[j]),
                &axes[i].tr_mul(&d),
            );
            if apart {
                continue;
            }
        }
        spheres.lists.link(i, j);
    }
}

/// Schedules the collision of `i` and `j` at `t`, keeping the solver state
/// at the predicted contact for it.
fn schedule_collision(
    calendar: &mut Calendar,
    found: &mut std::collections::HashMap<(u32, u32), WarmStart>,
    t: f64,
    i: usize,
    j: usize,
    warm: Option<WarmStart>,
) {
    calendar.schedule(t, EventKind::Collision, i, j);
    if let Some(w) = warm {
        // Found with the body of lower index as A (see `predict_pair`).
        found.insert((i.min(j) as u32, i.max(j) as u32), w);
    }
}

/// Body `b`'s centre and orientation at time `t`, by free motion from its
/// stored pose.
#[inline]
fn body_pose(kinds: &[Kind], b: &Body, t: f64) -> (V3, UnitQuaternion<f64>) {
    let dt = t - b.time;
    let r = position_after(&b.position, &b.velocity, dt);
    let q = body_spin(kinds, b).orientation_after(&b.orientation, dt);
    (r, q)
}

/// Asks for the first cache line of each listed body (all a sphere search
/// reads of it) at once, before the search reads them one after another.
#[inline]
fn prefetch_bodies(bodies: &[Body], list: &[u32]) {
    for &j in list {
        prefetch_body(bodies, j as usize);
    }
}

/// Asks for body `j`'s first cache line (see [`prefetch_bodies`]).
#[inline(always)]
fn prefetch_body(bodies: &[Body], j: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(b) = bodies.get(j) {
        // SAFETY: SSE is part of the x86_64 baseline, and a prefetch is a
        // hint that reads and writes no memory (of a valid reference here
        // in any case).
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                (b as *const Body).cast::<i8>(),
            );
        }
    }
}

/// Partners whose closed-form contact times are computed side by side.
const LANES: usize = 4;

/// Candidates gathered from the cells around a sphere at most (dense
/// spheres have about 27; more fall back to one at a time).
const GATHERED: usize = 64;

/// The members of `cells` one after another in `into`, and how many;
/// `None` if they do not fit.
#[inline]
fn gather<'a>(cells: impl Iterator<Item = &'a [u32]>, into: &mut [u32]) -> Option<usize> {
    let mut count = 0;
    for members in cells {
        // One by one (a cell holds a few: a library copy per cell cost
        // a tenth of a dense sphere run).
        for &j in members {
            *into.get_mut(count)? = j;
            count += 1;
        }
    }
    Some(count)
}

/// The particles as an MC system, checked to be overlap-free, pairs that
/// touch to the dynamics' contact `tolerance` let through (see
/// [`System::with_contacts`]).
fn system_of(
    box_: PeriodicBox,
    species: &[Species],
    particles: Vec<Particle>,
    tolerance: f64,
) -> Result<System, StateError> {
    let touching =
        |i: usize, j: usize| pair_touches(&box_, species, &particles[i], &particles[j], tolerance);
    System::with_contacts(box_, species.to_vec(), particles.clone(), touching)
}

/// Whether particles `a` and `b` are at most touching: their signed
/// distance, by the geometry layer's distance kernel (the one the
/// predictions follow), is no deeper than `tolerance` times the smaller
/// body's smallest half-extent (the contact tolerance of the dynamics).
fn pair_touches(
    box_: &PeriodicBox,
    species: &[Species],
    a: &Particle,
    b: &Particle,
    tolerance: f64,
) -> bool {
    let (sa, sb) = (
        &species[a.species as usize].shape,
        &species[b.species as usize].shape,
    );
    let d = box_.minimum_image(&(b.position - a.position));
    let rel = Relative::new(&d, &a.orientation, &b.orientation);
    let contact = crate::geometry::distance(
        sa,
        sb,
        &rel,
        &crate::geometry::DistanceOptions::default(),
        None,
    );
    let scale = sa.min_half_extent().min(sb.min_half_extent());
    contact.distance >= -tolerance * scale
}

/// The bodies as particles at time `now`, centres wrapped into the box.
fn particles_at(box_: &PeriodicBox, kinds: &[Kind], bodies: &[Body], now: f64) -> Vec<Particle> {
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

/// A body's free rotation since its stored time.
#[inline]
fn body_spin(kinds: &[Kind], b: &Body) -> Spin {
    kinds[b.species as usize].spin(&b.orientation, &b.angular_velocity)
}

/// How many bodies rotate.
fn kinds_rotating(bodies: &[Body], kinds: &[Kind]) -> usize {
    bodies
        .iter()
        .filter(|b| kinds[b.species as usize].rotates)
        .count()
}

/// The per-species dynamics data, checked against the options.
fn kinds_for(species: &[Species], options: &DynamicsOptions) -> Result<Vec<Kind>, EdmdError> {
    let masses = if options.masses.is_empty() {
        vec![1.0; species.len()]
    } else {
        options.masses.clone()
    };
    if masses.len() != species.len() || masses.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(EdmdError::BadMasses {
            species: species.len(),
            masses: options.masses.clone(),
        });
    }
    let mut kinds = Vec::with_capacity(species.len());
    for (s, &m) in species.iter().zip(&masses) {
        let principal = s.shape.inertia_tensor(m).diagonal();
        let (moments, top_axis) = if options.true_inertia {
            match s.shape.symmetric_top_axis() {
                Some(k) => (principal, k),
                None => {
                    return Err(EdmdError::NotATop {
                        species: s.name.clone(),
                        moments: principal.into(),
                    });
                }
            }
        } else {
            (V3::repeat(principal.sum() / 3.0), 2)
        };
        kinds.push(Kind {
            shape: s.shape,
            inverse_mass: 1.0 / m,
            rotates: s.rotation,
            moments,
            top_axis,
        });
    }
    Ok(kinds)
}

/// Degrees of freedom of `n` bodies, `rotors` of them turning: total
/// momentum is conserved (and zero) along each periodic axis only; walls
/// exchange momentum with the bodies.
fn degrees_of_freedom(box_: &PeriodicBox, n: usize, rotors: usize) -> f64 {
    let periodic = box_.walls().iter().filter(|&&w| !w).count();
    (3 * n - periodic + 3 * rotors) as f64
}

/// Kinetic energy of one body (spherical top).
fn body_energy(b: &Body, kinds: &[Kind]) -> f64 {
    let k = &kinds[b.species as usize];
    let rot = k.rotational_energy(&b.orientation, &b.angular_velocity);
    0.5 * b.velocity.norm_squared() / k.inverse_mass + rot
}

/// Two distinct elements of a slice, mutably.
fn pair_mut<T>(s: &mut [T], i: usize, j: usize) -> (&mut T, &mut T) {
    debug_assert_ne!(i, j);
    if i < j {
        let (lo, hi) = s.split_at_mut(j);
        (&mut lo[i], &mut hi[0])
    } else {
        let (lo, hi) = s.split_at_mut(i);
        (&mut hi[0], &mut lo[j])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// A binary hard-sphere mixture run for a while, so that the bodies'
    /// stored times differ and some have crossed the box.
    fn mixture(neighbour_shell: Option<f64>) -> Dynamics {
        let species: Vec<Species> = ["Sphere(radius: 0.5)", "Sphere(radius: 0.3)"]
            .iter()
            .map(|s| Species {
                name: s.to_string(),
                shape: s.parse().unwrap(),
                rotation: false,
            })
            .collect();
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let box_ = PeriodicBox::new(Vector3::repeat(7.0)).unwrap();
        let system = crate::state::start::lattice(box_, species, &[100, 100], &mut rng).unwrap();
        let options = DynamicsOptions {
            neighbour_shell,
            ..DynamicsOptions::default()
        };
        let mut md = Dynamics::from_state(&system, &options, &mut rng).unwrap();
        md.run_collisions(5_000).unwrap();
        md
    }

    /// The cells' members are gathered in order, and a gathering that
    /// does not fit says so (the search then goes one by one).
    #[test]
    fn gathering_keeps_the_order_and_reports_overflow() {
        let cells: [&[u32]; 3] = [&[4, 1], &[], &[7, 3, 9]];
        let mut into = [0u32; 5];
        assert_eq!(gather(cells.iter().copied(), &mut into), Some(5));
        assert_eq!(into, [4, 1, 7, 3, 9]);
        let mut small = [0u32; 4];
        assert_eq!(gather(cells.iter().copied(), &mut small), None);
    }

    /// The contact times computed four side by side are those of the pair
    /// by pair search, to the bit, for any partners (near and far, either
    /// species, meeting or not); and the earliest over a list is the same
    /// pair at the same time by either.
    #[test]
    fn side_by_side_contact_times_are_the_pairwise_ones_to_the_bit() {
        let md = mixture(Some(0.2));
        assert!(md.closed_form);
        let n = md.bodies.len();
        let spheres = md.neighbours.as_ref().unwrap();
        let mut u = crate::test_support::uniform(3);
        let (mut finite, mut never) = (0, 0);
        for _ in 0..5_000 {
            let i = (u() * n as f64) as usize;
            // Listed partners (near) and any body (mostly far).
            let list = spheres.lists.of(i);
            let lanes: [usize; LANES] = std::array::from_fn(|k| {
                if k % 2 == 0 && !list.is_empty() {
                    list[(u() * list.len() as f64) as usize] as usize
                } else {
                    (u() * n as f64) as usize
                }
            });
            let times = md.closed_form_contacts(i, &lanes);
            for (t, &j) in times.iter().zip(&lanes) {
                if j == i {
                    continue;
                }
                let pairwise = md.closed_form_contact(i, j);
                assert_eq!(t.to_bits(), pairwise.to_bits(), "{i} {j}: {t} {pairwise}");
                if t.is_finite() {
                    finite += 1;
                } else {
                    never += 1;
                }
            }
        }
        assert!(finite > 1000 && never > 1000, "{finite} {never}");
        for i in 0..n {
            let list = spheres.lists.of(i);
            let keep = |j: usize| !j.is_multiple_of(3);
            let pairwise = md.earliest_closed_form(
                i,
                list.iter().map(|&j| j as usize).filter(|&j| keep(j)),
                f64::INFINITY,
            );
            let listed = md.earliest_closed_form_listed(i, list, keep, f64::INFINITY);
            assert_eq!(listed, pairwise, "{i}");
        }
        // A pair overlapping by rounding and closing, stored before now:
        // it touches now, not in the past.
        let mut md = md;
        let (i, j) = (0, md.neighbours.as_ref().unwrap().lists.of(0)[0] as usize);
        let sigma = md.contact_sums[md.pair_index(i, j)].unwrap();
        let t0 = md.now - 0.25;
        let (position, velocity) = (md.bodies[i].position, md.bodies[i].velocity);
        md.bodies[i].time = t0;
        md.bodies[j].time = t0;
        md.bodies[j].position = position + Vector3::x() * sigma * (1.0 - 1e-12);
        md.bodies[j].velocity = velocity - Vector3::x();
        let times = md.closed_form_contacts(i, &[j; LANES]);
        assert_eq!(times, [md.now; LANES]);
        assert_eq!(md.closed_form_contact(i, j), md.now);
    }
}
