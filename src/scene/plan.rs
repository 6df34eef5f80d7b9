//! The plan: what a scene simulates and what it leaves out, decided once
//! from the scene, with the reason for each choice (`hardbody check`
//! prints it). Nothing the plan leaves out costs time: only the pair kernels
//! of species pairs present are ever called, bodies that cannot turn are
//! never rotated, observables are computed only when switched on.

use std::fmt;

use crate::mc::box_moves::BoxMoves;

use super::{Ensemble, Neighbours, Stage, Start, ValidScene};
use crate::analysis::order::molecular_axis;
use crate::geometry::pair::{contact_sum, kernel_names};
use crate::mc::tuning::TuningSpan;
use crate::number::Num;
use crate::state::start::lattice_plan;
use crate::state::{NeighbourPlan, Species};

/// One species as simulated.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeciesPlan {
    /// The species as the drivers take it.
    pub species: Species,
    /// Number of particles.
    pub count: usize,
    /// Mass.
    pub mass: f64,
    /// Why it turns or not.
    pub rotation_reason: &'static str,
    /// Whether its bodies have sizes of their own (`sizes` in the scene).
    pub polydisperse: bool,
}

/// The kernels of one pair of species.
#[derive(Debug, Clone, PartialEq)]
pub struct PairPlan {
    /// Species indices (a ≤ b).
    pub species: (usize, usize),
    /// Overlap test (Monte Carlo).
    pub overlap: &'static str,
    /// Signed distance (EDMD collisions).
    pub distance: &'static str,
    /// Contact-time prediction (EDMD).
    pub prediction: &'static str,
}

/// Everything the scene switches on, with reasons.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Species, in scene order.
    pub species: Vec<SpeciesPlan>,
    /// Every unordered pair of species present.
    pub pairs: Vec<PairPlan>,
    /// Monte Carlo neighbour structure.
    pub mc_neighbours: NeighbourPlan,
    /// S₂ in `/stats`: only when some species is anisotropic and turns.
    pub nematic_order: bool,
    /// Whether any stage is Monte Carlo / Dynamics.
    pub has_mc: bool,
    /// See `has_mc`.
    pub has_dynamics: bool,
    /// Whether any Dynamics stage asks for the MSD / C₂.
    pub msd: bool,
    /// See `msd`.
    pub c2: bool,
    /// Per axis: hard walls (true) or periodic.
    pub walls: [bool; 3],
    /// The dynamics' neighbour structure, as the scene asks.
    pub neighbours: Neighbours,
    /// Per dynamics stage (its index): the shell of its neighbour lists
    /// (`Some(None)`: cells), where the packing fraction it starts at is
    /// known before running; `None` where it is not (after an NPT stage,
    /// or from a resumed state) and the choice depends on it (spheres get
    /// cells below φ = [`crate::edmd::dynamics::SPHERE_LISTS_FROM`], or
    /// [`crate::edmd::dynamics::POLYDISPERSE_SPHERE_LISTS_FROM`]).
    pub dynamics_shells: Vec<(usize, Option<Option<f64>>)>,
    /// Whether a lattice start orients the bodies at random (`Some(true)`)
    /// or aligns them with the box because its sites are closer than a
    /// bounding diameter (`Some(false)`); `None` for other starts.
    pub random_orientations: Option<bool>,
    /// The first jam stage: from it on the bodies are the species grown
    /// (all by one factor), not the scene's.
    pub first_jam: Option<usize>,
    /// Each stage's index and kind (`Stage::kind`).
    pub stage_kinds: Vec<(usize, &'static str)>,
}

