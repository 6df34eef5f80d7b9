//! Compression to a target packing fraction (HOOMD's QuickCompress scheme):
//! the box shrinks isotropically by a relative `step`, overlaps allowed,
//! and particle moves remove them. A move is kept only where the moved body
//! overlaps nothing, so the set of overlapping bodies only shrinks; once it
//! is empty the state is valid again and the next shrink follows. The step
//! is set by the share of bodies a shrink leaves overlapping (near
//! `overlapping_share`), not by the closest pair, so it does not fall as
//! N grows. Every shrink is followed by a sweep, and the last few
//! overlapping bodies get many extra moves (one stubborn pair would
//! otherwise hold up the next shrink of all). A shrink whose
//! overlaps outlast `cycle_patience` sweeps is undone (the last valid state
//! restored) and the step halved. The packing is jammed when the step falls
//! below `min_step`, or when the packing fraction gains less than
//! `progress` (relative) in `patience` sweeps.
//!
//! Between calls the state is valid whenever [`Compressor::is_valid`]
//! holds; an error or a jam leaves the last valid state in place.

use crate::number::Num;
use rand::Rng;
use serde::{Deserialize, Serialize};

use super::moves::{Counts, Ensemble, MoveSizes, particle_moves, sweep, sweep_by_species};
use super::sdf::Sdf;
use super::tuning::Tuner;
use crate::space::PeriodicBox;
use crate::state::{Particle, System};

/// The share of bodies a shrink should leave overlapping: the step grows
/// while fewer do and falls while many more do.
pub const OVERLAPPING_SHARE: f64 = 0.05;
/// The share when compressing to the jam: 25 times gentler, which lets the
/// packing relax on the way and jam denser (1000 spheres from a dilute
/// fluid: φ 0.632 against 0.600; ellipsoids 1.5:1, 0.699 against 0.640).
pub const JAMMING_SHARE: f64 = 0.002;
/// The window of the scale distribution measuring the pressure.
const PRESSURE_WINDOW: f64 = 0.02;
/// A pressure target is reached when βP is measured within this relative
/// distance of it: close enough for the NPT sampling that follows.
pub const PRESSURE_TOLERANCE: f64 = 0.03;
/// The largest change of packing fraction, as a ratio, between two
/// pressure measurements.
const MAX_PHI_RATIO: f64 = 1.25;

/// Sweeps over which a pressure is measured (after as many that relax the
/// structure): some 50 000 particle configurations, at least 20 sweeps.
fn measuring_sweeps(n: usize) -> u64 {
    (50_000 / n.max(1) as u64).max(20)
}

/// The species with the most particles (the first of those tied).
fn most_numerous(system: &System) -> usize {
    let mut counts = vec![0usize; system.species().len()];
    for p in system.particles() {
        counts[p.species as usize] += 1;
    }
    (0..counts.len())
        .rev()
        .max_by_key(|&s| counts[s])
        .unwrap_or(0)
}

/// Extra moves an overlapping body gets after each sweep.
pub const CLEARING_TRIES: usize = 10;

/// Knobs of a compression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompressOptions {
    /// Target packing fraction.
    pub target: f64,
    /// Give up after this many sweeps.
    pub max_sweeps: u64,
    /// First relative shrink of the box edge tried.
    pub initial_step: f64,
    /// Largest relative shrink of the box edge in one step.
    pub max_step: f64,
    /// A step below this means the packing is jammed.
    pub min_step: f64,
    /// Sweeps a shrink's overlaps may take to clear before it is undone.
    pub cycle_patience: u64,
    /// Sweeps over which the packing fraction must gain `progress`.
    pub patience: u64,
    /// Smallest relative gain of packing fraction in `patience` sweeps.
    pub progress: f64,
    /// A jam ends the compression successfully, where the target could
    /// not be reached.
    pub until_jammed: bool,
    /// The share of bodies each shrink aims to leave overlapping.
    pub overlapping_share: f64,
    /// A target βP instead of the packing fraction: the packing fraction is
    /// then found from the measured pressure (`target` bounds it).
    pub pressure: Option<f64>,
}

impl CompressOptions {
    /// Defaults for a target packing fraction.
    pub fn to(target: f64) -> Self {
        Self {
            target,
            max_sweeps: 1_000_000,
            initial_step: 0.01,
            max_step: 0.05,
            min_step: 1e-6,
            cycle_patience: 100,
            patience: 2000,
            progress: 1e-4,
            until_jammed: false,
            overlapping_share: OVERLAPPING_SHARE,
            pressure: None,
        }
    }

