//! Metropolis Monte Carlo of hard particles: the system (box, species,
//! particles, cell list), trial moves, volume moves and step-size tuning.
//!
//! A move is accepted iff it creates no overlap (hard-particle Metropolis);
//! volume moves in ln V carry the NPT weight. Overlap tests go through the
//! geometry layer's pair dispatch only.

pub mod compress;
pub mod moves;
pub mod parallel;
pub mod sdf;
pub mod start;
pub mod tuning;

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::geometry::capsule::{Capsule, bounding_capsule};
use crate::geometry::{Placed, Relative, Shape, overlap, placed_overlap};
use crate::space::capsule_lists::Segment;
use crate::space::slots::Slots;
use crate::space::{AabbCells, CapsuleLists, PackedCells, PeriodicBox, SphereLists};

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
pub enum McError {
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
}

/// How candidate neighbours are found, chosen from the species (the plan):
/// cells as wide as the largest interaction range with the 27-cell stencil
/// for near-isotropic particles of similar size; AABB cells, much smaller,
/// for elongated or flat particles; one grid per species, each as wide as
/// that species' diameter, for size-asymmetric mixtures (a small particle
/// then looks through small cells of its own kind and the few large cells
/// of the large kind, never through hundreds of small particles binned in
/// a large cell).
#[derive(Debug, Clone)]
enum Neighbours {
    Cells(PackedCells),
    Aabb(AabbCells),
    PerSpecies(Vec<PackedCells>),
}

/// The neighbour structure Monte Carlo uses for a set of species, and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeighbourPlan {
    /// AABB cells (true) or 27-stencil cells as wide as the range.
    pub aabb_cells: bool,
    /// One grid per species (size-asymmetric mixtures); then `aabb_cells`
    /// is false.
    pub per_species: bool,
    /// Width of the AABB cells.
    pub aabb_width: f64,
    /// Some species is elongated or flat (bounding radius > 1.5 × its
    /// smallest half-extent).
    pub elongated: bool,
    /// The smallest bounding diameter is under half the interaction range.
    pub size_asymmetric: bool,
    /// Spheres on one grid: the skin of their Verlet lists
    /// ([`SphereLists`]), the smallest radius times [`SPHERE_SKIN`].
    pub sphere_skin: Option<f64>,
    /// AABB cells: the padding of the reference capsules of their Verlet
    /// lists ([`CapsuleLists`]), the smallest thickness times
    /// [`CAPSULE_PAD`].
    pub capsule_pad: Option<f64>,
}

impl NeighbourPlan {
    /// The structure the species call for.
    pub fn for_species(species: &[Species]) -> Self {
        let (aabb_cells, aabb_width, elongated, size_asymmetric) = Neighbours::plan(species);
        let aabb_cells = aabb_cells && !size_asymmetric;
        let one_grid = !aabb_cells && !size_asymmetric;
        let smallest = species
            .iter()
            .map(|s| s.shape.bounding_radius())
            .fold(f64::INFINITY, f64::min);
        Self {
            aabb_cells,
            per_species: size_asymmetric,
            aabb_width,
            elongated,
            size_asymmetric,
            sphere_skin: (one_grid && species.iter().all(|s| s.shape.is_sphere()))
                .then_some(SPHERE_SKIN * smallest),
            capsule_pad: (aabb_cells && capsules_fit(species)).then(|| {
                let thinnest = species
                    .iter()
                    .map(|s| 2.0 * s.shape.min_half_extent())
                    .fold(f64::INFINITY, f64::min);
                CAPSULE_PAD * thinnest
            }),
        }
    }
}

