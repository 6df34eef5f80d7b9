//! The event calendar: predicted events with lazy invalidation (the
//! lecture's scheme) in a tournament tree of one collision and one
//! neighbourhood event per particle. Every particle carries a stamp that
//! grows whenever its trajectory changes; an event remembers the stamps of
//! its particles when it was predicted, and is stale, and skipped when it
//! comes up, if either has moved on since. Scheduling and removal of the
//! earliest event are O(log n); invalidation is O(1).

use std::cmp::Ordering;

/// What happens at an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum EventKind {
    /// Particles `i` and `j` touch.
    Collision,
    /// Particle `i` leaves its cell through the face `axis`, upwards or
    /// downwards.
    CellCrossing {
        /// 0, 1 or 2.
        axis: u8,
        /// Leaving through the face at the larger coordinate.
        up: bool,
    },
    /// Particle `i` has moved the shell from the centre of its neighbour
    /// sphere, which is rebuilt.
    Escape,
    /// Particle `i` touches the hard wall normal to `axis`, at the larger
    /// coordinate if `up`.
    Wall {
        /// 0, 1 or 2.
        axis: u8,
        /// The wall at +L/2.
        up: bool,
    },
    /// The search for particle `i`'s next wall contact stopped here
    /// (a turning body near a wall) and goes on from here.
    WallSearch,
}

/// A predicted event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    /// When it happens.
    pub time: f64,
    /// What happens.
    pub kind: EventKind,
    /// The particle.
    pub i: u32,
    /// The partner (collisions), else equal to `i`.
    pub j: u32,
    /// The stamps of `i` and `j` when the event was predicted.
    pub stamp_i: u32,
    /// See `stamp_i`.
    pub stamp_j: u32,
}

impl Event {
    /// Earliest first; equal times broken by kind and particles, so that
    /// the order, and the trajectory, does not depend on insertion order.
    fn key_cmp(&self, other: &Self) -> Ordering {
        self.time
            .total_cmp(&other.time)
            .then_with(|| self.kind.cmp(&other.kind))
            .then_with(|| self.i.cmp(&other.i))
            .then_with(|| self.j.cmp(&other.j))
    }
}

/// No event: the key of an empty slot (later than any real event).
const NONE: Event = Event {
    time: f64::INFINITY,
    kind: EventKind::Collision,
    i: u32::MAX,
    j: u32::MAX,
    stamp_i: 0,
    stamp_j: 0,
};

/// Whether `a` comes before `b` (the time decides but for ties).
#[inline(always)]
fn earlier(a: &Event, b: &Event) -> bool {
    if a.time != b.time {
        a.time < b.time
    } else {
        a.key_cmp(b) == Ordering::Less
    }
}

/// The slot of a particle's next collision; the other holds its next
/// neighbourhood event (cell crossing, neighbour-region escape, wall).
const COLLISION: usize = 0;
const NEIGHBOURHOOD: usize = 1;

/// Predicted events, earliest first, with per-particle stamps.
///
/// One event per particle and kind is all the dynamics ever needs (its
/// searches schedule only a particle's earliest collision, and one
/// crossing, escape or wall event at a time), so each particle holds two
/// slots, and a complete tree of eight children per node over the
/// particles keeps at each node the particle whose earlier slot is the
/// earliest in its subtree, with its time (a tournament tree over the
/// particles' next events; a node's children are compared side by side,
/// without reading their events unless two times are equal).
/// A changed particle's leaf-to-root path is brought up to date, O(log n)
/// and stopping as soon as the path's winners stop changing, when the
/// earliest event is next asked for (a collision changes both bodies'
/// slots several times: one walk each); the earliest event is at the
/// root. Unlike a heap with lazy deletion, stale events are overwritten in
/// place rather than piled up, so the calendar's size is fixed (about 90
/// bytes per particle, of which the tree's 18 grow up to eight times when
/// n is just above a power of eight) and it stays in cache. A leaf's event
/// is read from its particle's slots, not kept twice.
#[derive(Debug, Clone)]
pub struct Calendar {
    stamps: Vec<u32>,
    /// Per particle: its next collision and its next neighbourhood event
    /// ([`NONE`] when empty).
    slots: Vec<[Event; 2]>,
    /// The tree's levels, leaves first: entry k of level l is the earliest
    /// event under node k of level l (its leaf and time); the eight
    /// children of node k of level l + 1 are the group `levels[l][k]`,
    /// side by side in two cache lines.
    levels: Vec<Vec<Group>>,
    /// The earliest event of all: the winner of the top group.
    root: Entry,
    /// Particles whose slots changed since the tree was last brought up
    /// to date, each once (`pending`): the first `dirty_count` of `dirty`
    /// (room for every particle, and one slot to write past the last).
    dirty: Vec<u32>,
    dirty_count: usize,
    pending: Vec<bool>,
}