    /// Defaults for a compression to the packing fraction at which the
    /// measured βP is `pressure`, at most `bound`.
    pub fn to_pressure(pressure: f64, bound: f64) -> Self {
        Self {
            pressure: Some(pressure),
            ..Self::to(bound)
        }
    }

    /// Defaults for a compression toward `target` that ends successfully
    /// at the jam short of it, compressing gently ([`JAMMING_SHARE`]).
    pub fn until_jammed(target: f64) -> Self {
        Self {
            until_jammed: true,
            overlapping_share: JAMMING_SHARE,
            ..Self::to(target)
        }
    }
}

/// Why compression could not start or did not finish.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompressError {
    /// The target is not a packing fraction in (0, 1).
    #[error("compression target {0} is not a packing fraction in (0, 1)")]
    BadTarget(f64),
    /// The target lies below the start: nothing to compress.
    #[error("compression target {target} is below the starting packing fraction {start}")]
    TargetBelowStart {
        /// Requested.
        target: f64,
        /// Where the system is.
        start: f64,
    },
    /// Move sizes that cannot move anything.
    #[error("translation move size must be > 0, got {}", Num(*.0))]
    ZeroMoveSize(f64),
    /// Jammed short of the target.
    #[error(
        "jammed at packing fraction {:.4} after {sweeps} sweeps (target {}); `until_jammed: true` ends the stage there", Num(*.reached), Num(*.target)
    )]
    Jammed {
        /// Packing fraction reached.
        reached: f64,
        /// Requested.
        target: f64,
        /// Sweeps done.
        sweeps: u64,
    },
    /// Jammed before the pressure asked was measured.
    #[error(
        "jammed at packing fraction {:.4} after {sweeps} sweeps before betaP reached {}: a pressure this high is that of a jammed packing or near it; for one, use Compress(packing_fraction: 0.74, until_jammed: true) or Jam()",
        Num(*.reached),
        Num(*.pressure)
    )]
    JammedBelowPressure {
        /// Packing fraction reached.
        reached: f64,
        /// The βP asked.
        pressure: f64,
        /// Sweeps done.
        sweeps: u64,
    },
    /// The target needs a box edge shorter than twice the interaction
    /// range (the minimum image would not be unique): too few particles
    /// for that packing fraction.
    #[error(
        "at packing fraction {} the box edge would be {:.4}, below twice the interaction range {:.4}: use more particles (reached {:.4})",
        Num(*.target),
        Num(*.edge),
        Num(*.range),
        Num(*.reached)
    )]
    BoxLimit {
        /// Packing fraction reached.
        reached: f64,
        /// Requested.
        target: f64,
        /// The shortest edge the target needs.
        edge: f64,
        /// Twice the largest bounding radius.
        range: f64,
    },
    /// Ran out of sweeps.
    #[error(
        "reached packing fraction {:.4} of {} in the allowed {sweeps} sweeps",
        Num(*.reached),
        Num(*.target)
    )]
    OutOfSweeps {
        /// Packing fraction reached.
        reached: f64,
        /// Requested.
        target: f64,
        /// Sweeps done.
        sweeps: u64,
    },
    /// The target pressure is not a positive number.
    #[error("compression target pressure {0} is not a positive number")]
    BadPressure(f64),
    /// The last valid state could not be rebuilt (a bug, not an input).
    #[error("restoring the last overlap-free state failed: {0}")]
    Restore(String),
}

/// How a completed compression went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompressReport {
    /// Sweeps used.
    pub sweeps: u64,
    /// Final packing fraction: the target, or where it jammed.
    pub packing_fraction: f64,
    /// Ended at a jam short of the target (with `until_jammed`).
    pub jammed: bool,
    /// Move counters over the whole compression.
    pub counts: Counts,
    /// Move sizes at the end (tuned as it went).
    pub sizes: MoveSizes,
    /// Box shrinks made, and shrinks undone.
    pub shrinks: u64,
    /// Shrinks undone because their overlaps did not clear.
    pub undone: u64,
    /// At a jam, βP/ρ of the final configuration from its scale
    /// distribution (large: the pressure diverges at the jam).
    pub compressibility: Option<f64>,
    /// For a pressure target, the last βP measured (near the packing
    /// fraction reached, which the last measurement's secant step set).
    pub pressure: Option<f64>,
}

