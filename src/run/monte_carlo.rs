//! The Monte Carlo stage: NVT or NPT sweeps, serial or on slabs, with
//! move sizes tuned while the stage settles and the SDF pressure in NVT.

use rand::RngCore;
use rand_pcg::Pcg64;

use crate::log::{LogWriter, NS_PER_SWEEP, ResumeInfo};
use crate::mc::moves::{Counts, Ensemble as McEnsemble, sweep};
use crate::mc::parallel::{MAX_CHUNK, ParallelSweeps, sweeps_on_slabs};
use crate::mc::sdf::Sdf;
use crate::mc::tuning::{Tuner, TuningSpan};
use crate::scene::Ensemble;
use crate::state::System;

use super::*;

impl Runner<'_> {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn monte_carlo(
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
                log.stats(time, &self.mc_stats(index, &system, s, &window, pressure))?;
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
                log.frame(time, &self.record_system(&system, index, s, info))?;
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
                *s = Sdf::new(0.02, 200);
                p
            }
        }
    }
}
