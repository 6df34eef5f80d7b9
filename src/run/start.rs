//! The first state of a run: a lattice, layers, random insertion, or the
//! last state of another log, checked against the scene.

use std::path::Path;

use nalgebra::{UnitQuaternion, Vector3};
use rand_pcg::Pcg64;

use crate::log::StateRecord;
use crate::log::read::read_log;
use crate::scene::plan::Plan;
use crate::scene::{Scene, Start, ValidScene};
use crate::space::periodic_box::BoxError;
use crate::state::start::{lattice, random_insertion_sized};
use crate::state::{Particle, StateError, System};

use super::*;

/// The first state of a scene.
pub(super) fn start_state(
    scene: &ValidScene,
    plan: &Plan,
    rng: &mut Pcg64,
) -> Result<System, RunError> {
    let species = plan.mc_species();
    let counts: Vec<usize> = plan.species.iter().map(|s| s.count).collect();
    match &scene.start {
        Start::Lattice => match scene.body_sizes() {
            // Sites spaced for each species' largest body, then each body
            // at its own size.
            Some(sizes) => {
                let sites = lattice(scene.periodic_box(), scene.lattice_species(), &counts, rng)?;
                let particles = sites.particles().to_vec();
                System::with_sizes(*sites.periodic_box(), species, particles, sizes)
                    .map_err(|e| RunError::Start(e.into()))
            }
            None => Ok(lattice(scene.periodic_box(), species, &counts, rng)?),
        },
        // Sites spaced for each species' largest body; the bodies keep
        // their sizes as they take their layers' sites.
        Start::Layered(axis) => layered(
            lattice(scene.periodic_box(), scene.lattice_species(), &counts, rng)?,
            species,
            scene.body_sizes(),
            *axis as usize,
        )
        .map_err(|e| RunError::Start(e.into())),
        Start::Random => {
            let n: usize = counts.iter().sum();
            Ok(random_insertion_sized(
                scene.periodic_box(),
                species,
                &counts,
                scene.body_sizes(),
                1000 * n as u64,
                rng,
            )?)
        }
        Start::Resume(path) => resumed_start(path, plan),
        Start::Crystal { .. } => {
            let crystal = (scene.crystal())
                .expect("a Crystal start")
                .map_err(|e| RunError::Start(e.into()))?;
            let built = match scene.body_sizes() {
                Some(sizes) => {
                    crate::state::crystal::crystal_sized(&crystal, species, &counts, sizes)
                }
                None => crate::state::crystal::crystal(&crystal, species, &counts),
            };
            Ok(built.map_err(|e| RunError::Start(e.into()))?)
        }
    }
}

/// The species of a lattice start put in layers along `axis`: the sites
/// sorted by that coordinate, the first species on the lowest; `species`
/// and `sizes` (one per body, in species order) those of the bodies.
pub(super) fn layered(
    system: System,
    species: Vec<crate::state::Species>,
    sizes: Option<Vec<f64>>,
    axis: usize,
) -> Result<System, StateError> {
    let mut sites: Vec<Particle> = system.particles().to_vec();
    sites.sort_by(|a, b| a.position[axis].total_cmp(&b.position[axis]));
    let mut kinds: Vec<u16> = system.particles().iter().map(|p| p.species).collect();
    kinds.sort_unstable();
    // Aligned bodies stay aligned (the lattice chose the orientations for
    // its spacing); a body takes the orientation of its new site's species
    // only when orientations are random, which any site allows.
    for (p, k) in sites.iter_mut().zip(kinds) {
        p.species = k;
    }
    match sizes {
        Some(sizes) => System::with_sizes(*system.periodic_box(), species, sites, sizes),
        None => System::new(*system.periodic_box(), species, sites),
    }
}

/// Whether the scene's start can be made before anything runs: a
/// `Resume` start's log is read and its last state checked against the
/// scene (what `run` would refuse, `check` refuses too).
pub fn check_start(scene: &ValidScene) -> Result<(), RunError> {
    if let Start::Resume(path) = &scene.start {
        let plan = Plan::of(scene);
        resumed_start(path, &plan)?;
    }
    Ok(())
}