/// βP/ρ of one configuration, from its scale distribution (whose fit
/// window follows the distribution's decay down to a jam's).
fn compressibility(system: &System) -> Option<f64> {
    let density = system.len() as f64 / system.periodic_box().volume();
    let mut sdf = Sdf::new(0.02, 200);
    sdf.add(system);
    sdf.pressure().map(|p| p / density)
}

/// Compresses `system` to `opts.target`; on success the packing fraction is
/// the target (to rounding), or with `until_jammed` where it jammed, and
/// the state is overlap-free.
pub fn compress<R: Rng>(
    system: &mut System,
    sizes: MoveSizes,
    opts: &CompressOptions,
    rng: &mut R,
) -> Result<CompressReport, CompressError> {
    let mut c = Compressor::new(system, sizes, opts)?;
    loop {
        if let Some(report) = c.sweep(system, rng)? {
            return Ok(report);
        }
    }
}

/// Everything a compression carries from one valid state to the next
/// besides the system and the random stream: with them, enough to resume
/// it exactly.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CompressorState {
    /// Sweeps done.
    pub sweeps: u64,
    /// Move sizes now (of a mixture: its most numerous species', handed on
    /// to the next stage).
    pub sizes: MoveSizes,
    /// A mixture's move sizes per species, each tuned on its own
    /// acceptance: one size for all is tuned by the many small bodies, and
    /// is far too long for the few large ones, which then never move and
    /// jam the packing early.
    #[serde(default)]
    pub species_sizes: Vec<MoveSizes>,
    /// A mixture's counts per species since the last move-size update.
    #[serde(default)]
    pub species_window: Vec<Counts>,
    /// Relative shrink of the box edge tried next.
    pub step: f64,
    /// Counts since the last move-size update.
    pub window: Counts,
    /// Counts over the whole compression.
    pub counts: Counts,
    /// Largest translation the tuner allows (half the starting box's
    /// shortest edge, kept so that a resumed compression tunes as the
    /// original did).
    pub max_translate: f64,
    /// The last shrink landed on the target.
    #[serde(default)]
    pub at_target: bool,
    /// Sweep and packing fraction at which progress was last checked.
    #[serde(default)]
    pub progress_mark: (u64, f64),
    /// Box shrinks made.
    #[serde(default)]
    pub shrinks: u64,
    /// Shrinks undone.
    #[serde(default)]
    pub undone: u64,
    /// The packing fraction aimed at now (a pressure target moves it;
    /// `None`: the options' target).
    #[serde(default)]
    pub target: Option<f64>,
    /// For a pressure target, the last packing fraction and βP measured.
    #[serde(default)]
    pub measured: Option<(f64, f64)>,
    /// For a pressure target, measured close to it: the packing fraction
    /// aimed at now is the last.
    #[serde(default)]
    pub settling: bool,
}

/// A compression one sweep at a time (see [`compress`]).
#[derive(Debug, Clone)]
pub struct Compressor {
    opts: CompressOptions,
    tuner: Tuner,
    state: CompressorState,
    /// Bodies overlapping since the last shrink (empty: the state is valid).
    overlapping: Vec<usize>,
    /// Sweeps since the last shrink.
    since_shrink: u64,
    /// The last valid state, put back when a shrink is undone.
    valid_box: Option<PeriodicBox>,
    valid_particles: Vec<Particle>,
    /// For a pressure target: the sweeps of the measurement under way,
    /// and its scale distribution.
    measuring: u64,
    sdf: Sdf,
}

impl Compressor {
    /// Checks the options against the system.
    pub fn new(
        system: &System,
        sizes: MoveSizes,
        opts: &CompressOptions,
    ) -> Result<Self, CompressError> {
        if !(opts.target > 0.0 && opts.target < 1.0) {
            return Err(CompressError::BadTarget(opts.target));
        }
        if let Some(p) = opts.pressure
            && !(p.is_finite() && p > 0.0)
        {
            return Err(CompressError::BadPressure(p));
        }
        let start = system.packing_fraction();
        if opts.pressure.is_some() {
            // Measured where it starts; the packing fraction follows.
            return Ok(Self::resume(
                opts,
                CompressorState {
                    target: Some(start),
                    at_target: true,
                    ..Self::fresh(system, sizes, opts)
                },
            ));
        }
        if opts.target < start {
            return Err(CompressError::TargetBelowStart {
                target: opts.target,
                start,
            });
        }
        if sizes.translate.is_nan() || sizes.translate <= 0.0 {
            return Err(CompressError::ZeroMoveSize(sizes.translate));
        }
        // Said at once, not found out as a "jam" thousands of sweeps later.
        let edge = system.periodic_box().lengths().min() * (start / opts.target).cbrt();
        let range = system.interaction_range();
        if edge < 2.0 * range {
            return Err(CompressError::BoxLimit {
                reached: start,
                target: opts.target,
                edge,
                range,
            });
        }
        Ok(Self::resume(opts, Self::fresh(system, sizes, opts)))
    }

