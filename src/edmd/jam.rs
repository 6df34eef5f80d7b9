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
//! The bodies grow at γ from start to end, or at a fluid rate of their
//! own until Z = 10³ ([`JamOptions::fluid_rate`]). The rate through the
//! fluid and the glass sets how dense and how ordered the packing is, and
//! the rate of the last approach how well the bodies settle into their
//! cages: growing ten times faster until Z = 10³ left 1000 spheroids
//! 1.5:1 at φ_J = 0.704 against 0.716, and 1000 spheres at 0.632 against
//! 0.644 (γ = 10⁻²), without saving collisions; bodies with flat faces
//! grown slowly through the fluid pack far denser than at random
//! (docs/benchmarks/jam-schedule-2026-11-27.md).
//! Measured on 500 spheres without settling rounds: growing at 10⁻² after
//! Z = 10³ leaves the backbone hypostatic (z = 5.70), 10⁻³ gives z = 5.95,
//! 10⁻⁴ gives 5.99 (docs/benchmarks/jam-2026-11-26.md).
//!
//! Where the pressure passes its bound on a packing whose contacts do not
//! certify it ([`certificate`]), the pressure came from the growth, and
//! the packing settles: its bodies rest at their size for [`REST_CHUNKS`]
//! chunks (1000 spheres grown at 10⁻² fell from βPV/N = 1.6×10¹³ to
//! 2.6×10⁷ there) and grow on at a tenth of the rate, for at most
//! [`JamOptions::settle_rounds`] rounds; 1000 spheres at 10⁻² then jam
//! with z = 5.94 after one round (docs/benchmarks/jam-settle-2026-12-02.md).
//!
//! A chunk is one [`Dynamics::growing`] run: the sizes at its start times
//! 1 + γt, up to a fixed relative growth (the margin its cells and
//! neighbour regions are built for, 5 %: wider costs more candidates per
//! search, narrower more rebuilds while the fluid is dilute) or a number
//! of collisions per body, whichever comes first. A chunk whose numerics fail (a contact the
//! solver could not certify) is run again from its start at half the
//! rate; below [`JamOptions::growth_floor`] the run ends at the last
//! state that was certified.

use nalgebra::Vector3;
use rand::Rng;

use super::dynamics::{
    Dynamics, DynamicsDump, DynamicsOptions, EdmdError, automatic_neighbour_shell,
};
use super::predict::{PredictorOptions, SolverWork};
use crate::state::{Species, System};

type V3 = Vector3<f64>;

/// How a jamming run grows the bodies and when it stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JamOptions {
    /// γ: the relative growth of every body's linear size per unit time
    /// (time in units of σ√(1/kT), σ the bodies' size: the growth runs
    /// every body at unit mass, whatever the species' masses).
    pub growth_rate: f64,
    /// The rate until Z reaches [`SETTLE_FROM`] (default: γ). Faster
    /// keeps the structure of the fluid (random jammed packings of bodies
    /// that would order), slower lets it pack denser.
    pub fluid_rate: Option<f64>,
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
    /// Stop growing at this packing fraction instead (a dense fluid or
    /// glass, not a jammed packing), reached to round-off.
    pub packing_fraction: Option<f64>,
    /// Settling rounds at most: where the pressure passes its bound (of at
    /// least [`SETTLE_BOUND`]) on a packing its contacts do not certify
    /// ([`certificate`]), the bodies
    /// rest at their size for [`REST_CHUNKS`] chunks and grow on at a
    /// tenth of the rate (0: end there, not certified).
    pub settle_rounds: u32,
}

impl Default for JamOptions {
    fn default() -> Self {
        Self {
            growth_rate: DEFAULT_GROWTH_RATE,
            fluid_rate: None,
            pressure: DEFAULT_JAM_PRESSURE,
            growth_floor: DEFAULT_GROWTH_RATE * 1e-4,
            margin: 0.05,
            collisions_per_body: 100,
            max_collisions: 0,
            packing_fraction: None,
            settle_rounds: DEFAULT_SETTLE_ROUNDS,
        }
    }
}

