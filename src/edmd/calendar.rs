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
/// slots, and a complete binary tree over the particles keeps at each node
/// the particle whose earlier slot is the earliest in its subtree (a
/// tournament tree over the particles' next events).
/// A changed particle's leaf-to-root path is brought up to date, O(log n)
/// and stopping as soon as the path's winners stop changing, when the
/// earliest event is next asked for (a collision changes both bodies'
/// slots several times: one walk each); the earliest event is at the
/// root. Unlike a heap with lazy deletion, stale events are overwritten in
/// place rather than piled up, so the calendar's size is fixed (about 100
/// bytes per particle) and it stays in cache.
#[derive(Debug, Clone)]
pub struct Calendar {
    stamps: Vec<u32>,
    /// Per particle: its next collision and its next neighbourhood event
    /// ([`NONE`] when empty).
    slots: Vec<[Event; 2]>,
    /// Per leaf (particles, then padding up to a power of two): the
    /// earlier of its two slots.
    next: Vec<Event>,
    /// `winners[k]`, 1 <= k < leaves: the leaf of the earliest event under
    /// node k (children 2k and 2k + 1; node k >= leaves is leaf k − leaves).
    winners: Vec<u32>,
    leaves: usize,
    /// Particles whose slots changed since the tree was last brought up
    /// to date, each once (`pending`).
    dirty: Vec<u32>,
    pending: Vec<bool>,
}

impl Calendar {
    /// An empty calendar for `n` particles.
    pub fn new(n: usize) -> Self {
        let leaves = n.max(2).next_power_of_two();
        let mut winners = vec![0; leaves];
        // Every leaf empty: the leftmost wins every node.
        for (k, w) in winners.iter_mut().enumerate().skip(1) {
            *w = ((k << (leaves.trailing_zeros() - k.ilog2())) - leaves) as u32;
        }
        Self {
            stamps: vec![0; n],
            slots: vec![[NONE; 2]; n],
            next: vec![NONE; leaves],
            winners,
            leaves,
            dirty: Vec::new(),
            pending: vec![false; n],
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
            let p = self.winners[1] as usize;
            let e = self.next[p];
            if e.time == f64::INFINITY {
                return None;
            }
            if self.is_current(&e) {
                return Some(e);
            }
            self.clear_slot(p, &e);
        }
    }

    /// Removes and returns the earliest event whose first particle is
    /// unchanged.
    pub fn pop(&mut self) -> Option<Event> {
        let e = self.peek()?;
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
        if !self.pending[i] {
            self.pending[i] = true;
            self.dirty.push(i as u32);
        }
    }

    /// Brings the paths of every changed particle up to date.
    fn flush(&mut self) {
        while let Some(p) = self.dirty.pop() {
            self.pending[p as usize] = false;
            self.update(p as usize);
        }
    }

    /// Empties the slot of particle `p` that holds `e`.
    fn clear_slot(&mut self, p: usize, e: &Event) {
        let held = usize::from(self.slots[p][COLLISION] != *e);
        self.put(p, [COLLISION, NEIGHBOURHOOD][held], NONE);
    }

    /// Particle `p`'s slots changed: its leaf and the winners above it.
    #[inline]
    fn update(&mut self, p: usize) {
        let [a, b] = &self.slots[p];
        self.next[p] = if earlier(b, a) { *b } else { *a };
        let mut node = (self.leaves + p) >> 1;
        while node >= 1 {
            let (l, r) = (self.child_winner(2 * node), self.child_winner(2 * node + 1));
            let w = if earlier(&self.next[r as usize], &self.next[l as usize]) {
                r
            } else {
                l
            };
            let old = self.winners[node];
            self.winners[node] = w;
            // Above here nothing changed: the same winner, whose event is
            // unchanged (it is not p).
            if w == old && w as usize != p {
                break;
            }
            node >>= 1;
        }
    }

    /// The winning leaf of node `k` (a leaf itself when `k >= leaves`).
    #[inline(always)]
    fn child_winner(&self, k: usize) -> u32 {
        if k >= self.leaves {
            (k - self.leaves) as u32
        } else {
            self.winners[k]
        }
    }
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
            self.slots[i][k].take()
        }
    }

    /// Random schedules, invalidations and pops, with ties in time: the
    /// tree yields exactly the model's events, earliest first, never a
    /// stale one, and holds at most two events per particle.
    #[test]
    fn yields_the_earliest_current_event_as_a_brute_force_scan_does() {
        let mut u = crate::test_support::uniform(5);
        for n in [1, 2, 3, 7, 50] {
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
                    let got = cal.pop();
                    assert_eq!(got, model.pop());
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