    fn fresh(system: &System, sizes: MoveSizes, opts: &CompressOptions) -> CompressorState {
        let kinds = system.species().len();
        let (species_sizes, species_window) = if kinds > 1 {
            (vec![sizes; kinds], vec![Counts::default(); kinds])
        } else {
            (Vec::new(), Vec::new())
        };
        CompressorState {
            sweeps: 0,
            sizes,
            species_sizes,
            species_window,
            step: opts.initial_step,
            window: Counts::default(),
            counts: Counts::default(),
            max_translate: system.periodic_box().lengths().min() / 2.0,
            at_target: false,
            progress_mark: (0, system.packing_fraction()),
            shrinks: 0,
            undone: 0,
            target: None,
            measured: None,
            settling: false,
        }
    }

    /// Continues a compression from a state saved while it was valid.
    pub fn resume(opts: &CompressOptions, state: CompressorState) -> Self {
        Self {
            opts: *opts,
            tuner: Tuner {
                target: 0.3,
                max_translate: state.max_translate,
            },
            state,
            overlapping: Vec::new(),
            since_shrink: 0,
            valid_box: None,
            valid_particles: Vec::new(),
            measuring: 0,
            sdf: Sdf::new(PRESSURE_WINDOW, 200),
        }
    }

    /// The state to save (with the system and the random stream); complete
    /// only while [`Compressor::is_valid`].
    pub fn state(&self) -> &CompressorState {
        &self.state
    }

    /// No body overlaps and no pressure measurement is under way: the
    /// system may be saved (with [`Compressor::state`]) or handed on.
    pub fn is_valid(&self) -> bool {
        self.overlapping.is_empty() && self.measuring == 0
    }

    /// The packing fraction aimed at now.
    fn target(&self) -> f64 {
        self.state.target.unwrap_or(self.opts.target)
    }

    /// Bodies overlapping now.
    pub fn overlapping(&self) -> usize {
        self.overlapping.len()
    }

    fn report(&self, system: &System, jammed: bool) -> CompressReport {
        CompressReport {
            sweeps: self.state.sweeps,
            packing_fraction: system.packing_fraction(),
            jammed,
            counts: self.state.counts,
            sizes: self.state.sizes,
            shrinks: self.state.shrinks,
            undone: self.state.undone,
            compressibility: jammed.then(|| compressibility(system)).flatten(),
            pressure: self.state.measured.map(|(_, p)| p),
        }
    }

    /// One sweep of moves, counted, with the move sizes tuned every 20 (a
    /// mixture's per species).
    fn moves<R: Rng>(&mut self, system: &mut System, rng: &mut R) {
        let st = &mut self.state;
        st.sweeps += 1;
        let c = if st.species_sizes.is_empty() {
            sweep(system, &st.sizes, &Ensemble::Nvt, rng)
        } else {
            sweep_by_species(system, &st.species_sizes, &mut st.species_window, rng)
        };
        st.counts += c;
        st.window += c;
        if st.sweeps.is_multiple_of(20) {
            if st.species_sizes.is_empty() {
                self.tuner.update(&mut st.sizes, &st.window);
            } else {
                for (sizes, window) in st.species_sizes.iter_mut().zip(&mut st.species_window) {
                    self.tuner.update(sizes, window);
                    *window = Counts::default();
                }
                st.sizes = st.species_sizes[most_numerous(system)];
            }
            st.window = Counts::default();
        }
    }