impl Calendar {
    /// An empty calendar for `n` particles.
    pub fn new(n: usize) -> Self {
        let mut leaves = ARITY;
        while leaves < n {
            leaves *= ARITY;
        }
        // Every leaf empty: the leftmost wins every node.
        let mut levels = Vec::new();
        let mut span = 1;
        while span < leaves {
            let groups = leaves / (span * ARITY);
            levels.push(
                (0..groups)
                    .map(|g| Group {
                        times: [f64::INFINITY; ARITY],
                        leaves: std::array::from_fn(|c| ((g * ARITY + c) * span) as u32),
                    })
                    .collect(),
            );
            span *= ARITY;
        }
        Self {
            stamps: vec![0; n],
            slots: vec![[NONE; 2]; n],
            levels,
            root: Entry {
                time: f64::INFINITY,
                leaf: 0,
            },
            dirty: vec![0; n + 1],
            dirty_count: 0,
            pending: vec![false; n],
        }
    }

    /// Asks for what scheduling an event of particle `i` will touch (its
    /// slots, stamp and leaf), ahead of it (a hint: nothing changes).
    #[inline]
    pub fn prefetch(&self, i: usize) {
        crate::edmd::prefetch::prefetch_lines(self.slots.get(i..=i).unwrap_or_default());
        crate::edmd::prefetch::prefetch_lines(self.stamps.get(i..=i).unwrap_or_default());
        if let Some(leaves) = self.levels.first() {
            crate::edmd::prefetch::prefetch_lines(
                leaves.get(i / ARITY..=i / ARITY).unwrap_or_default(),
            );
        }
    }

    /// Particle `i`'s current stamp.
    #[inline]
    pub fn stamp(&self, i: usize) -> u32 {
        self.stamps[i]
    }

    /// Invalidates every pending event of particle `i`.
    #[inline]
    pub fn invalidate(&mut self, i: usize) {
        self.stamps[i] = self.stamps[i].wrapping_add(1);
    }

    /// Schedules an event of `i` (and `j`) with their current stamps.
    ///
    /// A collision takes `i`'s collision slot unless the one there is
    /// current and earlier (the dynamics schedules only a body's earliest
    /// collision, so a later one would be invalidated by it, or found
    /// again when the body's search is renewed there); any other kind
    /// replaces `i`'s neighbourhood event.
    #[inline]
    pub fn schedule(&mut self, time: f64, kind: EventKind, i: usize, j: usize) {
        debug_assert!(!time.is_nan(), "an event at NaN");
        let e = Event {
            time,
            kind,
            i: i as u32,
            j: j as u32,
            stamp_i: self.stamps[i],
            stamp_j: self.stamps[j],
        };
        if kind == EventKind::Collision {
            let held = &self.slots[i][COLLISION];
            if !(self.is_current(held) && earlier(held, &e)) {
                self.put(i, COLLISION, e);
            }
        } else {
            self.put(i, NEIGHBOURHOOD, e);
        }
    }

    /// Puts `e` in slot `slot` of particle `p`, whose path is then stale.
    #[inline]
    fn put(&mut self, p: usize, slot: usize, e: Event) {
        self.slots[p][slot] = e;
        self.mark(p);
    }

    /// Whether `e`'s first particle has not changed since `e` was
    /// predicted. Events are yielded while this holds: a collision whose
    /// partner has changed is stale as a collision, but tells the dynamics
    /// that the first particle's search, which stopped at this event, must
    /// be renewed (see [`Calendar::partner_current`]).
    #[inline]
    fn is_current(&self, e: &Event) -> bool {
        e.i != u32::MAX && self.stamps[e.i as usize] == e.stamp_i
    }

    /// Whether `e`'s second particle has not changed since `e` was
    /// predicted (with [`Calendar::pop`]'s guarantee on the first: the
    /// event is valid).
    #[inline]
    pub fn partner_current(&self, e: &Event) -> bool {
        self.stamps[e.j as usize] == e.stamp_j
    }

    /// The earliest event whose first particle is unchanged, if any is
    /// left in the calendar (events stale in their first particle are
    /// dropped on the way).
    pub fn peek(&mut self) -> Option<Event> {
        loop {
            self.flush();
            // Padding leaves win only when every slot is empty.
            if self.root.time == f64::INFINITY {
                return None;
            }
            let p = self.root.leaf as usize;
            let e = self.next(p);
            if self.is_current(&e) {
                return Some(e);
            }
            self.clear_slot(p, &e);
        }
    }

