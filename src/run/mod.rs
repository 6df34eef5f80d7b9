//! Runs a scene: makes the start, runs the stages in order (each from
//! exactly the state the previous one ended with) and writes the log.
//!
//! Hand-off: Monte Carlo stages pass the system and the tuned move sizes
//! on; a dynamics stage starts from the system with Maxwell–Boltzmann
//! velocities at its temperature, or continues the previous dynamics stage
//! (velocities rescaled if the temperature changes); a Monte Carlo stage
//! after dynamics takes the final positions and orientations.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector3};
use rand::{RngCore, SeedableRng};
use rand_pcg::Pcg64;

use crate::analysis::order::nematic_order;
use crate::edmd::dynamics::{Dynamics, DynamicsDump, DynamicsOptions, EdmdError};
use crate::edmd::predict::PredictorOptions;
use crate::log::file::{lock_for_reading, same_file};
use crate::log::read::{RawMessage, ReadOptions, read_log, read_log_with};
use crate::log::{
    DynamicsProgress, FailureRecord, LogError, LogWriter, NS_PER_SWEEP, NS_PER_TIME_UNIT,
    ResumeInfo, StateRecord, Stats, partial_path,
};
use crate::mc::compress::{CompressOptions, Compressor, CompressorState};
use crate::mc::moves::{Count, Counts, Ensemble as McEnsemble, MoveSizes, sweep};
use crate::mc::parallel::{MAX_CHUNK, ParallelSweeps, sweeps_on_slabs};
use crate::mc::sdf::Sdf;
use crate::mc::tuning::{DriftWatch, Tuner, TuningSpan};
use crate::scene::plan::Plan;
use crate::scene::{DEFAULT_COMPRESS_SWEEPS, Ensemble, Scene, Stage, Start};
use crate::space::PeriodicBox;
use crate::state::start::{StartError, lattice, random_insertion};
use crate::state::{Particle, Species, StateError, System};

/// Sweeps between move-size updates while tuning (50: a window of 20
/// holds only 20 box moves, too few to steer the volume step by).
const TUNE_WINDOW: u64 = 50;

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
    #[error("stage {index} ({kind}): {message}; the log up to the failure is in {}", partial.display())]
    Stage {
        /// Index of the stage.
        index: usize,
        /// Its kind.
        kind: &'static str,
        /// What went wrong.
        message: String,
        /// The partial log.
        partial: PathBuf,
    },
}

impl RunError {
    /// Whether the input (scene, start, output path) is at fault rather
    /// than the simulation.
    pub fn is_bad_input(&self) -> bool {
        matches!(self, RunError::Start(_) | RunError::Resume(_))
            || matches!(
                self,
                RunError::Log(LogError::Io { .. } | LogError::Busy { .. })
            )
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
    scene: &Scene,
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
    scene: &Scene,
    scene_text: &str,
    log_path: &Path,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
    from: Option<ResumePoint>,
) -> Result<RunSummary, RunError> {
    let plan = Plan::of(scene);
    let mut runner = Runner {
        scene,
        plan,
        clock: 0,
        sizes: initial_sizes(scene),
        stop,
        failure: None,
        drift: DriftWatch::default(),
        notes: Vec::new(),
    };
    let (mut phase, first_stage, mut resume) = match &from {
        None => {
            let mut rng = Pcg64::seed_from_u64(scene.seed);
            (
                Phase::Mc(start_state(scene, &runner.plan, &mut rng)?),
                0,
                None,
            )
        }
        Some(point) => {
            let index = point.record.stage_index;
            let system =
                system_from_record(&point.record, &runner.plan).map_err(RunError::Resume)?;
            let phase = runner
                .resumed_phase(system, &point.record, &point.info, index)
                .map_err(RunError::Resume)?;
            runner.sizes = point.info.sizes;
            if point.info.stage_complete {
                runner.clock = point.log_time;
                (phase, index + 1, None)
            } else {
                runner.clock = point.info.stage_clock;
                (phase, index, Some(point.info.clone()))
            }
        }
    };
    let species = runner.plan.mc_species();
    let created = match &from {
        Some(point) if point.in_place => {
            LogWriter::create_replacing_partial(log_path, scene_text, &scene.to_ron(), &species)
        }
        _ => LogWriter::create(log_path, scene_text, &scene.to_ron(), &species),
    };
    let mut log = match created {
        Ok(log) => log,
        // A disk too full for the log's start: nothing is kept.
        Err(source) if source.is_disk_full() => {
            return Err(RunError::LogWrite { source, kept: None });
        }
        Err(e) => return Err(e.into()),
    };
    if let Some(point) = &from {
        for (topic, time, data) in &point.prefix {
            if let Err(source) = log.copy(topic, *time, data) {
                let kept = log.abandon().unwrap_or(None);
                return Err(RunError::LogWrite { source, kept });
            }
        }
    }
    let mut lines = Vec::new();
    let mut interrupted = false;
    for (index, stage) in scene.stages.iter().enumerate().skip(first_stage) {
        progress.stage(index, scene.stages.len(), &describe(stage), ticks(stage));
        let mut rng = stage_rng(scene.seed, index);
        let started = Instant::now();
        let outcome = runner.run_stage(
            index,
            stage,
            phase,
            resume.take(),
            &mut log,
            progress,
            &mut rng,
        );
        match outcome {
            Ok((next, line, stopped)) => {
                let line = format!("{line} ({:.1} s)", started.elapsed().as_secs_f64());
                progress.stage_done(&line);
                lines.push(format!("stage {index} ({}): {line}", stage.kind()));
                phase = next;
                if stopped {
                    interrupted = true;
                    break;
                }
            }
            Err(message) => {
                // Why, in the log too (with the dynamics' state to replay
                // it from, if the dynamics failed).
                let (at, dump) = match runner.failure.take() {
                    Some((at, dump)) => (at, Some(dump)),
                    None => (runner.clock, None),
                };
                let failure = FailureRecord {
                    stage_index: index,
                    message: message.clone(),
                    dump,
                };
                // A log that cannot be written (a full disk) takes no
                // failure record: the write is the failure.
                let written = log.failure(at, &failure);
                let first_error = log.error();
                let kept = log.abandon();
                if let Some(source) = first_error {
                    return Err(RunError::LogWrite {
                        source,
                        kept: kept.unwrap_or(None),
                    });
                }
                written?;
                let Some(partial) = kept? else {
                    unreachable!("a log written without error is kept");
                };
                return Err(RunError::Stage {
                    index,
                    kind: stage.kind(),
                    message,
                    partial,
                });
            }
        }
    }
    let _ = phase;
    let path = log.finish()?;
    Ok(RunSummary {
        log: path,
        stages: lines,
        interrupted,
        notes: runner.notes,
    })
}

/// A stage's random stream: independent of the other stages', fixed by
/// the scene seed and the stage index.
/// Sweeps the approach to an NPT stage's pressure may take.
const APPROACH_SWEEPS: u64 = 100_000;

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
    }
}

