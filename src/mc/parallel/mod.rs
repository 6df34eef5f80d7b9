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
//! its slabs through a view of its own (`MemberView`: the system to read,
//! and `state::shared::SphereSlots` to write the centres, cells
//! and lists through, with no way to the rest of the system), which
//! places only particles of the slabs it is sweeping and keeps each in its
//! slab, and members
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

use crate::mc::moves::{Counts, Ensemble, MoveSizes};
use crate::state::System;

mod replicas;
mod shared;

use replicas::{Exchange, member_sweeps};
use shared::{SharingTerms, shared_sweeps};

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
    /// `threads` threads ([`slab_count`]); none in a tilted box (its slabs
    /// would be cut across the shear: such systems keep replicas).
    fn count_in(system: &System, threads: usize) -> Option<usize> {
        if system.periodic_box().is_tilted() {
            return None;
        }
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
            let (counts, strains) = crate::geometry::pair::counting_strains(|| {
                member_sweeps((me, team), Some(&exchange), &mut system, &work)
            });
            counts.with_strains(strains)
        });
        drop(systems);
        self.in_step_at = Some(system.stamp());
        per_thread.into_iter().fold(Counts::default(), |a, c| a + c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::{room_in_ball, room_in_box};

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