impl JamOptions {
    /// The rate until Z reaches [`SETTLE_FROM`].
    pub fn fluid_rate(&self) -> f64 {
        self.fluid_rate.unwrap_or(self.growth_rate)
    }
}

/// The default γ.
pub const DEFAULT_GROWTH_RATE: f64 = 1e-3;
/// The reduced pressure from which the bodies grow at γ (below it, at the
/// fluid rate) and the neighbour shell is a fraction of the automatic
/// one.
pub const SETTLE_FROM: f64 = 1e3;

/// The neighbour shell from [`SETTLE_FROM`] on, as a fraction of the
/// automatic one. There every body rattles in a cage about 1/Z of its size
/// (Z = βPV/N): a thinner shell lists fewer partners to search at each
/// collision, and its escapes stay rare. The events are the same (the
/// lists hold every pair that can meet before an escape): to the bit for
/// spheres, to within the contact tolerance for bodies, whose searches an
/// escape renews from another start.
const SETTLED_SHELL: f64 = 0.25;
/// The contact tolerance of the predictions while growing (relative to
/// the smaller body's smallest half-extent), at most: with the default
/// 10⁻¹⁰, 1000 spheroids 1.5:1 stalled near βPV/N = 5×10⁹ (collisions at
/// one instant); with this and [`JAM_NEWTON_TOLERANCE`] they jam to
/// 10¹² (docs/benchmarks/jam-bodies-2026-11-26.md).
pub const JAM_CONTACT_TOLERANCE: f64 = 1e-13;
/// Newton's tolerance on the distance while growing, at most.
pub const JAM_NEWTON_TOLERANCE: f64 = 1e-14;
/// Newton's iteration cap while growing, at least. Superballs of exponent
/// 12 face to face, aligned to 1e-8, touch where the faces' curvature is
/// 1e-16 of the size's, and Newton's steps along the faces there are
/// round-off over that curvature. Capped at the default 60, 1000 of them
/// grown at 10⁻² met 29 caps (each a fallback to GJK, which stalls on
/// flat faces) by βPV/N = 6×10⁹, and a chunk failed there on a contact
/// missed by 1.3×10⁻¹⁰. Such pairs are a few in 10⁷ distances.
pub const JAM_NEWTON_ITERATIONS: u32 = 1000;
/// GJK's tolerance on the distance while growing, at most (cuboids): with
/// the default 10⁻¹², GJK called two nearly aligned cubes 8.5×10⁻¹³
/// apart face to face where they were 5.5×10⁻¹⁴ apart, and the collision
/// found a predicted contact missed (1000 cubes near βPV/N = 3×10¹¹).
pub const JAM_GJK_TOLERANCE: f64 = 1e-14;

/// The predictions of a growing chunk: `options` with the contact
/// tolerance and the distance solvers' tolerances at most the jam's
/// (gaps near the bound are 1/Z of the size: contacts of bodies are found,
/// and their distances solved, finer than that).
pub fn jam_predictor(mut options: PredictorOptions) -> PredictorOptions {
    options.contact_tolerance = options.contact_tolerance.min(JAM_CONTACT_TOLERANCE);
    let distance = &mut options.distance;
    distance.newton.tolerance = distance.newton.tolerance.min(JAM_NEWTON_TOLERANCE);
    distance.newton.max_iterations = distance.newton.max_iterations.max(JAM_NEWTON_ITERATIONS);
    distance.gjk_tolerance = distance.gjk_tolerance.min(JAM_GJK_TOLERANCE);
    options
}
/// Settling rounds at most, by default: from γ = 10⁻² the third round
/// grows at 10⁻⁵.
pub const DEFAULT_SETTLE_ROUNDS: u32 = 3;
/// The least bound on βPV/N that settling rounds serve: below it a jam
/// asks for a dense glass, whose contacts (1/Z of the size apart) are no
/// network to certify.
pub const SETTLE_BOUND: f64 = 1e9;
/// Chunks of rest at fixed size that begin a settling round. A packing
/// whose pressure came from growing faster than it could settle relaxes
/// in them: 1000 spheres grown at 10⁻² from βPV/N = 1.4×10¹² to 3.6×10⁵
/// in ten chunks, where a jammed one keeps its pressure
/// (docs/benchmarks/jam-settle-2026-12-02.md).
pub const REST_CHUNKS: u32 = 10;
/// The isostatic contacts a backbone of bodies with translations only
/// may lack and still be certified, as a fraction (z ≥ 5.91 for
/// spheres): 1000 spheres grown at 10⁻³ reach z = 5.96, at 10⁻⁴ 5.996,
/// where at 10⁻² their backbone, if any is left, has z near 5.7.
pub const ISOSTATIC_SLACK: f64 = 0.015;

