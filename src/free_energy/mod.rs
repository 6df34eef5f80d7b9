//! Absolute free energies of the state a scene ends in: of a crystal by
//! Frenkel–Ladd integration (`frenkel_ladd.rs`), of a fluid by integrating
//! its equation of state from the ideal gas (`fluid.rs`), and the
//! coexistence of the two (`coexistence.rs`).
//!
//! It runs scenes (through [`crate::run`]) and Monte Carlo with springs
//! ([`crate::mc::einstein`]); the command line and Python call it.

pub mod coexistence;
pub mod fluid;
pub mod frenkel_ladd;
pub mod parts;

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use nalgebra::Vector3;

pub use coexistence::{
    Branch, BranchPoint, Coexistence, CoexistenceOptions, Phase, branch_below, branch_point,
    coexistence,
};
pub use fluid::{EosPoint, EquationOfState, FluidFreeEnergy, fluid_free_energy};
pub use frenkel_ladd::{CrystalFreeEnergy, FrenkelLadd, PathPoint, crystal_free_energy};
pub use parts::{CoexistencePart, PartResult, coexistence_of_parts, coexistence_part};

use crate::mc::einstein::{Anchors, TetherError};
use crate::run::{Progress, RecordError, RunError, Simulation, system_from_record};
use crate::scene::plan::Plan;
use crate::scene::{Start, ValidScene};
use crate::state::System;

type V3 = Vector3<f64>;

/// What stops a free energy from being found.
#[derive(Debug, thiserror::Error)]
pub enum FreeEnergyError {
    /// The scene does not start from a crystal.
    #[error(
        "the scene starts from {0}: the free energy of a solid needs a lattice to tether its \
         bodies to; start it from Crystal(lattice: ..., cells: ..., packing_fraction: ...)"
    )]
    NoLattice(&'static str),
    /// The box has walls.
    #[error("the box has walls: free energies are computed in periodic boxes only")]
    Walls,
    /// The state cannot be tethered to its lattice.
    #[error("the scene's final state cannot be tethered to its start lattice: {0}")]
    Tether(#[from] TetherError),
    /// A body left its site while the path ran.
    #[error(
        "a body left its site at βλ = {spring}: {source}; the crystal melted, or rows of it \
         slide along their axis (aligned flat faces let them: a simple cubic crystal of cubes \
         does), and its free energy is not that of a crystal on its sites (run it denser, or \
         check that the lattice is stable)"
    )]
    Melted {
        /// βλ of the point where it happened (0: the free crystal).
        spring: f64,
        /// Which body and how far.
        source: TetherError,
    },
    /// The ideal Einstein crystal overlaps in almost every sample.
    #[error(
        "springs βλ_max = {spring} are too weak for the path: only {overlap_free} of the \
         Einstein crystal's samples are overlap-free, under 1 %; give stronger springs, or \
         none to have them chosen"
    )]
    SpringsTooWeak {
        /// βλ_max.
        spring: f64,
        /// The overlap-free fraction.
        overlap_free: f64,
    },
    /// λ_max is outside (c, widest · c].
    #[error(
        "springs βλ_max = {spring} are out of the path's range ({shift}, {widest} × {shift}], \
         set by the free crystal's spread (c = {shift}): weaker springs leave the Einstein \
         crystal no narrower than the free one, stronger ones spread the quadrature too thin"
    )]
    PathOutOfRange {
        /// βλ_max.
        spring: f64,
        /// c.
        shift: f64,
        /// The widest λ_max / c.
        widest: f64,
    },
    /// A state given as a fluid is ordered, or orders on the path.
    #[error(
        "the state at packing fraction {packing_fraction:.4} is ordered ({order}): a fluid's \
         free energy integrates its equation of state from the ideal gas, which would cross \
         the transition; for a crystal, start the scene from Crystal(...) (Frenkel–Ladd)"
    )]
    Ordered {
        /// φ of the ordered state.
        packing_fraction: f64,
        /// Which order, and how much.
        order: String,
    },
    /// A crystal melted on its branch of the equation of state.
    #[error(
        "the crystal melted when expanded to packing fraction {packing_fraction:.4} (global \
         Q₆ = {q6:.3}): its branch reaches below the crystal's stability; give a denser crystal \
         or a smaller span"
    )]
    MeltedBranch {
        /// φ where it melted.
        packing_fraction: f64,
        /// Its Q₆.
        q6: f64,
    },
    /// The two phases' chemical potentials do not cross where measured.
    #[error("no coexistence found: {0}")]
    NoCrossing(String),
    /// A scene given for one phase is of the other.
    #[error("the {role} scene {why}")]
    WrongPhase {
        /// `fluid` or `solid`.
        role: &'static str,
        /// What is wrong with it.
        why: &'static str,
    },
    /// The orientational springs are too weak at λ_max for a finite
    /// group's wells to be told apart.
    #[error(
        "orientational springs κλ_max = {spring} are too weak: a body's images under its \
         symmetries lie {edge} apart in 1 − cos θ, and κλ_max × that must reach 40; give a \
         larger twist or stronger springs"
    )]
    ShallowWells {
        /// κλ_max.
        spring: f64,
        /// The well's edge.
        edge: f64,
    },
    /// An option cannot be used.
    #[error("Frenkel–Ladd options: {0}")]
    Options(String),
    /// Stopped before the path was done.
    #[error("stopped before the path was done: no free energy")]
    Stopped,
    /// The scene's run failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The scene's final state cannot be read back.
    #[error("the scene's final state: {0}")]
    Record(#[from] RecordError),
}