impl Plan {
    /// The plan of a validated scene.
    pub fn of(scene: &ValidScene) -> Plan {
        let species: Vec<SpeciesPlan> = scene
            .mc_species()
            .into_iter()
            .zip(&scene.species)
            .map(|(species, s)| {
                let rotation_reason = if s.shape.is_sphere() {
                    "a sphere: orientation is irrelevant, never rotated"
                } else if !s.rotation {
                    "rotation: false, orientations frozen"
                } else {
                    "anisotropic: rotation moves and free rotation"
                };
                SpeciesPlan {
                    species,
                    count: s.count,
                    mass: s.mass,
                    rotation_reason,
                    polydisperse: s.sizes.is_some(),
                }
            })
            .collect();
        let mut pairs = Vec::new();
        for a in 0..species.len() {
            for b in a..species.len() {
                let (sa, sb) = (&species[a].species.shape, &species[b].species.shape);
                let (overlap, distance) = kernel_names(sa, sb);
                let prediction = if contact_sum(sa, sb).is_some() {
                    "closed form (quadratic in time)"
                } else {
                    "bracketing on the distance with the rate bound, grazing search, safeguarded root"
                };
                pairs.push(PairPlan {
                    species: (a, b),
                    overlap,
                    distance,
                    prediction,
                });
            }
        }
        let mc_species: Vec<Species> = species.iter().map(|s| s.species.clone()).collect();
        let nematic_order = species
            .iter()
            .any(|s| s.species.rotation && molecular_axis(&s.species.shape).is_some());
        let has_mc = scene
            .stages
            .iter()
            .any(|s| !matches!(s, Stage::Dynamics { .. } | Stage::Jam { .. }));
        let has_dynamics = scene
            .stages
            .iter()
            .any(|s| matches!(s, Stage::Dynamics { .. } | Stage::Jam { .. }));
        let asks = |f: fn(&Stage) -> bool| scene.stages.iter().any(f);
        let first_jam = scene.first_jam();
        Plan {
            mc_neighbours: NeighbourPlan::for_species(&mc_species),
            species,
            pairs,
            nematic_order,
            has_mc,
            has_dynamics,
            msd: asks(|s| matches!(s, Stage::Dynamics { msd: true, .. })),
            c2: asks(|s| matches!(s, Stage::Dynamics { c2: true, .. })),
            walls: scene.wall_axes(),
            neighbours: scene.accuracy.neighbours,
            dynamics_shells: scene
                .stages
                .iter()
                .enumerate()
                .filter(|(_, s)| matches!(s, Stage::Dynamics { .. }))
                .map(|(i, _)| {
                    let grown = first_jam.is_some_and(|j| j < i);
                    let shell = match scene.packing_fraction_before(i) {
                        // The automatic choice follows the bodies' size,
                        // which a jam stage before changes.
                        _ if grown && scene.accuracy.neighbours == Neighbours::Auto => None,
                        Some(phi) => Some(scene.neighbour_shell(phi)),
                        // Known all the same where the choice does not depend
                        // on it (all but the automatic choice for spheres).
                        None => {
                            let (dilute, dense) =
                                (scene.neighbour_shell(0.0), scene.neighbour_shell(1.0));
                            (dilute == dense).then_some(dense)
                        }
                    };
                    (i, shell)
                })
                .collect(),
            random_orientations: match scene.start {
                Start::Lattice | Start::Layered(_) => Some(
                    lattice_plan(
                        &scene.box_vector(),
                        &scene.lattice_species(),
                        scene.particle_count(),
                    )
                    .random_orientations,
                ),
                Start::Random => Some(true),
                Start::Resume(_) | Start::Crystal { .. } => None,
            },
            first_jam,
            stage_kinds: scene.stages.iter().map(Stage::kind).enumerate().collect(),
        }
    }

    /// The species as the drivers take them.
    pub fn mc_species(&self) -> Vec<Species> {
        self.species.iter().map(|s| s.species.clone()).collect()
    }

    /// Masses per species.
    pub fn masses(&self) -> Vec<f64> {
        self.species.iter().map(|s| s.mass).collect()
    }