    /// Removes and returns the earliest event whose first particle is
    /// unchanged.
    pub fn pop(&mut self) -> Option<Event> {
        self.pop_if(|_| true)
    }

    /// [`Calendar::pop`] if that event satisfies `wanted`, else nothing
    /// is removed (one look at the earliest event instead of a peek and a
    /// pop).
    #[inline]
    pub fn pop_if(&mut self, wanted: impl FnOnce(&Event) -> bool) -> Option<Event> {
        let e = self.peek().filter(wanted)?;
        self.clear_slot(e.i as usize, &e);
        Some(e)
    }

    /// Events held, stale ones included.
    pub fn len(&self) -> usize {
        self.slots
            .iter()
            .flatten()
            .filter(|e| e.time != f64::INFINITY)
            .count()
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Drops every event.
    pub fn clear(&mut self) {
        let stamps = std::mem::take(&mut self.stamps);
        *self = Self {
            stamps,
            ..Self::new(self.slots.len())
        };
    }

    /// Subtracts `origin` from every event time (keeping the order: the
    /// map t ↦ t − origin is monotone in floating point), and drops stale
    /// entries on the way.
    pub fn shift_times(&mut self, origin: f64) {
        let mut shifted = Self {
            stamps: std::mem::take(&mut self.stamps),
            ..Self::new(self.slots.len())
        };
        for (i, slots) in self.slots.iter().enumerate() {
            for (k, e) in slots.iter().enumerate() {
                if e.time != f64::INFINITY && shifted.is_current(e) {
                    shifted.slots[i][k] = Event {
                        time: e.time - origin,
                        ..*e
                    };
                }
            }
            shifted.update(i);
        }
        *self = shifted;
    }

    /// Particle `i`'s slots changed: its path is brought up to date before
    /// the earliest event is next read.
    #[inline]
    fn mark(&mut self, i: usize) {
        // Without a branch on whether it already was (it often is, at
        // random): written past the end, and counted only if new.
        let new = !self.pending[i];
        self.pending[i] = true;
        self.dirty[self.dirty_count] = i as u32;
        self.dirty_count += usize::from(new);
    }

    /// Brings the paths of every changed particle up to date.
    fn flush(&mut self) {
        while self.dirty_count > 0 {
            self.dirty_count -= 1;
            let p = self.dirty[self.dirty_count] as usize;
            self.pending[p] = false;
            self.update(p);
        }
    }

    /// Empties the slot of particle `p` that holds `e`.
    fn clear_slot(&mut self, p: usize, e: &Event) {
        // Collisions are held in the collision slot, all else in the other.
        let held = [COLLISION, NEIGHBOURHOOD][usize::from(e.kind != EventKind::Collision)];
        debug_assert_eq!(self.slots[p][held], *e);
        self.put(p, held, NONE);
    }

    /// Particle `p`'s next event: the earlier of its two slots.
    #[inline(always)]
    fn next(&self, p: usize) -> Event {
        let [a, b] = &self.slots[p];
        if earlier(b, a) { *b } else { *a }
    }

    /// Particle `p`'s slots changed: its leaf and the winners above it.
    #[inline]
    fn update(&mut self, p: usize) {
        // The earlier of the two slots' times (which slot holds it, the
        // tree does not record): a minimum, not a branch on which.
        let [a, b] = &self.slots[p];
        let mut entry = Entry {
            time: if b.time < a.time { b.time } else { a.time },
            leaf: p as u32,
        };
        let mut k = p;
        for l in 0..self.levels.len() {
            let (g, c) = (k / ARITY, k % ARITY);
            let group = &mut self.levels[l][g];
            let old = Entry {
                time: group.times[c],
                leaf: group.leaves[c],
            };
            (group.times[c], group.leaves[c]) = (entry.time, entry.leaf);
            // Above here nothing changed: the same winner, whose event is
            // unchanged (it is not p).
            if old == entry && entry.leaf as usize != p {
                return;
            }
            let (earliest, at) = earliest_of(&group.times);
            // The first of the earliest (`at` has a bit set: the minimum
            // is one of the times).
            let first = at.trailing_zeros() as usize % ARITY;
            entry = Entry {
                time: earliest,
                leaf: group.leaves[first],
            };
            if at & (at - 1) != 0 && earliest != f64::INFINITY {
                entry.leaf = self.tie_winner(&self.levels[l][g], at);
            }
            k = g;
        }
        self.root = entry;
    }

    /// Which of a group's entries whose times are equal and earliest (bit
    /// c of `at` for entry c) wins: the events' keys decide. Rare, and
    /// kept out of the walk.
    #[cold]
    #[inline(never)]
    fn tie_winner(&self, group: &Group, at: u32) -> u32 {
        let first = at.trailing_zeros() as usize;
        let mut best = group.leaves[first];
        for c in first + 1..ARITY {
            let leaf = group.leaves[c];
            if at & (1 << c) != 0 && earlier(&self.next(leaf as usize), &self.next(best as usize)) {
                best = leaf;
            }
        }
        best
    }
}

/// The earliest of eight times (none NaN), and which of them equal it
/// (bit c for time c).
#[inline(always)]
fn earliest_of(t: &[f64; ARITY]) -> (f64, u32) {
    // Four pairs side by side in SSE2 (part of every x86-64): the compiler
    // compares the eight one by one otherwise.
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_cmpeq_pd, _mm_cvtsd_f64, _mm_min_pd, _mm_movemask_pd, _mm_set_pd, _mm_unpackhi_pd,
            _mm_unpacklo_pd,
        };
        // SAFETY: SSE2 is part of the x86_64 baseline, and these
        // intrinsics touch no memory.
        unsafe {
            let pairs: [_; 4] = std::array::from_fn(|c| _mm_set_pd(t[2 * c + 1], t[2 * c]));
            let both = _mm_min_pd(
                _mm_min_pd(pairs[0], pairs[1]),
                _mm_min_pd(pairs[2], pairs[3]),
            );
            let one = _mm_min_pd(both, _mm_unpackhi_pd(both, both));
            let earliest = _mm_unpacklo_pd(one, one);
            let mut at = 0;
            for (c, &pair) in pairs.iter().enumerate() {
                at |= (_mm_movemask_pd(_mm_cmpeq_pd(pair, earliest)) as u32) << (2 * c);
            }
            (_mm_cvtsd_f64(one), at)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let lesser = |a: f64, b: f64| if b < a { b } else { a };
        let pairs: [f64; 4] = std::array::from_fn(|c| lesser(t[2 * c], t[2 * c + 1]));
        let earliest = lesser(lesser(pairs[0], pairs[1]), lesser(pairs[2], pairs[3]));
        let mut at = 0u32;
        for (c, &time) in t.iter().enumerate() {
            at |= u32::from(time == earliest) << c;
        }
        (earliest, at)
    }
}

