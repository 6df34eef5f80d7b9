//! Parallel sweeps by domain decomposition (HPMC's checkerboard, in one
//! dimension): the box is cut along its longest axis into an even number
//! of slabs, each at least one interaction range wide, shifted by a random
//! offset every sweep. Slabs of one colour (even or odd) are separated by
//! slabs of the other, so they are swept at once, every move confined to
//! its slab (a move that would leave it is rejected, which keeps the
//! proposal symmetric) and the other colour frozen; the two colours go in
//! random order.
//!
//! Each thread sweeps its slabs on a system of its own: the first thread
//! on the caller's, the others on replicas kept between sweeps
//! ([`ParallelSweeps`]). A replica is exact for its own slabs (its cells
//! and lists follow its moves as in a serial sweep) and for the frozen
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
//! [`MIN_SLABS`] / 2 threads: a run is the same for one thread and for two.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::sync::RwLock;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use super::System;
use super::moves::{Counts, Ensemble, MoveSizes, box_move, particle_moves, sweep};

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
/// serial sweep, and 1.4x faster on two: the same trajectory on any
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
            for k in (colour..slabs.count).step_by(2) {
                let members = &scratch.slab_members[k];
                if members.is_empty() {
                    continue;
                }
                let mut rng = stream(seed, index, colour as u64, k as u64);
                let box_ = *system.periodic_box();
                let moved = &mut scratch.moved;
                counts += particle_moves(
                    system,
                    members.len(),
                    |rng: &mut Pcg64| members[rng.gen_range(0..members.len())],
                    sizes,
                    &mut rng,
                    |r| slabs.slab_of(&box_.wrap_near(r)) == k,
                    |i| {
                        if exchange.is_some() {
                            moved.push(i);
                        }
                    },
                );
            }
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

/// Parallel sweeps with the replicas they keep between sweeps (one per
/// thread beyond the first). Replicas are copied from the system when it
/// changed since they were last in step with it (a serial sweep, another
/// system): reuse one `ParallelSweeps` for a run of sweeps of one system.
#[derive(Debug, Default)]
pub struct ParallelSweeps {
    replicas: Vec<System>,
    /// The system's stamp when the replicas were last equal to it.
    in_step_at: Option<u64>,
}

impl ParallelSweeps {
    /// No replicas yet (made at the first sweep on more than one thread).
    pub fn new() -> Self {
        Self::default()
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
