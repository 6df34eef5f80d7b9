//! A run taken a step at a time: the stages of a scene run one by one, or
//! part of one (so many sweeps, so much simulated time), with the state
//! read and set between steps. `run_scene` and `resume_run` are this with
//! every stage run in one go.
//!
//! A stage paused part way writes a frame there and goes on from it as a
//! resumed run would: the Monte Carlo stages give the same states bit for
//! bit as when run in one go; the dynamics restarts its predictions at the
//! pause (the same trajectory to round-off).

use super::*;
use crate::log::{NS_PER_SWEEP, NS_PER_TIME_UNIT};

/// How far [`Simulation::advance`] runs the stage under way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Advance {
    /// Sweeps of a Monte Carlo or compression stage (growth chunks of a
    /// jam stage).
    Sweeps(u64),
    /// Simulated time of a dynamics stage.
    Time(f64),
}

impl std::fmt::Display for Advance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Advance::Sweeps(n) => write!(f, "{n} sweeps"),
            Advance::Time(t) => write!(f, "time {t}"),
        }
    }
}

/// What a step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Step {
    /// The stage the step ran.
    pub stage_index: usize,
    /// Whether the stage ended (otherwise it paused, or was stopped).
    pub stage_done: bool,
    /// Whether the run was stopped (`stop` set) rather than paused.
    pub interrupted: bool,
}

/// The state between steps.
#[allow(clippy::large_enum_variant)] // one per run
enum Held {
    /// Handed on by a finished stage (or the start).
    Between(Phase),
    /// A stage paused at a frame (log time, state), to go on from.
    Paused(u64, Box<StateRecord>),
    /// A stage failed: the log was kept as a partial log.
    Failed,
}

/// A scene run step by step, writing its log as it goes.
pub struct Simulation {
    runner: Runner,
    log: Option<LogWriter>,
    /// The stage the next step runs (the number of stages once all ran).
    next: usize,
    held: Held,
    lines: Vec<String>,
    interrupted: bool,
}

impl Simulation {
    /// Makes the start of `scene` (parsed from `scene_text`, which the log
    /// records) and opens its log at `log_path` (written via
    /// `<log_path>.partial`, renamed by [`Simulation::finish`]).
    pub fn new(scene: &ValidScene, scene_text: &str, log_path: &Path) -> Result<Self, RunError> {
        Self::open(scene, scene_text, log_path, None)
    }

    pub(super) fn open(
        scene: &ValidScene,
        scene_text: &str,
        log_path: &Path,
        from: Option<ResumePoint>,
    ) -> Result<Self, RunError> {
        let mut runner = Runner {
            scene: scene.clone(),
            plan: Plan::of(scene),
            clock: 0,
            sizes: initial_sizes(scene),
            pause_at: None,
            stopped_at: None,
            failure: None,
            drift: DriftWatch::default(),
            notes: Vec::new(),
        };
        let (held, next) = match &from {
            None => {
                let mut rng = Pcg64::seed_from_u64(scene.seed);
                let system = start_state(scene, &runner.plan, &mut rng)?;
                (Held::Between(Phase::Mc(system)), 0)
            }
            Some(point) if point.info.stage_complete => {
                let index = point.record.stage_index;
                let phase = runner.phase_of(&point.record, &point.info, index)?;
                runner.sizes = point.info.sizes;
                runner.clock = point.log_time;
                (Held::Between(phase), index + 1)
            }
            Some(point) => {
                // Checked here, so that a log that cannot be resumed is
                // refused before anything is written.
                runner.phase_of(&point.record, &point.info, point.record.stage_index)?;
                (
                    Held::Paused(point.log_time, Box::new(point.record.clone())),
                    point.record.stage_index,
                )
            }
        };
        if from.is_none()
            && let Start::Resume(input) = &scene.start
        {
            // The log a scene starts from is an input like any other: a
            // run never replaces it.
            check_output(log_path, true, &[Path::new(input)])?;
        }
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
        Ok(Self {
            runner,
            log: Some(log),
            next,
            held,
            lines: Vec::new(),
            interrupted: false,
        })
    }

    /// The scene run.
    pub fn scene(&self) -> &Scene {
        &self.runner.scene
    }

    /// The stage the next step runs (None once every stage has run).
    pub fn stage_index(&self) -> Option<usize> {
        (self.next < self.runner.scene.stages.len()).then_some(self.next)
    }

    /// The log time (ns) where the run stands.
    pub fn log_time(&self) -> u64 {
        match &self.held {
            Held::Paused(t, _) => *t,
            _ => self.runner.clock,
        }
    }

    fn stage_to_run(&self) -> Result<usize, RunError> {
        self.stage_index()
            .ok_or(RunError::Request("every stage of the scene has run".into()))
    }

    /// Whether the stage the next step runs has begun (and paused).
    pub fn paused(&self) -> bool {
        matches!(self.held, Held::Paused(..))
    }

    /// Runs the rest of the stage under way (or the next one).
    pub fn run_stage(
        &mut self,
        progress: &mut dyn Progress,
        stop: &AtomicBool,
    ) -> Result<Step, RunError> {
        self.step(None, progress, stop)
    }

