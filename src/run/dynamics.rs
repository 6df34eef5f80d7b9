//! The dynamics stage: the hand-off from a state or a previous dynamics,
//! the event-driven run between stats and frames, and its frames.

use nalgebra::Vector3;
use rand_pcg::Pcg64;

use crate::edmd::dynamics::{Dynamics, DynamicsOptions};
use crate::edmd::predict::PredictorOptions;
use crate::log::{DynamicsProgress, LogWriter, NS_PER_TIME_UNIT, ResumeInfo, StateRecord, Stats};
use crate::mc::moves::Counts;
use crate::scene::Stage;
use crate::state::System;

use super::*;

impl Runner<'_> {
    /// The phase a logged frame continues: the system, or for a dynamics
    /// frame the dynamics rebuilt from it.
    pub(super) fn resumed_phase(
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
    pub(super) fn dynamics(
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
                let system = self.to_system(other)?;
                let options =
                    self.dynamics_options(temperature, true_inertia, system.packing_fraction());
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
                return Err(e.into());
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
                log.stats(time, &stats)?;
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
                dynamics.resynchronize()?;
                let p = DynamicsProgress {
                    time: dynamics.time(),
                    collisions: dynamics.collisions(),
                    next_stats: k_stats,
                    next_frame: k_frames,
                    interval: Some(dynamics.interval()),
                    solver_work: Some(dynamics.solver_work()),
                    ..progress_at
                };
                log.frame(time, &self.record_dynamics(&dynamics, index, p, end))?;
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

    pub(super) fn dynamics_options(
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
