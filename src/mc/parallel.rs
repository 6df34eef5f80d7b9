//! Parallel sweeps by domain decomposition (HPMC's checkerboard, in one
//! dimension): the box is cut along its longest axis into an even number
//! of slabs, each at least one interaction range wide, shifted by a random
//! offset every sweep. Slabs of one colour (even or odd) are separated by
//! slabs of the other, so they are swept at once, every move confined to
//! its slab (a move that would leave it is rejected, which keeps the
//! proposal symmetric) and the other colour frozen; the two colours go in
//! random order.
//!
//! Hard spheres in slabs wide enough share one system: every member sweeps
//! its slabs on its own copy of the system's header (the scalars; the
//! vectors of positions, cells and lists are the system's), and members
//! sweeping slabs two apart touch disjoint storage (`SharingTerms` says
//! how wide that asks, and why), which they reach element by element
//! ([`crate::space::slots::Slots`]), so that no member reads what another
//! writes: Miri's race detector, under Tree Borrows, runs the small
//! sharing team of `tests/mc_parallel.rs` clean. Accepted moves are
//! placed once, by the member that made them, so placing runs in
//! parallel as trials do. What is not shared: the growth of a cell or
//! list (room is made beforehand for the most hard spheres allow, and
//! growing inside a team panics, never moves storage from under another
//! member) and the review of the Verlet lists, which member 0 makes
//! between sweeps from the members' windows, with the box move, while the
//! others wait. A sweep whose slabs a box move made too thin is member
//! 0's alone.
//!
//! Other systems keep replicas: each thread sweeps its slabs on a system
//! of its own, the first thread on the caller's, the others on replicas
//! kept between sweeps ([`ParallelSweeps`]). A replica is exact for its
//! own slabs (its cells and lists follow its moves as in a serial sweep)
//! and for the frozen
//! colour; the slabs other threads sweep lie out of reach. After each
//! colour every thread places the moves the others made into its own
//! system, so that all of them hold the same state again. A trial move
//! costs what it costs in a serial sweep; what is not parallel is each
//! thread placing the others' accepted moves (and, where the replicas are
//! stale, one copy of the system). In NPT every thread makes the box move
//! on its own system: they agree, so do the answers, and the replicas
//! stay in step. A team handed several sweeps at once
//! ([`ParallelSweeps::sweeps`]) is woken once for all of them.
//!
//! Every slab draws from its own stream keyed on (seed, sweep, colour,
//! slab), and the slabs do not depend on the thread count below
//! [`MIN_SLABS`] / 2 threads: a run is the same for one thread and for
//! two, and the same whether the members share the system or keep
//! replicas (the lists' review, deferred or not, changes no answer).

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::sync::RwLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use super::moves::{Counts, Ensemble, MoveSizes, box_move, particle_moves, sweep};
use crate::state::{Neighbours, SPHERE_LISTS_REVIEW, System};

type V3 = Vector3<f64>;

/// The random stream of one (seed, sweep, colour, slab). Each part is
/// mixed in after the key so far is scrambled, so that no two parts cancel
/// (a seed equal to the sweep index once gave every sweep one stream).
fn stream(seed: u64, sweep: u64, colour: u64, slab: u64) -> Pcg64 {
    let mut key = 0x9E37_79B9_7F4A_7C15;
    for part in [seed, sweep, colour, slab] {
        key = (key ^ part)
            .wrapping_mul(0xBF58_476D_1CE4_E5B9)
            .rotate_left(31);
    }
    Pcg64::seed_from_u64(key)
}

/// A barrier for a team that is all running at once: the last to arrive
/// bumps the generation the others spin on. A member that panics marks it
/// broken (see [`Member`]), and the others panic at it instead of
/// spinning for ever.
struct SpinBarrier {
    team: usize,
    arrived: AtomicUsize,
    generation: AtomicUsize,
    broken: AtomicBool,
}

impl SpinBarrier {
    fn new(team: usize) -> Self {
        Self {
            team,
            arrived: AtomicUsize::new(0),
            generation: AtomicUsize::new(0),
            broken: AtomicBool::new(false),
        }
    }

    fn wait(&self) {
        let generation = self.generation.load(Ordering::Acquire);
        if self.arrived.fetch_add(1, Ordering::AcqRel) + 1 == self.team {
            self.arrived.store(0, Ordering::Relaxed);
            self.generation.fetch_add(1, Ordering::Release);
        } else {
            while self.generation.load(Ordering::Acquire) == generation {
                assert!(
                    !self.broken.load(Ordering::Relaxed),
                    "another thread of the parallel sweep panicked"
                );
                std::hint::spin_loop();
            }
        }
    }
}

/// Held by each member of a team while it works: if the member unwinds,
/// the barrier is marked broken.
struct Member<'a>(&'a SpinBarrier);

