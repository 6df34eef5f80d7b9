//! The dynamics of hard rigid bodies: bodies move freely and lazily (each
//! keeps the time its stored pose belongs to), the calendar yields the next
//! collision, cell crossing or wall contact, and only the bodies involved
//! are advanced, changed and re-predicted (De Michele Sec. 2.7).
//!
//! - `mod.rs`: the [`Dynamics`] state, its bodies, the options;
//! - `build.rs`: construction from a state, from parts or from a dump;
//! - `kinds.rs`: what is kept per kind of body (shape, mass, moments, the
//!   spins no collision changes);
//! - `error.rs`: what can go wrong, [`EdmdError`];
//! - `events.rs`: the event loop;
//! - `collisions.rs`: contact and impulse of a colliding pair;
//! - `crossings.rs`: cell crossings, box escapes and walls;
//! - `scheduling.rs`: the earliest collision of a body with its
//!   neighbours;
//! - `observables.rs`: what the dynamics reports.

mod build;
mod collisions;
mod crossings;
mod error;
mod events;
mod kinds;
mod lanes;
mod observables;
mod scheduling;

use build::*;
pub use error::EdmdError;
pub use kinds::top_moments;
use kinds::*;
#[cfg(test)]
use lanes::*;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use observables::*;
pub use observables::{Interval, Sample, StressSums, SymmetricTensor};
use scheduling::*;

use crate::edmd::calendar::Calendar;
use crate::edmd::motion::{FreeTop, position_after};
use crate::edmd::predict::{Predictor, PredictorOptions};
use crate::edmd::search::{Growth, Progress, SearchError};
use crate::geometry::{Shape, WarmStart};
use crate::space::{CellList, Marks, NeighbourLists, PeriodicBox};
use crate::state::Species;

type V3 = Vector3<f64>;

/// Settings of a dynamics run.
#[derive(Debug, Clone, PartialEq)]
pub struct DynamicsOptions {
    /// kT of the Maxwell–Boltzmann start; the kinetic energy is set to
    /// exactly (dof/2) kT.
    pub temperature: f64,
    /// Mass per species (empty: all 1).
    pub masses: Vec<f64>,
    /// Collision prediction for non-spherical pairs.
    pub predictor: PredictorOptions,
    /// Rotate every body with its own principal moments (an asymmetric top
    /// in closed form; symmetric for bodies of revolution); otherwise every
    /// body is a spherical top with the mean moment (De Michele's choice,
    /// eqs. 4–6).
    pub true_inertia: bool,
    /// Neighbour lists (Donev et al.; De Michele Sec. 3.3): each body gets
    /// a neighbour region fixed where the body was when it was built, and
    /// collisions are predicted only between bodies whose regions overlap;
    /// a region is rebuilt when its body is about to leave it. Systems of
    /// spheres use the bounding sphere grown by this shell (rebuilt when the
    /// centre has moved by the shell); any other system the paper's
    /// oriented boxes, the body's bounding box grown by the shell on every
    /// face (rebuilt when the turning body is about to poke out of a face).
    /// `None`: cells with cell-crossing events.
    pub neighbour_shell: Option<f64>,
}

impl Default for DynamicsOptions {
    fn default() -> Self {
        Self {
            temperature: 1.0,
            masses: Vec::new(),
            predictor: PredictorOptions::default(),
            true_inertia: false,
            neighbour_shell: None,
        }
    }
}

/// Below this packing fraction hard spheres run faster with cells.
pub const SPHERE_LISTS_FROM: f64 = 0.45;

/// The same for polydisperse spheres, whose cells are as wide as their
/// largest pair: 1000 spheres of Gaussian sizes (std 0.05, 0.1, 0.2) ran
/// lists in 0.8–0.9 of the cells' time at φ = 0.3 (0.6 of it at std 0.2)
/// and 0.5 at φ = 0.4, cells in 0.8 of the lists' at φ = 0.2
/// (docs/polydisperse.md).
pub const POLYDISPERSE_SPHERE_LISTS_FROM: f64 = 0.3;

