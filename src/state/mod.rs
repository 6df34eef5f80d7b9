//! The state both drivers share and hand to each other: the species, the
//! particles, and the validated configuration (box, species, particles)
//! with the neighbour structures that answer its overlap queries. Monte
//! Carlo moves it; the dynamics starts from it and hands one back.
//!
//! - `mod.rs`: species, particles, the configuration's fields, errors;
//! - `system.rs`: construction, validation and what it reports;
//! - `overlap.rs`: the overlap queries (one particle, a trial, the whole);
//! - `neighbours.rs`: which neighbour structure, and its upkeep as
//!   particles move;
//! - `rescale.rs`: box changes, with or without overlaps allowed;
//! - `start.rs`: first states (lattices, random insertion);
//! - `sizes.rs`: polydisperse sizes (the distributions, drawn per body).

pub mod crystal;
pub mod densest;
mod neighbours;
mod overlap;
mod rescale;
pub(crate) mod shared;
pub mod sizes;
pub mod start;
mod system;

use neighbours::aabb_half_extents;
pub use neighbours::{
    CAPSULE_CELLS, CAPSULE_FIT, CAPSULE_PAD, CAPSULE_SLACK, NeighbourPlan, SPHERE_SKIN,
};
pub(crate) use neighbours::{Neighbours, SPHERE_LISTS_REVIEW};

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::geometry::capsule::Capsule;
use crate::geometry::{Placed, Shape};
use crate::space::slots::Slots;
use crate::space::{CapsuleLists, PeriodicBox, SphereLists};

type V3 = Vector3<f64>;

/// A kind of particle.
#[derive(Debug, Clone, PartialEq)]
pub struct Species {
    /// Name, as in the scene.
    pub name: String,
    /// Shape.
    pub shape: Shape,
    /// Whether orientations change (false: frozen; always false for spheres).
    pub rotation: bool,
}

impl Species {
    /// The body axis the nematic order and C₂ follow: the shape's molecular
    /// axis if the species turns, else none (frozen or isotropic bodies
    /// carry no orientational order of their own).
    pub fn order_axis(&self) -> Option<Vector3<f64>> {
        if self.rotation {
            crate::analysis::order::molecular_axis(&self.shape)
        } else {
            None
        }
    }
}

/// One particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Particle {
    /// Centre, in [−L/2, L/2).
    pub position: V3,
    /// Body → lab rotation.
    pub orientation: UnitQuaternion<f64>,
    /// Index into the species list.
    pub species: u16,
}

/// What can go wrong setting up or running Monte Carlo.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateError {
    /// Two particles overlap in a state that must be overlap-free.
    #[error("particles {0} and {1} overlap")]
    Overlap(usize, usize),
    /// A particle touches or crosses a hard wall.
    #[error("particle {0} touches or crosses a hard wall")]
    WallOverlap(usize),
    /// The box is smaller than twice the largest interaction range, so the
    /// minimum image is not unique.
    #[error("box {lengths:?} is smaller than twice the interaction range {range}")]
    BoxTooSmall {
        /// Box edges.
        lengths: [f64; 3],
        /// Largest centre–centre distance at which two particles can touch.
        range: f64,
    },
    /// A particle names a species that does not exist.
    #[error("particle {0} has species {1}, but there are only {2} species")]
    UnknownSpecies(usize, u16, usize),
    /// No particles.
    #[error("the system has no particles")]
    Empty,
    /// Sizes given for another number of particles.
    #[error("{sizes} sizes for {particles} particles")]
    SizesCount {
        /// Sizes given.
        sizes: usize,
        /// Particles.
        particles: usize,
    },
    /// A size that is not finite and positive.
    #[error("particle {0} has size {1}: a size is a finite positive scale factor")]
    BadSize(usize, f64),
}