impl Neighbours {
    /// The structure the species call for: (AABB cells?, their width,
    /// elongated?, size-asymmetric?).
    fn plan(species: &[Species]) -> (bool, f64, bool, bool) {
        let radii: Vec<f64> = species.iter().map(|s| s.shape.bounding_radius()).collect();
        let max_radius = radii.iter().cloned().fold(0.0, f64::max);
        let range = 2.0 * max_radius;
        let smallest = radii.iter().cloned().fold(f64::INFINITY, f64::min);
        let thickness = species
            .iter()
            .map(|s| 2.0 * s.shape.min_half_extent())
            .fold(0.0, f64::max);
        let elongated = species
            .iter()
            .any(|s| s.shape.bounding_radius() > 1.5 * s.shape.min_half_extent());
        let asymmetric = 2.0 * smallest < 0.5 * range;
        let use_aabb = elongated || asymmetric;
        // Cells between the thickness and the range, nearer the thickness:
        // thin enough to separate neighbours, wide enough that a particle
        // spans few of them. Measured on aligned needles (2.5:0.5:0.5,
        // φ = 0.5): t^¾ r^¼ gave 4.3e5 moves/s, t 3.4e5, √(t r) 3.4e5, r 2.3e5.
        (
            use_aabb,
            thickness.powf(0.75) * range.powf(0.25),
            elongated,
            asymmetric,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn build(
        plan: &NeighbourPlan,
        range: f64,
        box_: &PeriodicBox,
        centres: &[V3],
        halves: &[V3],
        kinds: &[u16],
        species_radii: &[f64],
    ) -> Self {
        let radii: Vec<f64> = kinds.iter().map(|&s| species_radii[s as usize]).collect();
        if plan.per_species {
            let grids = (0..species_radii.len())
                .map(|s| {
                    let members = centres
                        .iter()
                        .zip(&radii)
                        .map(|(c, r)| (*c, *r))
                        .enumerate()
                        .filter(move |(i, _)| kinds[*i] as usize == s);
                    PackedCells::with_members(box_, 2.0 * species_radii[s], centres.len(), members)
                })
                .collect();
            Neighbours::PerSpecies(grids)
        } else if plan.aabb_cells {
            Neighbours::Aabb(AabbCells::new(
                box_.lengths(),
                plan.aabb_width,
                centres,
                halves,
            ))
        } else {
            Neighbours::Cells(PackedCells::new(box_, range, centres, &radii))
        }
    }
}

/// The spheres' Verlet-list skin over the smallest radius. Measured
/// side by side on one core (spheres φ = 0.5, N = 4096, moves tuned to
/// 30 % acceptance; two soaks loading the machine): no lists 2.8–3.2e6
/// moves/s; skins of 1.0 radius 3.7–4.0e6, 1.4 3.0–3.3e6, 2.0 2.3–3.2e6,
/// 0.6 2.1–3.0e6 (moves leave half the skin too often), 0.4 1.6–1.9e6.
pub const SPHERE_SKIN: f64 = 1.0;

/// The padding of the capsule lists' reference capsules over the
/// smallest thickness. Measured side by side on one core (ellipsoids
/// 2.5:0.5:0.5, φ = 0.5, N = 4096, aligned start, moves tuned to 30 %
/// acceptance): pads of 0.25 and 0.35 1.19–1.24e6 moves/s, 0.5
/// 0.97–1.10e6, 0.15 keeps to the cells (the moves are too long for
/// it: 7.6e5); AABB cells alone 8.2–8.5e5.
pub const CAPSULE_PAD: f64 = 0.25;

/// The width of the capsule lists' own cells over that of the AABB cells:
/// they hold the reference capsules' boxes grown by the pad, larger than
/// the bodies'. Measured side by side on one core (N = 4096, φ = 0.5):
/// needles 2.5:0.5:0.5 1.50–1.56e6 moves/s at 1.0, 1.54–1.63e6 at 1.3
/// (1.41e6 at 1.7); oblate 1:1:0.5 2.04e6 at 1.0, 2.29–2.31e6 at 1.3.
pub const CAPSULE_CELLS: f64 = 1.3;

/// The most the bounding capsule of a species may hold over the body's
/// own volume for the capsule lists to be used: cubes (2.7) keep to
/// their AABB cells, which fit them well. Measured side by side (φ = 0.5,
/// N = 4096): needles 2.5:0.5:0.5 (capsule 1.4 volumes) 1.42–1.50x faster
/// on lists on one core, 1.1–1.2x with two threads; oblate ellipsoids
/// 1:1:0.5 (2.0) 1.95x and 1.4–1.7x; cubes 1.07x on one core but 0.9x with
/// two threads (every thread places, and relists, every accepted move).
pub const CAPSULE_FIT: f64 = 2.5;

/// Whether every species fills its bounding capsule well enough for the
/// capsule lists (see [`CAPSULE_FIT`]).
fn capsules_fit(species: &[Species]) -> bool {
    species
        .iter()
        .all(|s| bounding_capsule(&s.shape).1.volume() <= CAPSULE_FIT * s.shape.volume())
}

/// The capsule lists' slack over their pad: how far a body at rest may
/// have strayed from its reference before it is relisted (then a trial
/// reaches 2 − 0.6 pads). Measured as [`CAPSULE_PAD`]: 0.6 1.22–1.23e6,
/// 1.0 1.19–1.22e6 moves/s (more trials beyond the lists).
pub const CAPSULE_SLACK: f64 = 0.6;

/// Accepted moves per sphere over which the sphere lists are reviewed:
/// after that many in one box they are built if the moves are short
/// enough to repay them, dropped if they no longer are. In NVT that is
/// soon after the start; in NPT and compression only while the box stays
/// put that long (a box change drops the lists: every centre moves).
const SPHERE_LISTS_REVIEW: usize = 4;

/// The AABB half-extents of a body with OBB half-extents `h` rotated by `r`.
#[inline]
fn aabb_half_extents(r: &Matrix3<f64>, h: &V3) -> V3 {
    r.abs() * h
}

/// Particles of several species in a periodic box, with a cell list.
#[derive(Debug, Clone)]
pub struct System {
    box_: PeriodicBox,
    species: Vec<Species>,
    /// Written element by element by the members of a team that shares
    /// the system ([`parallel`]), as are the centres, cells and lists.
    particles: Slots<Particle>,
    /// Cached rotation matrices of the orientations.
    rotations: Vec<Matrix3<f64>>,
    /// Bounding radius per species, and the largest.
    radii: Vec<f64>,
    max_radius: f64,
    /// Centres, contiguous (the hot loop reads only these); kept equal to
    /// `particles[i].position`.
    positions: Slots<V3>,
    /// OBB half-extents per species.
    obb: Vec<V3>,
    /// Lab-frame AABB half-extents per particle.
    aabb: Vec<V3>,
    /// Each particle's shape as placed (for the lab-frame overlap kernels).
    placed: Vec<Placed>,
    cells: Neighbours,
    /// Which neighbour structure, and why.
    plan: NeighbourPlan,
    /// Largest distance at which two centres can still touch.
    range: f64,
    /// Every species is a sphere: overlap is the distance of centres alone.
    all_spheres: bool,
    /// Spheres on one grid: Verlet lists with a skin answer most moves
    /// (the cells answer the rest), while the box stays put and the moves
    /// are short (see [`System::review_sphere_lists`]).
    sphere_lists: Option<SphereLists>,
    /// Bounding capsule per species, with the body axis it lies along.
    capsules: Vec<(usize, Capsule)>,
    /// Bodies on AABB cells: Verlet lists over their bounding capsules,
    /// on the same terms as the sphere lists.
    capsule_lists: Option<CapsuleLists>,
    /// Accepted moves in this box since the lists were last reviewed, and
    /// the sum of their squared steps.
    list_window: (usize, f64),
    /// The lists are reviewed after the moves rather than during them: a
    /// member of a team sharing this system's memory
    /// ([`parallel`]) only counts its moves in the window.
    review_deferred: bool,
    /// For such a member: the moves in the system's window when it took
    /// its copy.
    list_window_base: usize,
    /// Scratch for the centres of a trial box change.
    scaled: Vec<V3>,
    /// Overlap tests switched off (ideal-gas checks only).
    ideal: bool,
    /// An identity of the state (see [`System::stamp`]), renewed when it
    /// is asked for after a change.
    stamp: u64,
    /// The state changed since `stamp` was handed out (a move placed, a
    /// box rescaled): a plain flag, so that the hot path of every accepted
    /// move touches no shared counter.
    changed: bool,
}

/// Stamps handed out so far: each state asked for its stamp after a change
/// takes a new one.
static STAMPS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

fn new_stamp() -> u64 {
    STAMPS.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1
}

impl System {
    /// A system, checked to be overlap-free and in a box large enough for
    /// the minimum image.
    pub fn new(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
    ) -> Result<Self, McError> {
        Self::with_contacts(box_, species, particles, |_, _| false)
    }

    /// As [`System::new`], except that pairs (i < j) for which
    /// `touching(i, j)` holds are let through where the overlap kernels
    /// count them as overlapping: a state of the event-driven dynamics
    /// holds the pair of its last collision touching to round-off, which
    /// another kernel's arithmetic may put either side of contact. A move
    /// of such a particle is then judged against its partner as usual
    /// (moves that part them are accepted).
    pub fn with_contacts(
        box_: PeriodicBox,
        species: Vec<Species>,
        particles: Vec<Particle>,
        touching: impl Fn(usize, usize) -> bool,
    ) -> Result<Self, McError> {
        if particles.is_empty() {
            return Err(McError::Empty);
        }
        for (i, p) in particles.iter().enumerate() {
            if p.species as usize >= species.len() {
                return Err(McError::UnknownSpecies(i, p.species, species.len()));
            }
        }
        let species: Vec<Species> = species
            .into_iter()
            .map(|s| Species {
                rotation: s.rotation && !s.shape.is_sphere(),
                ..s
            })
            .collect();
        let radii: Vec<f64> = species.iter().map(|s| s.shape.bounding_radius()).collect();
        let max_radius = radii.iter().cloned().fold(0.0, f64::max);
        let range = 2.0 * max_radius;
        let particles: Vec<Particle> = particles
            .into_iter()
            .map(|p| Particle {
                position: box_.wrap(&p.position),
                ..p
            })
            .collect();
        let rotations: Vec<Matrix3<f64>> = particles
            .iter()
            .map(|p| p.orientation.to_rotation_matrix().into_inner())
            .collect();
        Self::check_box(&box_, range)?;
        let obb: Vec<V3> = species.iter().map(|s| s.shape.obb_half_extents()).collect();
        let aabb: Vec<V3> = particles
            .iter()
            .zip(&rotations)
            .map(|(p, r)| aabb_half_extents(r, &obb[p.species as usize]))
            .collect();
        let placed: Vec<Placed> = particles
            .iter()
            .zip(&rotations)
            .map(|(p, r)| Placed::new(&species[p.species as usize].shape, r))
            .collect();
        let plan = NeighbourPlan::for_species(&species);
        let capsules = species.iter().map(|s| bounding_capsule(&s.shape)).collect();
        let positions: Vec<V3> = particles.iter().map(|p| p.position).collect();
        let kinds: Vec<u16> = particles.iter().map(|p| p.species).collect();
        let all_spheres = species.iter().all(|s| s.shape.is_sphere());
        let cells = Neighbours::build(&plan, range, &box_, &positions, &aabb, &kinds, &radii);
        let system = Self {
            box_,
            species,
            particles: particles.into(),
            rotations,
            radii,
            max_radius,
            positions: positions.into(),
            obb,
            aabb,
            placed,
            cells,
            plan,
            range,
            all_spheres,
            sphere_lists: None,
            capsules,
            capsule_lists: None,
            list_window: (0, 0.0),
            review_deferred: false,
            list_window_base: 0,
            scaled: Vec::new(),
            ideal: false,
            stamp: new_stamp(),
            changed: false,
        };
        if let Some(i) = system.first_wall_overlap() {
            return Err(McError::WallOverlap(i));
        }
        // Through the neighbour structure: O(N), where the all-pairs check is
        // O(N²) (that one is for tests).
        for i in 0..system.len() {
            if system.overlaps_where_it_is(i) {
                let partners: Vec<usize> = system.partners_of(i).collect();
                match partners.iter().find(|&&j| !touching(i.min(j), i.max(j))) {
                    Some(&j) => return Err(McError::Overlap(i.min(j), i.max(j))),
                    None if partners.is_empty() => return Err(McError::Overlap(i, i)),
                    None => {} // Touching partners only.
                }
            }
        }
        Ok(system)
    }

    fn check_box(box_: &PeriodicBox, range: f64) -> Result<(), McError> {
        if box_.lengths().min() < 2.0 * range {
            Err(McError::BoxTooSmall {
                lengths: box_.lengths().into(),
                range,
            })
        } else {
            Ok(())
        }
    }

    /// The largest centre–centre distance at which two particles can
    /// touch (twice the largest bounding radius): the box edges must stay
    /// at least twice this for the minimum image to be unique.
    pub fn interaction_range(&self) -> f64 {
        self.range
    }

    /// Switches overlap tests off (an ideal gas of the same particles), for
    /// checking the volume-move statistics.
    pub fn set_ideal(&mut self, ideal: bool) {
        self.changed = true;
        self.ideal = ideal;
    }

    /// The box.
    pub fn periodic_box(&self) -> &PeriodicBox {
        &self.box_
    }

    /// The particles.
    pub fn particles(&self) -> &[Particle] {
        self.particles.as_slice()
    }

    /// The species.
    pub fn species(&self) -> &[Species] {
        &self.species
    }

    /// An identity of the state: a system and a clone of it have the same
    /// stamp until either changes (a stamp asked for after any move placed
    /// or box rescaled is a fresh one). Replicas kept for parallel sweeps
    /// are reused while the system's stamp is the one they were
    /// synchronised at.
    pub fn stamp(&mut self) -> u64 {
        if self.changed {
            self.stamp = new_stamp();
            self.changed = false;
        }
        self.stamp
    }

    /// The neighbour structure it uses, and why.
    pub fn plan(&self) -> &NeighbourPlan {
        &self.plan
    }

    /// Whether sphere moves are answered by Verlet lists now (built once
    /// the box has stayed put long enough; see [`NeighbourPlan::sphere_skin`]).
    pub fn uses_sphere_lists(&self) -> bool {
        self.sphere_lists.is_some()
    }

    /// Whether capsule Verlet lists answer most moves now (bodies on AABB
    /// cells, once the moves are short; see [`NeighbourPlan::capsule_pad`]).
    pub fn uses_capsule_lists(&self) -> bool {
        self.capsule_lists.is_some()
    }

    /// Whether candidates come from AABB cells (elongated or flat species)
    /// rather than range-wide cells.
    pub fn uses_aabb_cells(&self) -> bool {
        self.plan.aabb_cells
    }

    /// Whether each species has a grid of its own (size-asymmetric
    /// mixtures).
    pub fn uses_per_species_cells(&self) -> bool {
        self.plan.per_species
    }

    /// How many particles the neighbour structure hands to the overlap test
    /// for particle `i` where it is (itself included): the work of one
    /// trial move before the pair kernels.
    pub fn candidates_of(&self, i: usize) -> usize {
        let mut count = 0;
        let mut seen = |_: usize, _: &V3| {
            count += 1;
            false
        };
        let position = self.positions[i];
        let si = self.particles[i].species as usize;
        match &self.cells {
            Neighbours::Cells(cells) => {
                cells.any_near(&position, &mut seen);
            }
            Neighbours::Aabb(cells) => match &self.capsule_lists {
                // Itself included, as the cells count it.
                Some(lists) => count = lists.of(i).len() + 1,
                None => {
                    let h = aabb_half_extents(&self.rotations[i], &self.obb[si]);
                    cells.any_near(&position, &h, |j| seen(j, &position));
                }
            },
            Neighbours::PerSpecies(grids) => {
                for (sj, grid) in grids.iter().enumerate() {
                    grid.any_within(&position, self.radii[si] + self.radii[sj], &mut seen);
                }
            }
        }
        count
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Always false: a system has particles.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// φ = Σ vᵢ / V.
    pub fn packing_fraction(&self) -> f64 {
        let v: f64 = self
            .particles
            .iter()
            .map(|p| self.species[p.species as usize].shape.volume())
            .sum();
        v / self.box_.volume()
    }

    /// Whether particle `i`, placed at `position` with rotation `rotation`,
    /// would overlap any other particle (periodic images included).
    pub fn overlaps_at(&self, i: usize, position: &V3, rotation: &Matrix3<f64>) -> bool {
        self.overlaps_at_except(i, position, rotation, |j| j == i)
    }

    /// Whether a body of species `s` at `position` turned by `rotation`
    /// touches or crosses a hard wall.
    fn touches_wall(&self, s: usize, position: &V3, rotation: &Matrix3<f64>) -> bool {
        let extents = self.species[s].shape.lab_half_extents(rotation);
        self.box_.wall_gap(position, &extents) <= 0.0
    }

    /// The first particle touching or crossing a hard wall, if any.
    pub fn first_wall_overlap(&self) -> Option<usize> {
        (0..self.len()).find(|&i| {
            self.touches_wall(
                self.particles[i].species as usize,
                &self.positions[i],
                &self.rotations[i],
            )
        })
    }

    /// Whether particle `i` (its species), placed at `position` with
    /// `rotation`, overlaps particle `j` placed at `position_j` with
    /// `rotation_j`.
    pub(crate) fn pair_overlaps(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        j: usize,
        position_j: &V3,
        rotation_j: &Matrix3<f64>,
    ) -> bool {
        if self.ideal {
            return false;
        }
        let (si, sj) = (
            self.particles[i].species as usize,
            self.particles[j].species as usize,
        );
        // Both positions lie in the box: |d| < 3L/2.
        let d = self.box_.minimum_image_near(&(position_j - position));
        let reach = self.radii[si] + self.radii[sj];
        if d.norm_squared() > reach * reach {
            return false;
        }
        let (shape_i, shape_j) = (&self.species[si].shape, &self.species[sj].shape);
        if shape_i.is_sphere() && shape_j.is_sphere() {
            return true;
        }
        if self.plan.aabb_cells {
            // Disjoint AABBs, as the AABB cells would have told.
            let (hi, hj) = (
                aabb_half_extents(rotation, &self.obb[si]),
                aabb_half_extents(rotation_j, &self.obb[sj]),
            );
            if (0..3).any(|k| d[k].abs() > hi[k] + hj[k]) {
                return false;
            }
        }
        let (placed_i, placed_j) = (
            Placed::new(shape_i, rotation),
            Placed::new(shape_j, rotation_j),
        );
        if let Some(answer) = placed_overlap(&placed_i, &placed_j, &d) {
            return answer;
        }
        let rel = Relative {
            translation: rotation.tr_mul(&d),
            rotation: rotation.tr_mul(rotation_j),
        };
        overlap(shape_i, shape_j, &rel)
    }

    /// As [`System::overlaps_at`], for a trial move of particle `i`: where
    /// its capsule list finds the overlap, the partner goes to the front
    /// of the list, where the next trial of `i`, most likely overlapping
    /// it too, meets it first. (The order of a list changes no answer.)
    /// `rotation` `None` keeps the particle's own (a translation).
    pub(crate) fn trial_overlaps(
        &mut self,
        i: usize,
        position: &V3,
        rotation: Option<&Matrix3<f64>>,
    ) -> bool {
        let rotation = rotation.unwrap_or(&self.rotations[i]);
        if self.capsule_lists.is_none() {
            return self.overlaps_at(i, position, rotation);
        }
        let hit = std::cell::Cell::new(None);
        let overlaps = self.overlap_search(i, position, rotation, |j| j == i, &hit);
        if let (Some(at), Some(lists)) = (hit.get(), &mut self.capsule_lists) {
            lists.to_front(i, at);
        }
        overlaps
    }

    /// As [`System::overlaps_at`], ignoring every particle `j` for which
    /// `skip(j)` holds (the particle itself always among them).
    pub(crate) fn overlaps_at_except(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        skip: impl Fn(usize) -> bool,
    ) -> bool {
        self.overlap_search(i, position, rotation, skip, &std::cell::Cell::new(None))
    }

    /// As [`System::overlaps_at_except`]; where a capsule list finds the
    /// overlap, `hit` is set to the partner's place on the list.
    #[inline]
    fn overlap_search(
        &self,
        i: usize,
        position: &V3,
        rotation: &Matrix3<f64>,
        skip: impl Fn(usize) -> bool,
        hit: &std::cell::Cell<Option<usize>>,
    ) -> bool {
        if self.ideal {
            return false;
        }
        let si = self.particles[i].species as usize;
        let shape_i = &self.species[si].shape;
        let ri = self.radii[si];
        if self.box_.has_walls() && self.touches_wall(si, position, rotation) {
            return true;
        }
        if let (Neighbours::Cells(cells), true) = (&self.cells, self.all_spheres) {
            let centre = self.box_.wrap_near(position);
            if let Some(lists) = &self.sphere_lists
                && let Some(answer) =
                    lists.overlaps(i, &centre, &self.positions, &self.box_, |j| !skip(j))
            {
                return answer;
            }
            return cells.sphere_overlaps_where(&centre, ri, |j| !skip(j as usize));
        }
        // The largest reach any partner could have: most candidates fail
        // this before their species is even looked up.
        let reach_max = ri + self.max_radius;
        // A translation tests the particle's own rotation (the very matrix
        // `rotations[i]`), already placed.
        let placed_i = if std::ptr::eq(rotation, &self.rotations[i]) {
            self.placed[i]
        } else {
            Placed::new(shape_i, rotation)
        };
        let test = |j: usize, d: &V3| {
            let d2 = d.norm_squared();
            if d2 > reach_max * reach_max || skip(j) {
                return false;
            }
            let sj = self.particles[j].species as usize;
            let reach = ri + self.radii[sj];
            if d2 > reach * reach {
                return false;
            }
            let shape_j = &self.species[sj].shape;
            if shape_i.is_sphere() && shape_j.is_sphere() {
                return true; // within the sum of radii
            }
            if let Some(answer) = placed_overlap(&placed_i, &self.placed[j], d) {
                return answer;
            }
            let rel = Relative {
                translation: rotation.tr_mul(d),
                rotation: rotation.tr_mul(&self.rotations[j]),
            };
            overlap(shape_i, shape_j, &rel)
        };
        match &self.cells {
            // At the position it would be stored at (a trial translation may
            // have left the box).
            Neighbours::Cells(cells) => cells.any_near(&self.box_.wrap_near(position), test),
            Neighbours::PerSpecies(grids) => {
                let at = self.box_.wrap_near(position);
                grids
                    .iter()
                    .enumerate()
                    .any(|(sj, grid)| grid.any_within(&at, ri + self.radii[sj], |j, d| test(j, d)))
            }
            Neighbours::Aabb(cells) => {
                // Both centres lie within half a box of the box: |d| < 3L/2.
                let separation = |j: usize| {
                    self.box_
                        .minimum_image_near(&(self.positions[j] - position))
                };
                let h = aabb_half_extents(rotation, &self.obb[si]);
                let candidate = |j: usize| {
                    // Disjoint AABBs (the registry is coarser than them).
                    let d = separation(j);
                    let hj = &self.aabb[j];
                    if (0..3).any(|k| d[k].abs() > h[k] + hj[k]) {
                        return false;
                    }
                    test(j, &d)
                };
                let Some(lists) = &self.capsule_lists else {
                    return cells.any_near(position, &h, candidate);
                };
                let axis = rotation.column(self.capsules[si].0).into();
                if lists.reach(&self.box_, i, position, &axis) {
                    let at = lists.of(i).iter().position(|&j| candidate(j as usize));
                    hit.set(at);
                    return at.is_some();
                }
                // While the lists are on, their cells hold every body.
                lists.any_near(position, &h, candidate)
            }
        }
    }

    /// The first overlapping pair found through the neighbour structure
    /// (O(N): for systems too large for [`System::first_overlap_all_pairs`]);
    /// a body on a wall is paired with itself.
    pub fn first_overlap(&self) -> Option<(usize, usize)> {
        let i = (0..self.len()).find(|&i| self.overlaps_where_it_is(i))?;
        Some(match self.partners_of(i).next() {
            Some(j) => (i.min(j), i.max(j)),
            None => (i, i),
        })
    }

    /// The particles that particle `i` overlaps where it is, by testing
    /// every other one (for naming an overlap, not for moves).
    fn partners_of(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        let (p, r) = (&self.positions[i], &self.rotations[i]);
        (0..self.len()).filter(move |&j| {
            j != i && self.pair_overlaps(i, p, r, j, &self.positions[j], &self.rotations[j])
        })
    }

    /// The first overlapping pair by testing all N(N−1)/2 pairs, without the
    /// cell list: the independent check that a state is overlap-free.
    pub fn first_overlap_all_pairs(&self) -> Option<(usize, usize)> {
        let n = self.particles.len();
        for i in 0..n {
            let (pi, si) = (&self.particles[i], self.particles[i].species as usize);
            for j in i + 1..n {
                let pj = &self.particles[j];
                let d = self.box_.minimum_image(&(pj.position - pi.position));
                let reach = self.radii[si] + self.radii[pj.species as usize];
                if d.norm_squared() > reach * reach {
                    continue; // the pair kernels would reject it the same way
                }
                let rel = Relative::new(&d, &pi.orientation, &pj.orientation);
                if overlap(
                    &self.species[si].shape,
                    &self.species[pj.species as usize].shape,
                    &rel,
                ) {
                    return Some((i, j));
                }
            }
        }
        None
    }

    /// Moves particle `i` (the caller has checked that it creates no overlap).
    pub(crate) fn place(
        &mut self,
        i: usize,
        position: V3,
        orientation: UnitQuaternion<f64>,
        rotation: Matrix3<f64>,
    ) {
        self.changed = true;
        let position = self.box_.wrap_near(&position);
        let step = self
            .box_
            .minimum_image_near(&(position - self.positions[i]));
        self.particles[i].position = position;
        self.positions[i] = position;
        let species = self.particles[i].species as usize;
        let (axis_k, capsule) = self.capsules[species];
        // How far the capsule's axis turned, at its ends (read only where
        // capsule lists may come: a sphere's rotation is never touched).
        let turn: V3 = match self.plan.capsule_pad {
            Some(_) => {
                (rotation.column(axis_k) - self.rotations[i].column(axis_k)) * capsule.half_length
            }
            None => V3::zeros(),
        };
        let h = if self.all_spheres {
            // Spheres: orientation, rotation, placed shape and box never change.
            self.aabb[i]
        } else {
            self.particles[i].orientation = orientation;
            self.rotations[i] = rotation;
            self.placed[i] = Placed::new(&self.species[species].shape, &rotation);
            let h = aabb_half_extents(&rotation, &self.obb[species]);
            self.aabb[i] = h;
            h
        };
        match &mut self.cells {
            Neighbours::Cells(cells) => {
                cells.update(i, &position);
                if let Some(lists) = &mut self.sphere_lists {
                    lists.moved(i, &position, &self.box_);
                }
            }
            // While the lists are on, their cells stand in for these.
            Neighbours::Aabb(cells) => match &mut self.capsule_lists {
                Some(lists) => {
                    lists.moved(&self.box_, i, &position, &rotation.column(axis_k).into())
                }
                None => cells.update(i, &position, &h),
            },
            Neighbours::PerSpecies(grids) => grids[species].update(i, &position),
        }
        if let Some(skin) = self.plan.sphere_skin {
            self.review_sphere_lists(step.norm_squared(), skin);
        } else if let Some(pad) = self.plan.capsule_pad {
            // How far the segment's ends moved, the farther of the two.
            let shift = (step + turn).norm().max((step - turn).norm());
            self.review_capsule_lists(shift * shift, pad);
        }
    }

    /// Counts an accepted sphere move of squared length `step_sq`; every
    /// [`SPHERE_LISTS_REVIEW`] moves per sphere, builds the lists if the
    /// root-mean-square step is under a quarter of the `skin`, drops them
    /// if it is not. A sphere is relisted when it has wandered half a skin
    /// from its reference, about every (skin / 2)² / ⟨step²⟩ moves: at
    /// least every four moves pays for the lists; dilute spheres, whose
    /// tuned moves are long, keep to the cells. (Moves tuned to 30 %
    /// acceptance, N = 4096, one core: rms step / skin 0.54, 0.30, 0.24,
    /// 0.19 at φ 0.3, 0.4, 0.45, 0.5; lists against cells at φ 0.45
    /// 4.3–4.4e6 against 3.8–4.0e6 moves/s, at φ 0.5 7.5e6 against 5.0e6.)
    fn review_sphere_lists(&mut self, step_sq: f64, skin: f64) {
        if let Some(short) = self.moves_short(step_sq, 0.25 * skin) {
            self.keep_sphere_lists(short, skin);
        }
    }

    /// Builds the sphere lists if the moves are `short` and they are not
    /// there, drops them if the moves are not.
    fn keep_sphere_lists(&mut self, short: bool, skin: f64) {
        if short && self.sphere_lists.is_none() {
            let radii: Vec<f64> = (self.particles.iter())
                .map(|p| self.radii[p.species as usize])
                .collect();
            self.sphere_lists = Some(SphereLists::new(
                &self.box_,
                self.positions.as_slice(),
                &radii,
                skin,
            ));
        } else if !short {
            self.sphere_lists = None;
        }
    }

    /// Counts an accepted move of squared length `step_sq` in the review
    /// window; once it holds [`SPHERE_LISTS_REVIEW`] moves per particle,
    /// empties it and says whether their root-mean-square length was
    /// under `limit`.
    fn moves_short(&mut self, step_sq: f64, limit: f64) -> Option<bool> {
        self.list_window.0 += 1;
        self.list_window.1 += step_sq;
        if self.review_deferred {
            return None;
        }
        self.window_verdict(limit)
    }

    /// Once the review window holds [`SPHERE_LISTS_REVIEW`] moves per
    /// particle, empties it and says whether their root-mean-square length
    /// was under `limit`.
    fn window_verdict(&mut self, limit: f64) -> Option<bool> {
        let (moves, sum) = self.list_window;
        if moves < SPHERE_LISTS_REVIEW * self.positions.len() {
            return None;
        }
        self.list_window = (0, 0.0);
        Some(sum / (moves as f64) < limit * limit)
    }

    /// Reviews the sphere lists on the window counted so far (moves a
    /// team made with the review deferred): as the last of those moves
    /// would have, had it been made alone.
    fn review_sphere_lists_now(&mut self) {
        if let Some(skin) = self.plan.sphere_skin
            && let Some(short) = self.window_verdict(0.25 * skin)
        {
            self.keep_sphere_lists(short, skin);
        }
    }

    /// As [`System::review_sphere_lists`] for the capsule lists: built if
    /// the root-mean-square shift of a segment's end per accepted move is
    /// under half the `pad` (a body is relisted when an end has strayed
    /// [`CAPSULE_SLACK`] pads, about every (0.6 pad / shift)² moves).
    fn review_capsule_lists(&mut self, shift_sq: f64, pad: f64) {
        let Some(short) = self.moves_short(shift_sq, 0.5 * pad) else {
            return;
        };
        if short && self.capsule_lists.is_none() {
            let segments: Vec<Segment> = (0..self.len()).map(|i| self.segment(i)).collect();
            self.capsule_lists = Some(CapsuleLists::new(
                &self.box_,
                &segments,
                pad,
                CAPSULE_SLACK * pad,
                CAPSULE_CELLS * self.plan.aabb_width,
            ));
        } else if !short && self.capsule_lists.take().is_some() {
            // The AABB cells were left as they were when the lists came.
            self.cells = self.neighbours_as_they_are();
        }
    }

    /// The neighbour structure of the plan built for the particles where
    /// they are.
    fn neighbours_as_they_are(&self) -> Neighbours {
        let kinds: Vec<u16> = self.particles.iter().map(|p| p.species).collect();
        Neighbours::build(
            &self.plan,
            self.range,
            &self.box_,
            self.positions.as_slice(),
            &self.aabb,
            &kinds,
            &self.radii,
        )
    }

    /// The core segment of particle `i`'s bounding capsule as it sits.
    fn segment(&self, i: usize) -> Segment {
        let (k, capsule) = self.capsules[self.particles[i].species as usize];
        Segment {
            centre: self.positions[i],
            axis: self.rotations[i].column(k).into(),
            half_length: capsule.half_length,
            radius: capsule.radius,
        }
    }

    /// The box of these edges, if valid and at least twice the interaction
    /// range along each.
    fn box_with_lengths(&self, lengths: V3) -> Option<PeriodicBox> {
        let new_box = self.box_.with_lengths(lengths).ok()?;
        Self::check_box(&new_box, self.range).ok()?;
        Some(new_box)
    }

    /// Puts the system in `new_box`, every centre scaled by `factor` (the
    /// neighbour structures are the caller's to renew).
    fn scale_into(&mut self, new_box: PeriodicBox, factor: &V3) {
        self.box_ = new_box;
        for (p, r) in self.particles.iter_mut().zip(&mut self.positions) {
            p.position = new_box.wrap(&p.position.component_mul(factor));
            *r = p.position;
        }
    }

    /// Rescales the box to `lengths` and the centres with it, overlaps or
    /// not (a compression that lets the moves remove them); returns false,
    /// and changes nothing, where the box would be invalid or shorter than
    /// twice the interaction range.
    pub(crate) fn rescale_allowing_overlaps(&mut self, lengths: V3) -> bool {
        let Some(new_box) = self.box_with_lengths(lengths) else {
            return false;
        };
        let factor = lengths.component_div(&self.box_.lengths());
        self.scale_into(new_box, &factor);
        self.capsule_lists = None;
        self.cells = self.neighbours_as_they_are();
        if let Some(mut lists) = self.sphere_lists.take()
            && lists.rescaled(&self.box_, &factor, self.positions.as_slice())
        {
            self.sphere_lists = Some(lists);
        }
        self.list_window = (0, 0.0);
        self.changed = true;
        true
    }

    /// Puts the box and the particles back as `box_` and `particles` hold
    /// them (a state this system had, of the same species), checked to be
    /// overlap-free.
    pub(crate) fn restore(
        &mut self,
        box_: PeriodicBox,
        particles: &[Particle],
    ) -> Result<(), McError> {
        let mut restored = System::new(box_, self.species.clone(), particles.to_vec())?;
        restored.ideal = self.ideal;
        *self = restored;
        Ok(())
    }

    /// Every particle that overlaps another or a wall, in index order,
    /// written to `out`.
    pub(crate) fn overlapping_particles(&self, out: &mut Vec<usize>) {
        out.clear();
        out.extend((0..self.len()).filter(|&i| self.overlaps_where_it_is(i)));
    }

    /// Whether particle `i` overlaps another or a wall where it is.
    pub(crate) fn overlaps_where_it_is(&self, i: usize) -> bool {
        self.overlaps_at(i, &self.positions[i], &self.rotations[i])
    }

    /// Rescales the box to `lengths` and the positions with it, if that
    /// creates no overlap and keeps the box at least twice the interaction
    /// range; returns whether it did.
    pub(crate) fn try_rescale(&mut self, lengths: V3) -> bool {
        let Some(new_box) = self.box_with_lengths(lengths) else {
            return false;
        };
        let old_lengths = self.box_.lengths();
        let factor = lengths.component_div(&old_lengths);
        let shrinks = factor.iter().any(|&f| f < 1.0);
        // Most shrinks that fail make a listed pair overlap: the listed
        // pairs are measured on the scaled centres alone, before any cell
        // is rebuilt (the arithmetic of the centres scaled in place below,
        // so the same answer); below, only the strays are left to check.
        if shrinks
            && !self.ideal
            && !self.box_.has_walls()
            && let Some(lists) = &self.sphere_lists
        {
            self.scaled.clear();
            (self.scaled).extend(
                self.positions
                    .iter()
                    .map(|r| new_box.wrap(&r.component_mul(&factor))),
            );
            if lists.listed_overlap_after_rescale(&new_box, &factor, &self.scaled) {
                return false;
            }
        }
        // Every centre moves: the trial is made in place, on new cells and
        // without lists; a refused change puts back the centres, the cells
        // and the lists it kept aside (a copy of the whole system per box
        // move, fresh pages each time, was a quarter of an NPT sweep of
        // 4000 spheres).
        let lists = self.sphere_lists.take();
        let capsule_lists = self.capsule_lists.take();
        let old_box = self.box_;
        let old_positions = self.positions.clone();
        self.scale_into(new_box, &factor);
        let new_cells = self.neighbours_as_they_are();
        let old_cells = std::mem::replace(&mut self.cells, new_cells);
        // Scaling all centres up cannot create an overlap of convex bodies
        // (r ∉ A⊕(−B) ⇒ s·r ∉ A⊕(−B) for s ≥ 1); only a shrink along some
        // axis needs checking.
        let overlaps =
            |i: usize| self.overlaps_at(i, &self.particles[i].position, &self.rotations[i]);
        // Sphere lists answered above for all but the centres that strayed
        // far from their references (walls aside).
        if shrinks
            && !self.ideal
            && match &lists {
                Some(lists) if !self.box_.has_walls() => (lists)
                    .strays_after_rescale(&self.box_, &factor, self.positions.as_slice())
                    .any(overlaps),
                _ => (0..self.len()).any(overlaps),
            }
        {
            self.box_ = old_box;
            for (p, r) in self.particles.iter_mut().zip(&old_positions) {
                p.position = *r;
            }
            self.positions = old_positions;
            self.cells = old_cells;
            self.sphere_lists = lists;
            self.capsule_lists = capsule_lists;
            return false;
        }
        // The sphere lists go with the box (scaled) while the gap they keep
        // allows; the capsule lists do not.
        if let Some(mut lists) = lists
            && lists.rescaled(&self.box_, &factor, self.positions.as_slice())
        {
            self.sphere_lists = Some(lists);
        }
        self.list_window = (0, 0.0);
        self.changed = true;
        true
    }
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
            anisotropic: false,
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
        };
        let long = MoveSizes {
            translate: 1.5,
            rotate: 0.6,
            volume: 0.0,
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
            McError::Overlap(0, 1)
        );
        // A judge by the distance of centres, to a tolerance.
        let touching = |i: usize, j: usize| {
            let d = (particles[j].position - particles[i].position).norm();
            (d - 1.0).abs() <= 1e-12
        };
        assert_eq!(
            System::with_contacts(box_, species.clone(), particles.clone(), touching).unwrap_err(),
            McError::Overlap(2, 3)
        );
        let apart = vec![particles[0], particles[1], particles[2]];
        let system = System::with_contacts(box_, species, apart, touching).unwrap();
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
            McError::Overlap(2, 3)
        );
        // Across the periodic boundary: −2.95 and 2.9 are 0.15 apart.
        let particles = vec![sphere_at(-2.95), sphere_at(0.0), sphere_at(2.9)];
        assert_eq!(
            System::new(box_, species.clone(), particles).unwrap_err(),
            McError::Overlap(0, 2)
        );
        assert_eq!(
            System::new(box_, species.clone(), vec![]).unwrap_err(),
            McError::Empty
        );
        let stray = Particle {
            species: 3,
            ..sphere_at(0.0)
        };
        assert_eq!(
            System::new(box_, species.clone(), vec![stray]).unwrap_err(),
            McError::UnknownSpecies(0, 3, 1)
        );
        let small = PeriodicBox::new(V3::repeat(1.5)).unwrap();
        assert!(matches!(
            System::new(small, species, vec![sphere_at(0.0)]),
            Err(McError::BoxTooSmall { .. })
        ));
    }
}
