//! What Monte Carlo and compression stages write: their `/stats`, their
//! frames and the resume information a frame carries.

use nalgebra::Vector3;
use rand_pcg::Pcg64;

use crate::analysis::order::nematic_order;
use crate::log::{ResumeInfo, StateRecord, Stats};
use crate::mc::compress::CompressorState;
use crate::mc::moves::{Count, Counts};
use crate::state::{Species, System};

use super::*;

impl Runner {
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
            ..StateRecord::of_system(system)
        }
    }

    /// Resume information of a Monte Carlo stage.
    /// Resume information of a Monte Carlo or compression frame at
    /// `sweep`, with the counts of the stats interval and of the tuning
    /// window under way.
    pub(super) fn mc_resume(
        &self,
        rng: &Pcg64,
        sweep: u64,
        (window, tune_window): (Counts, Counts),
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
            jam: None,
        }
    }

    /// The `/stats` message of a Monte Carlo or compression interval
    /// ending at `sweep`.
    pub(super) fn mc_stats(
        &self,
        index: usize,
        system: &System,
        sweep: u64,
        window: &Counts,
        pressure: Option<f64>,
    ) -> Stats {
        let rate = |c: &Count| (c.tried > 0).then(|| c.rate());
        self.stats(
            index,
            Interval {
                sweep: Some(sweep),
                packing_fraction: system.packing_fraction(),
                pressure,
                box_lengths: system.periodic_box().lengths().into(),
                tilts: system.periodic_box().tilts().into(),
                acceptance: [
                    rate(&window.translate),
                    rate(&window.rotate),
                    rate(&window.volume),
                ],
                acceptance_shear: rate(&window.shear),
                acceptance_swap: rate(&window.swap),
                nematic_order: self.system_nematic_order(system),
                overlap_strains: Some(window.strains),
                ..Interval::default()
            },
        )
    }

    /// Tells the user, at the end of the run, of stage `index`'s overlap
    /// tests that the boolean test could not decide.
    pub(super) fn note_overlap_strains(
        &mut self,
        index: usize,
        strains: crate::geometry::pair::OverlapStrains,
    ) {
        if let Some(words) = strains.in_words() {
            let kind = self.scene.stages[index].kind();
            self.notes.push(format!(
                "stage {index} ({kind}): {words} (counted in /stats.overlap_strains; every move was decided, but the numerics were strained)"
            ));
        }
    }

    /// The `/stats` message of stage `index` over `interval`: every stage
    /// kind's messages are made here, the nematic order kept only where
    /// the plan measures it.
    pub(super) fn stats(&self, index: usize, interval: Interval) -> Stats {
        let [acceptance_translate, acceptance_rotate, acceptance_volume] = interval.acceptance;
        Stats {
            stage: self.scene.stages[index].kind().into(),
            stage_index: index,
            sweep: interval.sweep,
            time: interval.time,
            packing_fraction: interval.packing_fraction,
            pressure: interval.pressure,
            pressure_tensor: interval.pressure_tensor,
            box_lengths: interval.box_lengths,
            tilts: interval.tilts,
            acceptance_translate,
            acceptance_rotate,
            acceptance_volume,
            acceptance_shear: interval.acceptance_shear,
            acceptance_swap: interval.acceptance_swap,
            collisions: interval.collisions,
            temperature: interval.temperature,
            nematic_order: interval.nematic_order.filter(|_| self.plan.nematic_order),
            msd: interval.msd,
            c2: interval.c2,
            solver: interval.solver,
            overlap_strains: interval.overlap_strains,
        }
    }
}

/// What a stage measured over one stats interval (what it does not
/// measure stays `None`).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Interval {
    /// Monte Carlo: the sweep it ends at.
    pub(super) sweep: Option<u64>,
    /// Dynamics: the time since the stage began.
    pub(super) time: Option<f64>,
    pub(super) packing_fraction: f64,
    /// βP over the interval.
    pub(super) pressure: Option<f64>,
    /// βP_αβ over the interval (dynamics).
    pub(super) pressure_tensor: Option<[f64; 6]>,
    pub(super) box_lengths: [f64; 3],
    pub(super) tilts: [f64; 3],
    /// Translation, rotation and volume acceptance (Monte Carlo).
    pub(super) acceptance: [Option<f64>; 3],
    /// Shear acceptance (Monte Carlo, triclinic box moves).
    pub(super) acceptance_shear: Option<f64>,
    /// Size-swap acceptance (Monte Carlo with swaps).
    pub(super) acceptance_swap: Option<f64>,
    /// Dynamics: collisions since the stage began, kT.
    pub(super) collisions: Option<u64>,
    pub(super) temperature: Option<f64>,
    pub(super) nematic_order: Option<f64>,
    pub(super) msd: Option<f64>,
    pub(super) c2: Option<f64>,
    pub(super) solver: Option<crate::edmd::SolverWork>,
    /// Monte Carlo: undecided overlap tests over the interval.
    pub(super) overlap_strains: Option<crate::geometry::pair::OverlapStrains>,
}
