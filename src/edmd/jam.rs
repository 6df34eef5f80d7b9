//! Jammed packings by event-driven growth (Lubachevsky & Stillinger, J.
//! Stat. Phys. 60, 561 (1990); Donev, Torquato & Stillinger, J. Comput.
//! Phys. 202, 737 and 765 (2005)): every body's linear size grows at the
//! rate γ relative to its size while the bodies move and collide; the
//! collisions push growing bodies apart, and the heat the growth makes is
//! taken out by rescaling the velocities to kT between chunks of the run.
//! The packing fraction rises until the bodies are caged by their
//! neighbours and the pressure diverges: the run ends when the reduced
//! pressure Z = βPV/N passes a bound (Donev's 10¹²), its state jammed.
//!
//! The bodies grow ten times faster than γ while Z < 10³ (the fluid and
//! the glass, whose structure is random whatever the rate) and at γ from
//! there: the rate of the last approach sets how well the bodies settle
//! into their cages. Measured on 500 spheres: growing at 10⁻² to the end
//! leaves the backbone hypostatic (z = 5.70), 10⁻³ after Z = 10³ gives
//! z = 5.95, 10⁻⁴ gives 5.99 (docs/benchmarks/jam-2026-11-26.md).
//!
//! A chunk is one [`Dynamics::growing`] run: the sizes at its start times
//! 1 + γt, up to a fixed relative growth (the margin its cells and
//! neighbour regions are built for) or a number of collisions per body,
//! whichever comes first. A chunk whose numerics fail (a contact the
//! solver could not certify) is run again from its start at half the
//! rate; below [`JamOptions::growth_floor`] the run ends at the last
//! state that was certified.

use nalgebra::Vector3;
use rand::Rng;

use super::dynamics::{Dynamics, DynamicsOptions, EdmdError};
use crate::state::System;

type V3 = Vector3<f64>;

/// How a jamming run grows the bodies and when it stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JamOptions {
    /// γ: the relative growth of every body's linear size per unit time
    /// (time in units of σ√(m/kT), σ the bodies' size) once Z ≥
    /// [`SETTLE_FROM`]; ten times that below.
    pub growth_rate: f64,
    /// The reduced pressure Z = βPV/N at which the packing counts as
    /// jammed.
    pub pressure: f64,
    /// The rate below which a chunk that keeps failing is given up (the
    /// run then ends at its last certified state).
    pub growth_floor: f64,
    /// Relative growth of the sizes per chunk at most.
    pub margin: f64,
    /// Collisions per body per chunk at most (between thermostat steps).
    pub collisions_per_body: u64,
    /// Largest total number of collisions (a safety net; 0: none).
    pub max_collisions: u64,
}

impl Default for JamOptions {
    fn default() -> Self {
        Self {
            growth_rate: DEFAULT_GROWTH_RATE,
            pressure: DEFAULT_JAM_PRESSURE,
            growth_floor: DEFAULT_GROWTH_RATE * 1e-4,
            margin: 0.01,
            collisions_per_body: 100,
            max_collisions: 0,
        }
    }
}

/// The default γ.
pub const DEFAULT_GROWTH_RATE: f64 = 1e-3;
/// The reduced pressure from which the bodies grow at γ (below it, 10γ).
pub const SETTLE_FROM: f64 = 1e3;
/// How much faster than γ the bodies grow below [`SETTLE_FROM`].
pub const FLUID_SPEED_UP: f64 = 10.0;
/// The default bound on βPV/N (Donev et al.).
pub const DEFAULT_JAM_PRESSURE: f64 = 1e12;

/// Why a jamming run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JamEnd {
    /// The reduced pressure passed the bound: jammed.
    Jammed,
    /// Chunks kept failing down to the growth floor.
    GrowthFloor,
    /// The collision budget ran out.
    Budget,
    /// The caller stopped it.
    Stopped,
}

/// One chunk's figures, as the run goes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JamChunk {
    /// Chunks done.
    pub chunk: u64,
    /// Simulated time since the start.
    pub time: f64,
    /// Collisions since the start.
    pub collisions: u64,
    /// φ at the end of the chunk.
    pub packing_fraction: f64,
    /// βPV/N over the chunk (the collision virial).
    pub pressure: f64,
    /// kT before the velocities were rescaled.
    pub temperature: f64,
    /// The growth rate used.
    pub growth_rate: f64,
    /// The linear size relative to the start.
    pub size: f64,
}