fn describe(stage: &Stage) -> String {
    match stage {
        Stage::Compress {
            packing_fraction: Some(phi),
            ..
        } => format!("compress to {phi}"),
        Stage::Compress { pressure, .. } => {
            format!("compress to betaP = {}", pressure.unwrap_or(f64::NAN))
        }
        Stage::MonteCarlo {
            ensemble, sweeps, ..
        } => match ensemble {
            Ensemble::Nvt => format!("Monte Carlo NVT, {sweeps} sweeps"),
            Ensemble::Npt { pressure, .. } => {
                format!("Monte Carlo NPT betaP = {pressure}, {sweeps} sweeps")
            }
        },
        Stage::Dynamics {
            duration,
            temperature,
            ..
        } => format!("dynamics, t = {duration} at kT = {temperature}"),
    }
}

fn ticks(stage: &Stage) -> u64 {
    match stage {
        // Compression ends when it gets there: no length to show.
        Stage::Compress { .. } => 0,
        Stage::MonteCarlo { sweeps, .. } => *sweeps,
        Stage::Dynamics { duration, .. } => (duration * 1000.0).ceil() as u64,
    }
}

/// The first state of a scene.
fn start_state(scene: &Scene, plan: &Plan, rng: &mut Pcg64) -> Result<System, RunError> {
    let species = plan.mc_species();
    let counts: Vec<usize> = plan.species.iter().map(|s| s.count).collect();
    match &scene.start {
        Start::Lattice => Ok(lattice(scene.periodic_box(), species, &counts, rng)?),
        Start::Layered(axis) => layered(
            lattice(scene.periodic_box(), species, &counts, rng)?,
            *axis as usize,
        )
        .map_err(|e| RunError::Start(e.into())),
        Start::Random => {
            let n: usize = counts.iter().sum();
            Ok(random_insertion(
                scene.periodic_box(),
                species,
                &counts,
                1000 * n as u64,
                rng,
            )?)
        }
        Start::Resume(path) => resumed_start(path, plan),
    }
}

/// The species of a lattice start put in layers along `axis`: the sites
/// sorted by that coordinate, the first species on the lowest.
fn layered(system: System, axis: usize) -> Result<System, StateError> {
    let mut sites: Vec<Particle> = system.particles().to_vec();
    sites.sort_by(|a, b| a.position[axis].total_cmp(&b.position[axis]));
    let mut kinds: Vec<u16> = system.particles().iter().map(|p| p.species).collect();
    kinds.sort_unstable();
    // Aligned bodies stay aligned (the lattice chose the orientations for
    // its spacing); a body takes the orientation of its new site's species
    // only when orientations are random, which any site allows.
    for (p, k) in sites.iter_mut().zip(kinds) {
        p.species = k;
    }
    System::new(*system.periodic_box(), system.species().to_vec(), sites)
}

/// Whether the scene's start can be made before anything runs: a
/// `Resume` start's log is read and its last state checked against the
/// scene (what `run` would refuse, `check` refuses too).
pub fn check_start(scene: &Scene) -> Result<(), RunError> {
    if let Start::Resume(path) = &scene.start {
        let plan = Plan::of(scene);
        resumed_start(path, &plan)?;
    }
    Ok(())
}