/// Children per node of the calendar's tree: their entries fill two cache
/// lines, and a walk from a leaf to the root climbs a third of the levels
/// of a binary tree.
const ARITY: usize = 8;

/// A node's earliest event: its time and its particle (leaf).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    time: f64,
    leaf: u32,
}

/// The entries of a node's children, side by side.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(128))]
struct Group {
    times: [f64; ARITY],
    leaves: [u32; ARITY],
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The calendar's contract with a brute-force model: per particle the
    /// earliest current collision and the last neighbourhood event, popped
    /// by scanning every slot for the earliest current one.
    struct Model {
        stamps: Vec<u32>,
        slots: Vec<[Option<Event>; 2]>,
    }

    impl Model {
        fn current(&self, e: &Event) -> bool {
            self.stamps[e.i as usize] == e.stamp_i
        }

        fn schedule(&mut self, time: f64, kind: EventKind, i: usize, j: usize) {
            let e = Event {
                time,
                kind,
                i: i as u32,
                j: j as u32,
                stamp_i: self.stamps[i],
                stamp_j: self.stamps[j],
            };
            let slot = usize::from(kind != EventKind::Collision);
            match self.slots[i][slot] {
                Some(held)
                    if slot == 0 && self.current(&held) && held.key_cmp(&e) == Ordering::Less => {}
                _ => self.slots[i][slot] = Some(e),
            }
        }

        fn pop(&mut self) -> Option<Event> {
            self.pop_until(f64::INFINITY)
        }

        /// The earliest current event if it comes at `limit` or before.
        fn pop_until(&mut self, limit: f64) -> Option<Event> {
            let mut best: Option<(usize, usize)> = None;
            for (i, slots) in self.slots.iter().enumerate() {
                for (k, e) in slots.iter().enumerate() {
                    let Some(e) = e else { continue };
                    if !self.current(e) {
                        continue;
                    }
                    let earlier = best.is_none_or(|(bi, bk)| {
                        e.key_cmp(&self.slots[bi][bk].unwrap()) == Ordering::Less
                    });
                    if earlier {
                        best = Some((i, k));
                    }
                }
            }
            let (i, k) = best?;
            if self.slots[i][k]?.time > limit {
                return None;
            }
            self.slots[i][k].take()
        }
    }