/// The outcome: the last certified state and how the run ended.
#[derive(Debug, Clone)]
pub struct Jammed {
    /// The bodies at their final size (the species scaled), overlap-free.
    pub system: System,
    /// The velocities there, at kT.
    pub velocities: Vec<(V3, V3)>,
    /// The last chunk's figures (`None` if none finished).
    pub last: Option<JamChunk>,
    /// Why it ended.
    pub end: JamEnd,
    /// Chunks run again at a lower rate after a failure.
    pub retries: u64,
    /// The last failure that made a chunk run again (reported, not lost).
    pub last_failure: Option<String>,
}

/// Grows the bodies of `system` (Lubachevsky–Stillinger) until jammed, from
/// Maxwell–Boltzmann velocities at `dynamics.temperature` (drawn from
/// `rng`). `each_chunk` sees every chunk's figures and returns false to stop
/// there. Errors are those of building the dynamics (bad options or
/// state); numerical failures within the run lower the rate instead.
pub fn jam<R: Rng>(
    system: &System,
    options: &JamOptions,
    dynamics: &DynamicsOptions,
    rng: &mut R,
    mut each_chunk: impl FnMut(&JamChunk) -> bool,
) -> Result<Jammed, EdmdError> {
    if !(options.growth_rate.is_finite()
        && options.growth_rate > 0.0
        && options.margin.is_finite()
        && options.margin > 0.0)
    {
        return Err(EdmdError::BadGrowth {
            rate: options.growth_rate,
            margin: options.margin,
        });
    }
    let start = Dynamics::from_state(system, dynamics, rng)?;
    let mut state = system.clone();
    let mut velocities = start.velocities();
    let dof = start.degrees_of_freedom();
    let n = system.len() as u64;
    let size_of = |s: &System| s.species()[0].shape.bounding_radius();
    let initial_size = size_of(system);
    // The rate of the fluid; from Z ≥ SETTLE_FROM, γ (each lowered by
    // halves after a failure).
    let (mut rate, mut time, mut collisions, mut chunk) =
        (FLUID_SPEED_UP * options.growth_rate, 0.0, 0, 0);
    let mut settling = false;
    let mut retries = 0;
    let mut last_failure = None;
    let mut last = None;
    let end = loop {
        if options.max_collisions > 0 && collisions >= options.max_collisions {
            break JamEnd::Budget;
        }
        // A state the dynamics cannot be built on (bodies grown too big
        // for the box) is an error; a failure while it runs is numerical.
        let mut md = Dynamics::growing(&state, &velocities, dynamics, rate, options.margin)?;
        let ends = md.growth_ends().expect("growing");
        let outcome = md
            .run_collisions_until(options.collisions_per_body * n, ends)
            .and_then(|()| {
                let pressure = md.sample().pressure.unwrap_or(0.0);
                Ok((pressure, md.to_system()?))
            });
        let (pressure, next) = match outcome {
            Ok(done) => done,
            Err(e) => {
                last_failure = Some(e.to_string());
                if rate * 0.5 < options.growth_floor {
                    break JamEnd::GrowthFloor;
                }
                rate *= 0.5;
                retries += 1;
                continue;
            }
        };
        // Thermostat: the kinetic energy back to dof kT / 2.
        let kt = 2.0 * md.kinetic_energy() / dof;
        let factor = (dynamics.temperature / kt).sqrt();
        velocities = md
            .velocities()
            .iter()
            .map(|(v, w)| (v * factor, w * factor))
            .collect();
        chunk += 1;
        time += md.time();
        collisions += md.collisions();
        let z = pressure * next.periodic_box().volume() / n as f64;
        let figures = JamChunk {
            chunk,
            time,
            collisions,
            packing_fraction: next.packing_fraction(),
            pressure: z,
            temperature: kt,
            growth_rate: rate,
            size: size_of(&next) / initial_size,
        };
        state = next;
        last = Some(figures);
        if !settling && z >= SETTLE_FROM {
            settling = true;
            rate = rate.min(options.growth_rate);
        }
        if z >= options.pressure {
            break JamEnd::Jammed;
        }
        if !each_chunk(&figures) {
            break JamEnd::Stopped;
        }
    };
    Ok(Jammed {
        system: state,
        velocities,
        last,
        end,
        retries,
        last_failure,
    })
}
