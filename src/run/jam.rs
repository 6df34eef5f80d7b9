//! The jam stage: event-driven growth chunk by chunk ([`crate::edmd::jam`]),
//! a `/stats` message per chunk, a frame every [`FRAME_CHUNKS`] chunks
//! and at the end. Each frame holds the grown species, the velocities and
//! the run's progress: a resumed run goes on from it bit for bit.

use std::cell::Cell;

use rand_pcg::Pcg64;

use crate::edmd::jam::{
    DEFAULT_GROWTH_RATE, DEFAULT_JAM_PRESSURE, JamCertificate, JamChunk, JamEnd, JamOptions,
    JamRun, certificate,
};
use crate::log::{LogWriter, NS_PER_SWEEP, ResumeInfo, StateRecord, Stats};
use crate::mc::moves::Counts;
use crate::number::Num;
use crate::scene::{JAM_COLLISIONS_PER_BODY, Stage};

use super::cadence::{Mark, StagePlan, StageRun};
use super::records::Interval;
use super::*;
use crate::scene::plan::StageBuild;

/// Chunks between frames.
const FRAME_CHUNKS: u64 = 10;

/// A jam stage under way.
pub(super) struct JamStage {
    index: usize,
    run: JamRun,
    last: Option<JamChunk>,
    frame_due: bool,
    /// Chunks run again as of the last progress line.
    retries_shown: Cell<u64>,
}

impl JamStage {
    /// The stage from `phase` (its first frame written), or from the frame
    /// `resume` (whose state and velocities `phase` holds).
    pub(super) fn start(
        runner: &mut Runner,
        index: usize,
        phase: Phase,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        rng: &mut Pcg64,
    ) -> Result<Self, StageError> {
        let Stage::Jam {
            growth_rate,
            fluid_rate,
            pressure,
            packing_fraction,
        } = runner.scene.stages[index]
        else {
            unreachable!("called for jam stages")
        };
        let options = JamOptions {
            growth_rate: growth_rate.unwrap_or(DEFAULT_GROWTH_RATE),
            fluid_rate,
            pressure: pressure.unwrap_or(DEFAULT_JAM_PRESSURE),
            packing_fraction,
            max_collisions: JAM_COLLISIONS_PER_BODY * runner.scene.particle_count() as u64,
            ..JamOptions::default()
        };
        let resumed = resume.and_then(|r| r.jam);
        let run = match (resumed, phase) {
            (
                Some(progress),
                Phase::Moving {
                    system,
                    velocities,
                    angular_velocities,
                },
            ) => {
                let dynamics = runner.dynamics_options(1.0, false, &system);
                let moving: Vec<_> = velocities.into_iter().zip(angular_velocities).collect();
                JamRun::resume(&system, &moving, &options, &dynamics, progress)?
            }
            (Some(_), _) => return Err(StageError::NoJamVelocities),
            (None, phase) => {
                let system = runner.to_system(phase)?;
                let dynamics = runner.dynamics_options(1.0, false, &system);
                let run = JamRun::new(&system, &options, &dynamics, rng)?;
                runner.start_frame(log, &record(runner, &run, index, false))?;
                run
            }
        };
        Ok(Self {
            index,
            last: run.progress().last,
            retries_shown: Cell::new(run.progress().retries),
            run,
            frame_due: false,
        })
    }

    /// Log time where the run stands.
    fn time(&self, runner: &Runner) -> u64 {
        runner.clock + self.run.progress().chunk * NS_PER_SWEEP
    }
}

/// What the contact network says of a packing the jam ended.
enum Certificate {
    /// The contacts hold at least half the bodies at the gap the packing
    /// shows: its backbone, in words.
    Jammed(String),
    /// Not jammed, and why (a pressure made by growth faster than the
    /// packing could settle into its cages, which relaxes once the growth
    /// stops): a note for the user.
    NotJammed(String),
}

/// The contact network of a packing the jam ended, read at the gap the
/// packing shows ([`certificate`]).
fn certify(system: &System, reduced_pressure: Option<f64>) -> Certificate {
    let JamCertificate {
        gap: choice,
        network,
        held,
        refused,
    } = certificate(system, reduced_pressure);
    let reading = if held == 0 {
        format!("contacts at gap {:.1e}: no body is held", choice.gap)
    } else {
        format!(
            "contacts at gap {:.1e}: backbone of {held} bodies ({:.1} %), z = {:.3} against 2 d_f = {:.3}",
            choice.gap,
            100.0 * held as f64 / network.bodies.max(1) as f64,
            network.backbone_contact_number,
            network.isostatic_contact_number
        )
    };
    match refused {
        None => Certificate::Jammed(reading),
        Some(why) => Certificate::NotJammed(format!(
            "the packing is NOT certified jammed ({reading}; {why}): betaPV/N passed its bound while the bodies grew faster than they could settle into their cages, also after settling at lower rates; grow slower (a smaller growth_rate) and check with `hardbody analyze LOG --packing`"
        )),
    }
}

/// The frame of `run` where it stands.
fn record(runner: &Runner, run: &JamRun, index: usize, complete: bool) -> StateRecord {
    let system = run.system();
    StateRecord {
        stage_index: index,
        stage: "jam".into(),
        time: Some(run.progress().time),
        resume: Some(ResumeInfo {
            stage_clock: runner.clock,
            stage_complete: complete,
            sweep: 0,
            max_translate: 0.0,
            sizes: runner.sizes,
            rng: None,
            window: Counts::default(),
            tune_window: Counts::default(),
            compress: None,
            dynamics: None,
            drift: None,
            jam: Some(*run.progress()),
        }),
        ..StateRecord::of_system(system).with_velocities(run.velocities())
    }
}

