//! What Monte Carlo and compression stages write: their `/stats`, their
//! frames and the resume information a frame carries.

use nalgebra::Vector3;
use rand_pcg::Pcg64;

use crate::analysis::order::nematic_order;
use crate::log::{LogError, LogWriter, NS_PER_SWEEP, ResumeInfo, StateRecord, Stats};
use crate::mc::compress::CompressorState;
use crate::mc::moves::{Count, Counts};
use crate::state::{Species, System};

use super::*;

impl Runner<'_> {
    /// S₂ of the molecular axes of the turning anisotropic bodies, if the
    /// plan asks for it.
    pub(super) fn system_nematic_order(&self, system: &System) -> Option<f64> {
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
    pub(super) fn record_system(
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
    pub(super) fn mc_resume(
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

    pub(super) fn mc_stats(
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

    /// The last stats and frame of a Monte Carlo stage, and the clock
    /// moved past it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn end_mc_stage(
        &mut self,
        index: usize,
        system: &System,
        sweeps: u64,
        window: &Counts,
        pressure: Option<f64>,
        info: ResumeInfo,
        log: &mut LogWriter,
    ) -> Result<(), StageError> {
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
        write(log)?;
        self.clock = time;
        Ok(())
    }
}
