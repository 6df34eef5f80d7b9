//! The Monte Carlo stage: NVT or NPT sweeps, serial or on slabs, with
//! move sizes tuned while the stage settles, the SDF pressure in NVT and,
//! when asked, the SDF pressure tensor.

use rand::RngCore;
use rand_pcg::Pcg64;

use crate::geometry::pair::{OverlapStrains, counting_strains};
use crate::log::{NS_PER_SWEEP, ResumeInfo, StateRecord, Stats};
use crate::mc::moves::{Counts, Ensemble as McEnsemble, sweep_with_swaps};
use crate::mc::parallel::{MAX_CHUNK, ParallelSweeps, sweeps_on_slabs};
use crate::mc::sdf::{Sdf, SdfTensor};
use crate::mc::tuning::{Tuner, TuningSpan};
use crate::number::Num;
use crate::scene::Ensemble;
use crate::state::System;

use super::cadence::{Mark, StagePlan, StageRun};
use super::*;
use crate::scene::plan::StageBuild;

/// The scale distribution's widest window and its bins (HOOMD's x_max
/// and bins of 10⁻⁴), for the pressure and the pressure tensor alike.
const SDF_X_MAX: f64 = 0.02;
const SDF_BINS: usize = 200;

/// Sweeps between move-size updates while tuning (50: a window of 20
/// holds only 20 box moves, too few to steer the volume step by).
const TUNE_WINDOW: u64 = 50;

/// A Monte Carlo stage under way.
pub(super) struct MonteCarloStage<'a> {
    index: usize,
    system: System,
    rng: &'a mut Pcg64,
    ensemble: Ensemble,
    mc_ensemble: McEnsemble,
    sweeps: u64,
    span: TuningSpan,
    /// Its cap is fixed by the box the stage starts in.
    tuner: Tuner,
    stats_every: u64,
    frames_every: u64,
    /// NVT: pressure from the scale distribution function, sampled ten
    /// times per stats interval (not with walls: it assumes a periodic
    /// box).
    sdf: Option<Sdf>,
    /// βP_αβ from the scale distribution, when the scene asks for it;
    /// sampled as `sdf` is.
    tensor: Option<SdfTensor>,
    sdf_every: u64,
    /// Sweeps after which the SDF samples (the end of tuning).
    sampled_after: u64,
    /// Large systems sweep on slabs, on every core rayon has, the same
    /// trajectory on one or two; each sweep's streams are keyed on a seed
    /// drawn from the stage's generator, so that a resumed stage draws the
    /// same ones.
    slabs: Option<ParallelSweeps>,
    /// Size swaps per body per sweep.
    swaps: f64,
    seeds: Vec<u64>,
    /// Sweeps done.
    sweep: u64,
    window: Counts,
    tune_window: Counts,
    /// The translation acceptance of the last stats interval.
    acceptance: f64,
    pressure: Option<f64>,
    /// What the approach to an NPT stage's pressure did.
    approach: Option<String>,
    /// Undecided overlap tests of the stage (in this run of it).
    strains: OverlapStrains,
}