impl FreeEnergyError {
    /// Whether the input (scene, options) is at fault rather than the
    /// computation.
    pub fn is_bad_input(&self) -> bool {
        match self {
            FreeEnergyError::Run(e) => e.is_bad_input(),
            FreeEnergyError::Melted { .. } | FreeEnergyError::Stopped => false,
            _ => true,
        }
    }
}

/// The free energy of a scene's final state, by the route its start
/// calls for.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum FreeEnergy {
    /// A crystal, by Frenkel–Ladd.
    FrenkelLadd(CrystalFreeEnergy),
    /// A fluid, by its equation of state.
    EquationOfState(FluidFreeEnergy),
}

impl FreeEnergy {
    /// βF/N and its error.
    pub fn per_particle(&self) -> (f64, f64) {
        match self {
            FreeEnergy::FrenkelLadd(c) => (c.free_energy_per_particle, c.error),
            FreeEnergy::EquationOfState(f) => (f.free_energy_per_particle, f.error),
        }
    }
}

/// βF/N of the state `scene` ends in (its log written to `log_path`): by
/// Frenkel–Ladd if it starts from a crystal, else by integrating its
/// equation of state as a fluid.
pub fn scene_free_energy(
    scene: &ValidScene,
    scene_text: &str,
    log_path: &Path,
    crystal: &FrenkelLadd,
    fluid: &EquationOfState,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<FreeEnergy, FreeEnergyError> {
    if !scene.walls.is_empty() {
        return Err(FreeEnergyError::Walls);
    }
    if let Start::Crystal { .. } = scene.start {
        return solid_free_energy(scene, scene_text, log_path, crystal, progress, stop)
            .map(FreeEnergy::FrenkelLadd);
    }
    let (_, end) = run_to_end(scene, scene_text, log_path, progress, stop)?;
    fluid_free_energy(&end, fluid, progress, stop).map(FreeEnergy::EquationOfState)
}

/// What a user may choose of the paths (the command line's flags, the
/// Python keywords); the rest are the defaults.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PathChoices {
    /// Gauss–Legendre points of the path (the crystal's or the fluid's).
    pub points: Option<usize>,
    /// Sweeps sampled per point (a tenth more run first).
    pub sweeps: Option<u64>,
    /// λ_max of the crystal's springs.
    pub spring: Option<f64>,
    /// Seed (default: the scene's).
    pub seed: Option<u64>,
}

impl PathChoices {
    /// The Frenkel–Ladd path, `seed` the scene's.
    pub fn frenkel_ladd(&self, seed: u64) -> FrenkelLadd {
        let defaults = FrenkelLadd::default();
        FrenkelLadd {
            points: self.points.unwrap_or(defaults.points),
            sweeps: self.sweeps.unwrap_or(defaults.sweeps),
            equilibration: self.sweeps.map_or(defaults.equilibration, |s| s / 10),
            spring: self.spring,
            seed: self.seed.unwrap_or(seed),
            ..defaults
        }
    }

    /// The fluid's equation of state, `seed` the scene's.
    pub fn equation_of_state(&self, seed: u64) -> EquationOfState {
        let defaults = EquationOfState::default();
        EquationOfState {
            points: self.points.unwrap_or(defaults.points),
            sweeps: self.sweeps.unwrap_or(defaults.sweeps),
            equilibration: self.sweeps.map_or(defaults.equilibration, |s| s / 10),
            seed: self.seed.unwrap_or(seed),
            ..defaults
        }
    }