    /// The plan as data (`hardbody check --json`). Each stage's entry is
    /// what a run records of that stage as its driver built it (the log's
    /// `hardbody.stage` metadata), where the plan can know it before
    /// running: Monte Carlo stages their neighbour structure, dynamics
    /// stages theirs (`"decided at the stage's start"` where it depends on
    /// a packing fraction only the run will know).
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let species: Vec<_> = self
            .species
            .iter()
            .map(|s| {
                json!({
                    "name": s.species.name,
                    "shape": s.species.shape.to_string(),
                    "count": s.count,
                    "mass": s.mass,
                    "rotation": s.species.rotation,
                    "rotation_reason": s.rotation_reason,
                })
            })
            .collect();
        let pairs: Vec<_> = self
            .pairs
            .iter()
            .map(|p| {
                json!({
                    "species": [p.species.0, p.species.1],
                    "overlap": p.overlap,
                    "distance": p.distance,
                    "prediction": p.prediction,
                })
            })
            .collect();
        let stages: Vec<_> = (self.stage_kinds.iter())
            .map(|&(index, kind)| {
                let built = match kind {
                    "dynamics" => match self.dynamics_shells.iter().find(|(i, _)| *i == index) {
                        Some((_, Some(shell))) => StageBuild::Dynamics(*shell),
                        _ => StageBuild::DynamicsUndecided,
                    },
                    "jam" => StageBuild::Jam,
                    _ => StageBuild::MonteCarlo(&self.mc_neighbours),
                };
                stage_entry(index, kind, built)
            })
            .collect();
        json!({
            "species": species,
            "pairs": pairs,
            "walls": self.walls,
            "nematic_order": self.nematic_order,
            "msd": self.msd,
            "c2": self.c2,
            "random_orientations": self.random_orientations,
            "first_jam": self.first_jam,
            "stages": stages,
        })
    }
}

/// What a stage's driver is built with, as the plan and a run's record of
/// the stage both state it.
#[derive(Debug, Clone, Copy)]
pub enum StageBuild<'a> {
    /// Monte Carlo sweeps (or a compression) on these neighbours.
    MonteCarlo(&'a NeighbourPlan),
    /// Dynamics on neighbour lists of this shell (`None`: on cells).
    Dynamics(Option<f64>),
    /// Dynamics whose neighbours depend on a packing fraction only the run
    /// will know (the plan's word for it).
    DynamicsUndecided,
    /// A jam, whose chunks choose their neighbours as they grow.
    Jam,
}

/// Stage `index` (of kind `kind`, `Stage::kind`) built as `built`, as data:
/// `stage`, `kind`, and `mc_neighbours` or `neighbours`. The plan's
/// entries and a run's records are both made here.
pub fn stage_entry(index: usize, kind: &str, built: StageBuild) -> serde_json::Value {
    let mut entry = serde_json::json!({ "stage": index, "kind": kind });
    match built {
        StageBuild::MonteCarlo(n) => entry["mc_neighbours"] = mc_neighbours_json(n),
        StageBuild::Dynamics(shell) => entry["neighbours"] = dynamics_neighbours_json(shell),
        StageBuild::DynamicsUndecided => {
            entry["neighbours"] = serde_json::json!("decided at the stage's start")
        }
        StageBuild::Jam => {}
    }
    entry
}

/// A Monte Carlo neighbour structure as data.
fn mc_neighbours_json(n: &NeighbourPlan) -> serde_json::Value {
    let structure = if n.per_species {
        "a grid per species"
    } else if n.aabb_cells {
        "cells of bounding boxes"
    } else {
        "cells"
    };
    serde_json::json!({
        "structure": structure,
        "aabb_width": n.aabb_cells.then_some(n.aabb_width),
        "sphere_skin": n.sphere_skin,
        "capsule_pad": n.capsule_pad,
    })
}

/// A dynamics neighbour structure as data (`shell`: the lists' shell, or
/// `None` for cells).
fn dynamics_neighbours_json(shell: Option<f64>) -> serde_json::Value {
    match shell {
        None => serde_json::json!({ "structure": "cells" }),
        Some(shell) => serde_json::json!({ "structure": "lists", "shell": shell }),
    }
}

