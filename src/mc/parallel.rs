//! Parallel sweeps on a checkerboard (as HPMC): the box is cut into an even
//! number of cells per axis, each at least one interaction range wide, and
//! shifted by a random offset every sweep. The eight colours of the 2×2×2
//! checkerboard are visited in random order; the cells of one colour are
//! separated by cells of the others, so they are swept in parallel with
//! every move confined to its cell (a move that would leave the cell is
//! rejected, which keeps the proposal symmetric) and particles of other
//! cells frozen.
//!
//! Every cell draws from its own stream keyed on (seed, sweep, colour,
//! cell), so a run is the same for any number of threads.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, RwLock};

use super::System;
use super::moves::{
    Counts, Ensemble, MoveSizes, box_move, propose_rotation, propose_translation, sweep,
};

type V3 = Vector3<f64>;

/// The random stream of one (seed, sweep, colour, cell).
fn stream(seed: u64, sweep: u64, colour: u64, cell: u64) -> Pcg64 {
    let mut key = seed ^ 0x9E37_79B9_7F4A_7C15;
    for part in [sweep, colour, cell] {
        key = (key ^ part)
            .wrapping_mul(0xBF58_476D_1CE4_E5B9)
            .rotate_left(31);
    }
    Pcg64::seed_from_u64(key)
}

/// A barrier for a team that is all running at once (a rayon broadcast):
/// the last to arrive bumps the generation the others spin on.
struct SpinBarrier {
    team: usize,
    arrived: AtomicUsize,
    generation: AtomicUsize,
}

impl SpinBarrier {
    fn new(team: usize) -> Self {
        Self {
            team,
            arrived: AtomicUsize::new(0),
            generation: AtomicUsize::new(0),
        }
    }

    fn wait(&self) {
        let generation = self.generation.load(Ordering::Acquire);
        if self.arrived.fetch_add(1, Ordering::AcqRel) + 1 == self.team {
            self.arrived.store(0, Ordering::Relaxed);
            self.generation.fetch_add(1, Ordering::Release);
        } else {
            while self.generation.load(Ordering::Acquire) == generation {
                std::hint::spin_loop();
            }
        }
    }
}

/// A particle's state while its cell is being swept (its rotation matrix
/// is the system's until it turns).
#[derive(Clone, Copy)]
struct Local {
    index: usize,
    position: V3,
    orientation: UnitQuaternion<f64>,
    moved: bool,
}

/// Particles per checkerboard cell aimed at: enough that a cell's bookkeeping
/// (its stream, its copies) is paid for by its moves; few enough that the
/// same-cell pairs, tested directly, stay cheap.
const PARTICLES_PER_CELL: f64 = 12.0;

/// Cells per axis for the checkerboard: the largest even number whose cells
/// are at least `width` wide, or `None` when fewer than two fit.
fn grid(lengths: &V3, width: f64) -> Option<[usize; 3]> {
    let mut dims = [0usize; 3];
    for k in 0..3 {
        let n = (lengths[k] / width).floor() as usize;
        let even = n - n % 2;
        if even < 2 {
            return None;
        }
        dims[k] = even;
    }
    Some(dims)
}

