//! Runs a scene: makes the start, runs the stages in order (each from
//! exactly the state the previous one ended with) and writes the log.
//!
//! Hand-off: Monte Carlo stages pass the system and the tuned move sizes
//! on; a dynamics stage starts from the system with Maxwell–Boltzmann
//! velocities at its temperature, or continues the previous dynamics stage
//! (velocities rescaled if the temperature changes); a Monte Carlo stage
//! after dynamics takes the final positions and orientations.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_pcg::Pcg64;

use crate::analysis::order::{molecular_axis, nematic_order};
use crate::edmd::dynamics::{Dynamics, DynamicsOptions, EdmdError};
use crate::edmd::predict::PredictorOptions;
use crate::log::read::read_log;
use crate::log::{LogError, LogWriter, NS_PER_SWEEP, NS_PER_TIME_UNIT, StateRecord, Stats};
use crate::mc::compress::{CompressError, CompressOptions, compress_observed};
use crate::mc::moves::{Count, Counts, Ensemble as McEnsemble, MoveSizes, sweep};
use crate::mc::sdf::Sdf;
use crate::mc::start::{StartError, lattice, random_insertion};
use crate::mc::tuning::Tuner;
use crate::mc::{McError, Particle, System};
use crate::scene::plan::Plan;
use crate::scene::{DEFAULT_COMPRESS_SWEEPS, Ensemble, Scene, Stage, Start};
use crate::space::PeriodicBox;

/// Sweeps between move-size updates while tuning.
const TUNE_WINDOW: u64 = 20;

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
            || matches!(self, RunError::Log(LogError::Io { .. }))
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
    let plan = Plan::of(scene);
    let mut rng = Pcg64::seed_from_u64(scene.seed);
    let system = start_state(scene, &plan, &mut rng)?;
    let mut log = LogWriter::create(log_path, scene_text, &scene.to_ron(), &plan.mc_species())?;
    let mut runner = Runner {
        scene,
        plan,
        clock: 0,
        sizes: initial_sizes(scene),
        stop,
    };
    let mut phase = Phase::Mc(system);
    let mut lines = Vec::new();
    let mut interrupted = false;
    for (index, stage) in scene.stages.iter().enumerate() {
        progress.stage(index, scene.stages.len(), &describe(stage), ticks(stage));
        let mut rng = stage_rng(scene.seed, index);
        let started = Instant::now();
        let outcome = runner.run_stage(index, stage, phase, &mut log, progress, &mut rng);
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
                let partial = log.abandon()?;
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
    })
}

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
    }
}

fn describe(stage: &Stage) -> String {
    match stage {
        Stage::Compress {
            packing_fraction, ..
        } => format!("compress to {packing_fraction}"),
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
        Start::Lattice => Ok(lattice(scene.box_vector(), species, &counts, rng)?),
        Start::Random => {
            let n: usize = counts.iter().sum();
            Ok(random_insertion(
                scene.box_vector(),
                species,
                &counts,
                1000 * n as u64,
                rng,
            )?)
        }
        Start::Resume(path) => {
            let contents =
                read_log(Path::new(path), false).map_err(|e| RunError::Resume(e.to_string()))?;
            let (_, record) = contents
                .last_state
                .ok_or_else(|| RunError::Resume(format!("{path} holds no complete state")))?;
            system_from_record(&record, plan).map_err(RunError::Resume)
        }
    }
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
    let counts_match = plan.species.iter().enumerate().all(|(k, s)| {
        record
            .species_of
            .iter()
            .filter(|&&x| x as usize == k)
            .count()
            == s.count
    });
    if !counts_match || record.positions.len() != record.species_of.len() {
        return Err("the logged particle counts differ from the scene's".into());
    }
    let box_ = PeriodicBox::new(Vector3::from(record.box_lengths))
        .map_err(|e| format!("logged box: {e}"))?;
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
    System::new(box_, species, particles).map_err(|e: McError| format!("logged state: {e}"))
}

struct Runner<'a> {
    scene: &'a Scene,
    plan: Plan,
    /// Log time at the start of the current stage (ns).
    clock: u64,
    /// Monte Carlo move sizes, carried from stage to stage.
    sizes: MoveSizes,
    stop: &'a AtomicBool,
}

/// What a stage returns: the next phase, a summary line, and whether the
/// run was stopped.
type StageResult = Result<(Phase, String, bool), String>;