impl Drop for Member<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.broken.store(true, Ordering::Relaxed);
        }
    }
}

/// Slabs per sweep at least: two per colour, so that two threads share
/// every colour, whatever the thread count up to two (the trajectory does
/// not depend on it).
pub const MIN_SLABS: usize = 4;

/// The number of slabs: twice the threads (at least [`MIN_SLABS`]), but
/// no more than the slabs at least `range` wide that an even count fits
/// in `length`; `None` when not even two fit.
fn slab_count(length: f64, range: f64, threads: usize) -> Option<usize> {
    let fit = (length / range).floor() as usize;
    let fit = fit - fit % 2;
    (fit >= 2).then(|| (2 * threads).max(MIN_SLABS).min(fit))
}

/// Particles from which a Monte Carlo stage sweeps on slabs (measured to
/// pay at N = 4096 on two cores; smaller systems not yet measured).
pub const SLABS_FROM: usize = 4000;

/// Whether a stage of `n` particles sweeps on slabs ([`ParallelSweeps`]),
/// on any thread count, so that its trajectory is the same on one core
/// and on two: from [`SLABS_FROM`] particles. (On one thread the slab
/// sweep of dense spheres on Verlet lists measured 5 % slower than the
/// serial sweep; on two, members sharing the system, 1.1-1.8x faster
/// than serial, as the host's load allowed: the same trajectory on any
/// machine is worth that.)
pub fn sweeps_on_slabs(n: usize) -> bool {
    n >= SLABS_FROM
}

/// A move to hand to the other threads: the particle's final pose in a
/// colour.
type Placed = (usize, V3, UnitQuaternion<f64>, Matrix3<f64>);

/// Sweeps run back to back in one team at most (the run hands over the
/// sweeps up to its next tuning, sample, stats or frame; this bounds how
/// long an interruption waits).
pub const MAX_CHUNK: usize = 16;

/// Where the slabs of one sweep lie.
#[derive(Debug, Clone, Copy)]
struct Slabs {
    axis: usize,
    length: f64,
    count: usize,
    offset: f64,
    inverse_width: f64,
}

impl Slabs {
    /// The slabs of a sweep of `system` on `threads` threads, the offset
    /// drawn from `master`; `None` when the box is too small for two.
    fn of_sweep(system: &System, threads: usize, master: &mut Pcg64) -> Option<Self> {
        let lengths = system.periodic_box().lengths();
        let axis = lengths.imax();
        let length = lengths[axis];
        let count = Self::count_in(system, threads)?;
        let width = length / count as f64;
        Some(Self {
            axis,
            length,
            count,
            offset: master.r#gen::<f64>() * width,
            inverse_width: 1.0 / width,
        })
    }

    /// How many slabs `system`'s box takes along its longest axis for
    /// `threads` threads ([`slab_count`]).
    fn count_in(system: &System, threads: usize) -> Option<usize> {
        let lengths = system.periodic_box().lengths();
        slab_count(lengths.max(), system.range, threads)
    }

    /// The slab of a position in the box: shift by the offset (under one
    /// slab), wrap into [0, L) by one compare.
    #[inline]
    fn slab_of(&self, r: &V3) -> usize {
        let mut s = r[self.axis] + 0.5 * self.length + self.offset;
        if s >= self.length {
            s -= self.length;
        }
        ((s.max(0.0) * self.inverse_width) as usize).min(self.count - 1)
    }

    /// The member of a team of `team` that sweeps slab `k`: each takes a
    /// contiguous share of each colour's slabs (members beyond the slabs
    /// take none).
    fn owner(&self, k: usize, team: usize) -> usize {
        (k / 2) / (self.count / 2).div_ceil(team)
    }
}

/// The barrier and the outboxes through which a team's members hand each
/// other the moves of a colour: two per member, for even and odd colours
/// (counted over the team's sweeps). A member refills the outbox of colour
/// n + 2 only after the barrier of colour n + 1, which every other member
/// reaches after it has read colour n's: one barrier per colour.
struct Exchange {
    barrier: SpinBarrier,
    outboxes: Vec<[RwLock<Vec<Placed>>; 2]>,
}

/// What a member keeps from sweep to sweep: the particles of each of its
/// slabs, in index order, and those it moved in a colour.
#[derive(Debug, Default)]
struct Scratch {
    slab_members: Vec<Vec<usize>>,
    moved: Vec<usize>,
    marked: Vec<bool>,
}

impl Scratch {
    /// Lists the particles of the slabs member `me` of `team` sweeps.
    fn sort(&mut self, system: &System, slabs: &Slabs, me: usize, team: usize) {
        self.slab_members.resize_with(slabs.count, Vec::new);
        for members in &mut self.slab_members {
            members.clear();
        }
        for (i, r) in system.positions.iter().enumerate() {
            let k = slabs.slab_of(r);
            if slabs.owner(k, team) == me {
                self.slab_members[k].push(i);
            }
        }
    }
}

