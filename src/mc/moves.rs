//! Trial moves: translation, rotation, and box moves (ln V, ln L along
//! one axis, or a shear), with their counters.

use super::box_moves::{BoxMoveOutcome, BoxMoves, box_move};
use std::ops::{Add, AddAssign, Sub};

use nalgebra::{Unit, UnitQuaternion, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;

use crate::geometry::pair::OverlapStrains;
use crate::state::System;

/// Attempts and acceptances of one kind of move; counts add.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Count {
    /// Moves tried.
    pub tried: u64,
    /// Moves accepted.
    pub accepted: u64,
}

impl Count {
    /// Accepted / tried (NaN when nothing was tried).
    pub fn rate(&self) -> f64 {
        self.accepted as f64 / self.tried as f64
    }
    /// Nothing tried.
    pub fn is_empty(&self) -> bool {
        self.tried == 0
    }
    pub(crate) fn record(&mut self, accepted: bool) {
        self.tried += 1;
        self.accepted += accepted as u64;
    }
}

impl Add for Count {
    type Output = Count;
    fn add(self, o: Count) -> Count {
        Count {
            tried: self.tried + o.tried,
            accepted: self.accepted + o.accepted,
        }
    }
}

/// Counters of every move kind.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Counts {
    /// Translations.
    pub translate: Count,
    /// Rotations.
    pub rotate: Count,
    /// Box moves that change the volume (ln V or one edge).
    pub volume: Count,
    /// Box moves that shear (a tilt factor).
    #[serde(default)]
    pub shear: Count,
    /// Two bodies exchanging their sizes (polydisperse bodies).
    #[serde(default, skip_serializing_if = "Count::is_empty")]
    pub swap: Count,
    /// Overlap tests the boolean test left undecided (counted by the
    /// scope each thread ran its sweeps in, see
    /// [`crate::geometry::pair::counting_strains`]).
    #[serde(default)]
    pub strains: OverlapStrains,
}

impl Counts {
    /// These counts with the overlap strains of the sweeps they count.
    pub fn with_strains(mut self, strains: OverlapStrains) -> Counts {
        self.strains += strains;
        self
    }

    /// Counts a box move under its kind.
    pub(crate) fn record_box(&mut self, outcome: BoxMoveOutcome) {
        if outcome.shear {
            self.shear.record(outcome.accepted);
        } else {
            self.volume.record(outcome.accepted);
        }
    }
}

impl Add for Counts {
    type Output = Counts;
    fn add(self, o: Counts) -> Counts {
        Counts {
            translate: self.translate + o.translate,
            rotate: self.rotate + o.rotate,
            volume: self.volume + o.volume,
            shear: self.shear + o.shear,
            swap: self.swap + o.swap,
            strains: self.strains + o.strains,
        }
    }
}

impl Sub for Count {
    type Output = Count;
    fn sub(self, o: Count) -> Count {
        Count {
            tried: self.tried - o.tried,
            accepted: self.accepted - o.accepted,
        }
    }
}

impl Sub for Counts {
    type Output = Counts;
    /// The moves counted since `o` was read off the same counter.
    fn sub(self, o: Counts) -> Counts {
        Counts {
            translate: self.translate - o.translate,
            rotate: self.rotate - o.rotate,
            volume: self.volume - o.volume,
            shear: self.shear - o.shear,
            swap: self.swap - o.swap,
            strains: self.strains - o.strains,
        }
    }
}

impl AddAssign for Counts {
    fn add_assign(&mut self, o: Counts) {
        *self = *self + o;
    }
}

/// Move sizes.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MoveSizes {
    /// Side of the cube a translation is drawn from.
    pub translate: f64,
    /// Largest rotation angle (radians).
    pub rotate: f64,
    /// Largest change of ln V (or ln L for a per-axis move).
    pub volume: f64,
    /// Largest change of a tilt factor in a shear move.
    #[serde(default = "default_shear")]
    pub shear: f64,
}

fn default_shear() -> f64 {
    0.01
}

/// The thermodynamic ensemble of a stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ensemble {
    /// Fixed N, V, T.
    Nvt,
    /// Fixed N, P, T: βP and the kind of box move.
    Npt {
        /// βP (1/length³).
        pressure: f64,
        /// Which box moves.
        moves: BoxMoves,
    },
}

/// One sweep: N particle moves (translation, or rotation with probability
/// ½ for rotating species), then in NPT one box move.
pub fn sweep<R: Rng>(
    system: &mut System,
    sizes: &MoveSizes,
    ensemble: &Ensemble,
    rng: &mut R,
) -> Counts {
    let n = system.len();
    let mut counts = particle_moves(
        system,
        n,
        |rng| rng.gen_range(0..n),
        sizes,
        rng,
        |_| true,
        |_, _, _, _| {},
    );
    if let Some(outcome) = ensemble_box_move(system, sizes, ensemble, rng) {
        counts.record_box(outcome);
    }
    counts
}

