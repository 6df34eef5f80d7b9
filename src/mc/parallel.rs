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
//! stale, one copy of the system).
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

/// The random stream of one (seed, sweep, colour, slab).
fn stream(seed: u64, sweep: u64, colour: u64, slab: u64) -> Pcg64 {
    let mut key = seed ^ 0x9E37_79B9_7F4A_7C15;
    for part in [sweep, colour, slab] {
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

/// Whether a stage of `n` particles with neighbour plan `plan` sweeps on
/// slabs ([`ParallelSweeps`]), on any thread count, so that its trajectory
/// is the same on one core and on two: from [`SLABS_FROM`] particles, but
/// not for spheres on Verlet lists, whose serial sweep (a move in ~120 ns)
/// is faster than two threads that each place every accepted move.
pub fn sweeps_on_slabs(plan: &super::NeighbourPlan, n: usize) -> bool {
    n >= SLABS_FROM && plan.sphere_skin.is_none()
}

/// A move to hand to the other threads: the particle's final pose in a
/// colour.
type Placed = (usize, V3, UnitQuaternion<f64>, Matrix3<f64>);

/// Parallel sweeps with the replicas they keep between sweeps (one per
/// thread beyond the first). Replicas are copied from the system when it
/// changed since they were last in step with it (a box move in NPT, a
/// serial sweep, another system): reuse one `ParallelSweeps` for a run of
/// sweeps of one system.
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

    /// One sweep (N trial moves, then a box move in NPT) on the slabs, on
    /// the threads of the current rayon pool, all of which it occupies
    /// until the sweep ends (spinning at the barriers between colours):
    /// call it from outside parallel iterators. Falls back to the serial
    /// sweep when the box is too small for two slabs.
    pub fn sweep(
        &mut self,
        system: &mut System,
        sizes: &MoveSizes,
        ensemble: &Ensemble,
        seed: u64,
        sweep_index: u64,
    ) -> Counts {
        let threads = rayon::current_num_threads().max(1);
        let lengths = system.periodic_box().lengths();
        let mut master = stream(seed, sweep_index, u64::MAX, u64::MAX);
        let axis = lengths.imax();
        let length = lengths[axis];
        let Some(slabs) = slab_count(length, system.range, threads) else {
            return sweep(system, sizes, ensemble, &mut master);
        };
        let width = length / slabs as f64;
        let offset = master.r#gen::<f64>() * width;
        let inverse_width = 1.0 / width;
        // The slab of a position in the box: shift by the offset (under one
        // slab), wrap into [0, L) by one compare.
        let slab_of = move |r: &V3| -> usize {
            let mut s = r[axis] + 0.5 * length + offset;
            if s >= length {
                s -= length;
            }
            ((s.max(0.0) * inverse_width) as usize).min(slabs - 1)
        };
        // Members by counting sort: `order[start[k]..start[k + 1]]` are the
        // particles of slab k.
        let home: Vec<usize> = system.positions.iter().map(slab_of).collect();
        let mut start = vec![0usize; slabs + 1];
        for &k in &home {
            start[k + 1] += 1;
        }
        for k in 0..slabs {
            start[k + 1] += start[k];
        }
        let mut order = vec![0usize; home.len()];
        let mut fill = start.clone();
        for (i, &k) in home.iter().enumerate() {
            order[fill[k]] = i;
            fill[k] += 1;
        }
        let first = usize::from(master.r#gen::<bool>());
        let colours = [first, 1 - first];
        let team = threads.min(slabs / 2);
        // The moves of one slab, on the system of the thread that owns it;
        // the particles moved are listed in `moved` when other threads need
        // to hear of them.
        let sweep_slab =
            |system: &mut System, colour: usize, k: usize, mut moved: Option<&mut Vec<usize>>| {
                let members = &order[start[k]..start[k + 1]];
                if members.is_empty() {
                    return Counts::default();
                }
                let mut rng = stream(seed, sweep_index, colour as u64, k as u64);
                let box_ = *system.periodic_box();
                particle_moves(
                    system,
                    members.len(),
                    |rng: &mut Pcg64| members[rng.gen_range(0..members.len())],
                    sizes,
                    &mut rng,
                    |r| slab_of(&box_.wrap_near(r)) == k,
                    |i| {
                        if let Some(moved) = moved.as_mut() {
                            moved.push(i);
                        }
                    },
                )
            };
        // The slabs of a colour a thread sweeps: contiguous shares.
        let share = (slabs / 2).div_ceil(team);
        let slabs_of =
            move |colour: usize, me: usize| (colour..slabs).step_by(2).skip(me * share).take(share);
        let mut counts = Counts::default();
        if team == 1 {
            for colour in colours {
                for k in slabs_of(colour, 0) {
                    counts += sweep_slab(system, colour, k, None);
                }
            }
        } else {
            if self.in_step_at != Some(system.stamp()) || self.replicas.len() < team - 1 {
                self.replicas = (1..team).map(|_| system.clone()).collect();
            }
            let barrier = SpinBarrier::new(team);
            let outboxes: Vec<RwLock<Vec<Placed>>> =
                (0..team).map(|_| RwLock::new(Vec::new())).collect();
            let member = |me: usize, system: &mut System| {
                let _member = Member(&barrier);
                let mut counts = Counts::default();
                let mut moved = Vec::new();
                let mut marked = vec![false; system.len()];
                for colour in colours {
                    moved.clear();
                    for k in slabs_of(colour, me) {
                        counts += sweep_slab(system, colour, k, Some(&mut moved));
                    }
                    {
                        let mut outbox = outboxes[me].write().expect("no thread panicked");
                        outbox.clear();
                        for &i in &moved {
                            if !std::mem::replace(&mut marked[i], true) {
                                let p = &system.particles[i];
                                outbox.push((i, p.position, p.orientation, system.rotations[i]));
                            }
                        }
                        for &i in &moved {
                            marked[i] = false;
                        }
                    }
                    barrier.wait();
                    for (other, outbox) in outboxes.iter().enumerate() {
                        if other != me {
                            let outbox = outbox.read().expect("no thread panicked");
                            for &(i, position, orientation, rotation) in outbox.iter() {
                                system.place(i, position, orientation, rotation);
                            }
                        }
                    }
                    // Nobody refills an outbox before all have read it.
                    barrier.wait();
                }
                counts
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
                member(me, &mut system)
            });
            drop(systems);
            for c in per_thread {
                counts += c;
            }
            self.in_step_at = Some(system.stamp());
        }
        if let Ensemble::Npt {
            pressure,
            anisotropic,
        } = *ensemble
        {
            counts.volume.record(box_move(
                system,
                pressure,
                sizes.volume,
                anisotropic,
                &mut master,
            ));
        }
        counts
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