/// One sweep (N trial moves, then a box move in NPT) on the checkerboard.
/// Falls back to the serial sweep when the box is too small for a
/// checkerboard (fewer than two cells per axis).
pub fn parallel_sweep(
    system: &mut System,
    sizes: &MoveSizes,
    ensemble: &Ensemble,
    seed: u64,
    sweep_index: u64,
) -> Counts {
    let lengths = system.periodic_box().lengths();
    let mut master = stream(seed, sweep_index, u64::MAX, u64::MAX);
    let density = system.len() as f64 / lengths.product();
    let width = system.range.max((PARTICLES_PER_CELL / density).cbrt());
    let Some(dims) = grid(&lengths, width) else {
        return sweep(system, sizes, ensemble, &mut master);
    };
    let width = Vector3::new(
        lengths.x / dims[0] as f64,
        lengths.y / dims[1] as f64,
        lengths.z / dims[2] as f64,
    );
    let offset = Vector3::new(
        master.r#gen::<f64>(),
        master.r#gen::<f64>(),
        master.r#gen::<f64>(),
    )
    .component_mul(&width);
    // Cell of a position in the box: shift by the offset (under one cell),
    // wrap into [0, L) by one compare (no rounding call: this runs for
    // every particle and every trial move).
    let inverse_width = width.map(|w| 1.0 / w);
    let cell_of = |r: &V3| -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..3 {
            let mut s = r[k] + 0.5 * lengths[k] + offset[k];
            if s >= lengths[k] {
                s -= lengths[k];
            }
            c[k] = ((s.max(0.0) * inverse_width[k]) as usize).min(dims[k] - 1);
        }
        c
    };
    let flat = |c: [usize; 3]| c[0] + dims[0] * (c[1] + dims[1] * c[2]);
    let n_cells = dims[0] * dims[1] * dims[2];
    // Cell members by counting sort, copied once per sweep into one array
    // of locals grouped by cell: `locals[start[c]..start[c + 1]]` are the
    // particles of cell c.
    let home: Vec<usize> = system.positions.iter().map(|r| flat(cell_of(r))).collect();
    let mut start = vec![0usize; n_cells + 1];
    for &c in &home {
        start[c + 1] += 1;
    }
    for c in 0..n_cells {
        start[c + 1] += start[c];
    }
    let mut order = vec![0usize; home.len()];
    let mut fill = start.clone();
    for (i, &c) in home.iter().enumerate() {
        order[fill[c]] = i;
        fill[c] += 1;
    }
    let mut locals: Vec<Local> = order
        .iter()
        .map(|&i| Local {
            index: i,
            position: system.particles[i].position,
            orientation: system.particles[i].orientation,
            moved: false,
        })
        .collect();
    let colour_of = |c: usize| {
        let (x, y, z) = (
            c % dims[0],
            (c / dims[0]) % dims[1],
            c / (dims[0] * dims[1]),
        );
        ((x % 2) | (y % 2) << 1 | (z % 2) << 2) as u64
    };
    let mut colours: Vec<u64> = (0..8).collect();
    colours.shuffle(&mut master);
    // Each cell's locals behind its own (uncontended) lock: the thread that
    // sweeps a cell, then the one that places its moves, take it in turn.
    let mut cells: Vec<Mutex<&mut [Local]>> = Vec::with_capacity(n_cells);
    let mut rest: &mut [Local] = &mut locals;
    for c in 0..n_cells {
        let (here, after) = rest.split_at_mut(start[c + 1] - start[c]);
        rest = after;
        cells.push(Mutex::new(here));
    }
    let by_colour: Vec<Vec<usize>> = colours
        .iter()
        .map(|&colour| {
            (0..n_cells)
                .filter(|&c| colour_of(c) == colour && start[c + 1] > start[c])
                .collect()
        })
        .collect();
    // One team for the whole sweep (as many threads as rayon's pool here,
    // scoped threads so that no other pool work can sit between a barrier
    // and a team member): per colour, every thread sweeps its share of the
    // cells reading the system, a barrier, the first thread places the
    // moves, a barrier. Two spinning barriers per colour instead of a
    // parallel region per colour, whose wake-ups cost as much as the moves
    // of a small system.
    let team = rayon::current_num_threads().max(1);
    let barrier = SpinBarrier::new(team);
    let state = RwLock::new(system);
    let sweep_cell = |shared: &System, c: usize, colour: u64, local: &mut [Local]| {
        let mut rng = stream(seed, sweep_index, colour, c as u64);
        let mut counts = Counts::default();
        for _ in 0..local.len() {
            let k = rng.gen_range(0..local.len());
            let me = local[k];
            let rotates = shared.species[shared.particles[me.index].species as usize].rotation;
            let is_rotation = rotates && rng.r#gen::<bool>();
            let (position, orientation) = if is_rotation {
                (
                    me.position,
                    propose_rotation(&me.orientation, sizes.rotate, &mut rng),
                )
            } else {
                (
                    propose_translation(&me.position, sizes.translate, &mut rng),
                    me.orientation,
                )
            };
            let position = shared.box_.wrap_near(&position);
            // Spheres never need one.
            let rotation_of = |l: &Local| {
                if shared.all_spheres {
                    Matrix3::identity()
                } else if l.moved {
                    l.orientation.to_rotation_matrix().into_inner()
                } else {
                    shared.rotations[l.index]
                }
            };
            let rotation = if is_rotation {
                orientation.to_rotation_matrix().into_inner()
            } else {
                rotation_of(&me)
            };
            // Confined to the cell; then no overlap with the cell's own
            // particles (as they are now) or with the frozen rest.
            let reach =
                shared.radii[shared.particles[me.index].species as usize] + shared.max_radius;
            let accepted = flat(cell_of(&position)) == c
                && !local.iter().enumerate().any(|(m, o)| {
                    m != k
                        && shared
                            .box_
                            .minimum_image_near(&(o.position - position))
                            .norm_squared()
                            <= reach * reach
                        && shared.pair_overlaps(
                            me.index,
                            &position,
                            &rotation,
                            o.index,
                            &o.position,
                            &rotation_of(o),
                        )
                })
                && !shared.overlaps_at_except(me.index, &position, &rotation, |j| home[j] == c);
            if accepted {
                local[k] = Local {
                    position,
                    orientation,
                    moved: true,
                    ..me
                };
            }
            if is_rotation {
                counts.rotate.record(accepted);
            } else {
                counts.translate.record(accepted);
            }
        }
        counts
    };
    let member = |me: usize| {
        let mut counts = Counts::default();
        for (&colour, active) in colours.iter().zip(&by_colour) {
            {
                let shared = state.read().expect("no thread panicked");
                // Contiguous shares (cells are numbered z-major): each
                // thread keeps to one slab of the box, whose data stay in
                // its core's cache from colour to colour.
                let share = active.len().div_ceil(team);
                for &c in active.iter().skip(me * share).take(share) {
                    let mut local = cells[c].lock().expect("no thread panicked");
                    counts += sweep_cell(&shared, c, colour, &mut local);
                }
            }
            barrier.wait();
            if me == 0 {
                let mut system = state.write().expect("no thread panicked");
                for &c in active {
                    let mut local = cells[c].lock().expect("no thread panicked");
                    for l in local.iter_mut().filter(|l| l.moved) {
                        let rotation = l.orientation.to_rotation_matrix().into_inner();
                        system.place(l.index, l.position, l.orientation, rotation);
                        l.moved = false;
                    }
                }
            }
            barrier.wait();
        }
        counts
    };
    let per_thread: Vec<Counts> = std::thread::scope(|scope| {
        let others: Vec<_> = (1..team)
            .map(|me| scope.spawn(move || member(me)))
            .collect();
        let mut all = vec![member(0)];
        all.extend(
            others
                .into_iter()
                .map(|h| h.join().expect("no thread panicked")),
        );
        all
    });
    let system = state.into_inner().expect("no thread panicked");
    let mut counts = Counts::default();
    for c in per_thread {
        counts += c;
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