/// The neighbour structure a scene gets unless it names one, at packing
/// fraction `packing_fraction`: for spheres, cells below φ = 0.45 (0.3
/// where the bodies have sizes of their own, `polydisperse`) and lists
/// (bounding spheres) with a shell of a quarter of the diameter above; for every other system, oriented-box lists with a shell of a
/// tenth of the thinnest body's thickness (twice its smallest half-extent)
/// times the square root of the largest elongation (longest over shortest
/// half-extent) at φ = 0.5, wider where the free path between collisions
/// is longer, by (3 + ℓ(φ)/ℓ(0.5))/4: long and flat bodies rebuild their
/// boxes often, and so do bodies that fly far between collisions. Chosen
/// from `hardbody bench edmd-shell`, `edmd-density`, `edmd-elongation`
/// and the runs of docs/benchmarks/edmd-bodies-2026-12-02.md.
pub fn automatic_neighbour_shell(
    species: &[Species],
    packing_fraction: f64,
    polydisperse: bool,
) -> Option<f64> {
    if species.iter().all(|s| s.shape.is_sphere()) {
        let diameter = species
            .iter()
            .map(|s| 2.0 * s.shape.bounding_radius())
            .fold(f64::INFINITY, f64::min);
        // Read to 10⁻⁶ (as `free_path_scale` does), so that a plan's φ and
        // its run's, which differ in the last bits, choose alike.
        let micro = |phi: f64| (phi * 1e6).round();
        let from = if polydisperse {
            POLYDISPERSE_SPHERE_LISTS_FROM
        } else {
            SPHERE_LISTS_FROM
        };
        (micro(packing_fraction) >= micro(from)).then_some(0.25 * diameter)
    } else {
        let thickness = species
            .iter()
            .map(|s| 2.0 * s.shape.min_half_extent())
            .fold(f64::INFINITY, f64::min);
        let elongation = species
            .iter()
            .map(|s| {
                let h = s.shape.obb_half_extents();
                h.max() / h.min()
            })
            .fold(1.0, f64::max);
        Some(0.1 * thickness * elongation.sqrt() * free_path_scale(packing_fraction))
    }
}

/// (3 + ℓ(φ)/ℓ(0.5))/4, at most 20: how a body's best neighbour shell
/// grows with the free path ℓ between collisions. A box is left by
/// turning as well as by flight: three quarters of the shell at φ = 0.5
/// stays as ℓ shrinks, a quarter grows with it (1.76 at φ = 0.3, 6.5 at
/// φ = 0.1, where ellipsoids and cubes ran 1.7 and 2.3 times as long with
/// the shell of φ = 0.5). ℓ is the Enskog free path of hard spheres at
/// the same packing fraction, ℓ/σ = 1/(6√2 φ g(σ)) with the
/// Carnahan–Starling contact value g(σ) = (1 − φ/2)/(1 − φ)³ (Hansen &
/// McDonald, Theory of Simple Liquids, §8.2); only its ratio is used.
fn free_path_scale(packing_fraction: f64) -> f64 {
    let inverse_free_path = |phi: f64| phi * (1.0 - 0.5 * phi) / (1.0 - phi).powi(3);
    // Read to 10⁻⁶, so that a plan's φ and its run's, which differ in the
    // last bits, give one shell.
    let phi = ((packing_fraction * 1e6).round() * 1e-6).clamp(1e-6, 0.74);
    let free_path = inverse_free_path(0.5) / inverse_free_path(phi);
    (0.25 * (3.0 + free_path)).min(20.0)
}