/// The sweeps a team is handed.
#[derive(Debug, Clone, Copy)]
struct Work<'a> {
    sizes: &'a MoveSizes,
    ensemble: &'a Ensemble,
    /// One per sweep.
    seeds: &'a [u64],
    /// The index of the first sweep.
    first_index: u64,
    /// The threads the slabs are counted for (the pool's).
    threads: usize,
}

/// The work of member `me` of a team of `team` in sweeps `first_index..`
/// keyed on `seeds`, on its own `system`, handing its moves to the others
/// through `exchange` (none for a team of one). Every member draws the
/// same master stream and places every move, so that all end each sweep
/// in the same state, and all make the same box move (their systems
/// agree, so do the answers); only member 0 counts the moves that every
/// member makes.
fn member_sweeps(
    (me, team): (usize, usize),
    exchange: Option<&Exchange>,
    system: &mut System,
    work: &Work,
) -> Counts {
    let Work {
        sizes,
        ensemble,
        seeds,
        first_index,
        threads,
    } = *work;
    let mut counts = Counts::default();
    let mut scratch = Scratch::default();
    scratch.marked.resize(system.len(), false);
    // Colours swept so far (the outboxes alternate with them).
    let mut colours_done = 0usize;
    for (j, &seed) in seeds.iter().enumerate() {
        let index = first_index + j as u64;
        let mut master = stream(seed, index, u64::MAX, u64::MAX);
        let Some(slabs) = Slabs::of_sweep(system, threads, &mut master) else {
            let c = sweep(system, sizes, ensemble, &mut master);
            if me == 0 {
                counts += c;
            }
            continue;
        };
        scratch.sort(system, &slabs, me, team);
        let first = usize::from(master.r#gen::<bool>());
        for colour in [first, 1 - first] {
            scratch.moved.clear();
            let moved = &mut scratch.moved;
            counts += colour_moves(
                system,
                &scratch.slab_members,
                (&slabs, colour),
                (seed, index),
                sizes,
                |i| {
                    if exchange.is_some() {
                        moved.push(i);
                    }
                },
            );
            if let Some(exchange) = exchange {
                exchange.share(
                    me,
                    colours_done % 2,
                    system,
                    &scratch.moved,
                    &mut scratch.marked,
                );
            }
            colours_done += 1;
        }
        if let Ensemble::Npt {
            pressure,
            anisotropic,
        } = *ensemble
        {
            let accepted = box_move(system, pressure, sizes.volume, anisotropic, &mut master);
            if me == 0 {
                counts.volume.record(accepted);
            }
        }
    }
    counts
}

/// The moves of the slabs of `colour` listed in `slab_members` (those of
/// other members empty), each slab drawing from its stream keyed on
/// (`seed`, `index`, colour, slab) and every move confined to its slab;
/// `accepted` hears of each particle moved.
fn colour_moves(
    system: &mut System,
    slab_members: &[Vec<usize>],
    (slabs, colour): (&Slabs, usize),
    (seed, index): (u64, u64),
    sizes: &MoveSizes,
    mut accepted: impl FnMut(usize),
) -> Counts {
    let mut counts = Counts::default();
    for k in (colour..slabs.count).step_by(2) {
        let members = &slab_members[k];
        if members.is_empty() {
            continue;
        }
        let mut rng = stream(seed, index, colour as u64, k as u64);
        let box_ = *system.periodic_box();
        counts += particle_moves(
            system,
            members.len(),
            |rng: &mut Pcg64| members[rng.gen_range(0..members.len())],
            sizes,
            &mut rng,
            |r| slabs.slab_of(&box_.wrap_near(r)) == k,
            |i, _, _, moved| {
                if moved {
                    accepted(i)
                }
            },
        );
    }
    counts
}

impl Exchange {
    /// Hands the last pose of each particle in `moved` to the others, and
    /// places theirs in `system` (through the outboxes of `parity`).
    fn share(
        &self,
        me: usize,
        parity: usize,
        system: &mut System,
        moved: &[usize],
        marked: &mut [bool],
    ) {
        {
            let mut outbox = self.outboxes[me][parity]
                .write()
                .expect("no thread panicked");
            outbox.clear();
            for &i in moved {
                if !std::mem::replace(&mut marked[i], true) {
                    let p = &system.particles[i];
                    outbox.push((i, p.position, p.orientation, system.rotations[i]));
                }
            }
            for &i in moved {
                marked[i] = false;
            }
        }
        self.barrier.wait();
        for (other, outboxes) in self.outboxes.iter().enumerate() {
            if other != me {
                let outbox = outboxes[parity].read().expect("no thread panicked");
                for &(i, position, orientation, rotation) in outbox.iter() {
                    system.place(i, position, orientation, rotation);
                }
            }
        }
    }
}

/// What a team of threads sharing one system of hard spheres must keep
/// to (see the module docs): the least slab width, and the room cells and
/// lists must have for no move of the team to grow them.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SharingTerms {
    /// Members sweeping slabs two apart (at least this wide) touch
    /// disjoint memory.
    least_width: f64,
    /// The most members a cell of the moves' cells can hold.
    cell_room: usize,
    /// The most references a reference cell of the sphere lists can hold,
    /// and the most entries of one list (0 without sphere lists).
    reference_room: usize,
    list_room: usize,
}

