//! The dynamics stage: the hand-off from a state or a previous dynamics,
//! the event-driven run between stats and frames, and its frames.

use nalgebra::Vector3;
use rand_pcg::Pcg64;

use crate::edmd::dynamics::{Dynamics, DynamicsOptions};
use crate::edmd::predict::PredictorOptions;
use crate::log::{DynamicsProgress, LogWriter, NS_PER_TIME_UNIT, ResumeInfo, StateRecord, Stats};
use crate::mc::moves::Counts;
use crate::number::Num;
use crate::scene::{DYNAMICS_COLLISIONS_PER_BODY, Stage};
use crate::state::System;

use super::cadence::{Mark, StagePlan, StageRun};
use super::records::Interval;
use super::*;
use crate::scene::plan::StageBuild;

impl Runner {
    /// The phase a logged frame continues: the system, or for a dynamics
    /// frame the dynamics rebuilt from it.
    pub(super) fn resumed_phase(
        &self,
        system: System,
        record: &StateRecord,
        info: &ResumeInfo,
        index: usize,
    ) -> Result<Phase, PhaseError> {
        if info.jam.is_some() {
            let (Some(v), Some(w)) = (&record.velocities, &record.angular_velocities) else {
                return Err(PhaseError::NoVelocities("jam"));
            };
            return Ok(Phase::Moving {
                system,
                velocities: v.iter().map(|v| Vector3::from(*v)).collect(),
                angular_velocities: w.iter().map(|w| Vector3::from(*w)).collect(),
            });
        }
        let Some(d) = info.dynamics else {
            return Ok(Phase::Mc(system));
        };
        let Some(Stage::Dynamics { true_inertia, .. }) = self.scene.stages.get(index) else {
            return Err(PhaseError::NotDynamics(index));
        };
        let (Some(v), Some(w)) = (&record.velocities, &record.angular_velocities) else {
            return Err(PhaseError::NoVelocities("dynamics"));
        };
        let velocities: Vec<_> = v
            .iter()
            .zip(w)
            .map(|(v, w)| (Vector3::from(*v), Vector3::from(*w)))
            .collect();
        let options = self.dynamics_options(d.temperature, *true_inertia, &system);
        let dynamics = Dynamics::from_parts(&system, &velocities, &options, d.time, d.collisions)?;
        Ok(Phase::Dynamics {
            dynamics: Box::new(dynamics),
            temperature: d.temperature,
            true_inertia: *true_inertia,
        })
    }

    /// The dynamics' options for `system` (its bodies as they are: grown,
    /// after a jam stage).
    pub(super) fn dynamics_options(
        &self,
        temperature: f64,
        true_inertia: bool,
        system: &System,
    ) -> DynamicsOptions {
        DynamicsOptions {
            temperature,
            masses: self.plan.masses(),
            predictor: self.predictor_options(),
            true_inertia,
            neighbour_shell: self
                .scene
                .neighbour_shell_of(system.species(), system.packing_fraction()),
        }
    }

    pub(super) fn predictor_options(&self) -> PredictorOptions {
        let a = &self.scene.accuracy;
        let mut p = PredictorOptions {
            grazing_threshold: a.grazing_threshold,
            contact_tolerance: a.contact_tolerance,
            ..PredictorOptions::default()
        };
        p.distance.newton.tolerance = a.newton_tolerance;
        p
    }

    pub(super) fn record_dynamics(
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
            sizes: dynamics.sizes().map(<[f64]>::to_vec),
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
                jam: None,
            }),
            ..StateRecord::of_particles(
                dynamics.periodic_box(),
                &dynamics.species_now(),
                &dynamics.particles(),
            )
            .with_velocities(&dynamics.velocities())
        }
    }
}