/// [`sweep`], then `swaps` × N size swaps (rounded down, and up with
/// the probability of the remainder): each picks two bodies at random and
/// exchanges their sizes where [`System::try_swap_sizes`] allows (two of
/// one species, no overlap after). Each kind of move keeps the
/// equilibrium distribution, so their sequence does; swaps move a
/// polydisperse fluid through its configurations without the cage
/// escapes translations wait for.
pub fn sweep_with_swaps<R: Rng>(
    system: &mut System,
    sizes: &MoveSizes,
    ensemble: &Ensemble,
    swaps: f64,
    rng: &mut R,
) -> Counts {
    let mut counts = sweep(system, sizes, ensemble, rng);
    if swaps > 0.0 && system.sizes().is_some() {
        let n = system.len();
        let wanted = swaps * n as f64;
        let tries = wanted.floor() as usize + (rng.r#gen::<f64>() < wanted.fract()) as usize;
        for _ in 0..tries {
            let (i, j) = (rng.gen_range(0..n), rng.gen_range(0..n));
            counts.swap.record(system.try_swap_sizes(i, j));
        }
    }
    counts
}

/// The box move of an NPT `ensemble` with `sizes` (none in NVT).
pub(crate) fn ensemble_box_move<R: Rng>(
    system: &mut System,
    sizes: &MoveSizes,
    ensemble: &Ensemble,
    rng: &mut R,
) -> Option<BoxMoveOutcome> {
    match *ensemble {
        Ensemble::Npt { pressure, moves } => Some(box_move(
            system,
            pressure,
            (sizes.volume, sizes.shear),
            moves,
            rng,
        )),
        Ensemble::Nvt => None,
    }
}

/// The move sizes of each particle: one set for all, or one per species.
pub(crate) trait SizesOf {
    /// The sizes of particle `i`'s moves.
    fn of(&self, system: &System, i: usize) -> &MoveSizes;
}

impl SizesOf for MoveSizes {
    #[inline]
    fn of(&self, _: &System, _: usize) -> &MoveSizes {
        self
    }
}

impl SizesOf for [MoveSizes] {
    #[inline]
    fn of(&self, system: &System, i: usize) -> &MoveSizes {
        &self[system.particles[i].species as usize]
    }
}

/// `count` particle moves, each of the particle `pick` draws: a rotation
/// with probability ½ for rotating species, else a translation, confined to
/// where `inside` holds (everywhere for a serial sweep, a slab for a
/// parallel one); `tried` hears of each move: the particle, its species,
/// whether it was a rotation, and whether it was kept.
#[inline]
pub(crate) fn particle_moves<R: Rng>(
    target: &mut (impl MoveTarget + ?Sized),
    count: usize,
    mut pick: impl FnMut(&mut R) -> usize,
    sizes: &(impl SizesOf + ?Sized),
    rng: &mut R,
    inside: impl Fn(&Vector3<f64>) -> bool,
    mut tried: impl FnMut(usize, usize, bool, bool),
) -> Counts {
    let mut counts = Counts::default();
    // Systems where nothing turns skip the species lookup of every move.
    let any_rotates = target.system().species.iter().any(|s| s.rotation);
    for _ in 0..count {
        let i = pick(rng);
        let system = target.system();
        let species = system.particles[i].species as usize;
        let rotates = any_rotates && system.species[species].rotation;
        let size = *sizes.of(system, i);
        if rotates && rng.r#gen::<bool>() {
            let moved = rotate_on(target, i, size.rotate, rng);
            counts.rotate.record(moved);
            tried(i, species, true, moved);
        } else {
            let moved = translate_on(target, i, size.translate, rng, &inside);
            counts.translate.record(moved);
            tried(i, species, false, moved);
        }
    }
    counts
}

/// One NVT sweep with move sizes per species; `counts[s]` gains the
/// moves of species s.
pub(crate) fn sweep_by_species<R: Rng>(
    system: &mut System,
    sizes: &[MoveSizes],
    counts: &mut [Counts],
    rng: &mut R,
) -> Counts {
    let n = system.len();
    particle_moves(
        system,
        n,
        |rng| rng.gen_range(0..n),
        sizes,
        rng,
        |_| true,
        |_, species, rotation, moved| {
            let c = &mut counts[species];
            if rotation {
                c.rotate.record(moved);
            } else {
                c.translate.record(moved);
            }
        },
    )
}