/// The neighbour regions of [`DynamicsOptions::neighbour_shell`]: spheres,
/// or oriented boxes.
#[derive(Debug, Clone)]
struct NeighbourSpheres {
    shell: f64,
    /// Per species: the largest distance from the centre to a point of the
    /// region (bounding radius + shell for spheres, the box's half-diagonal
    /// for boxes).
    reach: Vec<f64>,
    /// Polydisperse spheres: per body, its own radius + shell (its
    /// species' `reach` is its largest body's); empty otherwise.
    body_reach: Vec<f64>,
    /// Where each body's region is centred (its centre when it was built,
    /// wrapped into the box).
    centres: Vec<V3>,
    /// Spheres, or oriented boxes and what shapes them.
    regions: Regions,
    lists: NeighbourLists,
    /// Scratch for relinking a body's list.
    marks: Marks,
}

/// The shape of the neighbour regions.
#[derive(Debug, Clone)]
enum Regions {
    /// Each body's bounding sphere grown by the shell.
    Spheres,
    /// Oriented boxes: per species the half-extents (the body's bounding
    /// box grown by the shell), per body the box axes (the body's axes
    /// when it was built).
    Boxes {
        half: Vec<V3>,
        axes: Vec<Matrix3<f64>>,
    },
}

/// A box region stops being trusted when its body is this fraction of the
/// shell from a face (the escape search stops there, never past the face).
const BOX_ESCAPE_MARGIN: f64 = 0.02;

/// A body's motion since its last event.
///
/// The first cache line holds all that a closed-form (sphere) search reads
/// of a partner: position, velocity, time and horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
struct Body {
    /// Centre at `time` (wrapped into the box at cell crossings only).
    position: V3,
    velocity: V3,
    /// The time the stored pose belongs to.
    time: f64,
    /// Where its last collision search stopped: its crossing time or the
    /// earliest collision it found, whichever is first (any later
    /// collision of this body will be invalidated by that event). If that
    /// collision is invalidated by the partner instead, the search is
    /// renewed from there.
    horizon: f64,
    orientation: UnitQuaternion<f64>,
    /// Lab frame.
    angular_velocity: V3,
    species: u16,
    /// Its index in `kinds`: its species', or with sizes of a shape that
    /// is not a sphere one of its own.
    kind: u32,
}

// Two cache lines, the first all a sphere search reads of a partner.
const _: () = assert!(std::mem::size_of::<Body>() == 128);

/// One body as the dynamics stores it: the pose at its own time (not the
/// common time), and its velocities.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BodyDump {
    /// Species index.
    pub species: u16,
    /// The time the pose belongs to (relative to `time_origin`).
    pub time: f64,
    /// Centre at `time`.
    pub position: [f64; 3],
    /// [w, x, y, z] at `time`.
    pub orientation: [f64; 4],
    /// Velocity.
    pub velocity: [f64; 3],
    /// Angular velocity, lab frame, at `time`.
    pub angular_velocity: [f64; 3],
}

/// Everything the predictions depend on, to the bit: each body's stored
/// pose and time (they differ from body to body between events), the
/// clock and the box. Written when a run fails so that the failure can be
/// replayed: [`Dynamics::from_dump`] predicts every event again from the
/// same stored poses, and predictions are canonical (a function of the
/// two stored poses alone; see `closed_form`), so the failing event comes
/// back.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DynamicsDump {
    /// Absolute time of `now` = 0.
    pub time_origin: f64,
    /// The clock, relative to `time_origin`.
    pub now: f64,
    /// Collisions so far.
    pub collisions: u64,
    /// Collisions at the last rebase (the next comes 32 N collisions
    /// after it).
    pub collisions_at_rebase: u64,
    /// Box edges.
    pub box_lengths: [f64; 3],
    /// Tilt factors (xy, xz, yz); zero in an orthorhombic box (and in
    /// dumps written before tilted boxes ran the dynamics).
    #[serde(default)]
    pub tilts: [f64; 3],
    /// Hard walls per axis.
    pub walls: [bool; 3],
    /// Per body.
    pub bodies: Vec<BodyDump>,
    /// The growth on the dump's clock, if the bodies grow (a jam's chunk):
    /// the species to replay with are then the largest the bodies become
    /// (those of [`Dynamics::species`]), scaled by `growth.at(now)` now.
    #[serde(default)]
    pub growth: Option<Growth>,
    /// Polydisperse spheres: each body's size relative to its species'
    /// shape ([`crate::state::System::sizes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sizes: Option<Vec<f64>>,
}