/// A dynamics stage under way.
pub(super) struct DynamicsStage {
    index: usize,
    dynamics: Box<Dynamics>,
    temperature: f64,
    true_inertia: bool,
    duration: f64,
    msd: bool,
    c2: bool,
    stats_dt: f64,
    frames_dt: f64,
    /// The stage's progress at its start or at the frame resumed from.
    progress_at: DynamicsProgress,
    /// The next stats and frame, counted from the stage's start.
    k_stats: u64,
    k_frames: u64,
    /// Where the stage stands: simulated time since its start, log time,
    /// and whether a frame is due there.
    next: f64,
    time: u64,
    frame_hit: bool,
    /// The last sample's collisions and pressure (progress), and the last
    /// pressure measured (the stage's line).
    collisions: u64,
    pressure: Option<f64>,
    last_pressure: Option<f64>,
}

impl DynamicsStage {
    /// The stage from `phase` (a state, or the previous dynamics stage
    /// carried on) with its first frame written, or from the frame
    /// `resume`.
    pub(super) fn start(
        runner: &mut Runner,
        index: usize,
        phase: Phase,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        rng: &mut Pcg64,
    ) -> Result<Self, StageError> {
        let Stage::Dynamics {
            duration,
            temperature,
            stats_every,
            frames_every,
            true_inertia,
            msd,
            c2,
        } = runner.scene.stages[index]
        else {
            unreachable!("called for dynamics stages")
        };
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
                    dynamics.set_velocities(&v)?;
                }
                dynamics
            }
            other => {
                let system = runner.to_system(other)?;
                let options = runner.dynamics_options(temperature, true_inertia, &system);
                fresh = true;
                Box::new(Dynamics::from_state(&system, &options, rng)?)
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
                    dynamics.resynchronize()?;
                }
                runner.start_frame(log, &runner.record_dynamics(&dynamics, index, p, false))?;
                p
            }
        };
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
        Ok(Self {
            index,
            dynamics,
            temperature,
            true_inertia,
            duration,
            msd,
            c2,
            stats_dt: stats_every.unwrap_or(duration / 100.0),
            frames_dt: frames_every.unwrap_or(duration / 20.0),
            k_stats: progress_at.next_stats,
            k_frames: progress_at.next_frame,
            progress_at,
            next: 0.0,
            time: runner.clock,
            frame_hit: false,
            collisions: 0,
            pressure: None,
            last_pressure: None,
        })
    }
}

/// Collisions per body between two looks at the collision budget.
const BUDGET_LOOK_EVERY: u64 = 1000;

impl DynamicsStage {
    /// Runs to `t_end`, looking at the collision rate every
    /// [`BUDGET_LOOK_EVERY`] collisions per body: a stage that would run
    /// past [`DYNAMICS_COLLISIONS_PER_BODY`] fails then.
    fn run_within_budget(&mut self, t_end: f64) -> Result<(), StageError> {
        let bodies = self.dynamics.len() as f64;
        let chunk = (self.dynamics.len() as u64).saturating_mul(BUDGET_LOOK_EVERY);
        loop {
            let before = self.dynamics.collisions();
            self.dynamics.run_collisions_until(chunk, t_end)?;
            if self.dynamics.collisions() - before < chunk {
                return Ok(());
            }
            let done = (self.dynamics.collisions() - self.progress_at.start_collisions) as f64;
            let elapsed = self.dynamics.time() - self.progress_at.start_time;
            let rate = done / bodies / elapsed;
            let projected = rate * self.duration;
            if projected.is_nan() || projected > DYNAMICS_COLLISIONS_PER_BODY as f64 {
                return Err(StageError::CollisionBudget {
                    rate,
                    duration: self.duration,
                    projected,
                });
            }
        }
    }
}

impl StageRun for DynamicsStage {
    fn built_with(&self) -> StagePlan {
        StagePlan::new(
            self.index,
            "dynamics",
            StageBuild::Dynamics(self.dynamics.neighbour_shell()),
        )
    }

    fn advance(&mut self, runner: &mut Runner) -> Result<Mark, StageError> {
        let next_stats = (self.k_stats as f64 * self.stats_dt).min(self.duration);
        let next_frame = (self.k_frames as f64 * self.frames_dt).min(self.duration);
        let mut next = next_stats.min(next_frame);
        if let Some(pause) = runner.pause_at {
            let until = pause.saturating_sub(runner.clock) as f64 / NS_PER_TIME_UNIT;
            if until > self.dynamics.time() - self.progress_at.start_time {
                next = next.min(until);
            }
        }
        self.run_within_budget(self.progress_at.start_time + next)?;
        self.next = next;
        self.time = runner.clock + (next * NS_PER_TIME_UNIT).round() as u64;
        self.frame_hit = next_frame <= next;
        let end = next >= self.duration;
        Ok(Mark {
            time: self.time,
            stats: next_stats <= next || end,
            frame: self.frame_hit,
            end,
        })
    }