/// A point uniform in the cube of side `size` centred on `position`.
pub fn propose_translation<R: Rng>(
    position: &Vector3<f64>,
    size: f64,
    rng: &mut R,
) -> Vector3<f64> {
    position
        + Vector3::new(
            rng.r#gen::<f64>() - 0.5,
            rng.r#gen::<f64>() - 0.5,
            rng.r#gen::<f64>() - 0.5,
        ) * size
}

/// `orientation` turned about a uniformly random axis by an angle uniform in
/// [−`max_angle`, `max_angle`] (a symmetric proposal).
pub fn propose_rotation<R: Rng>(
    orientation: &UnitQuaternion<f64>,
    max_angle: f64,
    rng: &mut R,
) -> UnitQuaternion<f64> {
    let axis = loop {
        let v = Vector3::new(
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        );
        if let Some(u) = Unit::try_new(v, 1e-12) {
            break u;
        }
    };
    let angle = max_angle * (2.0 * rng.r#gen::<f64>() - 1.0);
    UnitQuaternion::from_axis_angle(&axis, angle) * orientation
}

/// Translation uniform in a cube of side `size` around the old position.
pub fn translate<R: Rng>(system: &mut System, i: usize, size: f64, rng: &mut R) -> bool {
    translate_within(system, i, size, rng, |_| true)
}

/// [`translate`] confined to a region fixed for the duration of the moves
/// (a parallel sweep's slab): a trial centre outside it (`inside` false)
/// is rejected, which keeps the proposal symmetric.
#[inline]
pub fn translate_within<R: Rng>(
    system: &mut System,
    i: usize,
    size: f64,
    rng: &mut R,
    inside: impl Fn(&Vector3<f64>) -> bool,
) -> bool {
    translate_on(system, i, size, rng, inside)
}

/// Rotation about a uniformly random axis by a bounded angle.
pub fn rotate<R: Rng>(system: &mut System, i: usize, max_angle: f64, rng: &mut R) -> bool {
    rotate_on(system, i, max_angle, rng)
}

/// What trial moves act on: a system they read whole, whose particles
/// they place one at a time once a move is checked. A [`System`] is one;
/// a parallel sweep's member is another, which places only the particles
/// it owns.
pub(crate) trait MoveTarget {
    /// The system the moves read.
    fn system(&self) -> &System;
    /// Whether particle `i` at `position` (turned to `rotation`, or as it
    /// is) would overlap another ([`System::trial_overlaps`]: it may
    /// reorder `i`'s own list).
    fn trial_overlaps(
        &mut self,
        i: usize,
        position: &Vector3<f64>,
        rotation: Option<&nalgebra::Matrix3<f64>>,
    ) -> bool;
    /// Moves particle `i` to a pose the caller has checked overlaps
    /// nothing.
    fn place(
        &mut self,
        i: usize,
        position: Vector3<f64>,
        orientation: UnitQuaternion<f64>,
        rotation: nalgebra::Matrix3<f64>,
    );
}

impl MoveTarget for System {
    #[inline]
    fn system(&self) -> &System {
        self
    }
    #[inline]
    fn trial_overlaps(
        &mut self,
        i: usize,
        position: &Vector3<f64>,
        rotation: Option<&nalgebra::Matrix3<f64>>,
    ) -> bool {
        System::trial_overlaps(self, i, position, rotation)
    }
    #[inline]
    fn place(
        &mut self,
        i: usize,
        position: Vector3<f64>,
        orientation: UnitQuaternion<f64>,
        rotation: nalgebra::Matrix3<f64>,
    ) {
        System::place(self, i, position, orientation, rotation)
    }
}

/// [`translate_within`] on any [`MoveTarget`].
#[inline]
fn translate_on<R: Rng>(
    target: &mut (impl MoveTarget + ?Sized),
    i: usize,
    size: f64,
    rng: &mut R,
    inside: impl Fn(&Vector3<f64>) -> bool,
) -> bool {
    let position = propose_translation(&target.system().positions[i], size, rng);
    if !inside(&position) || target.trial_overlaps(i, &position, None) {
        return false;
    }
    // The orientation is read only for the moves that are kept.
    let system = target.system();
    let (orientation, rotation) = (system.particles[i].orientation, system.rotations[i]);
    target.place(i, position, orientation, rotation);
    true
}

/// [`rotate`] on any [`MoveTarget`].
#[inline]
fn rotate_on<R: Rng>(
    target: &mut (impl MoveTarget + ?Sized),
    i: usize,
    max_angle: f64,
    rng: &mut R,
) -> bool {
    let p = target.system().particles[i];
    let orientation = propose_rotation(&p.orientation, max_angle, rng);
    let rotation = orientation.to_rotation_matrix().into_inner();
    if target.trial_overlaps(i, &p.position, Some(&rotation)) {
        return false;
    }
    target.place(i, p.position, orientation, rotation);
    true
}