/// Event-driven molecular dynamics of hard bodies in a periodic box.
#[derive(Debug, Clone)]
pub struct Dynamics {
    box_: PeriodicBox,
    species: Vec<Species>,
    kinds: Vec<Kind>,
    /// Closed-form contact distance per species pair (spheres), else None.
    contact_sums: Vec<Option<f64>>,
    /// Polydisperse bodies: each body's size, the scale factor of its
    /// species' shape (as [`crate::state::System::sizes`]); `None` where every body has
    /// its species' size.
    sizes: Option<Vec<f64>>,
    /// With `sizes`: each body's bounding radius at its species' full
    /// size, whose sums are the contact distances of the pairs of spheres
    /// in place of `contact_sums`. With spheres alone the kinds' shapes
    /// are then their species' largest bodies', so that cells, neighbour
    /// spheres and bounds hold for every body; among other shapes each
    /// body has a kind at its own size. Empty without sizes.
    body_radii: Vec<f64>,
    /// Every pair in closed form (spheres only): a contact time is exact
    /// whenever it is found, so searches need no horizon, and a body that
    /// crosses into a cell searches only the layer of cells it now
    /// neighbours (Smallenburg's scheme); otherwise a crossing renews the
    /// whole search, which stopped at it.
    ///
    /// Every prediction, closed form or searched, is canonical: a body's
    /// stored pose changes only at its collisions and wall bounces
    /// (wrapped into the box there) and at rebases (at a collision), never
    /// at crossings or list rebuilds, and a pair is solved from the later
    /// of its two stored poses (searches: with the lower index as A, on a
    /// step grid the horizon does not cut, resumed with their solver
    /// state; see `predict_pair`); so the predicted times, and the
    /// trajectory, do not depend on when searches run or on the neighbour
    /// structure.
    closed_form: bool,
    /// Per axis: a pair can touch in more than one periodic image before
    /// its next crossing (fewer than four cells across the box, or one
    /// with neighbour lists; see `image_steps`); never with `closed_form`.
    narrow: [bool; 3],
    bodies: Vec<Body>,
    /// Per body: its free rotation from its stored pose, rebuilt wherever
    /// the stored pose or spin changes (a collision, a wall bounce, a
    /// rescheduling of everything); empty with `closed_form`, where no
    /// body turns.
    tops: Vec<FreeTop>,
    /// Per body: when it next leaves its cell or neighbour region (its
    /// events after that are invalidated there anyway, so none later is
    /// scheduled). Beside `bodies`, which keep a sphere search's reads in
    /// one cache line.
    crossing_times: Vec<f64>,
    /// Cells over the bodies' centres (with crossing events), or with
    /// neighbour lists over their neighbour spheres' centres (updated when
    /// a sphere is rebuilt, to find the spheres it overlaps).
    cells: CellList,
    cell_lengths: V3,
    /// Neighbour lists, when the options ask for them.
    neighbours: Option<NeighbourSpheres>,
    /// Scratch: the bodies a search looks at.
    candidates: Vec<u32>,
    /// Scratch: the members of the cells around a sphere, filled (not
    /// cleared) by each search with cells.
    around: Box<[u32; AROUND]>,
    /// Per body, with cells and closed-form pairs: what to add to the
    /// stored position to put it in its cell's image (the pose is kept
    /// through periodic crossings; see `closed_form`).
    cell_shifts: Vec<V3>,
    calendar: Calendar,
    predictor: Predictor,
    /// Time since `origin`.
    now: f64,
    /// Absolute time of `now` = 0 (moved forward at rebases).
    origin: f64,
    /// Collisions at the last rebase.
    collisions_at_rebase: u64,
    collisions: u64,
    interval: Interval,
    /// Σ m v⊗v, twice the translational kinetic energy in its trace
    /// (changes only at collisions).
    kinetic: SymmetricTensor,
    degrees_of_freedom: f64,
    packing_fraction: f64,
    /// Whether any body rotates (else orientations are never touched).
    rotating: bool,
    /// Per species: the body axis S₂ and C₂ follow (rotating anisotropic
    /// species only).
    molecular_axes: Vec<Option<V3>>,
    /// Per body: the box lengths it has been wrapped by (unwrapped centre =
    /// centre + image).
    images: Vec<V3>,
    /// Per body: unwrapped centre and lab-frame molecular axis at the
    /// reference time of the MSD and C₂.
    reference: Vec<(V3, Option<V3>)>,
    /// The distance solver's state at each scheduled collision's predicted
    /// contact, by (first, second) body: the collision starts from it.
    found: std::collections::HashMap<(u32, u32), WarmStart>,
    /// Scratch: searches put off until the cheap ones are done (partner,
    /// the time it got to, where to resume it).
    deferred: Vec<(u32, f64, Progress)>,
    /// Events processed at the current instant (a guard against loops).
    events_at_now: u64,
    /// The pair of the last collisions that changed no velocity, and how
    /// many in a row.
    futile: (u32, u32, u64),
    /// The options it was built with (to rebuild itself).
    options: DynamicsOptions,
    /// Every collision (time, lower index, higher index) while on.
    trace: Option<Vec<(f64, u32, u32)>>,
    /// Lubachevsky–Stillinger growth, if the bodies grow: each is its
    /// species' shape scaled by `growth.at(t)` (t on the dynamics' clock,
    /// relative to its origin). The species' shapes are the largest the
    /// bodies become (the scale reaches 1 at [`Dynamics::growth_ends`]):
    /// cells, neighbour regions, bounding spheres and turn bounds are
    /// theirs, so all stay conservative up to then, and only distances,
    /// support planes, contact times and impulses see the scale.
    growth: Option<Growth>,
}