/// What the contact network says of a packing whose pressure passed the
/// bound.
#[derive(Debug, Clone)]
pub struct JamCertificate {
    /// The gap the network was read at, and how it was chosen.
    pub gap: crate::analysis::contact_gap::GapChoice,
    /// The network there.
    pub network: crate::analysis::packing::ContactNetwork,
    /// Bodies of the backbone (those no rattler).
    pub held: usize,
    /// Why it does not certify the packing jammed, or `None` where it
    /// does: a plateau in the contact count against the gap, at least half
    /// the bodies held, and, where the bodies have translations only
    /// (spheres, or bodies that do not turn), a backbone with the
    /// isostatic d (N_b − 1) + 1 contacts (within [`ISOSTATIC_SLACK`]):
    /// such a packing with fewer has floppy modes, and its pressure relaxes
    /// once the growth stops. Bodies that turn jam hypostatic (Donev et
    /// al., Phys. Rev. E 75, 051304 (2007)).
    pub refused: Option<String>,
}

impl JamCertificate {
    /// Whether the contacts certify the packing jammed.
    pub fn jammed(&self) -> bool {
        self.refused.is_none()
    }
}

/// The certificate of `system` at reduced pressure `z` (the gap read
/// from the packing, with `z` as a guide).
pub fn certificate(system: &System, z: Option<f64>) -> JamCertificate {
    let (gap, network) = system.read_contact_network(z);
    let held = network.bodies - network.rattlers.len();
    let translations_only = network.isostatic_contact_number == 6.0;
    let isostatic = 3.0 * (held.max(1) - 1) as f64 + 1.0;
    let contacts = network.backbone_contact_number * held as f64 / 2.0;
    let refused = if let Some(warning) = &gap.warning {
        Some(warning.clone())
    } else if 2 * held < network.bodies {
        Some("fewer than half the bodies are held".into())
    } else if translations_only && contacts < isostatic * (1.0 - ISOSTATIC_SLACK) {
        Some("the backbone lacks contacts an isostatic one has: it has floppy modes".into())
    } else {
        None
    };
    JamCertificate {
        gap,
        network,
        held,
        refused,
    }
}

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
    /// The packing fraction asked was reached.
    PackingFraction,
    /// The caller stopped it.
    Stopped,
}

/// One chunk's figures, as the run goes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
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

/// Where a jamming run stands between chunks: with the state and the
/// velocities, all that continuing it bit for bit needs (a log's frame
/// carries it).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JamProgress {
    /// Chunks done.
    pub chunk: u64,
    /// Simulated time since the start.
    pub time: f64,
    /// Collisions since the start.
    pub collisions: u64,
    /// The growth rate the next chunk runs at.
    pub rate: f64,
    /// Whether Z has reached [`SETTLE_FROM`] (the rate is then γ, the
    /// neighbour shell the thinner one).
    pub settling: bool,
    /// Chunks run again at a lower rate after a failure.
    pub retries: u64,
    /// The first species' bounding radius at the start (sizes are
    /// reported relative to it).
    pub start_size: f64,
    /// The last chunk's figures.
    pub last: Option<JamChunk>,
    /// What the contact searches of every chunk run (those run again
    /// included) have cost, and their strains.
    #[serde(default)]
    pub solver: SolverWork,
    /// Settling rounds begun.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub settle_rounds: u32,
    /// Chunks of rest left in the round under way.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub resting: u32,
}

fn is_zero(k: &u32) -> bool {
    *k == 0
}