impl<'a> MonteCarloStage<'a> {
    /// The stage from its start (its first frame written) or from the
    /// frame `resume`.
    pub(super) fn start(
        runner: &mut Runner,
        index: usize,
        mut system: System,
        (ensemble, sweeps, span, pressure_tensor, swaps): (Ensemble, u64, TuningSpan, bool, f64),
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        rng: &'a mut Pcg64,
    ) -> Result<Self, StageError> {
        let mc_ensemble = match ensemble {
            Ensemble::Nvt => McEnsemble::Nvt,
            Ensemble::Npt { pressure, .. } => McEnsemble::Npt {
                pressure,
                moves: ensemble.box_moves().unwrap_or_default(),
            },
        };
        runner.drift = resume
            .as_ref()
            .and_then(|r| r.drift.clone())
            .unwrap_or_default();
        let mut approach = None;
        let (first, window, tune_window, max_translate) = match &resume {
            Some(r) => (r.sweep, r.window, r.tune_window, r.max_translate),
            None => {
                if let Ensemble::Npt { pressure, .. } = ensemble {
                    approach = runner.approach_pressure(&mut system, pressure, rng);
                }
                let max_translate = system.periodic_box().lengths().min() / 2.0;
                let info = runner.mc_resume(
                    rng,
                    0,
                    (Counts::default(), Counts::default()),
                    None,
                    max_translate,
                    false,
                );
                runner.start_frame(log, &runner.record_system(&system, index, 0, info))?;
                (0, Counts::default(), Counts::default(), max_translate)
            }
        };
        let stats_every = runner.scene.log.stats_every;
        let sdf = (matches!(ensemble, Ensemble::Nvt) && !system.periodic_box().has_walls())
            .then(|| Sdf::new(SDF_X_MAX, SDF_BINS));
        let tensor = pressure_tensor.then(|| SdfTensor::new(SDF_X_MAX, SDF_BINS));
        // Size swaps pair bodies anywhere in the box: those stages sweep
        // serially.
        let slabs = (sweeps_on_slabs(system.len()) && swaps == 0.0).then(ParallelSweeps::new);
        Ok(Self {
            index,
            system,
            rng,
            ensemble,
            mc_ensemble,
            sweeps,
            span,
            tuner: Tuner {
                target: 0.3,
                max_translate,
            },
            stats_every,
            frames_every: runner.scene.log.frames_every,
            sdf,
            tensor,
            sdf_every: (stats_every / 10).max(1),
            sampled_after: match span {
                TuningSpan::Fixed(t) => t,
                TuningSpan::UntilSettled { at_least, .. } => at_least,
            },
            slabs,
            swaps,
            seeds: Vec::with_capacity(MAX_CHUNK),
            sweep: first,
            window,
            tune_window,
            acceptance: f64::NAN,
            pressure: None,
            approach,
            strains: OverlapStrains::default(),
        })
    }

    /// Whether move sizes are tuned after sweep `s` (given whether the
    /// density has settled, which only a tuning window's end changes).
    fn tunes_at(&self, s: u64, settled: bool) -> bool {
        s.is_multiple_of(TUNE_WINDOW) && self.span.tunes_at(s, settled)
    }

    fn samples_at(&self, s: u64) -> bool {
        s > self.sampled_after && s.is_multiple_of(self.sdf_every)
    }

    /// Draws the seeds of the sweeps the slabs' team is handed at once, up
    /// to the next sweep after which something happens (or the run
    /// pauses); moves the sweep
    /// count past them and returns the index of the first.
    fn draw_chunk(&mut self, settled: bool, pause: Option<u64>) -> u64 {
        self.seeds.clear();
        let mut s = self.sweep;
        loop {
            s += 1;
            self.seeds.push(self.rng.next_u64());
            if self.eventful(s, settled) || pause == Some(s) || self.seeds.len() == MAX_CHUNK {
                break;
            }
        }
        self.sweep = s;
        s + 1 - self.seeds.len() as u64
    }

    /// Whether anything happens after sweep `s`: where a run of sweeps
    /// handed to the slabs' team at once ends.
    fn eventful(&self, s: u64, settled: bool) -> bool {
        s == self.sweeps
            || s.is_multiple_of(self.stats_every)
            || s.is_multiple_of(self.frames_every)
            || self.tunes_at(s, settled)
            || ((self.sdf.is_some() || self.tensor.is_some()) && self.samples_at(s))
    }
}