/// The system of the last intact state of the log at `path`.
fn resumed_start(path: &str, plan: &Plan) -> Result<System, RunError> {
    let contents = read_log(Path::new(path), false).map_err(|e| RunError::Resume(e.to_string()))?;
    let (_, record) = contents.last_state.ok_or_else(|| {
        RunError::Resume(match &contents.damage {
            Some(d) => format!("{path} holds no complete state before its damage ({d})"),
            None => format!("{path} holds no complete state"),
        })
    })?;
    system_from_record(&record, plan).map_err(|e| RunError::Resume(format!("{path}: {e}")))
}

/// A system from a logged state, checked against the scene's species.
pub fn system_from_record(record: &StateRecord, plan: &Plan) -> Result<System, String> {
    let species = plan.mc_species();
    let same = record.species.len() == species.len()
        && record
            .species
            .iter()
            .zip(&species)
            .all(|(r, s)| r.name == s.name && r.shape == s.shape);
    if !same {
        return Err(format!(
            "the logged species ({}) differ from the scene's ({})",
            record
                .species
                .iter()
                .map(|s| format!("{} {}", s.name, s.shape))
                .collect::<Vec<_>>()
                .join(", "),
            species
                .iter()
                .map(|s| format!("{} {}", s.name, s.shape))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let logged: Vec<usize> = (0..plan.species.len())
        .map(|k| {
            record
                .species_of
                .iter()
                .filter(|&&x| x as usize == k)
                .count()
        })
        .collect();
    let wanted: Vec<usize> = plan.species.iter().map(|s| s.count).collect();
    if logged != wanted {
        return Err(format!(
            "the logged particle counts per species {logged:?} differ from the scene's {wanted:?}"
        ));
    }
    let n = record.species_of.len();
    if record.positions.len() != n || record.orientations.len() != n {
        return Err(format!(
            "the logged state has {} positions and {} orientations for {n} particles",
            record.positions.len(),
            record.orientations.len()
        ));
    }
    let box_ = PeriodicBox::new(Vector3::from(record.box_lengths))
        .map_err(|e| format!("logged box: {e}"))?
        .with_walls(plan.walls);
    let particles = record
        .positions
        .iter()
        .zip(&record.orientations)
        .zip(&record.species_of)
        .map(|((p, q), &s)| Particle {
            position: Vector3::from(*p),
            orientation: UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
                q[0], q[1], q[2], q[3],
            )),
            species: s,
        })
        .collect();
    System::new(box_, species, particles).map_err(|e: StateError| format!("logged state: {e}"))
}

struct Runner<'a> {
    scene: &'a Scene,
    plan: Plan,
    /// Log time at the start of the current stage (ns).
    clock: u64,
    /// Monte Carlo move sizes, carried from stage to stage.
    sizes: MoveSizes,
    stop: &'a AtomicBool,
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
type StageResult = Result<(Phase, String, bool), String>;

impl Runner<'_> {
    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The phase a logged frame continues: the system, or for a dynamics
    /// frame the dynamics rebuilt from it.
    fn resumed_phase(
        &self,
        system: System,
        record: &StateRecord,
        info: &ResumeInfo,
        index: usize,
    ) -> Result<Phase, String> {
        let Some(d) = info.dynamics else {
            return Ok(Phase::Mc(system));
        };
        let Some(Stage::Dynamics { true_inertia, .. }) = self.scene.stages.get(index) else {
            return Err(format!(
                "frame of stage {index} has dynamics, the scene's stage does not"
            ));
        };
        let (Some(v), Some(w)) = (&record.velocities, &record.angular_velocities) else {
            return Err("a dynamics frame without velocities".into());
        };
        let velocities: Vec<_> = v
            .iter()
            .zip(w)
            .map(|(v, w)| (Vector3::from(*v), Vector3::from(*w)))
            .collect();
        let options =
            self.dynamics_options(d.temperature, *true_inertia, system.packing_fraction());
        let dynamics = Dynamics::from_parts(&system, &velocities, &options, d.time, d.collisions)
            .map_err(|e| e.to_string())?;
        Ok(Phase::Dynamics {
            dynamics: Box::new(dynamics),
            temperature: d.temperature,
            true_inertia: *true_inertia,
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn run_stage(
        &mut self,
        index: usize,
        stage: &Stage,
        phase: Phase,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        if let Some(r) = &resume
            && let Some(saved) = &r.rng
        {
            *rng = saved.clone();
        }
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
                    (None, None) => return Err("a compression without a target".into()),
                };
                let opts = CompressOptions {
                    max_sweeps: max_sweeps.unwrap_or(DEFAULT_COMPRESS_SWEEPS),
                    ..defaults
                };
                self.compress(index, system, &opts, resume, log, progress, rng)
            }
            Stage::MonteCarlo {
                ensemble, sweeps, ..
            } => {
                let system = self.to_system(phase)?;
                let span = stage.tuning_span().expect("a Monte Carlo stage tunes");
                self.monte_carlo(
                    index, system, ensemble, *sweeps, span, resume, log, progress, rng,
                )
            }
            Stage::Dynamics { .. } => {
                self.dynamics(index, stage, phase, resume, log, progress, rng)
            }
        }
    }

    /// The frame a stage starts from (at the log time the previous stage
    /// ended): the hand-off is visible, and checkable, in the log.
    fn start_frame(&self, log: &mut LogWriter, state: &StateRecord) -> Result<(), String> {
        log.frame(self.clock, state)
            .map_err(|e| format!("writing the log: {e}"))
    }

    fn to_system(&self, phase: Phase) -> Result<System, String> {
        match phase {
            Phase::Mc(system) => Ok(system),
            Phase::Dynamics { dynamics, .. } => dynamics
                .to_system()
                .map_err(|e| format!("the dynamics ended in an invalid state: {e}")),
        }
    }

    /// S₂ of the molecular axes of the turning anisotropic bodies, if the
    /// plan asks for it.
    fn system_nematic_order(&self, system: &System) -> Option<f64> {
        if !self.plan.nematic_order {
            return None;
        }
        let axes: Vec<Option<Vector3<f64>>> =
            system.species().iter().map(Species::order_axis).collect();
        nematic_order(
            system
                .particles()
                .iter()
                .filter_map(|p| axes[p.species as usize].map(|u| p.orientation * u)),
        )
    }

    /// A Monte Carlo frame with what resuming from it needs.
    fn record_system(
        &self,
        system: &System,
        index: usize,
        sweep: u64,
        resume: ResumeInfo,
    ) -> StateRecord {
        StateRecord {
            stage_index: index,
            stage: self.scene.stages[index].kind().into(),
            sweep: Some(sweep),
            resume: Some(resume),
            ..StateRecord::of_particles(system.periodic_box(), system.species(), system.particles())
        }
    }

    /// Resume information of a Monte Carlo stage.
    #[allow(clippy::too_many_arguments)]
    fn mc_resume(
        &self,
        rng: &Pcg64,
        sweep: u64,
        window: Counts,
        tune_window: Counts,
        compress: Option<CompressorState>,
        max_translate: f64,
        complete: bool,
    ) -> ResumeInfo {
        let drift = compress.is_none().then(|| self.drift.clone());
        ResumeInfo {
            stage_clock: self.clock,
            stage_complete: complete,
            sweep,
            max_translate,
            sizes: compress.as_ref().map(|c| c.sizes).unwrap_or(self.sizes),
            rng: Some(rng.clone()),
            window,
            tune_window,
            compress,
            dynamics: None,
            drift,
        }
    }

    fn mc_stats(
        &self,
        index: usize,
        system: &System,
        sweep: u64,
        window: &Counts,
        pressure: Option<f64>,
    ) -> Stats {
        let rate = |c: &Count| (c.tried > 0).then(|| c.rate());
        Stats {
            stage: self.scene.stages[index].kind().into(),
            stage_index: index,
            sweep: Some(sweep),
            time: None,
            packing_fraction: system.packing_fraction(),
            pressure,
            box_lengths: system.periodic_box().lengths().into(),
            acceptance_translate: rate(&window.translate),
            acceptance_rotate: rate(&window.rotate),
            acceptance_volume: rate(&window.volume),
            collisions: None,
            temperature: None,
            nematic_order: self.system_nematic_order(system),
            msd: None,
            c2: None,
            solver: None,
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn compress(
        &mut self,
        index: usize,
        mut system: System,
        opts: &CompressOptions,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        let write_error = |e: LogError| format!("writing the log: {e}");
        let (mut compressor, mut window) = match resume {
            Some(ResumeInfo {
                compress: Some(state),
                window,
                ..
            }) => (Compressor::resume(opts, state), window),
            Some(_) => return Err("a compression frame without the compression's state".into()),
            None => {
                let c = Compressor::new(&system, self.sizes, opts).map_err(|e| e.to_string())?;
                let info = self.mc_resume(
                    rng,
                    0,
                    Counts::default(),
                    Counts::default(),
                    Some(c.state().clone()),
                    0.0,
                    false,
                );
                self.start_frame(log, &self.record_system(&system, index, 0, info))?;
                (c, Counts::default())
            }
        };
        let (stats_every, frames_every) = (self.scene.log.stats_every, self.scene.log.frames_every);
        let mut last_counts = compressor.state().counts;
        let mut last_sweeps = compressor.state().sweeps;
        // Frames are written only where no body overlaps: a frame due
        // waits for the shrink's overlaps to clear.
        let mut frame_due = false;
        let outcome = loop {
            let step = compressor.sweep(&mut system, rng);
            let state = compressor.state();
            window += state.counts - last_counts;
            last_counts = state.counts;
            let s = state.sweeps;
            let time = self.clock + s * NS_PER_SWEEP;
            match step {
                Ok(None) => {}
                Ok(Some(report)) => break Ok(report),
                Err(e) => break Err(e),
            }
            if s != last_sweeps {
                last_sweeps = s;
                if s.is_multiple_of(stats_every) {
                    log.stats(time, &self.mc_stats(index, &system, s, &window, None))
                        .map_err(write_error)?;
                    progress.tick(s, &format!("phi {:.4}", system.packing_fraction()));
                    window = Counts::default();
                }
                frame_due |= s.is_multiple_of(frames_every);
            }
            let stop = self.stopped();
            if (frame_due || stop) && compressor.is_valid() {
                frame_due = false;
                let state = compressor.state().clone();
                let info =
                    self.mc_resume(rng, s, window, Counts::default(), Some(state), 0.0, false);
                log.frame(time, &self.record_system(&system, index, s, info))
                    .map_err(write_error)?;
            }
            if stop && compressor.is_valid() {
                self.sizes = compressor.state().sizes;
                self.clock = time;
                let line = format!(
                    "interrupted at packing fraction {:.4} after {s} sweeps",
                    system.packing_fraction()
                );
                return Ok((Phase::Mc(system), line, true));
            }
        };
        match outcome {
            Ok(report) => {
                self.sizes = report.sizes;
                let state = compressor.state().clone();
                let info = self.mc_resume(
                    rng,
                    state.sweeps,
                    window,
                    Counts::default(),
                    Some(state),
                    0.0,
                    true,
                );
                self.end_mc_stage(index, &system, report.sweeps, &window, None, info, log)?;
                let line = if report.jammed {
                    let pressure = report
                        .compressibility
                        .map(|z| format!(", betaP/rho = {z:.3e} from the last state"))
                        .unwrap_or_default();
                    format!(
                        "jammed at packing fraction {:.4} after {} sweeps{pressure}",
                        report.packing_fraction, report.sweeps
                    )
                } else {
                    format!(
                        "reached packing fraction {:.4} in {} sweeps",
                        report.packing_fraction, report.sweeps
                    )
                };
                Ok((Phase::Mc(system), line, false))
            }
            Err(e) => {
                // Log the state reached (overlap-free) before failing.
                let s = compressor.state().sweeps;
                let info = self.mc_resume(
                    rng,
                    s,
                    window,
                    Counts::default(),
                    Some(compressor.state().clone()),
                    0.0,
                    false,
                );
                let _ = log.frame(
                    self.clock + s * NS_PER_SWEEP,
                    &self.record_system(&system, index, s, info),
                );
                Err(e.to_string())
            }
        }
    }

    /// The last stats and frame of a Monte Carlo stage, and the clock
    /// moved past it.
    #[allow(clippy::too_many_arguments)]
    fn end_mc_stage(
        &mut self,
        index: usize,
        system: &System,
        sweeps: u64,
        window: &Counts,
        pressure: Option<f64>,
        info: ResumeInfo,
        log: &mut LogWriter,
    ) -> Result<(), String> {
        let time = self.clock + sweeps * NS_PER_SWEEP;
        let write = |log: &mut LogWriter| -> Result<(), LogError> {
            if !sweeps.is_multiple_of(self.scene.log.stats_every) {
                log.stats(
                    time,
                    &self.mc_stats(index, system, sweeps, window, pressure),
                )?;
            }
            // Always: this frame says the stage is complete.
            log.frame(time, &self.record_system(system, index, sweeps, info))
        };
        write(log).map_err(|e| format!("writing the log: {e}"))?;
        self.clock = time;
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn monte_carlo(
        &mut self,
        index: usize,
        mut system: System,
        ensemble: &Ensemble,
        sweeps: u64,
        span: TuningSpan,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        let mc_ensemble = match *ensemble {
            Ensemble::Nvt => McEnsemble::Nvt,
            Ensemble::Npt {
                pressure,
                anisotropic,
            } => McEnsemble::Npt {
                pressure,
                anisotropic,
            },
        };
        let (stats_every, frames_every) = (self.scene.log.stats_every, self.scene.log.frames_every);
        let write_error = |e: LogError| format!("writing the log: {e}");
        self.drift = resume
            .as_ref()
            .and_then(|r| r.drift.clone())
            .unwrap_or_default();
        let mut approach = None;
        let (first, mut window, mut tune_window, max_translate) = match &resume {
            Some(r) => (r.sweep, r.window, r.tune_window, r.max_translate),
            None => {
                if let Ensemble::Npt { pressure, .. } = ensemble {
                    approach = self.approach_pressure(&mut system, *pressure, rng);
                }
                let max_translate = system.periodic_box().lengths().min() / 2.0;
                let info = self.mc_resume(
                    rng,
                    0,
                    Counts::default(),
                    Counts::default(),
                    None,
                    max_translate,
                    false,
                );
                self.start_frame(log, &self.record_system(&system, index, 0, info))?;
                (0, Counts::default(), Counts::default(), max_translate)
            }
        };
        // The tuner's cap is fixed by the box the stage starts in.
        let tuner = Tuner {
            target: 0.3,
            max_translate,
        };
        // NVT: pressure from the scale distribution function, sampled ten
        // times per stats interval.
        let sdf_every = (stats_every / 10).max(1);
        // (Not with walls: the scale distribution assumes a periodic box.)
        let mut sdf = (matches!(ensemble, Ensemble::Nvt) && !system.periodic_box().has_walls())
            .then(|| Sdf::new(0.02, 200));
        let mut done = first;
        let mut stopped = false;
        let mut pressure = None;
        // Large systems sweep on slabs, on every core rayon has (set
        // RAYON_NUM_THREADS to choose), the same trajectory on one or two;
        // each sweep's streams are keyed on a seed drawn from the stage's
        // generator, so that a resumed stage draws the same ones.
        let mut slabs = sweeps_on_slabs(system.len()).then(ParallelSweeps::new);
        // What happens after sweep s (the loop below does it), and so
        // where the slabs' run of sweeps handed to their team at once ends.
        // (Given whether the density has settled, which only a tuning
        // window's end changes.)
        let tunes_at =
            |s: u64, settled: bool| s.is_multiple_of(TUNE_WINDOW) && span.tunes_at(s, settled);
        let sampled_after = match span {
            TuningSpan::Fixed(t) => t,
            TuningSpan::UntilSettled { at_least, .. } => at_least,
        };
        let samples_at = |s: u64| s > sampled_after && s.is_multiple_of(sdf_every);
        let sampling = sdf.is_some();
        let eventful = |s: u64, settled: bool| {
            s == sweeps
                || s.is_multiple_of(stats_every)
                || s.is_multiple_of(frames_every)
                || tunes_at(s, settled)
                || (sampling && samples_at(s))
        };
        let mut seeds = Vec::with_capacity(MAX_CHUNK);
        let mut s = first;
        while s < sweeps {
            let c = match &mut slabs {
                Some(slabs) => {
                    seeds.clear();
                    loop {
                        s += 1;
                        seeds.push(rng.next_u64());
                        if eventful(s, self.drift.settled) || seeds.len() == MAX_CHUNK {
                            break;
                        }
                    }
                    let first_index = s + 1 - seeds.len() as u64;
                    slabs.sweeps(&mut system, &self.sizes, &mc_ensemble, &seeds, first_index)
                }
                None => {
                    s += 1;
                    sweep(&mut system, &self.sizes, &mc_ensemble, rng)
                }
            };
            window += c;
            tune_window += c;
            if tunes_at(s, self.drift.settled) {
                tuner.update(&mut self.sizes, &tune_window);
                tune_window = Counts::default();
                if matches!(span, TuningSpan::UntilSettled { .. }) {
                    self.drift.observe(system.packing_fraction());
                }
            }
            if let Some(sdf) = sdf.as_mut()
                && samples_at(s)
            {
                sdf.add(&system);
            }
            done = s;
            let time = self.clock + s * NS_PER_SWEEP;
            if s.is_multiple_of(stats_every) {
                pressure = self.interval_pressure(ensemble, &mut sdf);
                log.stats(time, &self.mc_stats(index, &system, s, &window, pressure))
                    .map_err(write_error)?;
                progress.tick(
                    s,
                    &format!(
                        "phi {:.4}, acceptance {:.2}",
                        system.packing_fraction(),
                        window.translate.rate()
                    ),
                );
                window = Counts::default();
            }
            stopped = self.stopped();
            if s == sweeps {
                break;
            }
            if s.is_multiple_of(frames_every) || stopped {
                let info = self.mc_resume(rng, s, window, tune_window, None, max_translate, false);
                log.frame(time, &self.record_system(&system, index, s, info))
                    .map_err(write_error)?;
            }
            if stopped {
                break;
            }
        }
        if stopped && done < sweeps {
            self.clock += done * NS_PER_SWEEP;
        } else {
            if !done.is_multiple_of(stats_every) {
                pressure = self.interval_pressure(ensemble, &mut sdf);
            }
            let info = self.mc_resume(rng, done, window, tune_window, None, max_translate, true);
            self.end_mc_stage(index, &system, done, &window, pressure, info, log)?;
        }
        let line = format!(
            "{}{done} sweeps, packing fraction {:.4}{}{}",
            approach.unwrap_or_default(),
            system.packing_fraction(),
            pressure
                .map(|p| format!(", last betaP {p:.4}"))
                .unwrap_or_default(),
            if stopped { ", interrupted" } else { "" }
        );
        Ok((Phase::Mc(system), line, stopped && done < sweeps))
    }

    /// Before an NPT stage at `pressure` from a fresh start: compression
    /// (or expansion) to the packing fraction whose measured βP is within
    /// 3 % of it, so that the box moves start near the equilibrium density
    /// instead of creeping to it from a dilute start (their shrinks are
    /// limited by the closest pair, a gap of order 1/N of the box). Not
    /// with walls (the pressure is measured in a periodic box). Says what
    /// it did, if anything; where it cannot reach the pressure it leaves
    /// the last overlap-free state it had and the NPT stage goes on from
    /// there.
    fn approach_pressure(
        &mut self,
        system: &mut System,
        pressure: f64,
        rng: &mut Pcg64,
    ) -> Option<String> {
        if system.periodic_box().has_walls() {
            return None;
        }
        let start = system.packing_fraction();
        let opts = CompressOptions {
            max_sweeps: APPROACH_SWEEPS,
            ..CompressOptions::to_pressure(pressure, self.scene.densest_packing_fraction())
        };
        let mut compressor = Compressor::new(system, self.sizes, &opts).ok()?;
        let report = loop {
            match compressor.sweep(system, rng) {
                Ok(None) => {}
                Ok(Some(report)) => break Some(report),
                Err(_) => break None,
            }
        };
        let sweeps = compressor.state().sweeps;
        self.sizes = compressor.state().sizes;
        let end = system.packing_fraction();
        Some(match report {
            Some(r) => format!(
                "approached betaP {pressure} from packing fraction {start:.4} to {end:.4} (measured betaP {:.4}) in {sweeps} sweeps, then ",
                r.pressure.unwrap_or(f64::NAN)
            ),
            None => format!(
                "approach to betaP {pressure} stopped at packing fraction {end:.4} after {sweeps} sweeps, then "
            ),
        })
    }

    /// βP over the interval: the imposed value in NPT, the SDF estimate in
    /// NVT (then the accumulator restarts).
    fn interval_pressure(&self, ensemble: &Ensemble, sdf: &mut Option<Sdf>) -> Option<f64> {
        match ensemble {
            Ensemble::Npt { pressure, .. } => Some(*pressure),
            Ensemble::Nvt => {
                let s = sdf.as_mut()?;
                let p = s.pressure();
                *s = Sdf::new(0.02, 200);
                p
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn dynamics(
        &mut self,
        index: usize,
        stage: &Stage,
        phase: Phase,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        let Stage::Dynamics {
            duration,
            temperature,
            stats_every,
            frames_every,
            true_inertia,
            msd,
            c2,
        } = *stage
        else {
            unreachable!("called for dynamics stages")
        };
        let fail = |e: EdmdError| e.to_string();
        let write_error = |e: LogError| format!("writing the log: {e}");
        // A dynamics built here from the system is already as a resumed
        // run would rebuild it; one carried over from another stage is
        // resynchronized at its start frame.
        let mut fresh = false;
        let mut dynamics = match phase {
            Phase::Dynamics {
                mut dynamics,
                temperature: previous,
                true_inertia: same_tops,
            } if same_tops == true_inertia => {
                if previous != temperature {
                    let scale = (temperature / previous).sqrt();
                    let v: Vec<_> = dynamics
                        .velocities()
                        .iter()
                        .map(|(v, w)| (v * scale, w * scale))
                        .collect();
                    dynamics.set_velocities(&v).map_err(fail)?;
                }
                dynamics
            }
            other => {
                let system = self.to_system(other)?;
                let options =
                    self.dynamics_options(temperature, true_inertia, system.packing_fraction());
                fresh = true;
                Box::new(Dynamics::from_state(&system, &options, rng).map_err(fail)?)
            }
        };
        let progress_at = match resume.as_ref().and_then(|r| r.dynamics) {
            Some(p) => p,
            None => {
                let p = DynamicsProgress {
                    time: dynamics.time(),
                    start_time: dynamics.time(),
                    collisions: dynamics.collisions(),
                    start_collisions: dynamics.collisions(),
                    next_stats: 1,
                    next_frame: 1,
                    temperature,
                    interval: None,
                    solver_work: None,
                };
                if !fresh {
                    dynamics.resynchronize().map_err(fail)?;
                }
                self.start_frame(log, &self.record_dynamics(&dynamics, index, p, false))?;
                p
            }
        };
        let (t0, c0) = (progress_at.start_time, progress_at.start_collisions);
        let (mut k_stats, mut k_frames) = (progress_at.next_stats, progress_at.next_frame);
        match progress_at.interval {
            // Resumed: the interval goes on from the frame's sums.
            Some(interval) => dynamics.continue_interval(interval),
            None => {
                dynamics.sample();
            }
        }
        // The stage's solver counts, from zero or from the frame resumed.
        dynamics.continue_solver_work(progress_at.solver_work.unwrap_or_default());
        if msd || c2 {
            // After a resume the references restart at the resumed frame.
            dynamics.set_reference();
        }
        let stats_dt = stats_every.unwrap_or(duration / 100.0);
        let frames_dt = frames_every.unwrap_or(duration / 20.0);
        let mut stopped;
        let mut last_pressure = None;
        loop {
            let next_stats = (k_stats as f64 * stats_dt).min(duration);
            let next_frame = (k_frames as f64 * frames_dt).min(duration);
            let next = next_stats.min(next_frame);
            if let Err(e) = dynamics.run_until(t0 + next) {
                // The stored state at the failure goes to the log's
                // `/failure`, to replay the failing event from.
                let at = self.clock + ((dynamics.time() - t0) * NS_PER_TIME_UNIT).round() as u64;
                self.failure = Some((at, dynamics.dump()));
                return Err(e.to_string());
            }
            let time = self.clock + (next * NS_PER_TIME_UNIT).round() as u64;
            let end = next >= duration;
            if next_stats <= next || end {
                let sample = dynamics.sample();
                last_pressure = sample.pressure.or(last_pressure);
                let stats = Stats {
                    stage: "dynamics".into(),
                    stage_index: index,
                    sweep: None,
                    time: Some(next),
                    packing_fraction: sample.packing_fraction,
                    pressure: sample.pressure,
                    box_lengths: dynamics.periodic_box().lengths().into(),
                    acceptance_translate: None,
                    acceptance_rotate: None,
                    acceptance_volume: None,
                    collisions: Some(sample.collisions - c0),
                    temperature: Some(sample.temperature),
                    nematic_order: if self.plan.nematic_order {
                        sample.nematic_order
                    } else {
                        None
                    },
                    msd: msd.then(|| dynamics.mean_squared_displacement()),
                    c2: if c2 {
                        dynamics.orientational_correlation()
                    } else {
                        None
                    },
                    solver: Some(dynamics.solver_work()),
                };
                log.stats(time, &stats).map_err(write_error)?;
                progress.tick(
                    (next * 1000.0) as u64,
                    &format!(
                        "{} collisions, betaP {}",
                        sample.collisions - c0,
                        sample
                            .pressure
                            .map(|p| format!("{p:.3}"))
                            .unwrap_or_else(|| "-".into())
                    ),
                );
                k_stats += 1;
            }
            stopped = !end && self.stopped();
            if next_frame <= next || end || stopped {
                if next_frame <= next {
                    k_frames += 1;
                }
                // Every frame is a point the run can be resumed from bit
                // for bit: predictions restart from it in both runs.
                dynamics.resynchronize().map_err(fail)?;
                let p = DynamicsProgress {
                    time: dynamics.time(),
                    collisions: dynamics.collisions(),
                    next_stats: k_stats,
                    next_frame: k_frames,
                    interval: Some(dynamics.interval()),
                    solver_work: Some(dynamics.solver_work()),
                    ..progress_at
                };
                log.frame(time, &self.record_dynamics(&dynamics, index, p, end))
                    .map_err(write_error)?;
            }
            if end || stopped {
                self.clock = if end {
                    self.clock + (duration * NS_PER_TIME_UNIT).round() as u64
                } else {
                    time
                };
                break;
            }
        }
        if let Some(strains) = dynamics.solver_work().strains_in_words() {
            self.notes.push(format!(
                "stage {index} (dynamics): {strains} (counted in /stats.solver; each answer was certified, but the numerics were strained)"
            ));
        }
        let collisions = dynamics.collisions() - c0;
        let line = format!(
            "{collisions} collisions over t = {:.4}{}{}",
            dynamics.time() - t0,
            last_pressure
                .map(|p| format!(", last betaP {p:.4}"))
                .unwrap_or_default(),
            if stopped { ", interrupted" } else { "" }
        );
        Ok((
            Phase::Dynamics {
                dynamics,
                temperature,
                true_inertia,
            },
            line,
            stopped,
        ))
    }

    fn dynamics_options(
        &self,
        temperature: f64,
        true_inertia: bool,
        packing_fraction: f64,
    ) -> DynamicsOptions {
        DynamicsOptions {
            temperature,
            masses: self.plan.masses(),
            predictor: self.predictor_options(),
            true_inertia,
            neighbour_shell: self.scene.neighbour_shell(packing_fraction),
        }
    }

    fn predictor_options(&self) -> PredictorOptions {
        let a = &self.scene.accuracy;
        let mut p = PredictorOptions {
            grazing_threshold: a.grazing_threshold,
            contact_tolerance: a.contact_tolerance,
            ..PredictorOptions::default()
        };
        p.distance.newton.tolerance = a.newton_tolerance;
        p
    }

    fn record_dynamics(
        &self,
        dynamics: &Dynamics,
        index: usize,
        progress: DynamicsProgress,
        complete: bool,
    ) -> StateRecord {
        StateRecord {
            stage_index: index,
            stage: "dynamics".into(),
            time: Some(progress.time - progress.start_time),
            resume: Some(ResumeInfo {
                stage_clock: self.clock,
                stage_complete: complete,
                sweep: 0,
                max_translate: 0.0,
                sizes: self.sizes,
                rng: None,
                window: Counts::default(),
                tune_window: Counts::default(),
                compress: None,
                dynamics: Some(progress),
                drift: None,
            }),
            ..StateRecord::of_particles(
                dynamics.periodic_box(),
                &self.plan.mc_species(),
                &dynamics.particles(),
            )
            .with_velocities(&dynamics.velocities())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_layered_start_puts_the_species_in_order_along_the_axis() {
        let scene = Scene::parse(
            r#"Scene(box: (20.0, 6.0, 6.0), walls: [X],
                species: [Species(name: "a", shape: Sphere(radius: 0.4), count: 60),
                          Species(name: "b", shape: Ellipsoid(a: 0.4, b: 0.3, c: 0.3), count: 40)],
                start: Layered(X), stages: [Dynamics(duration: 1.0)])"#,
        )
        .unwrap();
        let plan = Plan::of(&scene);
        let system = start_state(&scene, &plan, &mut Pcg64::seed_from_u64(1)).unwrap();
        let x = |k: u16| {
            system
                .particles()
                .iter()
                .filter(move |p| p.species == k)
                .map(|p| p.position.x)
        };
        let a_max = x(0).fold(f64::NEG_INFINITY, f64::max);
        let b_min = x(1).fold(f64::INFINITY, f64::min);
        assert!(a_max <= b_min, "{a_max} > {b_min}");
        assert_eq!(x(0).count(), 60);
        assert_eq!(system.periodic_box().walls(), [true, false, false]);
        assert_eq!(system.first_wall_overlap(), None);
    }
}