/// Room above which sharing is not worth its memory (spheres of very
/// different sizes: the smallest sets the bounds).
const MOST_ROOM: usize = 512;

/// The most points pairwise farther apart than `closest` in a box with
/// edges `sides`: the fewer of the boxes of diameter `closest` it divides
/// into (one point each at most) and of the balls of diameter `closest`
/// around the points the box grown by `closest` holds by volume.
fn room_in_box(sides: &V3, closest: f64) -> usize {
    let pieces: f64 = sides
        .iter()
        .map(|&s| (s * 3f64.sqrt() / closest).ceil().max(1.0))
        .product();
    let ball = std::f64::consts::PI / 6.0 * closest.powi(3);
    let by_volume = sides.iter().map(|&s| s + closest).product::<f64>() / ball;
    pieces.min(by_volume.floor()) as usize
}

/// The most points pairwise farther apart than `closest` within `radius`
/// of one of them, that one included (balls of diameter `closest` around
/// them, by volume).
fn room_in_ball(radius: f64, closest: f64) -> usize {
    ((radius + 0.5 * closest) / (0.5 * closest)).powi(3).floor() as usize
}

impl SharingTerms {
    /// The terms for `system` with slabs along `axis`; `None` unless it is
    /// hard spheres on one grid of cells (for other shapes and for
    /// spheres of very different sizes, members keep replicas).
    ///
    /// Member A sweeps slab k, member B slab k + 2 (W apart, W the slab
    /// width; one slab between them either way round the box). A trial
    /// centre q lies in the slab; the 27 cells around it hold only points
    /// less than two cell widths from q, and B writes only cells holding
    /// one of its centres: W ≥ 2 cell widths. With sphere lists of skin
    /// s (σ the largest contact distance, a centre never more than s/2
    /// from its reference): A relists from the 27 reference cells around
    /// a centre in its slab and moves references that lay within s/2 of
    /// it, so W ≥ 2 reference-cell widths + s/2; A touches the lists of
    /// spheres whose references lie within σ + s of a reference within
    /// s/2 of its slab, so W > 2(σ + s) + s; the centres it reads lie
    /// within σ + 2s of its slab, which that covers.
    fn of(system: &System, axis: usize) -> Option<Self> {
        let Neighbours::Cells(cells) = &system.cells else {
            return None;
        };
        if !system.all_spheres || system.ideal || system.plan.per_species {
            return None;
        }
        let lengths = system.periodic_box().lengths();
        let widths = |dims: [usize; 3]| V3::from_fn(|k, _| lengths[k] / dims[k] as f64);
        // The closest two centres come: the smallest contact distance,
        // less a margin for pairs let through as touching.
        let closest = 0.999 * 2.0 * system.radii.iter().copied().fold(f64::INFINITY, f64::min);
        let cell = widths(cells.dims());
        let mut terms = Self {
            least_width: 2.0 * cell[axis],
            cell_room: room_in_box(&cell, closest),
            reference_room: 0,
            list_room: 0,
        };
        if let Some(skin) = system.plan.sphere_skin {
            let reach = system.range + skin;
            let dims = match &system.sphere_lists {
                Some(lists) => lists.reference_dims(),
                None => crate::space::cell_grid(&lengths, reach, system.len()),
            };
            let reference = widths(dims);
            terms.least_width = (terms.least_width)
                .max(2.0 * reference[axis] + 0.5 * skin)
                .max(2.0 * reach + skin);
            // A reference cell's references belong to centres within s/2
            // of it; listed centres lie within σ + 2s of each other.
            terms.reference_room = room_in_box(&reference.add_scalar(skin), closest);
            terms.list_room = room_in_ball(reach + skin, closest) - 1;
        }
        // A margin for the rounding of slab and cell boundaries.
        terms.least_width += 1e-9 * lengths[axis];
        let room = terms
            .cell_room
            .max(terms.reference_room)
            .max(terms.list_room);
        (room <= MOST_ROOM).then_some(terms)
    }

    /// The terms for `system` with slabs `width` wide along `axis`, if
    /// they are wide enough to share.
    fn at_width(system: &System, axis: usize, width: f64) -> Option<Self> {
        Self::of(system, axis).filter(|terms| width >= terms.least_width)
    }