/// The plan and the stages of a scene, as `hardbody check` prints them.
pub struct Report<'a> {
    /// The scene.
    pub scene: &'a ValidScene,
    /// Its plan.
    pub plan: &'a Plan,
}

impl fmt::Display for Report<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (scene, plan) = (self.scene, self.plan);
        let box_ = scene.periodic_box();
        let (l, t) = (box_.lengths(), box_.tilts());
        writeln!(
            f,
            "scene: {} particles of {} species in a box {} x {} x {}{} {} (packing fraction {:.4}), seed {}",
            scene.particle_count(),
            scene.species.len(),
            Num(l.x),
            Num(l.y),
            Num(l.z),
            if box_.is_tilted() {
                format!(" tilted ({}, {}, {})", Num(t.x), Num(t.y), Num(t.z))
            } else {
                String::new()
            },
            match plan.walls {
                [false, false, false] => "periodic in x, y, z".to_string(),
                [true, true, true] => "closed by hard walls in x, y, z".to_string(),
                w => {
                    let axes = |walled: bool| {
                        ["x", "y", "z"]
                            .iter()
                            .zip(w)
                            .filter(|(_, x)| *x == walled)
                            .map(|(a, _)| *a)
                            .collect::<Vec<_>>()
                            .join(", ")
                    };
                    format!("periodic in {}, walled in {}", axes(false), axes(true))
                }
            },
            Num(scene.particle_volume() / box_.volume()),
            scene.seed
        )?;
        writeln!(f, "species:")?;
        let sizes = scene.body_sizes();
        let mut first = 0;
        for (s, spec) in plan.species.iter().zip(&scene.species) {
            writeln!(
                f,
                "  {} x{}: {} (mass {}); {}",
                s.species.name,
                s.count,
                s.species.shape,
                Num(s.mass),
                s.rotation_reason
            )?;
            if let (Some(sizes), Some(spread)) = (&sizes, &spec.sizes) {
                let own = &sizes[first..first + s.count];
                let low = own.iter().copied().fold(f64::INFINITY, f64::min);
                let high = own.iter().copied().fold(0.0, f64::max);
                let mean = own.iter().sum::<f64>() / s.count as f64;
                let variance = own.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / s.count as f64;
                writeln!(
                    f,
                    "    sizes {} (scale factors of the shape, drawn from the seed): {low:.4} to {high:.4}, mean {mean:.4}, standard deviation {:.4}",
                    ron::to_string(spread).unwrap_or_default(),
                    variance.sqrt()
                )?;
            }
            first += s.count;
        }
        writeln!(f, "pair kernels (only the pairs present):")?;
        for p in &plan.pairs {
            let (a, b) = p.species;
            writeln!(
                f,
                "  {} / {}: overlap {}; distance {}",
                plan.species[a].species.name, plan.species[b].species.name, p.overlap, p.distance
            )?;
            if plan.has_dynamics {
                writeln!(f, "      contact time: {}", p.prediction)?;
            }
        }
        writeln!(f, "effects:")?;
        let walls = scene.wall_axes();
        if walls.iter().any(|&w| w) {
            let names: Vec<&str> = ["x", "y", "z"]
                .iter()
                .zip(walls)
                .filter(|(_, w)| *w)
                .map(|(n, _)| *n)
                .collect();
            writeln!(
                f,
                "  walls: hard walls at -L/2 and L/2 along {} (no periodic image there); pressure in dynamics from the momentum the walls take; no SDF pressure in NVT Monte Carlo",
                names.join(", ")
            )?;
        } else {
            writeln!(
                f,
                "  walls: none, periodic in x, y, z (walls: [] in the scene)"
            )?;
        }
        if plan.has_mc {
            let n = &plan.mc_neighbours;
            let why = match (n.elongated, n.size_asymmetric) {
                (_, true) => "the species differ in size by more than 2:1",
                (true, false) => "some species is elongated or flat",
                _ => "near-isotropic species of similar size",
            };
            if n.per_species {
                writeln!(
                    f,
                    "  Monte Carlo neighbours: one grid per species, each as wide as that species' bounding diameter ({why})"
                )?;
            } else if n.aabb_cells {
                writeln!(
                    f,
                    "  Monte Carlo neighbours: cells of width {:.4} holding bounding boxes ({why}), oriented-box pre-filter",
                    Num(n.aabb_width)
                )?;
                if let Some(pad) = n.capsule_pad.map(Num) {
                    writeln!(
                        f,
                        "  Monte Carlo neighbours: Verlet lists over bounding capsules padded by {pad:.4} while the box stays put and the moves are short (root-mean-square shift of a capsule's end under half the pad)"
                    )?;
                }
            } else if let Some(skin) = n.sphere_skin.map(Num) {
                writeln!(
                    f,
                    "  Monte Carlo neighbours: cells as wide as the interaction range; Verlet lists with a skin of {skin:.4} (spheres) while the box stays put and the moves are short (root-mean-square step under a quarter skin)"
                )?;
            } else {
                writeln!(
                    f,
                    "  Monte Carlo neighbours: cells as wide as the interaction range, 27-cell stencil ({why})"
                )?;
            }
        }
        if plan.has_mc {
            let n: usize = plan.species.iter().map(|s| s.count).sum();
            if crate::mc::parallel::sweeps_on_slabs(n) {
                let how = if plan.species.iter().all(|s| s.species.shape.is_sphere()) {
                    "the threads share one system where the slabs are wide enough (3.5 diameters for spheres of one size), else keep a replica each"
                } else {
                    "each thread keeps a replica"
                };
                writeln!(
                    f,
                    "  Monte Carlo sweeps: on slabs, in parallel on {} threads (N = {n} >= {}; {how}; the same trajectory on one thread or two; RAYON_NUM_THREADS sets the threads)",
                    rayon::current_num_threads(),
                    crate::mc::parallel::SLABS_FROM
                )?;
            } else {
                writeln!(
                    f,
                    "  Monte Carlo sweeps: serial (N = {n} < {})",
                    crate::mc::parallel::SLABS_FROM
                )?;
            }
        }
        if plan.has_dynamics {
            let spheres = plan.species.iter().all(|s| s.species.shape.is_sphere());
            let why = if plan.neighbours == Neighbours::Auto {
                "automatic: oriented boxes grown at phi = 0.5 by a tenth of the thinnest body's thickness times the square root of the largest elongation, wider as the free path between collisions grows (1.76x at phi = 0.3, 6.5x at phi = 0.1); for spheres bounding spheres grown by a quarter of the diameter, and cells instead when the stage starts below phi = 0.45 (0.3 for polydisperse spheres); accuracy.neighbours: Cells or Lists(shell: ...) to choose"
            } else {
                "accuracy.neighbours"
            };
            for (index, shell) in &plan.dynamics_shells {
                let what = match shell.map(|s| s.map(Num)) {
                    Some(None) => "linked cells with cell-crossing events".to_string(),
                    Some(Some(shell)) if spheres => format!(
                        "lists of the bodies whose bounding spheres grown by {shell:.4} overlap, rebuilt when a centre has moved {shell:.4}"
                    ),
                    Some(Some(shell)) => format!(
                        "lists of the bodies whose oriented bounding boxes grown by {shell:.4} overlap, rebuilt when a body is about to leave its box"
                    ),
                    None if spheres => format!(
                        "decided when the stage starts: linked cells below phi = {}, above it lists of the bodies whose bounding spheres grown by a quarter of the diameter overlap (the packing fraction it starts at is not known before running)",
                        if plan.species.iter().any(|s| s.polydisperse) {
                            crate::edmd::dynamics::POLYDISPERSE_SPHERE_LISTS_FROM
                        } else {
                            crate::edmd::dynamics::SPHERE_LISTS_FROM
                        }
                    ),
                    None => "decided when the stage starts: lists of the bodies whose oriented bounding boxes grown by a shell that follows the packing fraction overlap (the packing fraction it starts at is not known before running)".to_string(),
                };
                writeln!(f, "  dynamics neighbours, stage {index}: {what} ({why})")?;
            }
            let turning = plan.species.iter().any(|s| s.species.rotation);
            writeln!(
                f,
                "  free rotation: {}",
                if turning {
                    "for the species that turn"
                } else {
                    "none (no species turns)"
                }
            )?;
        }
        writeln!(
            f,
            "  nematic order S2: {}",
            if plan.nematic_order {
                "on (a species with a molecular axis turns)"
            } else if plan.species.iter().any(|s| s.species.rotation) {
                "off (no turning species has a molecular axis: spheres, cubes and bodies with three equal extents have none)"
            } else {
                "off (no species turns)"
            }
        )?;
        writeln!(
            f,
            "  mean-squared displacement: {}; C2(t): {}",
            if plan.msd {
                "on"
            } else {
                "off (msd: true asks)"
            },
            if plan.c2 { "on" } else { "off (c2: true asks)" }
        )?;
        let orientations = match plan.random_orientations {
            Some(false) => {
                "bodies aligned with the box axes (the sites are closer than a bounding diameter)"
            }
            _ => "random orientations",
        };
        writeln!(
            f,
            "start: {}",
            match &scene.start {
                Start::Lattice => format!("lattice filling the box, {orientations}"),
                Start::Random => "random insertion, random orientations".to_string(),
                Start::Resume(p) => format!("the last state in {p}"),
                Start::Layered(a) => format!(
                    "lattice filling the box, species in layers along {a:?} in scene order, {orientations}"
                ),
                Start::Crystal {
                    lattice,
                    cells,
                    packing_fraction,
                } => format!(
                    "crystal: {} cells of {} at packing fraction {}, the supercell is the box",
                    format_args!("{} x {} x {}", cells.0, cells.1, cells.2),
                    match lattice {
                        crate::scene::space::Lattice::Custom { basis, .. } =>
                            format!("a custom lattice ({} sites per cell)", basis.len()),
                        other => format!("{other:?}"),
                    },
                    Num(*packing_fraction)
                ),
            }
        )?;
        writeln!(f, "stages:")?;
        for (i, s) in scene.stages.iter().enumerate() {
            let text = match s {
                Stage::Compress {
                    packing_fraction,
                    pressure,
                    max_sweeps,
                    until_jammed,
                } => {
                    let target = match (packing_fraction, pressure) {
                        (Some(phi), _) if *until_jammed => {
                            format!("packing fraction {}, or to the jam short of it", Num(*phi))
                        }
                        (Some(phi), _) => format!("packing fraction {}", Num(*phi)),
                        (None, p) => format!(
                            "the packing fraction of betaP = {} (measured by the scale distribution, within 3 %)",
                            Num(p.unwrap_or(f64::NAN))
                        ),
                    };
                    format!(
                        "compress to {target} (at most {} sweeps)",
                        max_sweeps.unwrap_or(super::DEFAULT_COMPRESS_SWEEPS)
                    )
                }
                Stage::MonteCarlo {
                    ensemble,
                    sweeps,
                    tune_sweeps,
                    pressure_tensor,
                    swaps,
                } => {
                    let e = match ensemble {
                        Ensemble::Nvt => {
                            "NVT, pressure from the scale distribution function".to_string()
                        }
                        Ensemble::Npt { pressure, .. } => format!(
                            "NPT at betaP = {}, {} box moves",
                            Num(*pressure),
                            match ensemble.box_moves() {
                                Some(BoxMoves::Axes) => "per-axis",
                                Some(BoxMoves::Triclinic) => "per-axis and shear (triclinic)",
                                _ => "isotropic",
                            }
                        ),
                    };
                    let tuned = match s.tuning_span() {
                        Some(TuningSpan::UntilSettled { at_least, .. }) => format!(
                            "move sizes tuned over the first {at_least} and on until the density settles, then frozen"
                        ),
                        _ => format!(
                            "move sizes tuned over the first {}, then frozen",
                            tune_sweeps.unwrap_or(sweeps / 5)
                        ),
                    };
                    let tensor = if *pressure_tensor {
                        "; the pressure tensor from the scale distribution"
                    } else {
                        ""
                    };
                    let swapped = if *swaps > 0.0 {
                        format!(
                            "; {} size swaps per body per sweep (sweeps serial)",
                            Num(*swaps)
                        )
                    } else {
                        String::new()
                    };
                    format!("Monte Carlo, {e}, {sweeps} sweeps ({tuned}){tensor}{swapped}")
                }
                Stage::Jam {
                    growth_rate,
                    fluid_rate,
                    pressure,
                    packing_fraction,
                } => {
                    let rate = growth_rate.unwrap_or(crate::edmd::jam::DEFAULT_GROWTH_RATE);
                    let packing = packing_fraction
                        .map(|phi| format!(" or the packing fraction reaches {}", Num(phi)))
                        .unwrap_or_default();
                    let fluid = fluid_rate
                        .map(|f| {
                            format!(
                                " ({f:e} until betaPV/N = {:e})",
                                crate::edmd::jam::SETTLE_FROM
                            )
                        })
                        .unwrap_or_default();
                    format!(
                        "jam by event-driven growth: sizes grow at {rate:e} per unit time{fluid} at kT = 1, until betaPV/N passes {:e}{packing}",
                        pressure.unwrap_or(crate::edmd::jam::DEFAULT_JAM_PRESSURE)
                    )
                }
                Stage::Dynamics {
                    duration,
                    temperature,
                    true_inertia,
                    c2,
                    ..
                } => {
                    let turning = scene
                        .species
                        .iter()
                        .any(|s| s.rotation && !s.shape.is_sphere());
                    format!(
                        "event-driven dynamics for t = {} at kT = {}, {}{}",
                        Num(*duration),
                        Num(*temperature),
                        if *true_inertia {
                            "bodies turning with their own inertia tensors"
                        } else {
                            "bodies turning as spherical tops with their mean moment"
                        },
                        if *c2 && turning && !*true_inertia {
                            " (C2 then follows the mean moment: set true_inertia for the bodies' own rotational dynamics)"
                        } else {
                            ""
                        }
                    )
                }
            };
            writeln!(f, "  {i}: {text}")?;
        }
        write!(
            f,
            "log: {} (stats every {} sweeps, frames every {} sweeps in Monte Carlo stages)",
            scene.log.path, scene.log.stats_every, scene.log.frames_every
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    fn scene(species: &str) -> ValidScene {
        Scene::parse(&format!(
            "Scene(box: (20.0, 20.0, 20.0), species: [{species}], stages: [Dynamics(duration: 1.0)])"
        ))
        .unwrap()
    }

    #[test]
    fn spheres_pay_for_no_rotation_and_no_order() {
        let s = scene(r#"Species(name: "s", shape: Sphere(radius: 0.5), count: 10)"#);
        let p = Plan::of(&s);
        assert!(!p.species[0].species.rotation);
        assert!(!p.nematic_order);
        assert_eq!(p.pairs.len(), 1);
        assert!(p.pairs[0].prediction.starts_with("closed form"));
    }

    #[test]
    fn only_present_pairs_and_frozen_species() {
        let s = scene(
            r#"Species(name: "box", shape: Cuboid(a: 1.0, b: 1.0, c: 1.0), count: 4),
               Species(name: "rod", shape: Ellipsoid(a: 1.0, b: 0.5, c: 0.5), count: 4, rotation: false)"#,
        );
        let p = Plan::of(&s);
        assert_eq!(p.pairs.len(), 3);
        assert!(p.species[0].species.rotation);
        assert!(!p.species[1].species.rotation);
        // Cubes have no molecular axis and the rods are frozen.
        assert!(!p.nematic_order);
        let text = Report {
            scene: &s,
            plan: &p,
        }
        .to_string();
        assert!(text.contains("box / rod"), "{text}");
        assert!(!text.contains("OCSI"), "{text}");
    }
}
