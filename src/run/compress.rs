//! The compression stage, and the approach to an NPT stage's pressure
//! that starts an NPT stage from a fresh state.

use rand_pcg::Pcg64;

use crate::log::{LogWriter, NS_PER_SWEEP, ResumeInfo};
use crate::mc::compress::{CompressOptions, Compressor};
use crate::mc::moves::Counts;
use crate::state::System;

use super::*;

impl Runner<'_> {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn compress(
        &mut self,
        index: usize,
        mut system: System,
        opts: &CompressOptions,
        resume: Option<ResumeInfo>,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        rng: &mut Pcg64,
    ) -> StageResult {
        let (mut compressor, mut window) = match resume {
            Some(ResumeInfo {
                compress: Some(state),
                window,
                ..
            }) => (Compressor::resume(opts, state), window),
            Some(_) => return Err(StageError::NoCompressorState),
            None => {
                let c = Compressor::new(&system, self.sizes, opts)?;
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
                    log.stats(time, &self.mc_stats(index, &system, s, &window, None))?;
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
                log.frame(time, &self.record_system(&system, index, s, info))?;
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
                Err(e.into())
            }
        }
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
}
