//! What can go wrong setting up or running the dynamics.

use crate::edmd::search::SearchError;
use crate::state::StateError;

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
    /// A pair collides again and again, each collision changing no
    /// velocity: a contact the collision rule cannot resolve (reported
    /// rather than looped on).
    #[error(
        "{collisions} collisions in a row of particles {i} and {j} changed no velocity (the last at t = {time}): their contact cannot be resolved"
    )]
    Futile {
        /// First particle.
        i: usize,
        /// Second particle.
        j: usize,
        /// Simulated time.
        time: f64,
        /// Collisions in a row.
        collisions: u64,
    },
    /// Velocities given for a different number of bodies, not finite, or
    /// spinning a body that does not rotate.
    #[error(
        "velocities must be finite, one pair per body ({0} bodies), and zero spin for bodies that do not rotate"
    )]
    BadVelocities(usize),
    /// True inertia asked for a polyhedron whose inertia tensor is not
    /// diagonal in its body frame.
    #[error(
        "species \"{0}\" is a polyhedron whose body axes are not its principal axes of inertia: true_inertia turns bodies about their body axes, so give its vertices in its principal frame (or leave true_inertia off)"
    )]
    NotPrincipalAxes(String),
    /// A neighbour shell that is not a finite length > 0 (with a zero
    /// shell every body would rebuild its list at every instant).
    #[error("the neighbour shell must be a finite length > 0, got {0}")]
    BadShell(f64),
    /// A growth rate or margin that is not a finite number > 0.
    #[error("growth rate and margin must be finite and > 0, got {rate} and {margin}")]
    BadGrowth {
        /// The rate asked.
        rate: f64,
        /// The margin asked.
        margin: f64,
    },
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
        why: SearchError,
    },
}