    /// The branches of coexistence (the points are the fluid path's;
    /// the Frenkel–Ladd path keeps its defaults but for the springs).
    pub fn coexistence(&self, seed: u64) -> (EquationOfState, FrenkelLadd, CoexistenceOptions) {
        let defaults = CoexistenceOptions::default();
        let springs = FrenkelLadd {
            spring: self.spring,
            seed: self.seed.unwrap_or(seed),
            ..FrenkelLadd::default()
        };
        let branches = CoexistenceOptions {
            sweeps: self.sweeps.unwrap_or(defaults.sweeps),
            equilibration: self.sweeps.map_or(defaults.equilibration, |s| s / 10),
            seed: self.seed.unwrap_or(seed),
            ..defaults
        };
        (self.equation_of_state(seed), springs, branches)
    }
}

/// One phase's scene: the scene, its text and where its log goes.
pub struct PhaseScene<'a> {
    /// The scene.
    pub scene: &'a ValidScene,
    /// Its text, which the log records.
    pub text: &'a str,
    /// Its log.
    pub log: &'a Path,
}

/// Fluid–crystal coexistence from a fluid scene and a crystal scene: both
/// run, the fluid's free energy from its equation of state, the
/// crystal's by Frenkel–Ladd, the branches sampled below each, and the
/// chemical potentials crossed.
pub fn scene_coexistence(
    fluid: PhaseScene,
    solid: PhaseScene,
    options: (&EquationOfState, &FrenkelLadd, &CoexistenceOptions),
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<Coexistence, FreeEnergyError> {
    check_phases(fluid.scene, solid.scene)?;
    let (_, fluid_state) = run_to_end(fluid.scene, fluid.text, fluid.log, progress, stop)?;
    let fluid_energy = fluid_free_energy(&fluid_state, options.0, progress, stop)?;
    let (start, solid_state) = run_to_end(solid.scene, solid.text, solid.log, progress, stop)?;
    let anchors = carried_anchors(&start, &solid_state);
    let translations = lattice_translations(&start);
    let solid_energy = crystal_free_energy(
        &solid_state,
        &anchors,
        translations,
        options.1,
        progress,
        stop,
    )?;
    coexistence(
        (&fluid_state, &fluid_energy),
        (&solid_state, &solid_energy),
        options.2,
        progress,
        stop,
    )
}

/// Refuses a fluid given as the solid, a crystal given as the fluid,
/// and walls.
pub fn check_phases(fluid: &ValidScene, solid: &ValidScene) -> Result<(), FreeEnergyError> {
    if !matches!(solid.start, Start::Crystal { .. }) {
        return Err(FreeEnergyError::WrongPhase {
            role: "solid",
            why: "does not start from Crystal(...): there is no lattice to tether its bodies to",
        });
    }
    if matches!(fluid.start, Start::Crystal { .. }) {
        return Err(FreeEnergyError::WrongPhase {
            role: "fluid",
            why: "starts from a crystal: give a fluid (a Random or Lattice start compressed)",
        });
    }
    if !fluid.walls.is_empty() || !solid.walls.is_empty() {
        return Err(FreeEnergyError::Walls);
    }
    Ok(())
}

/// The scene run to its end: its start and final states.
fn run_to_end(
    scene: &ValidScene,
    scene_text: &str,
    log_path: &Path,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<(System, System), FreeEnergyError> {
    let plan = Plan::of(scene);
    let mut simulation = Simulation::new(scene, scene_text, log_path)?;
    let start = system_from_record(&simulation.state()?, &plan)?;
    while simulation.stage_index().is_some() {
        let step = simulation.run_stage(progress, stop)?;
        if step.interrupted {
            simulation.finish()?;
            return Err(FreeEnergyError::Stopped);
        }
    }
    let end = system_from_record(&simulation.state()?, &plan)?;
    simulation.finish()?;
    Ok((start, end))
}

/// βF/N of the crystal `scene` ends in: the scene is run (its log written
/// to `log_path`), its start lattice carried into the final box by the
/// box's deformation, and the bodies tethered to it.
pub fn solid_free_energy(
    scene: &ValidScene,
    scene_text: &str,
    log_path: &Path,
    options: &FrenkelLadd,
    progress: &mut dyn Progress,
    stop: &AtomicBool,
) -> Result<CrystalFreeEnergy, FreeEnergyError> {
    match scene.start {
        Start::Crystal { .. } => {}
        Start::Lattice => return Err(FreeEnergyError::NoLattice("a filled lattice")),
        Start::Random => return Err(FreeEnergyError::NoLattice("random insertion")),
        Start::Resume(_) => return Err(FreeEnergyError::NoLattice("another log")),
        Start::Layered(_) => return Err(FreeEnergyError::NoLattice("layers")),
    }
    if !scene.walls.is_empty() {
        return Err(FreeEnergyError::Walls);
    }
    let (start, end) = run_to_end(scene, scene_text, log_path, progress, stop)?;
    let anchors = carried_anchors(&start, &end);
    let translations = lattice_translations(&start);
    crystal_free_energy(&end, &anchors, translations, options, progress, stop)
}

/// `work` on each of `items` in parallel (rayon), its results in order:
/// the first error if any. Progress hears of the sweeps the workers count
/// in their `done` (`per_item` each) as a stage of `description`.
pub(crate) fn in_parallel<T: Sync, U: Send>(
    items: &[T],
    description: &str,
    per_item: u64,
    progress: &mut dyn Progress,
    work: impl Fn(usize, &T, &AtomicU64) -> Result<U, FreeEnergyError> + Sync,
) -> Result<Vec<U>, FreeEnergyError> {
    use rayon::prelude::*;
    progress.stage(0, 1, description, per_item * items.len() as u64);
    let done = AtomicU64::new(0);
    let results: Vec<Result<U, FreeEnergyError>> = std::thread::scope(|scope| {
        let workers = scope.spawn(|| {
            (items.par_iter().enumerate())
                .map(|(k, item)| work(k, item, &done))
                .collect()
        });
        while !workers.is_finished() {
            std::thread::sleep(std::time::Duration::from_millis(200));
            progress.tick(done.load(Ordering::Relaxed), "");
        }
        workers.join().expect("the workers do not panic")
    });
    let results = results.into_iter().collect::<Result<Vec<U>, _>>()?;
    progress.stage_done(&format!("{} points sampled", results.len()));
    Ok(results)
}

/// The bodies' start positions carried into `end`'s box by the affine map
/// between the two boxes, with their start orientations.
pub fn carried_anchors(start: &System, end: &System) -> Anchors {
    let (from, to) = (start.periodic_box(), end.periodic_box());
    let mut anchors = Anchors::of(start);
    for site in &mut anchors.sites {
        *site = to.map_from(from, site);
    }
    anchors
}

/// How many translations by the vector from body 0 to another body map
/// the crystal onto itself (each body onto one of its species and
/// orientation): N_c, the lattice translations in the box.
pub fn lattice_translations(crystal: &System) -> usize {
    let box_ = crystal.periodic_box();
    let particles = crystal.particles();
    let n = particles.len();
    // Fractional coordinates binned on a grid about one site per cell.
    let side = ((n as f64).cbrt().ceil() as usize).max(1);
    let fractional: Vec<V3> = (particles.iter())
        .map(|p| box_.fractional(&box_.wrap(&p.position)))
        .collect();
    let bin = |s: &V3| -> [usize; 3] {
        std::array::from_fn(|k| ((s[k].rem_euclid(1.0) * side as f64) as usize).min(side - 1))
    };
    let mut grid = vec![Vec::new(); side * side * side];
    let index = |b: [usize; 3]| (b[2] * side + b[1]) * side + b[0];
    for (i, s) in fractional.iter().enumerate() {
        grid[index(bin(s))].push(i);
    }
    let spacing = box_.volume().cbrt() / (n as f64).cbrt();
    let tolerance = 1e-6 * spacing;
    let same = |a: usize, b: usize| {
        let (p, q) = (&particles[a], &particles[b]);
        p.species == q.species && p.orientation.coords.dot(&q.orientation.coords).abs() > 1.0 - 1e-9
    };
    let has_site = |i: usize, s: &V3| {
        let home = bin(s);
        for dz in [side - 1, 0, 1] {
            for dy in [side - 1, 0, 1] {
                for dx in [side - 1, 0, 1] {
                    let cell = [
                        (home[0] + dx) % side,
                        (home[1] + dy) % side,
                        (home[2] + dz) % side,
                    ];
                    for &j in &grid[index(cell)] {
                        let d = box_.minimum_image(&box_.from_fractional(&(fractional[j] - s)));
                        if d.norm() < tolerance && same(i, j) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    };
    (0..n)
        .filter(|&j| {
            let shift = fractional[j] - fractional[0];
            (0..n).all(|i| has_site(i, &(fractional[i] + shift)))
        })
        .count()
}

/// βF/N extrapolated to N → ∞ by a straight line in 1/N, as Polson et
/// al. find it once the ln N/N terms are in (their abstract): the weighted
/// least-squares fit of values at several N.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SizeExtrapolation {
    /// The intercept at 1/N = 0.
    pub value: f64,
    /// Its standard error.
    pub error: f64,
    /// The slope in 1/N.
    pub slope: f64,
    /// χ² of the fit (about the number of sizes less two if the line
    /// fits).
    pub chi_squared: f64,
}

/// The straight line in 1/N through `(n, value, error)` at two or more
/// sizes (None for fewer, or errors that are not positive).
pub fn extrapolate_in_size(values: &[(usize, f64, f64)]) -> Option<SizeExtrapolation> {
    if values.len() < 2 || values.iter().any(|v| v.2.is_nan() || v.2 <= 0.0) {
        return None;
    }
    let (mut s, mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(n, y, e) in values {
        let (x, w) = (1.0 / n as f64, 1.0 / (e * e));
        s += w;
        sx += w * x;
        sy += w * y;
        sxx += w * x * x;
        sxy += w * x * y;
    }
    let det = s * sxx - sx * sx;
    if det <= 0.0 {
        return None;
    }
    let value = (sxx * sy - sx * sxy) / det;
    let slope = (s * sxy - sx * sy) / det;
    let chi_squared = (values.iter())
        .map(|&(n, y, e)| ((y - value - slope / n as f64) / e).powi(2))
        .sum();
    Some(SizeExtrapolation {
        value,
        error: (sxx / det).sqrt(),
        slope,
        chi_squared,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::Species;
    use crate::state::crystal::{CrystalSpec, UnitCell, crystal};

    fn lattice(cell: UnitCell, per_cell: usize, species: &[&str]) -> System {
        let species: Vec<Species> = (species.iter())
            .map(|s| Species {
                name: s.to_string(),
                shape: "Sphere(radius: 0.5)".parse().unwrap(),
                rotation: false,
            })
            .collect();
        let n = per_cell * 27;
        let counts: Vec<usize> = match species.len() {
            1 => vec![n],
            _ => vec![n - 1, 1],
        };
        let spec = CrystalSpec {
            cell,
            cells: [3, 3, 3],
            packing_fraction: 0.4,
        };
        crystal(&spec, species, &counts).unwrap()
    }

    /// Exact values on a line in 1/N give its intercept and slope, with
    /// the error of a two-point fit by hand; one size is not enough.
    #[test]
    fn extrapolation_in_size_fits_the_line() {
        let line = |n: usize| 5.9 - 7.0 / n as f64;
        let fit = extrapolate_in_size(&[(100, line(100), 0.01), (400, line(400), 0.01)]).unwrap();
        assert!((fit.value - 5.9).abs() < 1e-12 && (fit.slope + 7.0).abs() < 1e-9);
        assert!(fit.chi_squared < 1e-18);
        // Two points x₁, x₂ of equal error e: σ(a)² = e²(x₁² + x₂²)/(x₁ − x₂)².
        let (x1, x2) = (0.01f64, 0.0025f64);
        let by_hand = 0.01 * (x1 * x1 + x2 * x2).sqrt() / (x1 - x2);
        assert!((fit.error - by_hand).abs() < 1e-12);
        assert!(extrapolate_in_size(&[(100, 1.0, 0.1)]).is_none());
    }

    /// Bravais lattices given by conventional cells map onto themselves by
    /// every body's translation; hcp (two sites per primitive cell) by
    /// half of them; one body of another species leaves the identity only.
    #[test]
    fn lattice_translations_count_the_crystals_symmetry() {
        assert_eq!(
            lattice_translations(&lattice(UnitCell::fcc(), 4, &["a"])),
            108
        );
        assert_eq!(
            lattice_translations(&lattice(UnitCell::bcc(), 2, &["a"])),
            54
        );
        assert_eq!(
            lattice_translations(&lattice(UnitCell::hcp(), 4, &["a"])),
            54
        );
        assert_eq!(
            lattice_translations(&lattice(UnitCell::fcc(), 4, &["a", "b"])),
            1
        );
    }
}
