//! Runs a scene: makes the start, runs the stages in order (each from
//! exactly the state the previous one ended with) and writes the log.
//!
//! Hand-off: Monte Carlo stages pass the system and the tuned move sizes
//! on; a dynamics stage starts from the system with Maxwell–Boltzmann
//! velocities at its temperature, or continues the previous dynamics stage
//! (velocities rescaled if the temperature changes); a Monte Carlo stage
//! after dynamics takes the final positions and orientations.
//!
//! - `mod.rs`: running and resuming a scene, errors, the runner;
//! - `simulation.rs`: a run a step at a time (the stage loop);
//! - `start.rs`: the first state (or the last of another log);
//! - `cadence.rs`: the rhythm of stats, frames, stops and ends every
//!   stage keeps, and the seam (`StageRun`) each stage kind implements;
//! - `compress.rs`, `monte_carlo.rs`, `dynamics.rs`: one stage kind each;
//! - `records.rs`: the stats, frames and resume information of Monte
//!   Carlo stages.

mod cadence;
mod compress;
mod dynamics;
mod jam;
mod monte_carlo;
mod records;
mod simulation;
mod start;

use compress::CompressStage;
use dynamics::DynamicsStage;
use jam::JamStage;
use monte_carlo::MonteCarloStage;
pub use simulation::{Advance, Simulation, Step};
use start::start_state;
pub use start::{RecordError, check_start, system_from_record};

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::edmd::EdmdError;
use crate::edmd::dynamics::{Dynamics, DynamicsDump};
use crate::log::StorageFailure;
use crate::log::file::{OutputError, check_output, lock_for_reading, same_file};
use crate::log::read::{RawMessage, ReadOptions, read_log_with};
use crate::log::{FailureRecord, LogError, LogWriter, ResumeInfo, StateRecord, partial_path};
use crate::mc::compress::{CompressError, CompressOptions};
use crate::mc::moves::MoveSizes;
use crate::mc::tuning::DriftWatch;
use crate::number::Num;
use crate::scene::plan::Plan;
use crate::scene::{DEFAULT_COMPRESS_SWEEPS, Ensemble, Scene, Stage, Start, ValidScene};
use crate::state::StateError;
use crate::state::System;
use crate::state::start::StartError;

/// Told how a run goes (the command line draws progress bars or lines).
pub trait Progress {
    /// Stage `index` of `count` begins; its length in ticks (sweeps, or
    /// thousandths of simulated time; 0 when not known in advance).
    fn stage(&mut self, index: usize, count: usize, description: &str, ticks: u64);
    /// The stage has reached `tick`; `message` gives the latest figures.
    fn tick(&mut self, tick: u64, message: &str);
    /// The stage ended.
    fn stage_done(&mut self, message: &str);
}

/// Progress that is not shown.
pub struct Silent;

impl Progress for Silent {
    fn stage(&mut self, _: usize, _: usize, _: &str, _: u64) {}
    fn tick(&mut self, _: u64, _: &str) {}
    fn stage_done(&mut self, _: &str) {}
}

/// Why a run did not complete.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The start could not be made (the scene asks for the impossible).
    #[error("start: {0}")]
    Start(#[from] StartError),
    /// The start names a log that cannot be resumed from.
    #[error("start: {0}")]
    Resume(String),
    /// A step-by-step run was asked for what it cannot do (a number of
    /// sweeps of a dynamics stage, a step after the last stage, a
    /// configuration that overlaps).
    #[error("{0}")]
    Request(String),
    /// A logged frame to go on from does not make a state the scene can
    /// go on with.
    #[error("start: {0}")]
    Phase(#[from] PhaseError),
    /// The output path may not be written (it is an input, a link, a
    /// directory...).
    #[error("{0}")]
    Output(#[from] OutputError),
    /// The log could not be written.
    #[error("log: {0}")]
    Log(#[from] LogError),
    /// Writing the log failed (a full disk); what was written up to then
    /// is kept at `kept` if it holds a frame to resume from.
    #[error("log: {source}; {}", match kept {
        Some(p) => format!("the log up to the failure is in {}", p.display()),
        None => "no partial log was kept (it held no frame to resume from)".into(),
    })]
    LogWrite {
        /// The first write that failed.
        source: LogError,
        /// The partial log kept, if any.
        kept: Option<PathBuf>,
    },
    /// A stage failed; the log up to the failure is kept at `partial`.
    #[error("stage {index} ({kind}): {error}; the log up to the failure is in {}", partial.display())]
    Stage {
        /// Index of the stage.
        index: usize,
        /// Its kind.
        kind: &'static str,
        /// What went wrong.
        error: StageError,
        /// The partial log.
        partial: PathBuf,
    },
}

