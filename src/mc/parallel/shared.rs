//! Teams that share one system of hard spheres: how wide the slabs must
//! be for members to touch disjoint storage, the members' views (the
//! system read, only the slots of their own slabs' spheres written), and
//! the lists' review folded in between sweeps.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::Rng;

use super::replicas::{Scratch, colour_moves};
use super::*;
use crate::mc::moves::ensemble_box_move;
use crate::mc::moves::{Counts, Ensemble, MoveTarget};
use crate::state::shared::SphereSlots;
use crate::state::{Neighbours, SPHERE_LISTS_REVIEW, System};

type V3 = Vector3<f64>;

/// What a team of threads sharing one system of hard spheres must keep
/// to (see the module docs): the least slab width, and the room cells and
/// lists must have for no move of the team to grow them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SharingTerms {
    /// Members sweeping slabs two apart (at least this wide) touch
    /// disjoint memory.
    pub(super) least_width: f64,
    /// The most members a cell of the moves' cells can hold.
    pub(super) cell_room: usize,
    /// The most references a reference cell of the sphere lists can hold,
    /// and the most entries of one list (0 without sphere lists).
    pub(super) reference_room: usize,
    pub(super) list_room: usize,
}

/// Room above which sharing is not worth its memory (spheres of very
/// different sizes: the smallest sets the bounds).
const MOST_ROOM: usize = 512;

