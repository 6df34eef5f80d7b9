//! A coexistence cut into parts that run apart (on a cluster, one job
//! each): each phase's anchor (its scene run, then its free energy) and
//! each point of each branch (its scene run again, then expanded to the
//! point's density). Scene runs are reproducible to the bit and every
//! point has its own seed, so the parts crossed give what
//! [`super::scene_coexistence`] gives in one process.

use std::sync::atomic::{AtomicBool, AtomicU64};

use super::coexistence::{Branch, BranchPoint, Coexistence, CoexistenceOptions, Phase};
use super::coexistence::{branch_point, crossed, number_density, volume_per_body};
use super::{
    EquationOfState, FreeEnergyError, FrenkelLadd, PhaseScene, carried_anchors, check_phases,
    crystal_free_energy, fluid_free_energy, in_parallel, lattice_translations, run_to_end,
};
use crate::run::Progress;

/// One part of a coexistence; as JSON (a job's state point)
/// `{"part": "anchor", "phase": "fluid"}` or `{"part": "branch", "phase":
/// "crystal", "point": 3}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "part", rename_all = "snake_case", deny_unknown_fields)]
pub enum CoexistencePart {
    /// The phase's free energy at the state its scene ends in (the
    /// fluid's by its equation of state, the crystal's by Frenkel–Ladd).
    Anchor {
        /// Which phase.
        phase: Phase,
    },
    /// A point of the phase's branch.
    Branch {
        /// Which phase.
        phase: Phase,
        /// 0 at the anchor's density, down to `points − 1`.
        point: usize,
    },
}

impl CoexistencePart {
    /// Every part of a coexistence with `options`: both anchors, then
    /// each branch's points in order.
    pub fn all(options: &CoexistenceOptions) -> Vec<Self> {
        let mut parts = Vec::new();
        for phase in [Phase::Fluid, Phase::Crystal] {
            parts.push(Self::Anchor { phase });
            parts.extend((0..options.points).map(|point| Self::Branch { phase, point }));
        }
        parts
    }

    /// The phase it is of.
    pub fn phase(self) -> Phase {
        match self {
            Self::Anchor { phase } | Self::Branch { phase, .. } => phase,
        }
    }
}

impl std::fmt::Display for CoexistencePart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Anchor { phase } => write!(f, "the {}'s free energy", phase.name()),
            Self::Branch { phase, point } => {
                write!(f, "point {point} of the {}'s branch", phase.name())
            }
        }
    }
}

/// What a part found.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "result", rename_all = "snake_case", deny_unknown_fields)]
pub enum PartResult {
    /// A phase's anchor.
    Anchor {
        /// βF/N with its error.
        free_energy: (f64, f64),
        /// N/V of the state.
        density: f64,
        /// The bodies' volume per body (φ = ρ × this).
        volume_per_body: f64,
    },
    /// A branch's point.
    Point(BranchPoint),
}

/// Runs one `part` of the coexistence of `fluid` and `solid` with
/// `options` (the fluid's path, the crystal's, the branches'): the
/// part's phase's scene run to its end (its log at that phase's
/// [`PhaseScene::log`]), then its anchor's free energy or its branch
/// point.
pub fn coexistence_part(
    fluid: PhaseScene,
    solid: PhaseScene,
    options: (&EquationOfState, &FrenkelLadd, &CoexistenceOptions),
    part: CoexistencePart,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<PartResult, FreeEnergyError> {
    check_phases(fluid.scene, solid.scene)?;
    options.2.check()?;
    let phase = match part.phase() {
        Phase::Fluid => fluid,
        Phase::Crystal => solid,
    };
    let (start, end) = run_to_end(phase.scene, phase.text, phase.log, progress, stop)?;
    let anchor = |(free_energy, error): (f64, f64)| PartResult::Anchor {
        free_energy: (free_energy, error),
        density: number_density(&end),
        volume_per_body: volume_per_body(&end),
    };
    match part {
        CoexistencePart::Anchor {
            phase: Phase::Fluid,
        } => {
            let f = fluid_free_energy(&end, options.0, progress, stop)?;
            Ok(anchor((f.free_energy_per_particle, f.error)))
        }
        CoexistencePart::Anchor {
            phase: Phase::Crystal,
        } => {
            let anchors = carried_anchors(&start, &end);
            let translations = lattice_translations(&start);
            let c = crystal_free_energy(&end, &anchors, translations, options.1, progress, stop)?;
            Ok(anchor((c.free_energy_per_particle, c.error)))
        }
        CoexistencePart::Branch { phase, point } => {
            let branches = options.2;
            let description = format!("{} branch, point {point}", phase.name());
            let per_point = branches.sweeps + branches.equilibration;
            let measured = in_parallel(
                &[point],
                &description,
                per_point,
                progress,
                |_, &k, done: &AtomicU64| branch_point(&end, phase, branches, k, done, stop),
            )?;
            Ok(PartResult::Point(measured[0]))
        }
    }
}

/// Coexistence from its parts: each phase's anchor and its branch's
/// points in order, as [`coexistence_part`] found them.
pub fn coexistence_of_parts(
    fluid: (&PartResult, &[BranchPoint]),
    solid: (&PartResult, &[BranchPoint]),
    options: &CoexistenceOptions,
) -> Result<Coexistence, FreeEnergyError> {
    options.check()?;
    let branch = |(anchor, points): (&PartResult, &[BranchPoint]), name: &str| {
        let &PartResult::Anchor {
            free_energy,
            density,
            volume_per_body,
        } = anchor
        else {
            return Err(FreeEnergyError::Options(format!(
                "the {name}'s anchor is a branch point"
            )));
        };
        if points.len() != options.points {
            return Err(FreeEnergyError::Options(format!(
                "the {name}'s branch has {} points of {}",
                points.len(),
                options.points
            )));
        }
        Ok((
            Branch::fitted(density, free_energy, points.to_vec())?,
            volume_per_body,
        ))
    };
    crossed(branch(fluid, "fluid")?, branch(solid, "crystal")?, options)
}