    fn stats(&mut self, runner: &Runner) -> Stats {
        let sample = self.dynamics.sample();
        self.last_pressure = sample.pressure.or(self.last_pressure);
        self.pressure = sample.pressure;
        self.collisions = sample.collisions - self.progress_at.start_collisions;
        self.k_stats += 1;
        runner.stats(
            self.index,
            Interval {
                time: Some(self.next),
                packing_fraction: sample.packing_fraction,
                pressure: sample.pressure,
                pressure_tensor: sample.pressure_tensor.map(|t| t.0),
                box_lengths: self.dynamics.periodic_box().lengths().into(),
                tilts: self.dynamics.periodic_box().tilts().into(),
                collisions: Some(self.collisions),
                temperature: Some(sample.temperature),
                nematic_order: sample.nematic_order,
                msd: self.msd.then(|| self.dynamics.mean_squared_displacement()),
                c2: if self.c2 {
                    self.dynamics.orientational_correlation()
                } else {
                    None
                },
                solver: Some(self.dynamics.solver_work()),
                ..Interval::default()
            },
        )
    }

    fn progress(&self) -> (u64, String) {
        (
            (self.next * 1000.0) as u64,
            format!(
                "{} collisions, betaP {}",
                self.collisions,
                self.pressure
                    .map(|p| format!("{:.3}", Num(p)))
                    .unwrap_or_else(|| "-".into())
            ),
        )
    }

    fn frame_ready(&mut self) -> Result<bool, StageError> {
        // Every frame is a point the run can be resumed from bit for bit:
        // predictions restart from it in both runs.
        self.dynamics.resynchronize()?;
        Ok(true)
    }

    fn frame(&mut self, runner: &Runner, complete: bool) -> StateRecord {
        if self.frame_hit {
            self.k_frames += 1;
        }
        let p = DynamicsProgress {
            time: self.dynamics.time(),
            collisions: self.dynamics.collisions(),
            next_stats: self.k_stats,
            next_frame: self.k_frames,
            interval: Some(self.dynamics.interval()),
            solver_work: Some(self.dynamics.solver_work()),
            ..self.progress_at
        };
        runner.record_dynamics(&self.dynamics, self.index, p, complete)
    }

    fn failed(&mut self, runner: &mut Runner, _: &mut LogWriter) {
        // The stored state at the failure goes to the log's `/failure`, to
        // replay the failing event from.
        let since = self.dynamics.time() - self.progress_at.start_time;
        let at = runner.clock + (since * NS_PER_TIME_UNIT).round() as u64;
        runner.failure = Some((at, self.dynamics.dump()));
    }

    fn finish(self, runner: &mut Runner, stopped: bool) -> (Phase, String) {
        runner.clock = if stopped {
            self.time
        } else {
            runner.clock + (self.duration * NS_PER_TIME_UNIT).round() as u64
        };
        let index = self.index;
        if let Some(strains) = self.dynamics.solver_work().strains_in_words() {
            runner.notes.push(format!(
                "stage {index} (dynamics): {strains} (counted in /stats.solver; each answer was certified, but the numerics were strained)"
            ));
        }
        let line = format!(
            "{} collisions over t = {:.4}{}{}",
            self.dynamics.collisions() - self.progress_at.start_collisions,
            self.dynamics.time() - self.progress_at.start_time,
            self.last_pressure
                .map(|p| format!(", last betaP {:.4}", Num(p)))
                .unwrap_or_default(),
            if stopped { ", interrupted" } else { "" }
        );
        (
            Phase::Dynamics {
                dynamics: self.dynamics,
                temperature: self.temperature,
                true_inertia: self.true_inertia,
            },
            line,
        )
    }
}