    /// Whether `system`'s cells and lists have the room.
    fn roomy(&self, system: &System) -> bool {
        let Neighbours::Cells(cells) = &system.cells else {
            return false;
        };
        cells.capacity() >= self.cell_room
            && system.sphere_lists.as_ref().is_none_or(|lists| {
                let (references, list) = lists.room();
                references >= self.reference_room && list >= self.list_room
            })
    }

    /// Makes the room in `system`'s cells and lists.
    fn reserve(&self, system: &mut System) {
        if let Neighbours::Cells(cells) = &mut system.cells {
            cells.reserve(self.cell_room);
        }
        if let Some(lists) = &mut system.sphere_lists {
            lists.reserve(self.reference_room, self.list_room);
        }
    }
}

impl Slabs {
    /// Whether members can share `system`'s memory on these slabs (at
    /// least as wide as [`SharingTerms`] asks, the room made).
    fn shareable(&self, system: &System) -> bool {
        SharingTerms::at_width(system, self.axis, self.length / self.count as f64)
            .is_some_and(|terms| terms.roomy(system))
    }
}

/// The caller's system, which the members of a team of hard spheres share
/// (see the module docs).
struct SharedSystem(*mut System);

// SAFETY: the members touch the system only as `member_copy` and `whole`
// say.
unsafe impl Sync for SharedSystem {}

impl SharedSystem {
    /// A member's own header over the shared storage: the same vectors
    /// (positions, cells, lists), its own scalars. Its review window
    /// starts empty and is not reviewed (the review is made for the team
    /// between sweeps), and its cells and lists panic rather than grow
    /// (which would move storage from under the others). Never dropped:
    /// the storage is the system's.
    ///
    /// SAFETY: no member may be writing the system's header (between
    /// barriers, where only the storage changes), and the copy is used
    /// only until the next change of it (to the next barrier); members
    /// moving particles of slabs that [`Slabs::shareable`] allows touch
    /// disjoint storage.
    unsafe fn member_copy(&self) -> std::mem::ManuallyDrop<System> {
        // SAFETY: as the caller promises; the copy is never dropped.
        let mut copy = std::mem::ManuallyDrop::new(unsafe { std::ptr::read(self.0) });
        copy.review_deferred = true;
        copy.list_window_base = copy.list_window.0;
        copy.list_window = (0, 0.0);
        copy.changed = false;
        if let Neighbours::Cells(cells) = &mut copy.cells {
            cells.fix_capacity();
        }
        if let Some(lists) = &mut copy.sphere_lists {
            lists.fix_capacity();
        }
        copy
    }

    /// The system itself, for the one member that works on it while the
    /// others wait at a barrier holding no copy they will use again.
    ///
    /// SAFETY: as said; the reference is dropped before the barrier.
    #[allow(clippy::mut_from_ref)]
    unsafe fn whole(&self) -> &mut System {
        // SAFETY: as the caller promises.
        unsafe { &mut *self.0 }
    }
}

/// What members of a sharing team report after their moves of a sweep:
/// their review window and whether they moved anything.
type Report = std::sync::Mutex<Pending>;

/// Review windows and changes the members made since the system's header
/// last heard of them.
#[derive(Debug, Clone, Copy, Default)]
struct Pending {
    moves: usize,
    sum: f64,
    changed: bool,
}

impl Pending {
    fn add(&mut self, o: &Pending) {
        self.moves += o.moves;
        self.sum += o.sum;
        self.changed |= o.changed;
    }

    /// Hands the moves to `system`'s header and reviews its lists.
    fn fold_into(self, system: &mut System) {
        system.list_window.0 += self.moves;
        system.list_window.1 += self.sum;
        system.changed |= self.changed;
        system.review_sphere_lists_now();
    }
}