/// The system of the last intact state of the log at `path`.
pub(super) fn resumed_start(path: &str, plan: &Plan) -> Result<System, RunError> {
    let contents = read_log(Path::new(path), false).map_err(|e| RunError::Resume(e.to_string()))?;
    let (_, record) = contents.last_state.ok_or_else(|| {
        RunError::Resume(match &contents.damage {
            Some(d) => format!("{path} holds no complete state before its damage ({d})"),
            None => format!("{path} holds no complete state"),
        })
    })?;
    // Whether the frame holds grown bodies is decided by the scene that
    // wrote it, whose stages are not this scene's (a log whose scene cannot
    // be read has only its jam stages' frames taken as grown).
    let logged = contents
        .metadata
        .get("scene_resolved")
        .and_then(|text| Scene::parse(text).ok());
    let logged_first_jam = logged.as_ref().and_then(|s| s.first_jam());
    // Grown bodies are this scene's only if they were grown from its
    // species: any species would otherwise fit them by some factor.
    let grown = record.stage == "jam" || logged_first_jam.is_some_and(|j| j <= record.stage_index);
    if grown && let Some(logged) = &logged {
        let theirs: Vec<String> = (logged.species.iter())
            .map(|s| format!("{} {}", s.name, s.shape))
            .collect();
        let ours: Vec<String> = (plan.mc_species().iter())
            .map(|s| format!("{} {}", s.name, s.shape))
            .collect();
        if theirs != ours {
            return Err(RunError::Resume(format!(
                "{path}: its bodies were grown from the species ({}), this scene's are ({}): a grown state goes on only with the species it was grown from",
                theirs.join(", "),
                ours.join(", ")
            )));
        }
    }
    system_from_logged(&record, logged_first_jam, plan)
        .map_err(|e| RunError::Resume(format!("{path}: {e}")))
}