    /// A sweep of the pressure measurement at the packing fraction aimed
    /// at; at its end, the report if βP is within [`PRESSURE_TOLERANCE`]
    /// of `pressure`, else the next packing fraction to aim at (an
    /// expansion made at once: it cannot create an overlap).
    fn measure<R: Rng>(
        &mut self,
        system: &mut System,
        pressure: f64,
        rng: &mut R,
    ) -> Result<Option<CompressReport>, CompressError> {
        if self.state.sweeps >= self.opts.max_sweeps {
            self.measuring = 0;
            return Err(CompressError::OutOfSweeps {
                reached: system.packing_fraction(),
                target: self.target(),
                sweeps: self.opts.max_sweeps,
            });
        }
        self.moves(system, rng);
        self.measuring += 1;
        // The first half relaxes the structure a shrink left: just
        // compressed, fewer pairs are near contact than in equilibrium,
        // and the pressure measured at once is low.
        let half = measuring_sweeps(system.len());
        if self.measuring > half {
            self.sdf.add(system);
        }
        if self.measuring < 2 * half {
            return Ok(None);
        }
        self.measuring = 0;
        let measured = self.sdf.pressure();
        self.sdf = Sdf::new(PRESSURE_WINDOW, 200);
        let Some(measured) = measured.filter(|p| p.is_finite() && *p > 0.0) else {
            return Ok(None); // measured again
        };
        let phi = system.packing_fraction();
        self.state.progress_mark = (self.state.sweeps, phi);
        let previous = self.state.measured.replace((phi, measured));
        // ln βP against ln φ, through the last two measurements (slope at
        // least 1: βP grows at least as the density; ideal gas at first).
        let slope = previous
            .filter(|(phi0, p0)| (phi / phi0).ln().abs() > 1e-9 && *p0 != measured)
            .map(|(phi0, p0)| ((measured / p0).ln() / (phi / phi0).ln()).clamp(1.0, 50.0));
        let close = (measured / pressure - 1.0).abs() < PRESSURE_TOLERANCE;
        if close && slope.is_none() {
            return Ok(Some(self.report(system, false)));
        }
        let next = (phi * (pressure / measured).powf(1.0 / slope.unwrap_or(1.0)))
            .clamp(phi / MAX_PHI_RATIO, phi * MAX_PHI_RATIO)
            .min(self.opts.target);
        // Close: the last secant step is taken without measuring again, so
        // that what is left is the measurement's noise, not the tolerance.
        self.state.settling = close;
        if next <= phi {
            let lengths = system.periodic_box().lengths() * (phi / next).cbrt();
            if !system.rescale_allowing_overlaps(lengths) {
                return Err(CompressError::Restore(
                    "an expansion was refused".to_string(),
                ));
            }
            self.state.target = Some(system.packing_fraction());
            if close {
                return Ok(Some(self.report(system, false)));
            }
        } else {
            let edge = system.periodic_box().lengths().min() * (phi / next).cbrt();
            let range = system.interaction_range();
            if edge < 2.0 * range {
                return Err(CompressError::BoxLimit {
                    reached: phi,
                    target: next,
                    edge,
                    range,
                });
            }
            self.state.target = Some(next);
            self.state.at_target = false;
        }
        Ok(None)
    }

    /// Up to [`CLEARING_TRIES`] extra moves for each overlapping body, each
    /// kept where it overlaps nothing: a shrink's few overlaps then clear
    /// within a sweep instead of waiting for the sweep's one move of each
    /// body. (Not counted in the acceptances, which tune the move sizes.)
    fn clear_overlaps<R: Rng>(&mut self, system: &mut System, rng: &mut R) {
        // The last few get many more tries, at sizes down to an eighth: one
        // stubborn pair would otherwise hold up the next shrink of all.
        let last_few = self.overlapping.len() * 100 <= system.len();
        let tries = if last_few {
            10 * CLEARING_TRIES
        } else {
            CLEARING_TRIES
        };
        for k in 0..self.overlapping.len() {
            let i = self.overlapping[k];
            let species = system.particles()[i].species as usize;
            let sizes = *self
                .state
                .species_sizes
                .get(species)
                .unwrap_or(&self.state.sizes);
            for t in 0..tries {
                if !system.overlaps_where_it_is(i) {
                    break;
                }
                let scale = if last_few {
                    0.5f64.powi((t % 4) as i32)
                } else {
                    1.0
                };
                let scaled = MoveSizes {
                    translate: scale * sizes.translate,
                    rotate: scale * sizes.rotate,
                    ..sizes
                };
                particle_moves(system, 1, |_| i, &scaled, rng, |_| true, |_, _, _, _| {});
            }
        }
        self.overlapping.retain(|&i| system.overlaps_where_it_is(i));
    }