impl StageRun for JamStage {
    fn built_with(&self) -> StagePlan {
        StagePlan::new(self.index, "jam", StageBuild::Jam)
    }

    fn advance(&mut self, runner: &mut Runner) -> Result<Mark, StageError> {
        let figures = self.run.chunk()?;
        let time = self.time(runner);
        Ok(match figures {
            Some(chunk) => {
                self.last = Some(chunk);
                self.frame_due |= chunk.chunk.is_multiple_of(FRAME_CHUNKS);
                Mark {
                    time,
                    stats: true,
                    frame: self.frame_due,
                    end: self.run.end().is_some(),
                }
            }
            // Ended without a new chunk (its floor or budget): the state
            // of the last chunk is the stage's.
            None => Mark {
                time,
                stats: false,
                frame: true,
                end: true,
            },
        })
    }

    fn stats(&mut self, runner: &Runner) -> Stats {
        let system = self.run.system();
        let chunk = self.last.expect("stats after a chunk");
        let density = system.len() as f64 / system.periodic_box().volume();
        runner.stats(
            self.index,
            Interval {
                time: Some(chunk.time),
                packing_fraction: chunk.packing_fraction,
                pressure: Some(chunk.pressure * density),
                box_lengths: system.periodic_box().lengths().into(),
                tilts: system.periodic_box().tilts().into(),
                collisions: Some(chunk.collisions),
                temperature: Some(chunk.temperature),
                nematic_order: runner.system_nematic_order(system),
                solver: Some(self.run.progress().solver),
                ..Interval::default()
            },
        )
    }

    fn progress(&self) -> (u64, String) {
        let p = self.run.progress();
        let mut line = self
            .last
            .map(|c| {
                let growth = if c.growth_rate > 0.0 {
                    format!("growth rate {:e}", c.growth_rate)
                } else {
                    format!("resting (settling round {})", p.settle_rounds)
                };
                format!(
                    "phi {:.4}, betaPV/N {:.3e}, {} collisions, {growth}",
                    Num(c.packing_fraction),
                    c.pressure,
                    c.collisions,
                )
            })
            .unwrap_or_default();
        // Chunks run again: how many, and why the first time it is shown.
        if p.retries > 0 {
            line += &format!(", {} chunks run again", p.retries);
            if self.retries_shown.replace(p.retries) != p.retries {
                line += &format!(" (the last: {})", self.run.last_failure().unwrap_or("-"));
            }
        }
        (p.chunk, line)
    }

    fn frame_ready(&mut self) -> Result<bool, StageError> {
        // Between chunks the state is certified overlap-free.
        Ok(true)
    }

    fn frame(&mut self, runner: &Runner, complete: bool) -> StateRecord {
        self.frame_due = false;
        record(runner, &self.run, self.index, complete)
    }

    fn failed(&mut self, runner: &mut Runner, log: &mut LogWriter) {
        // The last certified state before the failure.
        let time = self.time(runner);
        let _ = log.frame(time, &self.frame(runner, false));
    }

    fn finish(self, runner: &mut Runner, stopped: bool) -> (Phase, String) {
        let index = self.index;
        let p = *self.run.progress();
        runner.clock += p.chunk * NS_PER_SWEEP;
        if p.retries > 0 {
            runner.notes.push(format!(
                "stage {index} (jam): {} chunks run again at a lower growth rate after a numerical failure (the last: {})",
                p.retries,
                self.run.last_failure().unwrap_or("-")
            ));
        }
        if let Some(strains) = p.solver.strains_in_words() {
            runner.notes.push(format!(
                "stage {index} (jam): {strains} (counted in /stats.solver; each answer was certified, but the numerics were strained)"
            ));
        }
        let system = self.run.system();
        let phi = Num(system.packing_fraction());
        let figures = self
            .last
            .map(|c| {
                format!(
                    ", betaPV/N {:.3e} after {} collisions in {} chunks (t = {:.4}, growth rate {:e}{})",
                    c.pressure,
                    c.collisions,
                    c.chunk,
                    c.time,
                    c.growth_rate,
                    match p.settle_rounds {
                        0 => String::new(),
                        k => format!(
                            ", after {k} settling round{}: rest at fixed size, then a tenth of the rate",
                            if k == 1 { "" } else { "s" }
                        ),
                    }
                )
            })
            .unwrap_or_default();
        let line = match self.run.end() {
            Some(JamEnd::Jammed) => match certify(system, self.last.map(|c| c.pressure)) {
                Certificate::Jammed(reading) => {
                    format!("jammed at packing fraction {phi:.4}{figures}; {reading}")
                }
                Certificate::NotJammed(why) => {
                    runner.notes.push(format!("stage {index} (jam): {why}"));
                    format!(
                        "betaPV/N passed its bound at packing fraction {phi:.4}{figures}, but NOT certified jammed (see below)"
                    )
                }
            },
            Some(JamEnd::GrowthFloor) => format!(
                "growth rate lowered to its floor at packing fraction {phi:.4}{figures}: not jammed ({})",
                self.run.last_failure().unwrap_or("-")
            ),
            Some(JamEnd::PackingFraction) => format!("grown to packing fraction {phi:.4}{figures}"),
            Some(JamEnd::Budget) => {
                format!(
                    "collision budget ({JAM_COLLISIONS_PER_BODY:e} per body) spent at packing fraction {phi:.4}{figures}: not jammed"
                )
            }
            Some(JamEnd::Stopped) | None => {
                debug_assert!(stopped);
                format!("interrupted at packing fraction {phi:.4}{figures}")
            }
        };
        (Phase::Mc(self.run.system().clone()), line)
    }
}