/// `dynamics` with every body at unit mass. The growth makes a packing,
/// a geometric object the masses have no part in; with unequal masses
/// the heavy bodies, slower than the growing surfaces that push them,
/// would carry a collision pressure past any bound long before the
/// packing jams (masses 1 and 10⁶ passed βPV/N = 10¹² at φ = 0.37). So
/// every body grows at unit mass, and γ's time unit is σ√(1/kT).
fn unit_masses(dynamics: &DynamicsOptions) -> DynamicsOptions {
    DynamicsOptions {
        masses: Vec::new(),
        ..dynamics.clone()
    }
}

/// A jamming run, chunk by chunk.
#[derive(Debug, Clone)]
pub struct JamRun {
    state: System,
    velocities: Vec<(V3, V3)>,
    progress: JamProgress,
    options: JamOptions,
    dynamics: DynamicsOptions,
    end: Option<JamEnd>,
    last_failure: Option<JamFailure>,
}

impl JamRun {
    /// A run from `system` with Maxwell–Boltzmann velocities at
    /// `dynamics.temperature` drawn from `rng`. The neighbour structure of
    /// each chunk is the automatic one at its packing fraction (the shell
    /// of `dynamics` is not used).
    pub fn new<R: Rng>(
        system: &System,
        options: &JamOptions,
        dynamics: &DynamicsOptions,
        rng: &mut R,
    ) -> Result<Self, EdmdError> {
        check(options)?;
        let dynamics = &unit_masses(dynamics);
        let velocities = Dynamics::from_state(system, dynamics, rng)?.velocities();
        let progress = JamProgress {
            chunk: 0,
            time: 0.0,
            collisions: 0,
            rate: options.fluid_rate(),
            settling: false,
            retries: 0,
            start_size: system.species()[0].shape.bounding_radius(),
            last: None,
            solver: SolverWork::default(),
            settle_rounds: 0,
            resting: 0,
        };
        Self::resume(system, &velocities, options, dynamics, progress)
    }

    /// The run continued from a state, its velocities and its progress.
    pub fn resume(
        system: &System,
        velocities: &[(V3, V3)],
        options: &JamOptions,
        dynamics: &DynamicsOptions,
        mut progress: JamProgress,
    ) -> Result<Self, EdmdError> {
        check(options)?;
        if velocities.len() != system.len() {
            return Err(EdmdError::BadVelocities(system.len()));
        }
        // The rate is the stage's or, after failed chunks, below it.
        let rate = if progress.settling {
            options.growth_rate
        } else {
            options.fluid_rate()
        };
        progress.rate = progress.rate.min(rate);
        Ok(Self {
            state: system.clone(),
            velocities: velocities.to_vec(),
            progress,
            options: *options,
            dynamics: unit_masses(dynamics),
            end: None,
            last_failure: None,
        })
    }