/// The work of member `me` of a team of `team` sharing `shared` (the
/// sweeps of [`member_sweeps`], with the same moves): every member sorts
/// its slabs and sweeps them on its copy of the header, a barrier after
/// the sort and after each colour. Where the header must change (a box move, a review of the
/// lists due, the team's last sweep), member 0 hands it the members'
/// review windows, reviews the lists, makes the box move and the room,
/// while the others wait and then take a fresh copy; in NVT that is one
/// sweep in [`SPHERE_LISTS_REVIEW`]. A sweep whose slabs are too thin to
/// share (a box move shrank them) or that has none is member 0's alone,
/// as a team of one makes it.
fn shared_member_sweeps(
    (me, team): (usize, usize),
    barrier: &SpinBarrier,
    reports: &[Report],
    shared: &SharedSystem,
    work: &Work,
) -> (Counts, SharedCounts) {
    let Work {
        sizes,
        ensemble,
        seeds,
        first_index,
        threads,
    } = *work;
    let mut counts = Counts::default();
    let mut sharing = SharedCounts::default();
    let mut scratch = Scratch::default();
    // SAFETY: before the first sweep, where no one writes the header.
    let mut local = unsafe { shared.member_copy() };
    let mut pending = Pending::default();
    let npt = matches!(ensemble, Ensemble::Npt { .. });
    for (j, &seed) in seeds.iter().enumerate() {
        let index = first_index + j as u64;
        let last = j + 1 == seeds.len();
        let mut master = stream(seed, index, u64::MAX, u64::MAX);
        let slabs = Slabs::of_sweep(&local, threads, &mut master).filter(|s| s.shareable(&local));
        let Some(slabs) = slabs else {
            // Once every member has read what it decided on.
            barrier.wait();
            if me == 0 {
                let alone = Work {
                    seeds: &seeds[j..=j],
                    first_index: index,
                    ..*work
                };
                // SAFETY: the others wait at the barrier below.
                let system = unsafe { shared.whole() };
                pending.fold_into(system);
                counts += member_sweeps((0, 1), None, system, &alone);
                sharing.alone += 1;
            }
            pending = Pending::default();
            barrier.wait();
            // SAFETY: after the barrier, member 0 done with the header.
            local = unsafe { shared.member_copy() };
            continue;
        };
        scratch.sort(&local, &slabs, me, team);
        // Sorting reads every centre: no member moves one before all have
        // sorted.
        barrier.wait();
        let first = usize::from(master.r#gen::<bool>());
        for colour in [first, 1 - first] {
            counts += colour_moves(
                &mut local,
                &scratch.slab_members,
                (&slabs, colour),
                (seed, index),
                sizes,
                |_| {},
            );
            if colour != first {
                *reports[me].lock().expect("no member panicked") = Pending {
                    moves: local.list_window.0,
                    sum: local.list_window.1,
                    changed: local.changed,
                };
                (local.list_window, local.changed) = ((0, 0.0), false);
            }
            barrier.wait();
        }
        // Every member sums the reports alike (a member writes its next
        // one only after the next colour's barrier, which all reach after
        // reading these).
        for report in reports {
            pending.add(&report.lock().expect("no member panicked"));
        }
        sharing.shared += u64::from(me == 0);
        let review_due = local.plan.sphere_skin.is_some()
            && local.list_window_base + pending.moves >= SPHERE_LISTS_REVIEW * local.len();
        if !(npt || review_due || last) {
            continue;
        }
        if me == 0 {
            // SAFETY: the others wait at the barrier below (or are done),
            // and take a fresh copy after it.
            let system = unsafe { shared.whole() };
            pending.fold_into(system);
            if let Ensemble::Npt {
                pressure,
                anisotropic,
            } = *ensemble
            {
                let accepted = box_move(system, pressure, sizes.volume, anisotropic, &mut master);
                counts.volume.record(accepted);
            }
            if let Some(terms) = SharingTerms::of(system, slabs.axis) {
                terms.reserve(system);
            }
        }
        pending = Pending::default();
        if !last {
            barrier.wait();
            // SAFETY: after the barrier, member 0 done with the header.
            local = unsafe { shared.member_copy() };
        }
    }
    (counts, sharing)
}

/// Sweeps of teams that shared their system: how many were shared, and
/// how many member 0 made alone (the slabs too thin to share).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SharedCounts {
    /// Sweeps whose slabs the members swept at once.
    pub shared: u64,
    /// Sweeps member 0 made alone.
    pub alone: u64,
}

impl std::ops::AddAssign for SharedCounts {
    fn add_assign(&mut self, o: Self) {
        self.shared += o.shared;
        self.alone += o.alone;
    }
}

/// Parallel sweeps, on one system the members share (hard spheres in
/// slabs wide enough: see the module docs) or each on a replica of its
/// own kept between sweeps (one per thread beyond the first). Replicas are
/// copied from the system when it changed since they were last in step
/// with it (a serial sweep, another system): reuse one `ParallelSweeps`
/// for a run of sweeps of one system.
#[derive(Debug, Default)]
pub struct ParallelSweeps {
    replicas: Vec<System>,
    /// The system's stamp when the replicas were last equal to it.
    in_step_at: Option<u64>,
    /// Never share a system: always replicas (to compare the two).
    replicas_only: bool,
    /// The sweeps of teams that shared the system so far.
    sharing: SharedCounts,
}

impl ParallelSweeps {
    /// No replicas yet (made at the first sweep on more than one thread
    /// that does not share the system).
    pub fn new() -> Self {
        Self::default()
    }

    /// Sweeps that always keep replicas, also where members could share
    /// the system: the same moves, for comparison.
    pub fn replicas_only() -> Self {
        Self {
            replicas_only: true,
            ..Self::default()
        }
    }