/// The outcome of a search for a body's next wall contact.
#[derive(Debug, Clone, Copy, PartialEq)]
enum WallContact {
    /// It touches the wall normal to `axis` (+L/2 if `up`) at `time`.
    At { time: f64, axis: usize, up: bool },
    /// No contact before the end of the search.
    None,
    /// The search stopped here without deciding.
    SearchedTo(f64),
}

/// How a pair's search ended (times absolute).
#[derive(Debug, Clone, Copy)]
enum PairSearch {
    /// A contact at this time, with the solver state there.
    Contact(f64, Option<WarmStart>),
    /// None before the horizon.
    Apart,
    /// Out of budget at this time; the progress to resume from is in the
    /// caller's slot.
    Unfinished(f64),
}

/// Steps a pair's contact search may take before it is put off behind the
/// other pairs of the same body.
const CHEAP_SEARCH: u32 = 16;

/// Body `b`'s centre and orientation at time `t`, by free motion from its
/// stored pose.
#[inline]
fn body_pose(kinds: &[Kind], b: &Body, t: f64) -> (V3, UnitQuaternion<f64>) {
    let dt = t - b.time;
    let r = position_after(&b.position, &b.velocity, dt);
    let q = body_spin(kinds, b).orientation_after(dt);
    (r, q)
}

impl Dynamics {
    /// Rebuilds body `i`'s free rotation from its stored pose.
    #[inline]
    pub(super) fn refresh_top(&mut self, i: usize) {
        if let Some(top) = self.tops.get_mut(i) {
            *top = body_spin(&self.kinds, &self.bodies[i]);
        }
    }

    /// Body `i`'s free rotation from its stored pose: the one kept, or
    /// built where none are (turning spheres whose pairs are all in
    /// closed form).
    #[inline]
    pub(super) fn top(&self, i: usize) -> std::borrow::Cow<'_, FreeTop> {
        match self.tops.get(i) {
            Some(top) => std::borrow::Cow::Borrowed(top),
            None => std::borrow::Cow::Owned(body_spin(&self.kinds, &self.bodies[i])),
        }
    }
}

