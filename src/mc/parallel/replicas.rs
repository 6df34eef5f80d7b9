//! Teams of replicas: each member sweeps its slabs on a system of its
//! own and places the moves the others hand it through the exchange.

use rand::Rng;
use rand_pcg::Pcg64;
use std::sync::RwLock;

use super::*;
use crate::mc::moves::ensemble_box_move;
use crate::mc::moves::{Counts, MoveSizes, MoveTarget, particle_moves, sweep};
use crate::state::System;

/// The barrier and the outboxes through which a team's members hand each
/// other the moves of a colour: two per member, for even and odd colours
/// (counted over the team's sweeps). A member refills the outbox of colour
/// n + 2 only after the barrier of colour n + 1, which every other member
/// reaches after it has read colour n's: one barrier per colour.
pub(super) struct Exchange {
    pub(super) barrier: SpinBarrier,
    pub(super) outboxes: Vec<[RwLock<Vec<Placed>>; 2]>,
}

/// What a member keeps from sweep to sweep: the particles of each of its
/// slabs, in index order, and those it moved in a colour.
#[derive(Debug, Default)]
pub(super) struct Scratch {
    pub(super) slab_members: Vec<Vec<usize>>,
    pub(super) moved: Vec<usize>,
    pub(super) marked: Vec<bool>,
}

impl Scratch {
    /// Lists the particles of the slabs member `me` of `team` sweeps.
    pub(super) fn sort(&mut self, system: &System, slabs: &Slabs, me: usize, team: usize) {
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

/// The work of member `me` of a team of `team` in sweeps `first_index..`
/// keyed on `seeds`, on its own `system`, handing its moves to the others
/// through `exchange` (none for a team of one). Every member draws the
/// same master stream and places every move, so that all end each sweep
/// in the same state, and all make the same box move (their systems
/// agree, so do the answers); only member 0 counts the moves that every
/// member makes.
pub(super) fn member_sweeps(
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
        if let Some(outcome) = ensemble_box_move(system, sizes, ensemble, &mut master)
            && me == 0
        {
            counts.record_box(outcome);
        }
    }
    counts
}

/// The moves of the slabs of `colour` listed in `slab_members` (those of
/// other members empty), each slab drawing from its stream keyed on
/// (`seed`, `index`, colour, slab) and every move confined to its slab;
/// `accepted` hears of each particle moved.
pub(super) fn colour_moves(
    target: &mut (impl MoveTarget + ?Sized),
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
        let box_ = *target.system().periodic_box();
        counts += particle_moves(
            target,
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
    pub(super) fn share(
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