    /// Runs the stage under way (or the next one) on by `by`, or to its
    /// end if that comes first. Monte Carlo and compression stages take
    /// sweeps, a jam stage growth chunks, dynamics time.
    pub fn advance(
        &mut self,
        by: Advance,
        progress: &mut dyn Progress,
        stop: &AtomicBool,
    ) -> Result<Step, RunError> {
        let index = self.stage_to_run()?;
        let stage = &self.runner.scene.stages[index];
        let now = self.log_time();
        let length = match (stage, by) {
            (Stage::Dynamics { .. }, Advance::Time(t)) if t.is_finite() && t > 0.0 => {
                (t * NS_PER_TIME_UNIT).round() as u64
            }
            (Stage::Dynamics { .. }, _) => {
                return Err(RunError::Request(format!(
                    "stage {index} is a dynamics stage: give a simulated time > 0, not {by}"
                )));
            }
            (_, Advance::Sweeps(n)) if n > 0 => n.saturating_mul(NS_PER_SWEEP),
            (_, _) => {
                return Err(RunError::Request(format!(
                    "stage {index} ({}) runs in sweeps: give a number of sweeps > 0, not {by}",
                    stage.kind()
                )));
            }
        };
        self.step(Some(now.saturating_add(length.max(1))), progress, stop)
    }

    fn step(
        &mut self,
        pause_at: Option<u64>,
        progress: &mut dyn Progress,
        stop: &AtomicBool,
    ) -> Result<Step, RunError> {
        let index = self.stage_to_run()?;
        let (phase, resume) = match std::mem::replace(&mut self.held, Held::Failed) {
            Held::Between(phase) => (phase, None),
            Held::Paused(_, record) => {
                let info = record
                    .resume
                    .clone()
                    .expect("a paused stage's frame carries its resume information");
                let phase = self.runner.phase_of(&record, &info, index)?;
                self.runner.sizes = info.sizes;
                self.runner.clock = info.stage_clock;
                (phase, Some(info))
            }
            Held::Failed => {
                return Err(RunError::Request(
                    "the run failed; its log up to the failure was kept".into(),
                ));
            }
        };
        let scene = &self.runner.scene;
        let stage = &scene.stages[index];
        let kind = stage.kind();
        progress.stage(index, scene.stages.len(), &describe(stage), ticks(stage));
        let started = Instant::now();
        self.runner.pause_at = pause_at;
        self.runner.stopped_at = None;
        let log = self
            .log
            .as_mut()
            .expect("a log until the run fails or finishes");
        let outcome = self
            .runner
            .run_stage(index, phase, resume, log, progress, stop);
        self.runner.pause_at = None;
        match outcome {
            Ok((next, line, stopped)) => {
                let line = format!("{line} ({:.1} s)", started.elapsed().as_secs_f64());
                progress.stage_done(&line);
                let interrupted = stopped && stop.load(Ordering::Relaxed);
                if stopped {
                    let (at, record) = self
                        .runner
                        .stopped_at
                        .take()
                        .expect("a stage stops at a frame");
                    self.held = Held::Paused(at, Box::new(record));
                } else {
                    self.held = Held::Between(next);
                    self.next += 1;
                }
                if !stopped || interrupted {
                    self.lines.push(format!("stage {index} ({kind}): {line}"));
                }
                self.interrupted |= interrupted;
                Ok(Step {
                    stage_index: index,
                    stage_done: !stopped,
                    interrupted,
                })
            }
            Err(error) => Err(self.fail(index, kind, error)),
        }
    }

    /// Records a stage's failure in the log and keeps the log as a
    /// partial log.
    fn fail(&mut self, index: usize, kind: &'static str, error: StageError) -> RunError {
        let Some(mut log) = self.log.take() else {
            unreachable!("a stage runs with a log");
        };
        // Why, in the log too (with the dynamics' state to replay it
        // from, if the dynamics failed).
        let (at, dump) = match self.runner.failure.take() {
            Some((at, dump)) => (at, Some(dump)),
            None => (self.runner.clock, None),
        };
        let failure = FailureRecord {
            stage_index: index,
            message: error.to_string(),
            dump,
        };
        // A log that cannot be written (a full disk) takes no failure
        // record: the write is the failure.
        let written = log.failure(at, &failure);
        let first_error = log.error();
        let kept = log.abandon();
        if let Some(source) = first_error {
            return RunError::LogWrite {
                source,
                kept: kept.unwrap_or(None),
            };
        }
        if let Err(e) = written {
            return e.into();
        }
        match kept {
            Ok(Some(partial)) => RunError::Stage {
                index,
                kind,
                error,
                partial,
            },
            Ok(None) => unreachable!("a log written without error is kept"),
            Err(e) => e.into(),
        }
    }