/// A body's free rotation since its stored time.
#[inline]
fn body_spin(kinds: &[Kind], b: &Body) -> FreeTop {
    kinds[b.kind as usize].spin(&b.orientation, &b.angular_velocity)
}

#[cfg(test)]
mod tests {
    use super::collisions::FUTILE_COLLISIONS;
    use super::*;
    use crate::state::{Particle, Species, System};
    use rand::SeedableRng;

    /// Species of the shapes written in `shapes`, not turning.
    fn spheres(shapes: &[&str]) -> Vec<Species> {
        shapes
            .iter()
            .map(|s| Species {
                name: s.to_string(),
                shape: s.parse().unwrap(),
                rotation: false,
            })
            .collect()
    }

    /// A binary hard-sphere mixture run for a while, so that the bodies'
    /// stored times differ and some have crossed the box.
    fn mixture(neighbour_shell: Option<f64>) -> Dynamics {
        let species = spheres(&["Sphere(radius: 0.5)", "Sphere(radius: 0.3)"]);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let box_ = PeriodicBox::new(Vector3::repeat(7.0)).unwrap();
        let system = crate::state::start::lattice(box_, species, &[100, 100], &mut rng).unwrap();
        let options = DynamicsOptions {
            neighbour_shell,
            ..DynamicsOptions::default()
        };
        let mut md = Dynamics::from_state(&system, &options, &mut rng).unwrap();
        md.run_collisions(5_000).unwrap();
        md
    }

    /// Spheres at φ = 0.45 get lists whichever last bits the packing
    /// fraction has (a plan's φ and its run's, counted body by body, may
    /// differ there), and cells below; polydisperse ones from φ = 0.3.
    #[test]
    fn spheres_choose_lists_from_phi_045_to_round_off() {
        let species = spheres(&["Sphere(radius: 0.5)"]);
        let at = |phi: f64| automatic_neighbour_shell(&species, phi, false);
        assert_eq!(at(0.45), Some(0.25));
        assert_eq!(at(0.45f64.next_down()), Some(0.25));
        assert_eq!(at(0.4499999999999999), Some(0.25));
        assert_eq!(at(0.4499), None);
        // Polydisperse spheres from φ = 0.3.
        let sized = |phi: f64| automatic_neighbour_shell(&species, phi, true);
        assert_eq!(sized(0.4), Some(0.25));
        assert_eq!(sized(0.3f64.next_down()), Some(0.25));
        assert_eq!(sized(0.2999), None);
    }

    /// A thousand collisions of one pair in a row that change nothing are
    /// let be (a grazing pair may give a few); the next is reported, with
    /// the pair. A collision that changes velocities, or one of another
    /// pair, starts the count again.
    #[test]
    fn futile_collisions_of_one_pair_are_reported_past_the_limit() {
        let mut md = mixture(None);
        for _ in 0..FUTILE_COLLISIONS {
            md.count_futile(3, 8, true).unwrap();
        }
        md.count_futile(3, 8, false).unwrap();
        md.count_futile(1, 2, true).unwrap();
        for _ in 0..FUTILE_COLLISIONS {
            md.count_futile(3, 8, true).unwrap();
        }
        assert!(matches!(
            md.count_futile(3, 8, true),
            Err(EdmdError::Futile {
                i: 3,
                j: 8,
                collisions,
                ..
            }) if collisions == FUTILE_COLLISIONS + 1
        ));
    }