    /// Puts back the last valid state.
    fn restore(&mut self, system: &mut System) -> Result<(), CompressError> {
        if let Some(box_) = self.valid_box.filter(|_| !self.overlapping.is_empty()) {
            system
                .restore(box_, &self.valid_particles)
                .map_err(|e| CompressError::Restore(e.to_string()))?;
            self.overlapping.clear();
        }
        Ok(())
    }

    /// Ends at a jam: successfully with `until_jammed`, else as an error;
    /// either way in the last valid state.
    fn jammed(&mut self, system: &mut System) -> Result<Option<CompressReport>, CompressError> {
        self.restore(system)?;
        if self.opts.until_jammed {
            return Ok(Some(self.report(system, true)));
        }
        let reached = system.packing_fraction();
        let sweeps = self.state.sweeps;
        Err(match self.opts.pressure {
            Some(pressure) => CompressError::JammedBelowPressure {
                reached,
                pressure,
                sweeps,
            },
            None => CompressError::Jammed {
                reached,
                target: self.target(),
                sweeps,
            },
        })
    }

    /// From a valid state: the report if the target is reached, else a
    /// shrink toward it (overlaps allowed) followed by a sweep of moves;
    /// from an invalid one, a sweep of moves, undoing the shrink if its
    /// overlaps have outlasted their patience. `Some` report when done.
    pub fn sweep<R: Rng>(
        &mut self,
        system: &mut System,
        rng: &mut R,
    ) -> Result<Option<CompressReport>, CompressError> {
        let opts = self.opts;
        if self.overlapping.is_empty() {
            if self.state.at_target {
                match opts.pressure {
                    Some(pressure) if !self.state.settling => {
                        return self.measure(system, pressure, rng);
                    }
                    _ => return Ok(Some(self.report(system, false))),
                }
            }
            let phi = system.packing_fraction();
            let (mark_sweeps, mark_phi) = self.state.progress_mark;
            if self.state.sweeps >= mark_sweeps + opts.patience {
                if phi < mark_phi * (1.0 + opts.progress) {
                    return self.jammed(system);
                }
                self.state.progress_mark = (self.state.sweeps, phi);
            }
            self.valid_box = Some(*system.periodic_box());
            self.valid_particles.clear();
            self.valid_particles.extend_from_slice(system.particles());
            // The factor of the current step, or the one that lands exactly
            // on the target, whichever shrinks less.
            let to_target = (phi / self.target()).cbrt();
            let factor = to_target.max(1.0 - self.state.step);
            let lengths = system.periodic_box().lengths() * factor;
            if !system.rescale_allowing_overlaps(lengths) {
                // Checked at the start; the box limit cannot bind on the way.
                return Err(CompressError::BoxLimit {
                    reached: phi,
                    target: self.target(),
                    edge: lengths.min(),
                    range: system.interaction_range(),
                });
            }
            self.state.shrinks += 1;
            self.state.at_target = factor == to_target;
            system.overlapping_particles(&mut self.overlapping);
            self.since_shrink = 0;
            // The next step from this one's share of overlapping bodies: a
            // share, unlike a count, means the same for every N.
            let share = self.overlapping.len() as f64 / system.len() as f64;
            if share < 0.5 * opts.overlapping_share {
                self.state.step = (self.state.step * 1.3).min(opts.max_step);
            } else if share > 2.0 * opts.overlapping_share {
                self.state.step *= 0.7;
            }
        }
        if self.state.sweeps >= opts.max_sweeps {
            self.restore(system)?;
            return Err(CompressError::OutOfSweeps {
                reached: system.packing_fraction(),
                target: self.target(),
                sweeps: opts.max_sweeps,
            });
        }
        self.moves(system, rng);
        self.since_shrink += 1;
        self.overlapping.retain(|&i| system.overlaps_where_it_is(i));
        if !self.is_valid() {
            self.clear_overlaps(system, rng);
        }
        if !self.is_valid() && self.since_shrink >= opts.cycle_patience {
            self.restore(system)?;
            self.state.undone += 1;
            self.state.at_target = false;
            self.state.step *= 0.5;
            if self.state.step < opts.min_step {
                return self.jammed(system);
            }
        }
        Ok(None)
    }
}