/// Particles of several species in a periodic box, with a cell list.
#[derive(Debug, Clone)]
pub struct System {
    pub(crate) box_: PeriodicBox,
    pub(crate) species: Vec<Species>,
    /// Written element by element by the members of a team that shares
    /// the system ([`parallel`]), as are the centres, cells and lists.
    pub(crate) particles: Slots<Particle>,
    /// Cached rotation matrices of the orientations.
    pub(crate) rotations: Vec<Matrix3<f64>>,
    /// Bounding radius per species (the largest of its bodies'), and the
    /// largest of all.
    pub(crate) radii: Vec<f64>,
    max_radius: f64,
    /// Bounding radius per body: its species' times its size.
    pub(crate) body_radii: Vec<f64>,
    /// Each body's size, the scale factor of its species' shape (absent:
    /// every body at size 1).
    pub(crate) sizes: Option<Vec<f64>>,
    /// With sizes, each body's shape: its species' scaled by its size
    /// (what every overlap test of it reads).
    pub(crate) body_shapes: Option<Vec<crate::geometry::Shape>>,
    /// Centres, contiguous (the hot loop reads only these); kept equal to
    /// `particles[i].position`.
    pub(crate) positions: Slots<V3>,
    /// OBB half-extents per species.
    obb: Vec<V3>,
    /// Lab-frame AABB half-extents per particle.
    aabb: Vec<V3>,
    /// Each particle's shape as placed (for the lab-frame overlap kernels).
    placed: Vec<Placed>,
    pub(crate) cells: Neighbours,
    /// Which neighbour structure, and why.
    pub(crate) plan: NeighbourPlan,
    /// Largest distance at which two centres can still touch.
    pub(crate) range: f64,
    /// Every species is a sphere: overlap is the distance of centres alone.
    pub(crate) all_spheres: bool,
    /// Spheres on one grid: Verlet lists with a skin answer most moves
    /// (the cells answer the rest), while the box stays put and the moves
    /// are short (see [`System::review_sphere_lists`]).
    pub(crate) sphere_lists: Option<SphereLists>,
    /// Bounding capsule per species, with the body axis it lies along.
    capsules: Vec<(usize, Capsule)>,
    /// Bodies on AABB cells: Verlet lists over their bounding capsules,
    /// on the same terms as the sphere lists.
    capsule_lists: Option<CapsuleLists>,
    /// Accepted moves in this box since the lists were last reviewed, and
    /// the sum of their squared steps.
    pub(crate) list_window: (usize, f64),
    /// Scratch for the centres of a trial box change.
    scaled: Vec<V3>,
    /// Overlap tests switched off (ideal-gas checks only).
    pub(crate) ideal: bool,
    /// An identity of the state (see [`System::stamp`]), renewed when it
    /// is asked for after a change.
    stamp: u64,
    /// The state changed since `stamp` was handed out (a move placed, a
    /// box rescaled): a plain flag, so that the hot path of every accepted
    /// move touches no shared counter.
    pub(crate) changed: bool,
}

/// Stamps handed out so far: each state asked for its stamp after a change
/// takes a new one.
static STAMPS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