    /// Each body's list holds exactly the bodies whose neighbour spheres
    /// overlap its own (brute force over all pairs), also around large
    /// spheres among small ones, whose lists outgrow a rebuild's first
    /// gathering; before and after a run of rebuilds.
    #[test]
    fn lists_hold_exactly_the_overlapping_spheres() {
        let species = spheres(&["Sphere(radius: 1.6)", "Sphere(radius: 0.1)"]);
        // Six large spheres 6 apart, small ones placed at random where
        // they overlap nothing.
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let box_ = PeriodicBox::new(Vector3::repeat(12.0)).unwrap();
        let mut u = crate::test_support::uniform(7);
        let mut particles: Vec<Particle> = (0..6)
            .map(|k| Particle {
                position: Vector3::from_fn(|a, _| if (k >> a) & 1 == 0 { -3.0 } else { 3.0 }),
                orientation: UnitQuaternion::identity(),
                species: 0,
            })
            .collect();
        while particles.len() < 5006 {
            let position = Vector3::from_fn(|_, _| 12.0 * (u() - 0.5));
            let radius = |p: &Particle| if p.species == 0 { 1.6 } else { 0.1 };
            if particles
                .iter()
                .all(|p| box_.minimum_image(&(p.position - position)).norm() > radius(p) + 0.1)
            {
                particles.push(Particle {
                    position,
                    orientation: UnitQuaternion::identity(),
                    species: 1,
                });
            }
        }
        let system = System::new(box_, species, particles).unwrap();
        let options = DynamicsOptions {
            neighbour_shell: Some(0.3),
            ..DynamicsOptions::default()
        };
        let mut md = Dynamics::from_state(&system, &options, &mut rng).unwrap();
        let check = |md: &Dynamics| {
            let spheres = md.neighbours.as_ref().unwrap();
            let reach = |k: usize| match spheres.body_reach.get(k) {
                Some(r) => *r,
                None => spheres.reach[md.bodies[k].species as usize],
            };
            let mut longest = 0;
            for i in 0..md.bodies.len() {
                let mut listed = spheres.lists.of(i).to_vec();
                listed.sort_unstable();
                let overlapping: Vec<u32> = (0..md.bodies.len())
                    .filter(|&j| {
                        let d = md
                            .box_
                            .minimum_image(&(spheres.centres[j] - spheres.centres[i]));
                        j != i && d.norm() <= reach(i) + reach(j)
                    })
                    .map(|j| j as u32)
                    .collect();
                assert_eq!(listed, overlapping, "{i}");
                longest = longest.max(listed.len());
            }
            longest
        };
        assert!(check(&md) > 64);
        md.run_collisions(5_000).unwrap();
        assert!(check(&md) > 64);
    }

    /// A batch of sphere pairs is skipped only when none can touch before
    /// its lane's horizon: never when a lane's computed time is before it
    /// (by one ulp), always when every lane's is well after it (the bound
    /// c/(−2b) is at least half the contact time).
    #[test]
    fn a_batch_is_skipped_only_when_no_contact_comes_before_its_horizon() {
        let md = mixture(Some(0.2));
        let n = md.bodies.len();
        let mut u = crate::test_support::uniform(5);
        let (mut kept, mut skipped) = (0, 0);
        for _ in 0..20_000 {
            let i = (u() * n as f64) as usize;
            let j = (u() * n as f64) as usize;
            if i == j {
                continue;
            }
            let products = md.lane_products::<false, false>(i, &[j; LANES], |j| md.sigma(i, j));
            let [t, ..] = md.lane_times(&products);
            if !t.is_finite() {
                continue;
            }
            assert!(
                products.may_meet_before(&[t.next_up(); LANES]),
                "{i} {j} at {t}"
            );
            assert!(products.may_meet_before(&[f64::INFINITY; LANES]), "{i} {j}");
            kept += 1;
            let t0 = md.bodies[i].time.max(md.bodies[j].time);
            if t > md.now {
                let early = t0 + 0.49 * (t - t0);
                assert!(!products.may_meet_before(&[early; LANES]), "{i} {j} at {t}");
                skipped += 1;
            }
        }
        assert!(kept > 500 && skipped > 500, "{kept} {skipped}");
    }