    /// Runs the next chunk; its figures, or `None` once the run has ended
    /// (see [`JamRun::end`]). Errors are those of building the dynamics
    /// (the bodies grown too big for the box); a numerical failure within
    /// a chunk runs it again at half the rate.
    pub fn chunk(&mut self) -> Result<Option<JamChunk>, EdmdError> {
        if self.end.is_some() {
            return Ok(None);
        }
        let n = self.state.len() as u64;
        if let Some(target) = self.options.packing_fraction
            && self.state.packing_fraction() >= target * (1.0 - 1e-12)
        {
            self.end = Some(JamEnd::PackingFraction);
            return Ok(None);
        }
        let p = &mut self.progress;
        loop {
            if self.options.max_collisions > 0 && p.collisions >= self.options.max_collisions {
                self.end = Some(JamEnd::Budget);
                return Ok(None);
            }
            let settled = if p.settling { SETTLED_SHELL } else { 1.0 };
            let mut dynamics = DynamicsOptions {
                neighbour_shell: automatic_neighbour_shell(
                    self.state.species(),
                    self.state.packing_fraction(),
                    self.state.sizes().is_some(),
                )
                .map(|shell| shell * settled),
                ..self.dynamics.clone()
            };
            dynamics.predictor = jam_predictor(dynamics.predictor);
            let resting = p.resting > 0;
            let (mut md, ends) = if resting {
                let md = Dynamics::from_parts(&self.state, &self.velocities, &dynamics, 0.0, 0)?;
                (md, f64::INFINITY)
            } else {
                let md = Dynamics::growing(
                    &self.state,
                    &self.velocities,
                    &dynamics,
                    p.rate,
                    self.options.margin,
                )?;
                // The end of the margin, or where the sizes reach the
                // packing fraction asked (they are 1 + rate t times
                // those of the chunk's start).
                let mut ends = md.growth_ends().expect("growing");
                if let Some(target) = self.options.packing_fraction {
                    let size = (target / self.state.packing_fraction()).cbrt();
                    ends = ends.min((size - 1.0) / p.rate);
                }
                (md, ends)
            };
            md.continue_solver_work(p.solver);
            let run = md.run_collisions_until(self.options.collisions_per_body * n, ends);
            p.solver = md.solver_work();
            let outcome = run.map_err(|e| e.to_string()).and_then(|()| {
                let sample = md.sample();
                // Collisions that all fall at one instant: bodies
                // caught at gaps the arithmetic no longer resolves.
                if sample.pressure.is_none() && md.collisions() > 0 {
                    return Err(format!(
                        "{} collisions without time advancing at βPV/N ≈ {:.3e}",
                        md.collisions(),
                        p.last.map_or(0.0, |c| c.pressure)
                    ));
                }
                let system = md.to_system().map_err(|e| e.to_string())?;
                Ok((sample.pressure.unwrap_or(0.0), system))
            });
            let (pressure, next) = match outcome {
                Ok(done) => done,
                Err(message) => {
                    self.last_failure = Some(JamFailure {
                        message,
                        dump: md.dump(),
                        species: md.species().to_vec(),
                        options: md.options().clone(),
                    });
                    if resting {
                        // A rest that fails ends the rest: the round
                        // grows on from its last certified state.
                        p.resting = 0;
                        p.retries += 1;
                        continue;
                    }
                    if p.rate * 0.5 < self.options.growth_floor {
                        self.end = Some(JamEnd::GrowthFloor);
                        return Ok(None);
                    }
                    p.rate *= 0.5;
                    p.retries += 1;
                    continue;
                }
            };
            // Thermostat: the kinetic energy back to dof kT / 2.
            let kt = md.temperature();
            let factor = (self.dynamics.temperature / kt).sqrt();
            self.velocities = md
                .velocities()
                .iter()
                .map(|(v, w)| (v * factor, w * factor))
                .collect();
            p.chunk += 1;
            p.time += md.time();
            p.collisions += md.collisions();
            let z = pressure * next.periodic_box().volume() / n as f64;
            let figures = JamChunk {
                chunk: p.chunk,
                time: p.time,
                collisions: p.collisions,
                packing_fraction: next.packing_fraction(),
                pressure: z,
                temperature: kt,
                growth_rate: if resting { 0.0 } else { p.rate },
                size: next.species()[0].shape.bounding_radius() / p.start_size,
            };
            self.state = next;
            p.last = Some(figures);
            if resting {
                p.resting -= 1;
                return Ok(Some(figures));
            }
            if !p.settling && z >= SETTLE_FROM {
                p.settling = true;
                // From the fluid rate to γ, keeping a slower growth after
                // failed chunks when γ is the slower.
                let (fluid, gamma) = (self.options.fluid_rate(), self.options.growth_rate);
                p.rate = if fluid >= gamma {
                    p.rate.min(gamma)
                } else {
                    p.rate / fluid * gamma
                };
            }
            if z >= self.options.pressure {
                // Not certified: rest, then grow on slower (a round), while
                // rounds and the floor allow.
                let settle = self.options.pressure >= SETTLE_BOUND
                    && p.settle_rounds < self.options.settle_rounds
                    && p.rate * 0.1 >= self.options.growth_floor
                    && !certificate(&self.state, Some(z)).jammed();
                if settle {
                    p.settle_rounds += 1;
                    p.resting = REST_CHUNKS;
                    p.rate *= 0.1;
                } else {
                    self.end = Some(JamEnd::Jammed);
                }
            } else if let Some(target) = self.options.packing_fraction
                && figures.packing_fraction >= target * (1.0 - 1e-12)
            {
                self.end = Some(JamEnd::PackingFraction);
            }
            return Ok(Some(figures));
        }
    }