    /// The sweeps of teams that shared the system so far.
    pub fn sharing(&self) -> SharedCounts {
        self.sharing
    }

    /// Whether sweeps of `system` on `threads` threads share it (hard
    /// spheres in slabs wide enough) rather than keep replicas, as things
    /// stand.
    pub fn would_share(&self, system: &System, threads: usize) -> bool {
        let lengths = system.periodic_box().lengths();
        !self.replicas_only
            && threads > 1
            && Slabs::count_in(system, threads).is_some_and(|count| {
                SharingTerms::at_width(system, lengths.imax(), lengths.max() / count as f64)
                    .is_some()
            })
    }

    /// One sweep (N trial moves, then a box move in NPT) on the slabs:
    /// [`ParallelSweeps::sweeps`] of one.
    pub fn sweep(
        &mut self,
        system: &mut System,
        sizes: &MoveSizes,
        ensemble: &Ensemble,
        seed: u64,
        sweep_index: u64,
    ) -> Counts {
        self.sweeps(system, sizes, ensemble, &[seed], sweep_index)
    }

    /// Sweeps back to back, the j-th keyed on `seeds[j]` and
    /// `first_index + j` (the same moves as one [`ParallelSweeps::sweep`]
    /// each), on the threads of the current rayon pool, all of which it
    /// occupies until the last ends (spinning at the barriers between
    /// colours): call it from outside parallel iterators. A sweep in a box
    /// too small for two slabs is the serial one. Waking the team costs
    /// tens of µs, as much as a tenth of a sweep of 4000 spheres: hand
    /// over several sweeps at once where nothing is read between them.
    pub fn sweeps(
        &mut self,
        system: &mut System,
        sizes: &MoveSizes,
        ensemble: &Ensemble,
        seeds: &[u64],
        first_index: u64,
    ) -> Counts {
        let threads = rayon::current_num_threads().max(1);
        let work = Work {
            sizes,
            ensemble,
            seeds,
            first_index,
            threads,
        };
        let team = Slabs::count_in(system, threads).map_or(1, |count| threads.min(count / 2));
        if team == 1 {
            return member_sweeps((0, 1), None, system, &work);
        }
        if self.would_share(system, threads) {
            let (counts, sharing) = shared_sweeps(system, team, &work);
            self.sharing += sharing;
            return counts;
        }
        if self.in_step_at != Some(system.stamp()) || self.replicas.len() < team - 1 {
            self.replicas = (1..team).map(|_| system.clone()).collect();
        }
        let exchange = Exchange {
            barrier: SpinBarrier::new(team),
            outboxes: (0..team)
                .map(|_| [RwLock::new(Vec::new()), RwLock::new(Vec::new())])
                .collect(),
        };
        // On rayon's own threads, which stay awake between the sweeps of
        // a run (a thread spawned per sweep cost 50-80 µs to start).
        let systems: Vec<std::sync::Mutex<&mut System>> = std::iter::once(&mut *system)
            .chain(self.replicas.iter_mut())
            .take(team)
            .map(std::sync::Mutex::new)
            .collect();
        let per_thread: Vec<Counts> = rayon::broadcast(|context| {
            let me = context.index();
            if me >= team {
                return Counts::default();
            }
            let mut system = systems[me].lock().expect("no thread panicked");
            let _member = Member(&exchange.barrier);
            member_sweeps((me, team), Some(&exchange), &mut system, &work)
        });
        drop(systems);
        self.in_step_at = Some(system.stamp());
        per_thread.into_iter().fold(Counts::default(), |a, c| a + c)
    }
}

