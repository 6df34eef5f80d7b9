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
use rayon::prelude::*;

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

/// A particle's state while its cell is being swept.
#[derive(Clone, Copy)]
struct Local {
    index: usize,
    position: V3,
    orientation: UnitQuaternion<f64>,
    rotation: Matrix3<f64>,
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
    // Cell of a position: shift by the offset, wrap into [0, L).
    let cell_of = |r: &V3| -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..3 {
            let mut s = r[k] + 0.5 * lengths[k] + offset[k];
            s -= lengths[k] * (s / lengths[k]).floor();
            c[k] = ((s / width[k]) as usize).min(dims[k] - 1);
        }
        c
    };
    let flat = |c: [usize; 3]| c[0] + dims[0] * (c[1] + dims[1] * c[2]);
    let n_cells = dims[0] * dims[1] * dims[2];
    // Cell members by counting sort: `order[start[c]..start[c + 1]]` are the
    // particles of cell c (one allocation per sweep, not one per cell).
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
    let members = |c: usize| &order[start[c]..start[c + 1]];
    let mut colours: Vec<u64> = (0..8).collect();
    colours.shuffle(&mut master);
    let mut counts = Counts::default();
    for colour in colours {
        let active: Vec<usize> = (0..n_cells)
            .filter(|&c| {
                let (x, y, z) = (
                    c % dims[0],
                    (c / dims[0]) % dims[1],
                    c / (dims[0] * dims[1]),
                );
                ((x % 2) | (y % 2) << 1 | (z % 2) << 2) as u64 == colour
            })
            .filter(|&c| !members(c).is_empty())
            .collect();
        let shared: &System = system;
        let results: Vec<(Vec<Local>, Counts)> = active
            .par_iter()
            .map(|&c| {
                let mut rng = stream(seed, sweep_index, colour, c as u64);
                let mut local: Vec<Local> = members(c)
                    .iter()
                    .map(|&i| {
                        let p = &shared.particles[i];
                        Local {
                            index: i,
                            position: p.position,
                            orientation: p.orientation,
                            rotation: shared.rotations[i],
                            moved: false,
                        }
                    })
                    .collect();
                let mut counts = Counts::default();
                for _ in 0..local.len() {
                    let k = rng.gen_range(0..local.len());
                    let me = local[k];
                    let rotates =
                        shared.species[shared.particles[me.index].species as usize].rotation;
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
                    let rotation = if is_rotation {
                        orientation.to_rotation_matrix().into_inner()
                    } else {
                        me.rotation
                    };
                    // Confined to the cell; then no overlap with the cell's
                    // own particles (as they are now) or with the frozen rest.
                    let reach = shared.radii[shared.particles[me.index].species as usize]
                        + shared.max_radius;
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
                                    &o.rotation,
                                )
                        })
                        && !shared
                            .overlaps_at_except(me.index, &position, &rotation, |j| home[j] == c);
                    if accepted {
                        local[k] = Local {
                            position,
                            orientation,
                            rotation,
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
                (local, counts)
            })
            .collect();
        for (local, c) in results {
            counts += c;
            for l in local.into_iter().filter(|l| l.moved) {
                system.place(l.index, l.position, l.orientation, l.rotation);
            }
        }
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