    /// Ends the run where it stands (the caller stopped it).
    pub fn stop(&mut self) {
        self.end.get_or_insert(JamEnd::Stopped);
    }

    /// Why the run ended, once it has.
    pub fn end(&self) -> Option<JamEnd> {
        self.end
    }

    /// The bodies now, at their size now (the species scaled).
    pub fn system(&self) -> &System {
        &self.state
    }

    /// The velocities now, at kT.
    pub fn velocities(&self) -> &[(V3, V3)] {
        &self.velocities
    }

    /// Where the run stands.
    pub fn progress(&self) -> &JamProgress {
        &self.progress
    }

    /// The last failure that made a chunk run again, if any.
    pub fn last_failure(&self) -> Option<&str> {
        self.last_failure.as_ref().map(|f| f.message.as_str())
    }

    /// That failure with what replays it.
    pub fn last_failure_replay(&self) -> Option<&JamFailure> {
        self.last_failure.as_ref()
    }
}

/// A chunk's numerical failure (the chunk was run again at half the
/// rate), with the chunk's dynamics where it failed: every body's stored
/// pose and the growth to the bit, so that the failing event can be
/// predicted again ([`JamFailure::replay`]) without running the jam up to
/// it. `dump` serialises (serde); `species` and `options` are the chunk's.
#[derive(Debug, Clone)]
pub struct JamFailure {
    /// The error, as reported.
    pub message: String,
    /// The chunk's dynamics at the failure (or at its end, for a failure
    /// found there: collisions at one instant, an overlap).
    pub dump: DynamicsDump,
    /// The chunk's species: the largest the bodies grow to in it.
    pub species: Vec<Species>,
    /// The chunk's options (its neighbour shell and tolerances).
    pub options: DynamicsOptions,
}

impl JamFailure {
    /// The chunk's dynamics rebuilt where it failed: running it on to
    /// [`Dynamics::growth_ends`] meets the failing event again.
    pub fn replay(&self) -> Result<Dynamics, EdmdError> {
        Dynamics::from_dump(&self.species, &self.dump, &self.options)
    }
}

fn check(options: &JamOptions) -> Result<(), EdmdError> {
    let positive = |x: f64| x.is_finite() && x > 0.0;
    let rates = [options.growth_rate, options.fluid_rate()];
    match rates.into_iter().find(|&r| !positive(r)) {
        None if positive(options.margin) => Ok(()),
        bad => Err(EdmdError::BadGrowth {
            rate: bad.unwrap_or(options.growth_rate),
            margin: options.margin,
        }),
    }
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
    /// What the contact searches cost, and their strains.
    pub solver: SolverWork,
}

/// Grows the bodies of `system` (Lubachevsky–Stillinger) until jammed, from
/// Maxwell–Boltzmann velocities at `dynamics.temperature` (drawn from
/// `rng`). `each_chunk` sees every chunk's figures and returns false to stop
/// there (see [`JamRun`] for the errors).
pub fn jam<R: Rng>(
    system: &System,
    options: &JamOptions,
    dynamics: &DynamicsOptions,
    rng: &mut R,
    mut each_chunk: impl FnMut(&JamChunk) -> bool,
) -> Result<Jammed, EdmdError> {
    let mut run = JamRun::new(system, options, dynamics, rng)?;
    while let Some(figures) = run.chunk()? {
        if run.end().is_none() && !each_chunk(&figures) {
            run.stop();
        }
    }
    Ok(Jammed {
        system: run.state,
        velocities: run.velocities,
        last: run.progress.last,
        end: run.end.expect("ended"),
        retries: run.progress.retries,
        last_failure: run.last_failure.map(|f| f.message),
        solver: run.progress.solver,
    })
}