fn new_stamp() -> u64 {
    STAMPS.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::moves::{Ensemble, MoveSizes, sweep};
    use rand::SeedableRng;

    /// A refused box change (made in place, then undone) leaves the system
    /// as it was: the same state and stamp, and the sweeps after it those
    /// of a copy that never tried, to the bit (spheres on lists, needles on
    /// capsule lists, cubes on AABB cells, and a mixture on per-species
    /// grids).
    #[test]
    fn a_refused_box_change_leaves_no_trace() {
        let mut systems: Vec<System> = [
            "Sphere(radius: 0.5)",
            "Ellipsoid(a: 1.25, b: 0.25, c: 0.25)",
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
        ]
        .iter()
        .map(|text| crate::bench::mc::dense_start(&text.parse().unwrap(), 400, 0.5).unwrap())
        .collect();
        systems.push(crate::test_support::cubes_among_spheres(
            1.0,
            0.15,
            15.0,
            [40, 280],
            8,
        ));
        let sizes = MoveSizes {
            translate: 0.05,
            rotate: 0.05,
            volume: 0.0,
            shear: 0.01,
        };
        for (k, mut system) in systems.into_iter().enumerate() {
            let mut r1 = rand_pcg::Pcg64::seed_from_u64(k as u64);
            for _ in 0..30 {
                sweep(&mut system, &sizes, &Ensemble::Nvt, &mut r1);
            }
            let stamp = system.stamp();
            let mut untouched = system.clone();
            assert_eq!(untouched.stamp(), stamp);
            let lengths = system.box_.lengths();
            // (The mixture's lattice is loose: halve it.)
            let shrink = if k < 3 { 0.8 } else { 0.5 };
            assert!(
                !system.try_rescale(lengths * shrink),
                "system {k}: accepted"
            );
            assert_eq!(system.stamp(), stamp, "system {k}");
            assert_eq!(system.box_.lengths(), lengths);
            assert!(system.particles() == untouched.particles(), "system {k}");
            let mut r2 = r1.clone();
            for _ in 0..10 {
                sweep(&mut system, &sizes, &Ensemble::Nvt, &mut r1);
                sweep(&mut untouched, &sizes, &Ensemble::Nvt, &mut r2);
            }
            assert!(
                system.particles() == untouched.particles(),
                "system {k}: the sweeps after the refusal part from the copy's"
            );
        }
    }

    /// Sphere lists change no answer: NVT sweeps of dense spheres with
    /// lists (built after four accepted moves per sphere) follow those of
    /// the same system kept on cells alone to the bit, and so do NPT sweeps,
    /// whose box changes the lists go through (rescaled); a refused box
    /// change keeps them too; and long moves drop them.
    #[test]
    fn sphere_lists_change_no_move_and_go_with_the_box() {
        let shape: Shape = "Sphere(radius: 0.5)".parse().unwrap();
        let mut listed = crate::bench::mc::dense_start(&shape, 343, 0.5).unwrap();
        let mut cells = listed.clone();
        cells.plan.sphere_skin = None;
        let sizes = MoveSizes {
            translate: 0.12,
            rotate: 0.0,
            volume: 0.0,
            shear: 0.01,
        };
        let (mut r1, mut r2) = (
            rand_pcg::Pcg64::seed_from_u64(4),
            rand_pcg::Pcg64::seed_from_u64(4),
        );
        for _ in 0..60 {
            sweep(&mut listed, &sizes, &Ensemble::Nvt, &mut r1);
            sweep(&mut cells, &sizes, &Ensemble::Nvt, &mut r2);
        }
        assert!(listed.uses_sphere_lists() && !cells.uses_sphere_lists());
        assert_eq!(listed.positions, cells.positions);
        // NPT at about the pressure of φ = 0.5, box moves of 0.3 % in
        // ln V: about a third of them accepted.
        let npt = Ensemble::Npt {
            pressure: 5.7,
            moves: crate::mc::box_moves::BoxMoves::Isotropic,
        };
        let sizes_npt = MoveSizes {
            volume: 0.003,
            ..sizes
        };
        let mut box_moves = 0;
        for k in 0..60 {
            let c = sweep(&mut listed, &sizes_npt, &npt, &mut r1);
            sweep(&mut cells, &sizes_npt, &npt, &mut r2);
            box_moves += c.volume.accepted;
            assert_eq!(listed.positions, cells.positions, "sweep {k}");
            assert_eq!(listed.box_.lengths(), cells.box_.lengths());
        }
        assert!(box_moves >= 10, "{box_moves} box moves accepted");
        assert!(listed.uses_sphere_lists());
        // Shrinking by a tenth overlaps dense spheres: refused, lists kept.
        assert!(!listed.try_rescale(listed.box_.lengths() * 0.9));
        assert!(listed.uses_sphere_lists());
        assert!(listed.try_rescale(listed.box_.lengths() * 1.01));
        assert!(listed.uses_sphere_lists());
        // Long moves (dilute spheres' tuned ones) would relist at almost
        // every move: the lists go, and stay away.
        let long = MoveSizes {
            translate: 1.0,
            ..sizes
        };
        let mut dilute = crate::bench::mc::dense_start(&shape, 343, 0.2).unwrap();
        for round in 0..2 {
            let sizes = [sizes, long][round];
            for _ in 0..60 {
                sweep(&mut dilute, &sizes, &Ensemble::Nvt, &mut r1);
            }
            assert_eq!(dilute.uses_sphere_lists(), round == 0, "round {round}");
        }
    }

    /// Capsule lists change no answer: NVT sweeps of dense needles with
    /// lists follow those of the same system kept on AABB cells alone to
    /// the bit, through the lists' coming (after four accepted moves per
    /// body), a box change that drops them, their return, and moves too
    /// long for them that drop them again (the cells rebuilt where the
    /// bodies are).
    #[test]
    fn capsule_lists_change_no_move_and_go_with_the_box() {
        let shape: Shape = "Ellipsoid(a: 0.5, b: 0.5, c: 2.5)".parse().unwrap();
        let mut listed = crate::bench::mc::dense_start(&shape, 500, 0.5).unwrap();
        let mut cells = listed.clone();
        assert!(listed.plan.capsule_pad.is_some());
        cells.plan.capsule_pad = None;
        let short = MoveSizes {
            translate: 0.1,
            rotate: 0.04,
            volume: 0.0,
            shear: 0.01,
        };
        let long = MoveSizes {
            translate: 1.5,
            rotate: 0.6,
            volume: 0.0,
            shear: 0.01,
        };
        let (mut r1, mut r2) = (
            rand_pcg::Pcg64::seed_from_u64(4),
            rand_pcg::Pcg64::seed_from_u64(4),
        );
        let mut run = |listed: &mut System, cells: &mut System, sizes: &MoveSizes| {
            for _ in 0..40 {
                let a = sweep(listed, sizes, &Ensemble::Nvt, &mut r1);
                let b = sweep(cells, sizes, &Ensemble::Nvt, &mut r2);
                assert_eq!(format!("{a:?}"), format!("{b:?}"));
            }
            assert_eq!(listed.positions, cells.positions);
            assert_eq!(listed.rotations, cells.rotations);
        };
        run(&mut listed, &mut cells, &short);
        assert!(listed.uses_capsule_lists() && !cells.uses_capsule_lists());
        assert_eq!(listed.first_overlap_all_pairs(), None);
        // Shrinking by a tenth overlaps dense needles: refused, lists kept.
        assert!(!listed.try_rescale(listed.box_.lengths() * 0.9));
        assert!(listed.uses_capsule_lists());
        let grown = listed.box_.lengths() * 1.01;
        assert!(listed.try_rescale(grown) && cells.try_rescale(grown));
        assert!(!listed.uses_capsule_lists());
        run(&mut listed, &mut cells, &short);
        assert!(listed.uses_capsule_lists());
        // Diluted, long moves are accepted: each would relist.
        let dilute = listed.box_.lengths() * 1.4;
        assert!(listed.try_rescale(dilute) && cells.try_rescale(dilute));
        run(&mut listed, &mut cells, &short);
        assert!(listed.uses_capsule_lists());
        run(&mut listed, &mut cells, &long);
        assert!(!listed.uses_capsule_lists());
        run(&mut listed, &mut cells, &short);
        assert_eq!(listed.first_overlap_all_pairs(), None);
    }

    /// Growing one edge, or shearing, can bring bodies that are not
    /// spheres into contact (two parallel needles side by side along the
    /// diagonal, moved closer across their axes): such a box change is
    /// checked and refused; the isotropic growth is accepted unchecked.
    #[test]
    fn one_edge_grown_or_a_shear_can_make_needles_overlap() {
        let species = vec![Species {
            name: "needle".into(),
            shape: "Ellipsoid(a: 2.0, b: 0.3, c: 0.3)".parse().unwrap(),
            rotation: true,
        }];
        let along_diagonal = UnitQuaternion::from_axis_angle(
            &nalgebra::Vector3::z_axis(),
            std::f64::consts::FRAC_PI_4,
        );
        let at = |x: f64, y: f64| Particle {
            position: V3::new(x, y, 0.0),
            orientation: along_diagonal,
            species: 0,
        };
        let box_ = PeriodicBox::new(V3::repeat(12.0)).unwrap();
        let system = System::new(box_, species, vec![at(0.0, 0.0), at(1.3, 0.3)]).unwrap();
        let mut grown = system.clone();
        assert!(!grown.try_rescale(V3::new(12.0, 24.0, 12.0)));
        assert_eq!(grown.particles(), system.particles());
        let mut sheared = system.clone();
        let tilted = box_.with_tilts(V3::new(-0.8, 0.0, 0.0)).unwrap();
        assert!(!sheared.try_change_box(tilted));
        let mut expanded = system.clone();
        assert!(expanded.try_rescale(V3::repeat(24.0)));
        assert_eq!(expanded.first_overlap_all_pairs(), None);
    }

    /// One species of spheres of diameter 1, and a periodic box of edge 6.
    fn unit_spheres_in_a_box_of_six() -> (Vec<Species>, PeriodicBox) {
        let species = vec![Species {
            name: "s".into(),
            shape: "Sphere(radius: 0.5)".parse().unwrap(),
            rotation: false,
        }];
        (species, PeriodicBox::new(V3::repeat(6.0)).unwrap())
    }

    fn sphere_at(x: f64) -> Particle {
        Particle {
            position: V3::new(x, 0.0, 0.0),
            orientation: UnitQuaternion::identity(),
            species: 0,
        }
    }

    /// A species without bodies keeps its own bound among polydisperse
    /// ones (a bound of zero would let a body of it, once placed, go
    /// unseen by the cells); one with bodies takes its largest's.
    #[test]
    fn a_species_without_bodies_keeps_its_own_bound_among_sized_ones() {
        let (mut species, box_) = unit_spheres_in_a_box_of_six();
        species.push(Species {
            name: "none".into(),
            shape: "Sphere(radius: 0.7)".parse().unwrap(),
            rotation: false,
        });
        let particles = vec![sphere_at(-2.0), sphere_at(1.0)];
        let system = System::with_sizes(box_, species, particles, vec![0.8, 1.2]).unwrap();
        assert_eq!(system.radii, vec![0.5 * 1.2, 0.7]);
    }

    /// Spheres exactly in contact count as overlapping for the kernels;
    /// `with_contacts` lets through the pairs its judge calls touching,
    /// and only those: a deeper pair is still named.
    #[test]
    fn touching_pairs_are_let_through_only_when_judged_touching() {
        let (species, box_) = unit_spheres_in_a_box_of_six();
        let particles = vec![
            sphere_at(-2.0),
            sphere_at(-1.0),
            sphere_at(1.0),
            sphere_at(1.9),
        ];
        assert_eq!(
            System::new(box_, species.clone(), particles.clone()).unwrap_err(),
            StateError::Overlap(0, 1)
        );
        // A judge by the distance of centres, to a tolerance.
        let touching = |i: usize, j: usize| {
            let d = (particles[j].position - particles[i].position).norm();
            (d - 1.0).abs() <= 1e-12
        };
        assert_eq!(
            System::with_contacts(box_, species.clone(), particles.clone(), None, touching)
                .unwrap_err(),
            StateError::Overlap(2, 3)
        );
        let apart = vec![particles[0], particles[1], particles[2]];
        let system = System::with_contacts(box_, species, apart, None, touching).unwrap();
        assert_eq!(system.len(), 3);
        // A move of a touching sphere is judged as usual: into its partner
        // rejected, away from it accepted.
        let (into, away) = (V3::new(-1.2, 0.0, 0.0), V3::new(-0.8, 0.0, 0.0));
        let r = Matrix3::identity();
        assert!(system.overlaps_at(1, &into, &r));
        assert!(!system.overlaps_at(1, &away, &r));
    }

    #[test]
    fn construction_names_the_overlapping_pair_and_bad_input() {
        let (species, box_) = unit_spheres_in_a_box_of_six();
        let particles = vec![
            sphere_at(-2.0),
            sphere_at(0.0),
            sphere_at(2.0),
            sphere_at(2.9),
        ];
        assert_eq!(
            System::new(box_, species.clone(), particles).unwrap_err(),
            StateError::Overlap(2, 3)
        );
        // Across the periodic boundary: −2.95 and 2.9 are 0.15 apart.
        let particles = vec![sphere_at(-2.95), sphere_at(0.0), sphere_at(2.9)];
        assert_eq!(
            System::new(box_, species.clone(), particles).unwrap_err(),
            StateError::Overlap(0, 2)
        );
        assert_eq!(
            System::new(box_, species.clone(), vec![]).unwrap_err(),
            StateError::Empty
        );
        let stray = Particle {
            species: 3,
            ..sphere_at(0.0)
        };
        assert_eq!(
            System::new(box_, species.clone(), vec![stray]).unwrap_err(),
            StateError::UnknownSpecies(0, 3, 1)
        );
        let small = PeriodicBox::new(V3::repeat(1.5)).unwrap();
        assert!(matches!(
            System::new(small, species, vec![sphere_at(0.0)]),
            Err(StateError::BoxTooSmall { .. })
        ));
    }
}