    /// Random schedules, invalidations and pops (some only up to a time
    /// limit), with ties in time: the tree yields exactly the model's
    /// events, earliest first, never a stale one, and holds at most two
    /// events per particle.
    #[test]
    fn yields_the_earliest_current_event_as_a_brute_force_scan_does() {
        let mut u = crate::test_support::uniform(5);
        for n in [1, 2, 3, 7, 9, 50, 64, 65, 700] {
            let mut cal = Calendar::new(n);
            let mut model = Model {
                stamps: vec![0; n],
                slots: vec![[None; 2]; n],
            };
            let mut now = 0.0;
            let mut popped = 0;
            for _ in 0..20_000 {
                let i = (u() * n as f64) as usize;
                let j = (u() * n as f64) as usize;
                let r = u();
                if r < 0.45 {
                    // Coarse times: ties between particles and kinds.
                    let time = now + (u() * 20.0).floor() * 0.5;
                    let kind = if u() < 0.6 {
                        EventKind::Collision
                    } else {
                        EventKind::CellCrossing {
                            axis: (u() * 3.0) as u8,
                            up: u() < 0.5,
                        }
                    };
                    cal.schedule(time, kind, i, j);
                    model.schedule(time, kind, i, j);
                } else if r < 0.6 {
                    cal.invalidate(i);
                    model.stamps[i] += 1;
                } else {
                    // Half the time only up to a limit, which may leave the
                    // earliest event where it is.
                    let limit = if u() < 0.5 {
                        f64::INFINITY
                    } else {
                        now + (u() * 8.0).floor() * 0.5
                    };
                    let got = cal.pop_if(|e| e.time <= limit);
                    assert_eq!(got, model.pop_until(limit));
                    if let Some(e) = got {
                        assert!(e.time >= now, "{} before {now}", e.time);
                        now = e.time;
                        popped += 1;
                    }
                }
                assert!(cal.len() <= 2 * n);
            }
            assert!(popped > 1000, "{popped} events popped");
            while let Some(e) = cal.pop() {
                assert_eq!(Some(e), model.pop());
            }
            assert_eq!(model.pop(), None);
        }
    }

    /// A collision later than the particle's current one is not kept; an
    /// earlier one, or any after an invalidation, replaces it.
    #[test]
    fn a_particle_keeps_its_earliest_collision() {
        let mut cal = Calendar::new(4);
        cal.schedule(2.0, EventKind::Collision, 0, 1);
        cal.schedule(3.0, EventKind::Collision, 0, 2);
        assert_eq!(cal.len(), 1);
        cal.schedule(1.0, EventKind::Collision, 0, 3);
        assert_eq!(cal.peek().map(|e| (e.time, e.j)), Some((1.0, 3)));
        cal.invalidate(0);
        assert_eq!(cal.peek(), None);
        cal.schedule(5.0, EventKind::Collision, 0, 1);
        cal.schedule(4.0, EventKind::Escape, 0, 0);
        assert_eq!(cal.pop().map(|e| e.kind), Some(EventKind::Escape));
        assert_eq!(cal.pop().map(|e| e.time), Some(5.0));
        assert!(cal.is_empty());
    }

    /// Shifting the origin keeps the order and subtracts the offset.
    #[test]
    fn shift_keeps_order() {
        let mut cal = Calendar::new(4);
        cal.schedule(1000.5, EventKind::Collision, 0, 1);
        cal.schedule(1000.25, EventKind::Collision, 1, 2);
        cal.schedule(1001.0, EventKind::Collision, 3, 2);
        cal.schedule(1000.75, EventKind::Escape, 2, 2);
        cal.invalidate(2);
        cal.shift_times(1000.0);
        // Events stale only in their partner stay: their first particle's
        // search may have ended there; those stale in it go.
        assert_eq!(cal.len(), 3);
        let mut popped = Vec::new();
        while let Some(e) = cal.pop() {
            popped.push((e.time, cal.partner_current(&e)));
        }
        assert_eq!(popped, [(0.25, false), (0.5, true), (1.0, false)]);
        cal.schedule(3.0, EventKind::Collision, 2, 0);
        cal.invalidate(2);
        assert_eq!(cal.pop(), None, "an event stale in its first particle");
    }
}