/// The most points pairwise farther apart than `closest` in a box with
/// edges `sides`: the fewer of the boxes of diameter `closest` it divides
/// into (one point each at most) and of the balls of diameter `closest`
/// around the points the box grown by `closest` holds by volume.
pub(super) fn room_in_box(sides: &V3, closest: f64) -> usize {
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
pub(super) fn room_in_ball(radius: f64, closest: f64) -> usize {
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
    pub(super) fn of(system: &System, axis: usize) -> Option<Self> {
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
        let closest =
            0.999 * 2.0 * (system.body_radii.iter().copied()).fold(f64::INFINITY, f64::min);
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
    pub(super) fn at_width(system: &System, axis: usize, width: f64) -> Option<Self> {
        Self::of(system, axis).filter(|terms| width >= terms.least_width)
    }

    /// Whether `system`'s cells and lists have the room.
    pub(super) fn roomy(&self, system: &System) -> bool {
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
    pub(super) fn reserve(&self, system: &mut System) {
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
    pub(super) fn shareable(&self, system: &System) -> bool {
        SharingTerms::at_width(system, self.axis, self.length / self.count as f64)
            .is_some_and(|terms| terms.roomy(system))
    }
}

/// The caller's system, which the members of a team of hard spheres share
/// (see the module docs).
pub(super) struct SharedSystem(*mut System);

// SAFETY: the members touch the system only through [`MemberView`] and
// `whole`, as they say.
unsafe impl Sync for SharedSystem {}

impl SharedSystem {
    /// The system itself, for the one member that works on it while the
    /// others wait at a barrier holding no view they will use again.
    ///
    /// SAFETY: as said; the reference is dropped before the barrier.
    #[allow(clippy::mut_from_ref)]
    unsafe fn whole(&self) -> &mut System {
        // SAFETY: as the caller promises.
        unsafe { &mut *self.0 }
    }
}

/// A member's view of the shared system between two barriers: it reads
/// the whole system, and writes only through its [`SphereSlots`] (the
/// centres, particles, cells and lists of spheres) the particles of the
/// slabs it is sweeping, each kept inside its slab ([`MoveTarget::place`]
/// refuses any other); no `&mut System` can be had from it. What a move
/// changes of the system's header (the lists' review window, whether
/// anything moved) it counts in fields of its own, handed to the system
/// between sweeps.
pub(super) struct MemberView {
    system: *const System,
    slots: std::mem::ManuallyDrop<SphereSlots>,
    /// The system's sphere-list skin and size, read when the view was
    /// made (the header is not to be read once member 0 may change it).
    skin: Option<f64>,
    len: usize,
    /// Moves in the system's review window when the view was made, and
    /// the moves and squared steps since, not yet handed over.
    window_base: usize,
    window: (usize, f64),
    changed: bool,
    /// The slabs of the sweep, the colour being swept, and this member and
    /// its team: which particles it may place. Nothing while between
    /// colours.
    sweeping: Option<(Slabs, usize, (usize, usize))>,
}

impl MemberView {
    /// A member's view over `shared`, sweeping no colour yet.
    ///
    /// SAFETY: no member may be writing the system's header (between
    /// barriers, where only the storage changes), and the view is used
    /// only until the next change of it (to the next barrier); members
    /// placing particles of slabs that [`Slabs::shareable`] allows touch
    /// disjoint storage.
    unsafe fn new(shared: &SharedSystem) -> Self {
        let system: *const System = shared.0;
        // SAFETY: as the caller promises.
        let whole = unsafe { &*system };
        // SAFETY: as the caller promises.
        let slots = unsafe { SphereSlots::of(whole) }
            .expect("a team shares only spheres on one grid of cells");
        Self {
            system,
            slots,
            skin: whole.plan.sphere_skin,
            len: whole.len(),
            window_base: whole.list_window.0,
            window: (0, 0.0),
            changed: false,
            sweeping: None,
        }
    }

    /// The moves and changes this view made since it was last asked,
    /// handed over.
    fn take_pending(&mut self) -> Pending {
        let pending = Pending {
            moves: self.window.0,
            sum: self.window.1,
            changed: self.changed,
        };
        (self.window, self.changed) = ((0, 0.0), false);
        pending
    }

    /// Whether the system's lists are due for review once it hears of
    /// `moves` more.
    fn review_due(&self, moves: usize) -> bool {
        self.skin.is_some() && self.window_base + moves >= SPHERE_LISTS_REVIEW * self.len
    }
}

impl MoveTarget for MemberView {
    fn system(&self) -> &System {
        // SAFETY: the header is unchanged while the view is used (see
        // `new`); the elements it reads no other member writes.
        unsafe { &*self.system }
    }

    /// Spheres keep no capsule lists: the trial only reads.
    fn trial_overlaps(&mut self, i: usize, position: &V3, rotation: Option<&Matrix3<f64>>) -> bool {
        let system = self.system();
        let rotation = rotation.unwrap_or(&system.rotations[i]);
        system.overlaps_at(i, position, rotation)
    }

    /// Places particle `i` if it lies in a slab of the colour this member
    /// sweeps and stays in it; panics otherwise (a member writing what it
    /// does not own would race with another).
    fn place(
        &mut self,
        i: usize,
        position: V3,
        _orientation: UnitQuaternion<f64>,
        _rotation: Matrix3<f64>,
    ) {
        let Some((slabs, colour, (me, team))) = self.sweeping else {
            panic!("a member places particles only while it sweeps a colour");
        };
        // SAFETY: as in `system`; the reference is to the header, apart
        // from the storage the slots write.
        let system = unsafe { &*self.system };
        let box_ = system.periodic_box();
        let from = system.positions[i];
        let to = slabs.slab_of(&box_.wrap_near(&position));
        let slab = slabs.slab_of(&from);
        assert!(
            slab == to && slab % 2 == colour && slabs.owner(slab, team) == me,
            "member {me} may not move particle {i} from slab {slab} to {to}"
        );
        let step_sq = self.slots.place(box_, i, &from, position);
        if self.skin.is_some() {
            self.window.0 += 1;
            self.window.1 += step_sq;
        }
        self.changed = true;
    }
}

/// What members of a sharing team report after their moves of a sweep:
/// their review window and whether they moved anything.
type Report = std::sync::Mutex<Pending>;

/// Review windows and changes the members made since the system's header
/// last heard of them.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Pending {
    moves: usize,
    sum: f64,
    changed: bool,
}

impl Pending {
    pub(super) fn add(&mut self, o: &Pending) {
        self.moves += o.moves;
        self.sum += o.sum;
        self.changed |= o.changed;
    }

    /// Hands the moves to `system`'s header and reviews its lists.
    pub(super) fn fold_into(self, system: &mut System) {
        system.list_window.0 += self.moves;
        system.list_window.1 += self.sum;
        system.changed |= self.changed;
        system.review_sphere_lists_now();
    }
}

/// The work of member `me` of a team of `team` sharing `shared` (the
/// sweeps of [`member_sweeps`], with the same moves): every member sorts
/// its slabs and sweeps them through its [`MemberView`], a barrier after
/// the sort and after each colour. Where the header must change (a box
/// move, a review of the lists due, the team's last sweep), member 0
/// hands it the members' review windows, reviews the lists, makes the box
/// move and the room, while the others wait and then take a fresh view;
/// in NVT that is one
/// sweep in [`SPHERE_LISTS_REVIEW`]. A sweep whose slabs are too thin to
/// share (a box move shrank them) or that has none is member 0's alone,
/// as a team of one makes it.
pub(super) fn shared_member_sweeps(
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
    let mut local = unsafe { MemberView::new(shared) };
    let mut pending = Pending::default();
    let npt = matches!(ensemble, Ensemble::Npt { .. });
    for (j, &seed) in seeds.iter().enumerate() {
        let index = first_index + j as u64;
        let last = j + 1 == seeds.len();
        let mut master = stream(seed, index, u64::MAX, u64::MAX);
        let system = local.system();
        let slabs = Slabs::of_sweep(system, threads, &mut master).filter(|s| s.shareable(system));
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
            local = unsafe { MemberView::new(shared) };
            continue;
        };
        scratch.sort(local.system(), &slabs, me, team);
        // Sorting reads every centre: no member moves one before all have
        // sorted.
        barrier.wait();
        let first = usize::from(master.r#gen::<bool>());
        for colour in [first, 1 - first] {
            local.sweeping = Some((slabs, colour, (me, team)));
            counts += colour_moves(
                &mut local,
                &scratch.slab_members,
                (&slabs, colour),
                (seed, index),
                sizes,
                |_| {},
            );
            local.sweeping = None;
            if colour != first {
                *reports[me].lock().expect("no member panicked") = local.take_pending();
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
        let review_due = local.review_due(pending.moves);
        if !(npt || review_due || last) {
            continue;
        }
        if me == 0 {
            // SAFETY: the others wait at the barrier below (or are done),
            // and take a fresh copy after it.
            let system = unsafe { shared.whole() };
            pending.fold_into(system);
            if let Some(outcome) = ensemble_box_move(system, sizes, ensemble, &mut master) {
                counts.record_box(outcome);
            }
            if let Some(terms) = SharingTerms::of(system, slabs.axis) {
                terms.reserve(system);
            }
        }
        pending = Pending::default();
        if !last {
            barrier.wait();
            // SAFETY: after the barrier, member 0 done with the header.
            local = unsafe { MemberView::new(shared) };
        }
    }
    (counts, sharing)
}

/// The sweeps of `work` by a team of `team` sharing `system`.
pub(super) fn shared_sweeps(
    system: &mut System,
    team: usize,
    work: &Work,
) -> (Counts, SharedCounts) {
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
        let ((counts, shared_counts), strains) = crate::geometry::pair::counting_strains(|| {
            shared_member_sweeps((me, team), &barrier, &reports, &shared, work)
        });
        (counts.with_strains(strains), shared_counts)
    });
    let counts = per_thread.iter().fold(Counts::default(), |a, c| a + c.0);
    (counts, per_thread[0].1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::panic::{AssertUnwindSafe, catch_unwind};

    /// A member's view places the particles of its own slabs of the colour
    /// it sweeps, inside them, and refuses every other: one in the other
    /// member's slab, one of the other colour, one that would leave its
    /// slab, and any while it sweeps no colour.
    #[test]
    fn a_member_places_only_what_it_owns() {
        let sphere: crate::geometry::Shape = "Sphere(radius: 0.5)".parse().unwrap();
        let mut system = crate::bench::mc::dense_start(&sphere, 4096, 0.5).unwrap();
        let slabs = Slabs::of_sweep(&system, 2, &mut stream(1, 0, 0, 0)).unwrap();
        assert_eq!(slabs.count, 4);
        let in_slab = |system: &System, k: usize| {
            (0..system.len())
                .find(|&i| slabs.slab_of(&system.positions[i]) == k)
                .unwrap()
        };
        let ones: Vec<usize> = (0..4).map(|k| in_slab(&system, k)).collect();
        let shared = SharedSystem(&mut system);
        // SAFETY: one view, on this thread alone.
        let mut view = unsafe { MemberView::new(&shared) };
        let pose = |view: &MemberView, i: usize| {
            let s = view.system();
            (s.positions[i], s.particles[i].orientation, s.rotations[i])
        };
        let refused = |view: &mut MemberView, i: usize, shift: f64| {
            let (mut r, q, m) = pose(view, i);
            r[slabs.axis] += shift;
            catch_unwind(AssertUnwindSafe(|| view.place(i, r, q, m))).is_err()
        };
        // Member 0 of two owns slabs 0 (even) and 1 (odd).
        assert!(refused(&mut view, ones[0], 0.0), "between colours");
        view.sweeping = Some((slabs, 0, (0, 2)));
        assert!(!refused(&mut view, ones[0], 0.0), "its own");
        assert!(refused(&mut view, ones[2], 0.0), "the other member's");
        assert!(refused(&mut view, ones[1], 0.0), "the other colour");
        let width = slabs.length / slabs.count as f64;
        assert!(refused(&mut view, ones[0], width), "leaving its slab");
        view.sweeping = Some((slabs, 1, (0, 2)));
        assert!(!refused(&mut view, ones[1], 0.0), "its own, odd");
        assert!(refused(&mut view, ones[3], 0.0), "the other member's, odd");
    }
}