/// The sweeps of `work` by a team of `team` sharing `system`.
fn shared_sweeps(system: &mut System, team: usize, work: &Work) -> (Counts, SharedCounts) {
    if let Some(terms) = SharingTerms::of(system, 0) {
        terms.reserve(system);
    }
    let barrier = SpinBarrier::new(team);
    let reports: Vec<Report> = (0..team).map(|_| Report::default()).collect();
    let shared = SharedSystem(system);
    let per_thread: Vec<(Counts, SharedCounts)> = rayon::broadcast(|context| {
        let me = context.index();
        if me >= team {
            return Default::default();
        }
        let _member = Member(&barrier);
        shared_member_sweeps((me, team), &barrier, &reports, &shared, work)
    });
    let counts = per_thread.iter().fold(Counts::default(), |a, c| a + c.0);
    (counts, per_thread[0].1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A member that panics breaks the barrier: the others panic at it
    /// rather than spin for ever.
    #[test]
    fn a_panicking_member_breaks_the_barrier() {
        let barrier = SpinBarrier::new(2);
        let outcome = std::thread::scope(|scope| {
            let failing = scope.spawn(|| {
                let _member = Member(&barrier);
                panic!("a member fails");
            });
            let waiting = scope.spawn(|| {
                let _member = Member(&barrier);
                barrier.wait();
            });
            (failing.join().is_err(), waiting.join().is_err())
        });
        assert_eq!(outcome, (true, true));
    }

    /// Streams keyed on different (seed, sweep, colour, slab) differ, also
    /// where parts repeat each other (seed = sweep, colour = slab).
    #[test]
    fn streams_of_different_keys_differ() {
        let keys: std::collections::HashSet<(u64, u64, u64, u64)> = (0..40u64)
            .flat_map(|a| {
                (0..40u64)
                    .flat_map(move |b| [(a, a, 0, b), (a, b, a, b), (a, b, 1, 1), (a, a, b, b)])
            })
            .collect();
        let firsts: std::collections::HashSet<u64> = (keys.iter())
            .map(|&(seed, sweep, colour, slab)| stream(seed, sweep, colour, slab).r#gen::<u64>())
            .collect();
        assert_eq!(firsts.len(), keys.len());
    }

    /// The rooms bound what random insertion packs: points pairwise
    /// farther apart than 1, inserted where they fit over a million
    /// tries, in boxes and in a ball (a room too small, say with a floor
    /// for the ceiling, fails it).
    #[test]
    fn rooms_hold_what_random_insertion_packs() {
        let mut u = crate::test_support::uniform(21);
        let mut pack = |inside: &dyn Fn(&V3) -> bool, corner: V3, sides: V3| {
            let mut points: Vec<V3> = Vec::new();
            for _ in 0..1_000_000 {
                let p = corner + V3::from_fn(|k, _| u() * sides[k]);
                if inside(&p) && points.iter().all(|q| (p - q).norm() > 1.0) {
                    points.push(p);
                }
            }
            points.len()
        };
        for sides in [
            V3::new(1.02, 1.02, 1.02),
            V3::new(1.6, 1.6, 1.6),
            V3::new(2.1, 2.1, 2.1),
            V3::new(1.1, 1.7, 2.6),
        ] {
            let packed = pack(&|_| true, V3::zeros(), sides);
            let room = room_in_box(&sides, 1.0);
            assert!(packed <= room, "{sides:?}: {packed} > {room}");
        }
        let radius = 2.0;
        let packed = 1 + pack(
            &|p: &V3| p.norm() <= radius,
            V3::repeat(-radius),
            V3::repeat(2.0 * radius),
        );
        let room = room_in_ball(radius, 1.0);
        assert!(packed <= room, "ball: {packed} > {room}");
    }

    /// Dense spheres of the benchmark (N = 4096, φ = 0.5) share their
    /// system on two threads: four slabs 4.06 diameters wide, over the
    /// 3.5 the Verlet lists ask (skin 0.5); a cell of the moves' holds at
    /// most 8 centres, a list at most 124 spheres. Other shapes do not.
    #[test]
    fn dense_spheres_are_shared_and_other_shapes_not() {
        let sphere: crate::geometry::Shape = "Sphere(radius: 0.5)".parse().unwrap();
        let system = crate::bench::mc::dense_start(&sphere, 4096, 0.5).unwrap();
        let terms = SharingTerms::of(&system, 0).unwrap();
        assert!((terms.least_width - 3.5).abs() < 1e-6, "{terms:?}");
        assert_eq!((terms.cell_room, terms.list_room), (8, 124), "{terms:?}");
        assert!(ParallelSweeps::new().would_share(&system, 2));
        assert!(!ParallelSweeps::new().would_share(&system, 1));
        let needle: crate::geometry::Shape = "Ellipsoid(a: 2.5, b: 0.5, c: 0.5)".parse().unwrap();
        let system = crate::bench::mc::dense_start(&needle, 1000, 0.3).unwrap();
        assert!(SharingTerms::of(&system, 0).is_none());
    }

    #[test]
    fn slabs_are_wide_enough_and_even() {
        // 16 wide, range 1: four slabs for one or two threads, eight for
        // four, never more than fit.
        assert_eq!(slab_count(16.0, 1.0, 1), Some(4));
        assert_eq!(slab_count(16.0, 1.0, 2), Some(4));
        assert_eq!(slab_count(16.0, 1.0, 4), Some(8));
        assert_eq!(slab_count(16.0, 1.0, 64), Some(16));
        assert_eq!(slab_count(3.5, 1.0, 2), Some(2));
        assert_eq!(slab_count(1.9, 1.0, 2), None);
        for threads in 1..9 {
            for length in [2.0, 2.9, 5.5, 7.99, 31.0] {
                if let Some(s) = slab_count(length, 1.0, threads) {
                    assert!(
                        s % 2 == 0 && length / s as f64 >= 1.0,
                        "{length} {threads}: {s}"
                    );
                }
            }
        }
    }
}