/// Why a logged state cannot be this scene's state.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordError {
    /// A tilted box where the scene has walls.
    #[error(
        "the logged box is tilted {0:?}, and walls close an orthorhombic box only: resume it without walls"
    )]
    TiltedWithWalls([f64; 3]),
    /// Other species (names or shapes) than the scene's.
    #[error("the logged species ({logged}) differ from the scene's ({scene})")]
    Species {
        /// The log's, as "name shape, ...".
        logged: String,
        /// The scene's.
        scene: String,
    },
    /// Other particle counts per species.
    #[error("the logged particle counts per species {logged:?} differ from the scene's {scene:?}")]
    Counts {
        /// The log's.
        logged: Vec<usize>,
        /// The scene's.
        scene: Vec<usize>,
    },
    /// Positions or orientations missing.
    #[error(
        "the logged state has {positions} positions and {orientations} orientations for {particles} particles"
    )]
    Lengths {
        /// Positions given.
        positions: usize,
        /// Orientations given.
        orientations: usize,
        /// Particles.
        particles: usize,
    },
    /// Sizes in the log and none in the scene, or the other way round.
    #[error("{0}")]
    Sizes(&'static str),
    /// A box that cannot be.
    #[error("logged box: {0}")]
    Box(#[from] BoxError),
    /// The particles overlap, or lie outside the walls.
    #[error("logged state: {0}")]
    State(#[from] StateError),
}

/// A system from a logged state, checked against the scene's species: the
/// frames of a jam stage and of the stages after it hold them grown, all by
/// one factor, and their touching pairs to round-off (as the dynamics
/// hands them on).
pub fn system_from_record(record: &StateRecord, plan: &Plan) -> Result<System, RecordError> {
    system_from_logged(record, plan.first_jam, plan)
}

/// [`system_from_record`] for a frame written by a scene whose first jam
/// stage is `first_jam` (another log's, for a `Resume` start).
fn system_from_logged(
    record: &StateRecord,
    first_jam: Option<usize>,
    plan: &Plan,
) -> Result<System, RecordError> {
    let grown = record.stage == "jam" || first_jam.is_some_and(|j| j <= record.stage_index);
    let mut species = plan.mc_species();
    let factor = record
        .species
        .first()
        .zip(species.first())
        .map_or(1.0, |(r, s)| {
            r.shape.bounding_radius() / s.shape.bounding_radius()
        });
    let same = record.species.len() == species.len()
        && record.species.iter().zip(&species).all(|(r, s)| {
            r.name == s.name
                && if grown {
                    let scaled = s.shape.scaled(factor);
                    r.shape.kind() == s.shape.kind()
                        && (r.shape.bounding_radius() - scaled.bounding_radius()).abs()
                            <= 1e-12 * scaled.bounding_radius()
                        && (r.shape.obb_half_extents() - scaled.obb_half_extents()).norm()
                            <= 1e-12 * scaled.bounding_radius()
                } else {
                    r.shape == s.shape
                }
        });
    if grown && same {
        for (s, r) in species.iter_mut().zip(&record.species) {
            s.shape = r.shape;
        }
    }
    if !same {
        let list = |named: Vec<String>| named.join(", ");
        return Err(RecordError::Species {
            logged: list(
                record
                    .species
                    .iter()
                    .map(|s| format!("{} {}", s.name, s.shape))
                    .collect(),
            ),
            scene: list(
                species
                    .iter()
                    .map(|s| format!("{} {}", s.name, s.shape))
                    .collect(),
            ),
        });
    }
    let logged: Vec<usize> = (0..plan.species.len())
        .map(|k| {
            record
                .species_of
                .iter()
                .filter(|&&x| x as usize == k)
                .count()
        })
        .collect();
    let wanted: Vec<usize> = plan.species.iter().map(|s| s.count).collect();
    if logged != wanted {
        return Err(RecordError::Counts {
            logged,
            scene: wanted,
        });
    }
    let polydisperse = plan.species.iter().any(|s| s.polydisperse);
    if polydisperse != record.sizes.is_some() {
        return Err(RecordError::Sizes(match polydisperse {
            true => {
                "the logged bodies have their species' sizes, and the scene gives sizes: resume a polydisperse log, or leave `sizes` out"
            }
            false => {
                "the logged bodies have sizes of their own, and the scene gives none: give the species the `sizes` that made the log"
            }
        }));
    }
    let n = record.species_of.len();
    if record.positions.len() != n || record.orientations.len() != n {
        return Err(RecordError::Lengths {
            positions: record.positions.len(),
            orientations: record.orientations.len(),
            particles: n,
        });
    }
    let box_ = record.periodic_box(plan.walls).map_err(|e| match e {
        BoxError::TiltedWithWalls { tilts, .. } => RecordError::TiltedWithWalls(tilts),
        e => e.into(),
    })?;
    let particles = record
        .positions
        .iter()
        .zip(&record.orientations)
        .zip(&record.species_of)
        .map(|((p, q), &s)| Particle {
            position: Vector3::from(*p),
            orientation: UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
                q[0], q[1], q[2], q[3],
            )),
            species: s,
        })
        .collect::<Vec<Particle>>();
    if !grown {
        return Ok(match &record.sizes {
            Some(sizes) => System::with_sizes(box_, species, particles, sizes.clone())?,
            None => System::new(box_, species, particles)?,
        });
    }
    Ok(System::with_touching(
        box_,
        species,
        particles,
        record.sizes.clone(),
        JAM_FRAME_TOUCHING,
    )?)
}

/// How deep (relative to the smaller body's smallest half-extent) pairs
/// of a jammed frame may touch: the dynamics' default contact tolerance
/// (a jam frame is certified finer than that).
const JAM_FRAME_TOUCHING: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_layered_start_puts_the_species_in_order_along_the_axis() {
        let scene = Scene::parse(
            r#"Scene(box: (20.0, 6.0, 6.0), walls: [X],
                species: [Species(name: "a", shape: Sphere(radius: 0.4), count: 60),
                          Species(name: "b", shape: Ellipsoid(a: 0.4, b: 0.3, c: 0.3), count: 40)],
                start: Layered(X), stages: [Dynamics(duration: 1.0)])"#,
        )
        .unwrap();
        let plan = Plan::of(&scene);
        let system = start_state(&scene, &plan, &mut Pcg64::seed_from_u64(1)).unwrap();
        let x = |k: u16| {
            system
                .particles()
                .iter()
                .filter(move |p| p.species == k)
                .map(|p| p.position.x)
        };
        let a_max = x(0).fold(f64::NEG_INFINITY, f64::max);
        let b_min = x(1).fold(f64::INFINITY, f64::min);
        assert!(a_max <= b_min, "{a_max} > {b_min}");
        assert_eq!(x(0).count(), 60);
        assert_eq!(system.periodic_box().walls(), [true, false, false]);
        assert_eq!(system.first_wall_overlap(), None);
    }
}