    /// The state where the run stands: after the last stage run, or at the
    /// frame a stage paused at.
    pub fn state(&self) -> Result<StateRecord, RunError> {
        // The stage that handed the state on (the first, at the start).
        let index = self.next.saturating_sub(1);
        let kind = |i: usize| self.runner.scene.stages[i].kind().to_string();
        let of = |system: &System| StateRecord {
            stage_index: index,
            stage: kind(index),
            ..StateRecord::of_system(system)
        };
        Ok(match &self.held {
            Held::Paused(_, record) => StateRecord {
                resume: None,
                ..(**record).clone()
            },
            Held::Between(Phase::Mc(system)) => of(system),
            Held::Between(Phase::Moving {
                system,
                velocities,
                angular_velocities,
            }) => {
                let v: Vec<_> = velocities
                    .iter()
                    .zip(angular_velocities)
                    .map(|(v, w)| (*v, *w))
                    .collect();
                of(system).with_velocities(&v)
            }
            Held::Between(Phase::Dynamics { dynamics, .. }) => {
                let system = dynamics
                    .to_system()
                    .map_err(|e| RunError::Request(format!("the dynamics' state: {e}")))?;
                of(&system).with_velocities(&dynamics.velocities())
            }
            Held::Failed => {
                return Err(RunError::Request(
                    "the run failed; its log up to the failure was kept".into(),
                ));
            }
        })
    }

    /// Sets the positions and orientations (unit quaternions [w, x, y,
    /// z]) of every particle, keeping their velocities; refused, with the
    /// state unchanged, if the bodies would overlap (or cross a wall).
    /// A paused stage goes on from the new configuration.
    pub fn set_configuration(
        &mut self,
        positions: &[[f64; 3]],
        orientations: &[[f64; 4]],
    ) -> Result<(), RunError> {
        let mut record = match &self.held {
            Held::Paused(_, record) => (**record).clone(),
            _ => self.state()?,
        };
        let n = record.positions.len();
        if positions.len() != n || orientations.len() != n {
            return Err(RunError::Request(format!(
                "{} positions and {} orientations for {n} particles",
                positions.len(),
                orientations.len()
            )));
        }
        let mut unit = Vec::with_capacity(n);
        for (i, q) in orientations.iter().enumerate() {
            let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !norm.is_finite() || (norm - 1.0).abs() > 1e-6 {
                return Err(RunError::Request(format!(
                    "orientation {i}: {q:?} is not a unit quaternion (norm {norm})"
                )));
            }
            unit.push(q.map(|x| x / norm));
        }
        // Wrapped into the box from farther than this many edges, a
        // position keeps fewer than about 10 of its 16 digits: a value such
        // as 1e300 would come back as 0, not as anything the user gave.
        const WRAPPED_FROM_AT_MOST: f64 = 1e6;
        let edges = record.box_lengths;
        if let Some((i, p)) = positions.iter().enumerate().find(|(_, p)| {
            !p.iter()
                .zip(&edges)
                .all(|(x, l)| x.is_finite() && x.abs() <= WRAPPED_FROM_AT_MOST * l)
        }) {
            return Err(RunError::Request(format!(
                "position {i}: {p:?} is not finite or lies more than {WRAPPED_FROM_AT_MOST:e} box edges away (positions are wrapped into the box; give them in it)"
            )));
        }
        record.positions = positions.to_vec();
        record.orientations = unit;
        let system = system_from_record(&record, &self.runner.plan).map_err(|e| {
            RunError::Request(match e {
                RecordError::State(e) => e.to_string(),
                other => other.to_string(),
            })
        })?;
        record.positions = system
            .particles()
            .iter()
            .map(|p| p.position.into())
            .collect();
        self.held = match std::mem::replace(&mut self.held, Held::Failed) {
            Held::Paused(at, _) => Held::Paused(at, Box::new(record)),
            Held::Between(Phase::Dynamics {
                dynamics,
                temperature,
                true_inertia,
            }) => {
                let options = self
                    .runner
                    .dynamics_options(temperature, true_inertia, &system);
                let rebuilt = Dynamics::from_parts(
                    &system,
                    &dynamics.velocities(),
                    &options,
                    dynamics.time(),
                    dynamics.collisions(),
                )
                .map_err(|e| RunError::Request(e.to_string()));
                match rebuilt {
                    Ok(d) => Held::Between(Phase::Dynamics {
                        dynamics: Box::new(d),
                        temperature,
                        true_inertia,
                    }),
                    Err(e) => {
                        self.held = Held::Between(Phase::Dynamics {
                            dynamics,
                            temperature,
                            true_inertia,
                        });
                        return Err(e);
                    }
                }
            }
            Held::Between(Phase::Moving {
                velocities,
                angular_velocities,
                ..
            }) => Held::Between(Phase::Moving {
                system,
                velocities,
                angular_velocities,
            }),
            Held::Between(Phase::Mc(_)) => Held::Between(Phase::Mc(system)),
            Held::Failed => unreachable!("a failed run has no state to set"),
        };
        Ok(())
    }

    /// Ends the run: the log is completed and renamed to its path.
    pub fn finish(self) -> Result<RunSummary, RunError> {
        let Some(log) = self.log else {
            return Err(RunError::Request(
                "the run failed; its log up to the failure was kept".into(),
            ));
        };
        let path = log.finish()?;
        Ok(RunSummary {
            log: path,
            stages: self.lines,
            interrupted: self.interrupted,
            notes: self.runner.notes,
        })
    }
}
