//! The compression stage, and the approach to an NPT stage's pressure
//! that starts an NPT stage from a fresh state.

use rand_pcg::Pcg64;

use crate::geometry::pair::{OverlapStrains, counting_strains};
use crate::log::{LogWriter, NS_PER_SWEEP, ResumeInfo, StateRecord, Stats};
use crate::mc::compress::{CompressOptions, CompressReport, Compressor};
use crate::mc::moves::Counts;
use crate::number::Num;
use crate::state::System;

use super::cadence::{Mark, StagePlan, StageRun};
use super::*;
use crate::scene::plan::StageBuild;

/// A compression under way.
pub(super) struct CompressStage<'a> {
    index: usize,
    system: System,
    rng: &'a mut Pcg64,
    compressor: Compressor,
    /// The counts of the stats interval under way.
    window: Counts,
    /// The compressor's counts and sweeps at the last advance.
    last_counts: Counts,
    last_sweeps: u64,
    /// Frames are written only where no body overlaps: a frame due waits
    /// for the shrink's overlaps to clear.
    frame_due: bool,
    stats_every: u64,
    frames_every: u64,
    report: Option<CompressReport>,
    /// Undecided overlap tests of the stage (in this run of it).
    strains: OverlapStrains,
}

impl<'a> CompressStage<'a> {
    /// The stage from its start (its first frame written) or from the
    /// frame `resume`.
    pub(super) fn start(
        runner: &mut Runner,
        index: usize,
        system: System,
        opts: &CompressOptions,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        rng: &'a mut Pcg64,
    ) -> Result<Self, StageError> {
        let (compressor, window) = match resume {
            Some(ResumeInfo {
                compress: Some(state),
                window,
                ..
            }) => (Compressor::resume(opts, state), window),
            Some(_) => return Err(StageError::NoCompressorState),
            None => {
                let c = Compressor::new(&system, runner.sizes, opts)?;
                let info = runner.mc_resume(
                    rng,
                    0,
                    (Counts::default(), Counts::default()),
                    Some(c.state().clone()),
                    0.0,
                    false,
                );
                runner.start_frame(log, &runner.record_system(&system, index, 0, info))?;
                (c, Counts::default())
            }
        };
        Ok(Self {
            index,
            system,
            rng,
            last_counts: compressor.state().counts,
            last_sweeps: compressor.state().sweeps,
            compressor,
            window,
            frame_due: false,
            stats_every: runner.scene.log.stats_every,
            frames_every: runner.scene.log.frames_every,
            report: None,
            strains: OverlapStrains::default(),
        })
    }
}

impl StageRun for CompressStage<'_> {
    fn built_with(&self) -> StagePlan {
        StagePlan::new(
            self.index,
            "compress",
            StageBuild::MonteCarlo(self.system.plan()),
        )
    }

    fn advance(&mut self, runner: &mut Runner) -> Result<Mark, StageError> {
        let (step, strains) =
            counting_strains(|| self.compressor.sweep(&mut self.system, self.rng));
        let state = self.compressor.state();
        self.window += state.counts - self.last_counts;
        self.window.strains += strains;
        self.last_counts = state.counts;
        let s = state.sweeps;
        let time = runner.clock + s * NS_PER_SWEEP;
        if let Some(report) = step? {
            self.report = Some(report);
            // The stats of the last sweep come with the final frame, unless
            // its interval ended there.
            return Ok(Mark {
                time,
                stats: !s.is_multiple_of(self.stats_every),
                frame: true,
                end: true,
            });
        }
        let mut stats = false;
        if s != self.last_sweeps {
            self.last_sweeps = s;
            stats = s.is_multiple_of(self.stats_every);
            self.frame_due |= s.is_multiple_of(self.frames_every);
        }
        Ok(Mark {
            time,
            stats,
            frame: self.frame_due,
            end: false,
        })
    }

    fn stats(&mut self, runner: &Runner) -> Stats {
        let s = self.compressor.state().sweeps;
        let stats = runner.mc_stats(self.index, &self.system, s, &self.window, None);
        self.strains += self.window.strains;
        if self.report.is_none() {
            self.window = Counts::default();
        }
        stats
    }

    fn progress(&self) -> (u64, String) {
        (
            self.compressor.state().sweeps,
            format!("phi {:.4}", Num(self.system.packing_fraction())),
        )
    }

    fn frame_ready(&mut self) -> Result<bool, StageError> {
        Ok(self.compressor.is_valid())
    }

    fn frame(&mut self, runner: &Runner, complete: bool) -> StateRecord {
        self.frame_due = false;
        let state = self.compressor.state().clone();
        let s = state.sweeps;
        let info = runner.mc_resume(
            self.rng,
            s,
            (self.window, Counts::default()),
            Some(state),
            0.0,
            complete,
        );
        runner.record_system(&self.system, self.index, s, info)
    }

    fn failed(&mut self, runner: &mut Runner, log: &mut LogWriter) {
        // The state reached (overlap-free) before the failure.
        let time = runner.clock + self.compressor.state().sweeps * NS_PER_SWEEP;
        let _ = log.frame(time, &self.frame(runner, false));
    }

    fn finish(self, runner: &mut Runner, _stopped: bool) -> (Phase, String) {
        runner.note_overlap_strains(self.index, self.strains);
        let s = self.compressor.state().sweeps;
        runner.sizes = self.compressor.state().sizes;
        runner.clock += s * NS_PER_SWEEP;
        let line = match self.report {
            None => format!(
                "interrupted at packing fraction {:.4} after {s} sweeps",
                Num(self.system.packing_fraction())
            ),
            Some(report) if report.jammed => {
                let pressure = report
                    .compressibility
                    .map(|z| format!(", betaP/rho = {z:.3e} from the last state"))
                    .unwrap_or_default();
                format!(
                    "jammed at packing fraction {:.4} after {} sweeps{pressure}",
                    Num(report.packing_fraction),
                    report.sweeps
                )
            }
            Some(report) => format!(
                "reached packing fraction {:.4} in {} sweeps",
                Num(report.packing_fraction),
                report.sweeps
            ),
        };
        (Phase::Mc(self.system), line)
    }
}

impl Runner {
    /// Before an NPT stage at `pressure` from a fresh start: compression
    /// (or expansion) to the packing fraction whose measured βP is within
    /// 3 % of it, so that the box moves start near the equilibrium density
    /// instead of creeping to it from a dilute start (their shrinks are
    /// limited by the closest pair, a gap of order 1/N of the box). Not
    /// with walls (the pressure is measured in a periodic box). Says what
    /// it did, if anything; where it cannot reach the pressure it leaves
    /// the last overlap-free state it had and the NPT stage goes on from
    /// there.
    pub(super) fn approach_pressure(
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
        let (pressure, start, end) = (Num(pressure), Num(start), Num(system.packing_fraction()));
        Some(match report {
            Some(r) => format!(
                "approached betaP {pressure} from packing fraction {start:.4} to {end:.4} (measured betaP {:.4}) in {sweeps} sweeps, then ",
                Num(r.pressure.unwrap_or(f64::NAN))
            ),
            None => format!(
                "approach to betaP {pressure} stopped at packing fraction {end:.4} after {sweeps} sweeps, then "
            ),
        })
    }
}