/// Why a logged frame is no state to go on from.
#[derive(Debug, thiserror::Error)]
pub enum PhaseError {
    /// Its bodies do not fit the scene, or overlap.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// A moving stage's frame without the velocities it goes on with.
    #[error("a {0} frame without velocities")]
    NoVelocities(&'static str),
    /// A frame with dynamics for a stage that is not a dynamics stage.
    #[error("frame of stage {0} has dynamics, the scene's stage does not")]
    NotDynamics(usize),
    /// The dynamics could not be rebuilt from it.
    #[error(transparent)]
    Dynamics(#[from] EdmdError),
}

/// Why a stage failed.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    /// The log could not be written.
    #[error("writing the log: {0}")]
    Log(#[from] LogError),
    /// The compression failed (jammed short of its target, or could not
    /// start).
    #[error(transparent)]
    Compress(#[from] CompressError),
    /// The dynamics failed.
    #[error(transparent)]
    Dynamics(#[from] EdmdError),
    /// The dynamics handed on a state that is not a valid hard-body state.
    #[error("the dynamics ended in an invalid state: {0}")]
    Handoff(StateError),
    /// A compression resumed from a frame that does not carry its state.
    #[error("a compression frame without the compression's state")]
    NoCompressorState,
    /// A jam frame without the velocities its growth goes on with.
    #[error("a jam frame without velocities")]
    NoJamVelocities,
    /// A dynamics stage whose collision rate would take it past
    /// [`DYNAMICS_COLLISIONS_PER_BODY`](crate::scene::DYNAMICS_COLLISIONS_PER_BODY).
    #[error(
        "{:.3} collisions per body and unit time (a packing at or near its jam?): t = {} would take {:.1e} collisions per body, more than the {:.0e} a dynamics stage may run; shorten the duration, or start from a looser packing",
        Num(*.rate),
        Num(*.duration),
        .projected,
        crate::scene::DYNAMICS_COLLISIONS_PER_BODY as f64
    )]
    CollisionBudget {
        /// Collisions per body and unit time so far.
        rate: f64,
        /// The stage's duration.
        duration: f64,
        /// Collisions per body the duration would take.
        projected: f64,
    },
    /// A compression stage without a target (the scene's checks refuse
    /// it).
    #[error("a compression without a target")]
    NoTarget,
}

impl RunError {
    /// Whether the input (scene, start, output path) is at fault rather
    /// than the simulation.
    pub fn is_bad_input(&self) -> bool {
        match self {
            RunError::Start(_)
            | RunError::Resume(_)
            | RunError::Phase(_)
            | RunError::Request(_) => true,
            RunError::Output(e) => !e.is_storage_failure(),
            RunError::Log(e @ LogError::Io { .. }) => !e.is_storage_failure(),
            RunError::Log(LogError::Busy { .. }) => true,
            _ => false,
        }
    }
}

/// How a completed (or interrupted) run went.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// The log written.
    pub log: PathBuf,
    /// One line per stage run.
    pub stages: Vec<String>,
    /// Whether the run was stopped early (the log is complete up to there).
    pub interrupted: bool,
    /// What the user should know of how the run went (a damaged log
    /// resumed from before its damage).
    pub notes: Vec<String>,
}

/// The state handed from stage to stage.
#[allow(clippy::large_enum_variant)] // one per run, moved between stages
enum Phase {
    Mc(System),
    /// A state with the velocities of a jam stage resumed.
    Moving {
        system: System,
        velocities: Vec<nalgebra::Vector3<f64>>,
        angular_velocities: Vec<nalgebra::Vector3<f64>>,
    },
    Dynamics {
        dynamics: Box<Dynamics>,
        temperature: f64,
        true_inertia: bool,
    },
}

/// Runs every stage of `scene` (parsed from `scene_text`, which the log
/// records) and writes the log to `log_path` (via
/// `<log_path>.partial`, renamed when the run ends). `stop` is polled
/// between sweeps and between output events: when set, the run ends
/// cleanly at the next one with a final frame.
pub fn run_scene(
    scene: &ValidScene,
    scene_text: &str,
    log_path: &Path,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<RunSummary, RunError> {
    run_with(scene, scene_text, log_path, progress, stop, None)
}

/// Where a resumed run picks up: the last frame of a log and the messages
/// before it.
struct ResumePoint {
    record: StateRecord,
    info: ResumeInfo,
    log_time: u64,
    prefix: Vec<RawMessage>,
    /// Whether the new log is written to the partial log resumed from
    /// (it then replaces it only once it holds as much).
    in_place: bool,
}

/// Continues the run logged in `log` (complete, stopped, or cut off by a
/// crash) from its last frame: the rest of the stage that frame is in and
/// the stages after it, as the log's own scene records them. The new log,
/// at `out`, holds the old one's messages up to that frame and then the
/// continuation, which is the same bit for bit as the uninterrupted run.
pub fn resume_run(
    log: &Path,
    out: &Path,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<RunSummary, RunError> {
    let bad = |m: String| RunError::Resume(format!("{}: {m}", log.display()));
    // Held to the end: a log still being written is not resumed from, and
    // two resumes of one log do not run at once.
    let _reading = lock_for_reading(log).map_err(|e| RunError::Resume(e.to_string()))?;
    let contents = read_log_with(
        log,
        ReadOptions {
            all_states: false,
            messages: true,
        },
    )
    .map_err(|e| RunError::Resume(e.to_string()))?;
    let text = contents
        .metadata
        .get("scene")
        .ok_or_else(|| bad("no scene in the log's metadata".into()))?
        .clone();
    let resolved = contents
        .metadata
        .get("scene_resolved")
        .ok_or_else(|| bad("no resolved scene in the log's metadata".into()))?;
    let scene = Scene::parse(resolved).map_err(|e| bad(format!("its scene: {e}")))?;
    let (log_time, record) = contents.last_state.ok_or_else(|| {
        bad(match &contents.damage {
            Some(d) => format!("no complete frame before the damage ({d})"),
            None => "no complete frame to resume from".into(),
        })
    })?;
    let info = record
        .resume
        .clone()
        .ok_or_else(|| bad("its last frame carries no resume information".into()))?;
    let mut notes = Vec::new();
    if let Some(d) = &contents.damage {
        notes.push(format!(
            "{}: {d}; resumed from the last intact frame before it (stage {}, {})",
            log.display(),
            record.stage_index,
            match (record.sweep, record.time) {
                (Some(s), _) => format!("sweep {s}"),
                (_, Some(t)) => format!("t = {t}"),
                _ => "its start".into(),
            }
        ));
    }
    let prefix: Vec<RawMessage> = contents
        .messages
        .into_iter()
        // (A failed run's `/failure` is not part of the state resumed.)
        .filter(|(topic, t, _)| *t <= log_time && topic != "/failure")
        .collect();
    let point = ResumePoint {
        record,
        info,
        log_time,
        prefix,
        in_place: same_file(&partial_path(out), log),
    };
    let mut summary = run_with(&scene, &text, out, progress, stop, Some(point))?;
    summary.notes.splice(0..0, notes);
    Ok(summary)
}

fn run_with(
    scene: &ValidScene,
    scene_text: &str,
    log_path: &Path,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
    from: Option<ResumePoint>,
) -> Result<RunSummary, RunError> {
    let mut simulation = Simulation::open(scene, scene_text, log_path, from)?;
    while simulation.stage_index().is_some() {
        if simulation.run_stage(progress, stop)?.interrupted {
            break;
        }
    }
    simulation.finish()
}

/// Sweeps the approach to an NPT stage's pressure may take.
const APPROACH_SWEEPS: u64 = 100_000;

/// A stage's random stream: independent of the other stages', fixed by
/// the scene seed and the stage index.
fn stage_rng(seed: u64, index: usize) -> Pcg64 {
    Pcg64::new(
        seed as u128 | ((index as u128 + 1) << 64),
        0xa02b_dbf7_bb3c_0a7a_c28f_a16a_64ab_f96d,
    )
}

fn initial_sizes(scene: &Scene) -> MoveSizes {
    let thinnest = scene
        .species
        .iter()
        .map(|s| s.shape.min_half_extent())
        .fold(f64::INFINITY, f64::min);
    MoveSizes {
        translate: 0.5 * thinnest,
        rotate: 0.2,
        volume: 0.01,
        shear: 0.01,
    }
}

fn describe(stage: &Stage) -> String {
    match stage {
        Stage::Compress {
            packing_fraction: Some(phi),
            ..
        } => format!("compress to {}", Num(*phi)),
        Stage::Compress { pressure, .. } => {
            format!("compress to betaP = {}", Num(pressure.unwrap_or(f64::NAN)))
        }
        Stage::MonteCarlo {
            ensemble, sweeps, ..
        } => match ensemble {
            Ensemble::Nvt => format!("Monte Carlo NVT, {sweeps} sweeps"),
            Ensemble::Npt { pressure, .. } => {
                format!(
                    "Monte Carlo NPT betaP = {}, {sweeps} sweeps",
                    Num(*pressure)
                )
            }
        },
        Stage::Dynamics {
            duration,
            temperature,
            ..
        } => format!(
            "dynamics, t = {} at kT = {}",
            Num(*duration),
            Num(*temperature)
        ),
        Stage::Jam {
            pressure,
            packing_fraction,
            ..
        } => {
            let bound = pressure.unwrap_or(crate::edmd::jam::DEFAULT_JAM_PRESSURE);
            match packing_fraction {
                Some(phi) => format!(
                    "jam to betaPV/N = {bound:e} or packing fraction {}",
                    Num(*phi)
                ),
                None => format!("jam to betaPV/N = {bound:e}"),
            }
        }
    }
}

fn ticks(stage: &Stage) -> u64 {
    match stage {
        // Compression ends when it gets there: no length to show.
        Stage::Compress { .. } | Stage::Jam { .. } => 0,
        Stage::MonteCarlo { sweeps, .. } => *sweeps,
        Stage::Dynamics { duration, .. } => (duration * 1000.0).ceil() as u64,
    }
}

struct Runner {
    scene: ValidScene,
    plan: Plan,
    /// Log time at the start of the current stage (ns).
    clock: u64,
    /// Monte Carlo move sizes, carried from stage to stage.
    sizes: MoveSizes,
    /// Log time (ns) at which the stage under way pauses: it stops there
    /// as at a stop, with a frame to go on from.
    pause_at: Option<u64>,
    /// The frame a stage stopped at (log time and state), to go on from.
    stopped_at: Option<(u64, StateRecord)>,
    /// Set by a dynamics stage that fails: the log time and the dynamics'
    /// stored state at the failure.
    failure: Option<(u64, DynamicsDump)>,
    /// Whether the density of the current NPT stage has settled (its move
    /// sizes are then frozen).
    drift: DriftWatch,
    /// What the user should hear of at the end (solver counts not zero).
    notes: Vec<String>,
}

/// What a stage returns: the next phase, a summary line, and whether the
/// run was stopped.
type StageResult = Result<(Phase, String, bool), StageError>;

impl Runner {
    /// Runs stage `index` from `phase` (or from the frame `resume`) to its
    /// end or a stop; its random stream is the stage's own (or the
    /// frame's).
    fn run_stage(
        &mut self,
        index: usize,
        phase: Phase,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        stop: &AtomicBool,
    ) -> StageResult {
        let mut rng = match resume.as_ref().and_then(|r| r.rng.clone()) {
            Some(saved) => saved,
            None => stage_rng(self.scene.seed, index),
        };
        let rng = &mut rng;
        let stage = &self.scene.stages[index];
        match stage {
            Stage::Compress {
                packing_fraction,
                pressure,
                max_sweeps,
                until_jammed,
            } => {
                let system = self.to_system(phase)?;
                // The scene's checks leave one target given.
                let defaults = match (packing_fraction, pressure) {
                    (Some(phi), _) if *until_jammed => CompressOptions::until_jammed(*phi),
                    (Some(phi), _) => CompressOptions::to(*phi),
                    (None, Some(p)) => {
                        CompressOptions::to_pressure(*p, self.scene.densest_packing_fraction())
                    }
                    (None, None) => return Err(StageError::NoTarget),
                };
                let opts = CompressOptions {
                    max_sweeps: max_sweeps.unwrap_or(DEFAULT_COMPRESS_SWEEPS),
                    ..defaults
                };
                let stage = CompressStage::start(self, index, system, &opts, resume, log, rng)?;
                self.drive(stage, log, progress, stop)
            }
            Stage::MonteCarlo {
                ensemble,
                sweeps,
                pressure_tensor,
                swaps,
                ..
            } => {
                let system = self.to_system(phase)?;
                let span = stage.tuning_span().expect("a Monte Carlo stage tunes");
                let stage = MonteCarloStage::start(
                    self,
                    index,
                    system,
                    (*ensemble, *sweeps, span, *pressure_tensor, *swaps),
                    resume,
                    log,
                    rng,
                )?;
                self.drive(stage, log, progress, stop)
            }
            Stage::Dynamics { .. } => {
                let stage = DynamicsStage::start(self, index, phase, resume, log, rng)?;
                self.drive(stage, log, progress, stop)
            }
            Stage::Jam { .. } => {
                let stage = JamStage::start(self, index, phase, resume, log, rng)?;
                self.drive(stage, log, progress, stop)
            }
        }
    }

    /// The frame a stage starts from (at the log time the previous stage
    /// ended): the hand-off is visible, and checkable, in the log.
    fn start_frame(&self, log: &mut LogWriter, state: &StateRecord) -> Result<(), StageError> {
        Ok(log.frame(self.clock, state)?)
    }

    /// The phase a stage goes on from at a logged frame (`info` its
    /// resume information) of stage `index`.
    fn phase_of(
        &self,
        record: &StateRecord,
        info: &ResumeInfo,
        index: usize,
    ) -> Result<Phase, PhaseError> {
        let system = system_from_record(record, &self.plan)?;
        self.resumed_phase(system, record, info, index)
    }

    fn to_system(&self, phase: Phase) -> Result<System, StageError> {
        match phase {
            Phase::Mc(system) | Phase::Moving { system, .. } => Ok(system),
            Phase::Dynamics { dynamics, .. } => dynamics.to_system().map_err(StageError::Handoff),
        }
    }
}