impl Runner<'_> {
    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    fn run_stage(
        &mut self,
        index: usize,
        stage: &Stage,
        phase: Phase,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        match stage {
            Stage::Compress {
                packing_fraction,
                max_sweeps,
            } => {
                let system = self.to_system(phase)?;
                self.start_frame(log, &self.record_system(&system, index, Some(0)))?;
                self.compress(
                    index,
                    system,
                    *packing_fraction,
                    *max_sweeps,
                    log,
                    progress,
                    rng,
                )
            }
            Stage::MonteCarlo {
                ensemble,
                sweeps,
                tune_sweeps,
            } => {
                let system = self.to_system(phase)?;
                self.start_frame(log, &self.record_system(&system, index, Some(0)))?;
                let tune = tune_sweeps.unwrap_or(sweeps / 5);
                self.monte_carlo(index, system, ensemble, *sweeps, tune, log, progress, rng)
            }
            Stage::Dynamics { .. } => self.dynamics(index, stage, phase, log, progress, rng),
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
        let axes: Vec<Option<Vector3<f64>>> = system
            .species()
            .iter()
            .map(|s| {
                if s.rotation {
                    molecular_axis(&s.shape)
                } else {
                    None
                }
            })
            .collect();
        nematic_order(
            system
                .particles()
                .iter()
                .filter_map(|p| axes[p.species as usize].map(|u| p.orientation * u)),
        )
    }

    fn record_system(&self, system: &System, index: usize, sweep: Option<u64>) -> StateRecord {
        StateRecord {
            stage_index: index,
            stage: self.scene.stages[index].kind().into(),
            sweep,
            ..StateRecord::of_particles(system.periodic_box(), system.species(), system.particles())
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
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn compress(
        &mut self,
        index: usize,
        mut system: System,
        target: f64,
        max_sweeps: Option<u64>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        let opts = CompressOptions {
            max_sweeps: max_sweeps.unwrap_or(DEFAULT_COMPRESS_SWEEPS),
            ..CompressOptions::to(target)
        };
        let (stats_every, frames_every) = (self.scene.log.stats_every, self.scene.log.frames_every);
        let mut window = Counts::default();
        let mut log_error: Option<LogError> = None;
        let mut last_sizes = self.sizes;
        let clock = self.clock;
        let result = compress_observed(
            &mut system,
            self.sizes,
            &opts,
            rng,
            |system, s, c, sizes| {
                window += *c;
                last_sizes = *sizes;
                let time = clock + s * NS_PER_SWEEP;
                let mut write = || -> Result<(), LogError> {
                    if s.is_multiple_of(stats_every) {
                        log.stats(time, &self.mc_stats(index, system, s, &window, None))?;
                        progress.tick(s, &format!("phi {:.4}", system.packing_fraction()));
                        window = Counts::default();
                    }
                    if s.is_multiple_of(frames_every) {
                        log.frame(time, &self.record_system(system, index, Some(s)))?;
                    }
                    Ok(())
                };
                if let Err(e) = write() {
                    log_error = Some(e);
                    return ControlFlow::Break(());
                }
                if self.stopped() {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            },
        );
        if let Some(e) = log_error {
            return Err(format!("writing the log: {e}"));
        }
        let (sweeps, stopped, line) = match result {
            Ok(report) => {
                self.sizes = report.sizes;
                (
                    report.sweeps,
                    false,
                    format!(
                        "reached packing fraction {:.4} in {} sweeps",
                        report.packing_fraction, report.sweeps
                    ),
                )
            }
            Err(CompressError::Stopped { reached, sweeps }) => {
                self.sizes = last_sizes;
                (
                    sweeps,
                    true,
                    format!("interrupted at packing fraction {reached:.4} after {sweeps} sweeps"),
                )
            }
            Err(e) => {
                // Log the state reached (overlap-free) before failing.
                let _ = log.frame(self.clock, &self.record_system(&system, index, None));
                return Err(e.to_string());
            }
        };
        self.end_mc_stage(index, &system, sweeps, &window, None, log)?;
        Ok((Phase::Mc(system), line, stopped))
    }

    /// The last stats and frame of a Monte Carlo stage, and the clock
    /// moved past it.
    fn end_mc_stage(
        &mut self,
        index: usize,
        system: &System,
        sweeps: u64,
        window: &Counts,
        pressure: Option<f64>,
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
            if !sweeps.is_multiple_of(self.scene.log.frames_every) {
                log.frame(time, &self.record_system(system, index, Some(sweeps)))?;
            }
            Ok(())
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
        tune: u64,
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
        let tuner = Tuner {
            target: 0.3,
            max_translate: system.periodic_box().lengths().min() / 2.0,
        };
        let (stats_every, frames_every) = (self.scene.log.stats_every, self.scene.log.frames_every);
        // NVT: pressure from the scale distribution function, sampled ten
        // times per stats interval.
        let sdf_every = (stats_every / 10).max(1);
        let mut sdf = matches!(ensemble, Ensemble::Nvt).then(|| Sdf::new(0.02, 200));
        let mut window = Counts::default();
        let mut tune_window = Counts::default();
        let mut done = 0;
        let mut stopped = false;
        let mut pressure = None;
        for s in 1..=sweeps {
            let c = sweep(&mut system, &self.sizes, &mc_ensemble, rng);
            window += c;
            tune_window += c;
            if s <= tune && s.is_multiple_of(TUNE_WINDOW) {
                tuner.update(&mut self.sizes, &tune_window);
                tune_window = Counts::default();
            }
            if let Some(sdf) = sdf.as_mut()
                && s > tune
                && s.is_multiple_of(sdf_every)
            {
                sdf.add(&system);
            }
            done = s;
            if s.is_multiple_of(stats_every) {
                pressure = self.interval_pressure(ensemble, &mut sdf);
                let time = self.clock + s * NS_PER_SWEEP;
                log.stats(time, &self.mc_stats(index, &system, s, &window, pressure))
                    .map_err(|e| format!("writing the log: {e}"))?;
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
            if s.is_multiple_of(frames_every) {
                let time = self.clock + s * NS_PER_SWEEP;
                log.frame(time, &self.record_system(&system, index, Some(s)))
                    .map_err(|e| format!("writing the log: {e}"))?;
            }
            if self.stopped() {
                stopped = true;
                break;
            }
        }
        if !done.is_multiple_of(stats_every) {
            pressure = self.interval_pressure(ensemble, &mut sdf);
        }
        self.end_mc_stage(index, &system, done, &window, pressure, log)?;
        let line = format!(
            "{done} sweeps, packing fraction {:.4}{}{}",
            system.packing_fraction(),
            pressure
                .map(|p| format!(", last betaP {p:.4}"))
                .unwrap_or_default(),
            if stopped { ", interrupted" } else { "" }
        );
        Ok((Phase::Mc(system), line, stopped))
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

    fn dynamics(
        &mut self,
        index: usize,
        stage: &Stage,
        phase: Phase,
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
                let options = DynamicsOptions {
                    temperature,
                    masses: self.plan.masses(),
                    predictor: self.predictor_options(),
                    true_inertia,
                };
                Box::new(Dynamics::from_state(&system, &options, rng).map_err(fail)?)
            }
        };
        let t0 = dynamics.time();
        let c0 = dynamics.collisions();
        self.start_frame(log, &self.record_dynamics(&dynamics, index, 0.0))?;
        dynamics.sample();
        if msd || c2 {
            dynamics.set_reference();
        }
        let stats_dt = stats_every.unwrap_or(duration / 100.0);
        let frames_dt = frames_every.unwrap_or(duration / 20.0);
        let (mut k_stats, mut k_frames) = (1u64, 1u64);
        let mut stopped = false;
        let mut last_pressure = None;
        loop {
            let next_stats = (k_stats as f64 * stats_dt).min(duration);
            let next_frame = (k_frames as f64 * frames_dt).min(duration);
            let next = next_stats.min(next_frame);
            dynamics.run_until(t0 + next).map_err(fail)?;
            let elapsed = next;
            let time = self.clock + (elapsed * NS_PER_TIME_UNIT).round() as u64;
            let end = next >= duration;
            if next_stats <= next || end {
                let sample = dynamics.sample();
                last_pressure = sample.pressure.or(last_pressure);
                let stats = Stats {
                    stage: "dynamics".into(),
                    stage_index: index,
                    sweep: None,
                    time: Some(elapsed),
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
                };
                log.stats(time, &stats)
                    .map_err(|e| format!("writing the log: {e}"))?;
                progress.tick(
                    (elapsed * 1000.0) as u64,
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
            if next_frame <= next || end {
                log.frame(time, &self.record_dynamics(&dynamics, index, elapsed))
                    .map_err(|e| format!("writing the log: {e}"))?;
                k_frames += 1;
            }
            if end {
                break;
            }
            if self.stopped() {
                stopped = true;
                if next_frame > next {
                    log.frame(time, &self.record_dynamics(&dynamics, index, elapsed))
                        .map_err(|e| format!("writing the log: {e}"))?;
                }
                self.clock = time;
                break;
            }
        }
        if !stopped {
            self.clock += (duration * NS_PER_TIME_UNIT).round() as u64;
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

    fn record_dynamics(&self, dynamics: &Dynamics, index: usize, time: f64) -> StateRecord {
        StateRecord {
            stage_index: index,
            stage: "dynamics".into(),
            time: Some(time),
            ..StateRecord::of_particles(
                dynamics.periodic_box(),
                &self.plan.mc_species(),
                &dynamics.particles(),
            )
            .with_velocities(&dynamics.velocities())
        }
    }
}