impl StageRun for MonteCarloStage<'_> {
    fn built_with(&self) -> StagePlan {
        StagePlan::new(
            self.index,
            "monte_carlo",
            StageBuild::MonteCarlo(self.system.plan()),
        )
    }

    fn advance(&mut self, runner: &mut Runner) -> Result<Mark, StageError> {
        let settled = runner.drift.settled;
        let pause = runner
            .pause_at
            .map(|t| t.saturating_sub(runner.clock) / NS_PER_SWEEP);
        let chunk = self
            .slabs
            .is_some()
            .then(|| self.draw_chunk(settled, pause));
        // The slabs' team counts its strains on its own threads.
        let (counts, strains) = counting_strains(|| match (&mut self.slabs, chunk) {
            (Some(slabs), Some(first_index)) => slabs.sweeps(
                &mut self.system,
                &runner.sizes,
                &self.mc_ensemble,
                &self.seeds,
                first_index,
            ),
            _ => {
                self.sweep += 1;
                let (sizes, ensemble) = (&runner.sizes, &self.mc_ensemble);
                sweep_with_swaps(&mut self.system, sizes, ensemble, self.swaps, self.rng)
            }
        });
        let counts = counts.with_strains(strains);
        let s = self.sweep;
        self.window += counts;
        self.tune_window += counts;
        if self.tunes_at(s, runner.drift.settled) {
            self.tuner.update(&mut runner.sizes, &self.tune_window);
            self.tune_window = Counts::default();
            if matches!(self.span, TuningSpan::UntilSettled { .. }) {
                runner.drift.observe(self.system.packing_fraction());
            }
        }
        if self.samples_at(s) {
            let ((), strains) = counting_strains(|| {
                if let Some(sdf) = &mut self.sdf {
                    sdf.add(&self.system);
                }
                if let Some(tensor) = &mut self.tensor {
                    tensor.add(&self.system);
                }
            });
            // Counted with the stage's tests since the interval and since
            // the tuning began, as the sweeps' are.
            self.window.strains += strains;
            self.tune_window.strains += strains;
        }
        let end = s == self.sweeps;
        Ok(Mark {
            time: runner.clock + s * NS_PER_SWEEP,
            stats: s.is_multiple_of(self.stats_every) || end,
            frame: s.is_multiple_of(self.frames_every),
            end,
        })
    }

    fn stats(&mut self, runner: &Runner) -> Stats {
        let s = self.sweep;
        self.pressure = runner.interval_pressure(&self.ensemble, &mut self.sdf);
        let mut stats = runner.mc_stats(self.index, &self.system, s, &self.window, self.pressure);
        if let Some(tensor) = &mut self.tensor {
            stats.pressure_tensor = tensor.pressure_tensor();
            *tensor = SdfTensor::new(SDF_X_MAX, SDF_BINS);
        }
        self.acceptance = self.window.translate.rate();
        self.strains += self.window.strains;
        // The counts restart with each interval (a stage's last, shorter
        // interval keeps them in its final frame).
        if s.is_multiple_of(self.stats_every) {
            self.window = Counts::default();
        }
        stats
    }

    fn progress(&self) -> (u64, String) {
        (
            self.sweep,
            format!(
                "phi {:.4}, acceptance {:.2}",
                Num(self.system.packing_fraction()),
                self.acceptance
            ),
        )
    }

    fn frame_ready(&mut self) -> Result<bool, StageError> {
        Ok(true)
    }

    fn frame(&mut self, runner: &Runner, complete: bool) -> StateRecord {
        let info = runner.mc_resume(
            self.rng,
            self.sweep,
            (self.window, self.tune_window),
            None,
            self.tuner.max_translate,
            complete,
        );
        runner.record_system(&self.system, self.index, self.sweep, info)
    }

    fn failed(&mut self, _: &mut Runner, _: &mut LogWriter) {}

    fn finish(self, runner: &mut Runner, stopped: bool) -> (Phase, String) {
        runner.clock += self.sweep * NS_PER_SWEEP;
        runner.note_overlap_strains(self.index, self.strains);
        let line = format!(
            "{}{} sweeps, packing fraction {:.4}{}{}",
            self.approach.unwrap_or_default(),
            self.sweep,
            Num(self.system.packing_fraction()),
            self.pressure
                .map(|p| format!(", last betaP {:.4}", Num(p)))
                .unwrap_or_default(),
            if stopped { ", interrupted" } else { "" }
        );
        (Phase::Mc(self.system), line)
    }
}

impl Runner {
    /// βP over the interval: the imposed value in NPT, the SDF estimate in
    /// NVT (then the accumulator restarts).
    pub(super) fn interval_pressure(
        &self,
        ensemble: &Ensemble,
        sdf: &mut Option<Sdf>,
    ) -> Option<f64> {
        match ensemble {
            Ensemble::Npt { pressure, .. } => Some(*pressure),
            Ensemble::Nvt => {
                let s = sdf.as_mut()?;
                let p = s.pressure();
                *s = Sdf::new(SDF_X_MAX, SDF_BINS);
                p
            }
        }
    }
}