    /// The contact times computed side by side are those of the pair
    /// by pair search, to the bit, for any partners (near and far, either
    /// species, meeting or not); and the earliest over a list is the same
    /// pair at the same time by either.
    #[test]
    fn side_by_side_contact_times_are_the_pairwise_ones_to_the_bit() {
        let md = mixture(Some(0.2));
        assert!(md.closed_form);
        let n = md.bodies.len();
        let spheres = md.neighbours.as_ref().unwrap();
        let mut u = crate::test_support::uniform(3);
        let (mut finite, mut never) = (0, 0);
        for _ in 0..5_000 {
            let i = (u() * n as f64) as usize;
            // Listed partners (near) and any body (mostly far).
            let list = spheres.lists.of(i);
            let lanes: [usize; LANES] = std::array::from_fn(|k| {
                if k % 2 == 0 && !list.is_empty() {
                    list[(u() * list.len() as f64) as usize] as usize
                } else {
                    (u() * n as f64) as usize
                }
            });
            let times = md.closed_form_contacts(i, &lanes);
            for (t, &j) in times.iter().zip(&lanes) {
                if j == i {
                    continue;
                }
                let pairwise = md.closed_form_contact(i, j);
                assert_eq!(t.to_bits(), pairwise.to_bits(), "{i} {j}: {t} {pairwise}");
                if t.is_finite() {
                    finite += 1;
                } else {
                    never += 1;
                }
            }
        }
        assert!(finite > 1000 && never > 1000, "{finite} {never}");
        let same_earliest = |md: &Dynamics, i: usize| {
            let list = md.neighbours.as_ref().unwrap().lists.of(i);
            let keep = |j: usize| !j.is_multiple_of(3);
            let pairwise = md.earliest_closed_form(
                i,
                list.iter().map(|&j| j as usize).filter(|&j| keep(j)),
                f64::INFINITY,
            );
            let listed = md.earliest_closed_form_listed(i, list, keep, f64::INFINITY);
            assert_eq!(listed, pairwise, "{i}");
        };
        for i in 0..n {
            same_earliest(&md, i);
        }
        // Each body in turn at now, the others not (the searches after a
        // collision): the same bits without moving it by zero.
        let mut md = md;
        let mut at_now = 0;
        for i in 0..n {
            let stored = md.bodies[i];
            md.advance(i);
            at_now += usize::from(stored.time != md.now);
            let list = md.neighbours.as_ref().unwrap().lists.of(i);
            for lanes in list.chunks_exact(LANES) {
                let lanes: [usize; LANES] = std::array::from_fn(|k| lanes[k] as usize);
                let products = md.lane_products::<true, false>(i, &lanes, |j| md.sigma(i, j));
                for (t, &j) in md.lane_times(&products).iter().zip(&lanes) {
                    let pairwise = md.closed_form_contact(i, j);
                    assert_eq!(t.to_bits(), pairwise.to_bits(), "{i} {j}: {t} {pairwise}");
                }
            }
            same_earliest(&md, i);
            md.bodies[i] = stored;
        }
        assert!(at_now > n / 2, "{at_now}");
        // A pair overlapping by rounding and closing, stored before now:
        // it touches now, not in the past.
        let (i, j) = (0, md.neighbours.as_ref().unwrap().lists.of(0)[0] as usize);
        let sigma = md.contact_sums[md.pair_index(i, j)].unwrap();
        let t0 = md.now - 0.25;
        let (position, velocity) = (md.bodies[i].position, md.bodies[i].velocity);
        md.bodies[i].time = t0;
        md.bodies[j].time = t0;
        md.bodies[j].position = position + Vector3::x() * sigma * (1.0 - 1e-12);
        md.bodies[j].velocity = velocity - Vector3::x();
        let times = md.closed_form_contacts(i, &[j; LANES]);
        assert_eq!(times, [md.now; LANES]);
        assert_eq!(md.closed_form_contact(i, j), md.now);
    }
}
