//! The event calendar: a binary heap of predicted events with lazy
//! invalidation (the lecture's scheme). Every particle carries a stamp that
//! grows whenever its trajectory changes; an event remembers the stamps of
//! its particles when it was predicted, and is stale, and skipped when it
//! comes up, if either has moved on since. Insertion and removal of the
//! earliest event are O(log n); invalidation is O(1).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

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

/// A heap entry, reversed so that `BinaryHeap` (a max-heap) yields the
/// earliest event.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Earliest(Event);

impl Eq for Earliest {}

impl PartialOrd for Earliest {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Earliest {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.key_cmp(&self.0)
    }
}

/// The heap is compacted (stale entries dropped) when it holds this many
/// entries per particle.
const COMPACT_PER_PARTICLE: usize = 4;

/// Predicted events, earliest first, with per-particle stamps.
#[derive(Debug, Clone)]
pub struct Calendar {
    heap: BinaryHeap<Earliest>,
    stamps: Vec<u32>,
    /// Heap size at which stale entries are dropped.
    compact_at: usize,
}

impl Calendar {
    /// An empty calendar for `n` particles.
    pub fn new(n: usize) -> Self {
        Self {
            heap: BinaryHeap::with_capacity(2 * COMPACT_PER_PARTICLE * n.max(64)),
            stamps: vec![0; n],
            compact_at: COMPACT_PER_PARTICLE * n.max(64),
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
    #[inline]
    pub fn schedule(&mut self, time: f64, kind: EventKind, i: usize, j: usize) {
        if self.heap.len() >= self.compact_at {
            self.compact();
        }
        self.heap.push(Earliest(Event {
            time,
            kind,
            i: i as u32,
            j: j as u32,
            stamp_i: self.stamps[i],
            stamp_j: self.stamps[j],
        }));
    }

    /// Whether `e`'s first particle has not changed since `e` was
    /// predicted. Events are yielded while this holds: a collision whose
    /// partner has changed is stale as a collision, but tells the dynamics
    /// that the first particle's search, which stopped at this event, must
    /// be renewed (see [`Calendar::partner_current`]).
    #[inline]
    fn is_current(&self, e: &Event) -> bool {
        self.stamps[e.i as usize] == e.stamp_i
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
        while let Some(&Earliest(e)) = self.heap.peek() {
            if self.is_current(&e) {
                return Some(e);
            }
            self.heap.pop();
        }
        None
    }

    /// Removes and returns the earliest event whose first particle is
    /// unchanged.
    pub fn pop(&mut self) -> Option<Event> {
        let e = self.peek()?;
        self.heap.pop();
        Some(e)
    }

    /// Entries held, stale ones included.
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }

    /// Drops every event.
    pub fn clear(&mut self) {
        self.heap.clear();
    }

    /// Drops the entries stale in their first particle. Those would wait
    /// in the heap until their time came; a heap a few times the number
    /// of particles stays in cache, where one tens of times larger costs a
    /// cache miss per level of every pop.
    fn compact(&mut self) {
        let stamps = &self.stamps;
        self.heap
            .retain(|Earliest(e)| stamps[e.i as usize] == e.stamp_i);
        // Twice what is left, so that compacting stays O(1) per event even
        // when most entries are current.
        self.compact_at =
            (COMPACT_PER_PARTICLE * self.stamps.len().max(64)).max(2 * self.heap.len());
    }

    /// Subtracts `origin` from every event time (keeping the order: the
    /// map t ↦ t − origin is monotone in floating point), and drops stale
    /// entries on the way.
    pub fn shift_times(&mut self, origin: f64) {
        let stamps = &self.stamps;
        let events: Vec<Earliest> = std::mem::take(&mut self.heap)
            .into_vec()
            .into_iter()
            .filter(|Earliest(e)| stamps[e.i as usize] == e.stamp_i)
            .map(|Earliest(e)| {
                Earliest(Event {
                    time: e.time - origin,
                    ..e
                })
            })
            .collect();
        self.heap = BinaryHeap::from(events);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Events come out in time order, invalidated ones never do, and the
    /// heap sheds them as it grows.
    #[test]
    fn yields_valid_events_in_time_order() {
        let mut u = crate::test_support::uniform(5);
        let n = 50;
        let mut cal = Calendar::new(n);
        let mut expected = Vec::new();
        for k in 0..2000 {
            let i = (u() * n as f64) as usize;
            let j = (u() * n as f64) as usize;
            let t = u() * 100.0;
            cal.schedule(t, EventKind::Collision, i, j);
            expected.push((t, i, j, k));
            if k % 7 == 0 {
                cal.invalidate(i);
                expected.retain(|&(_, a, b, _)| a != i && b != i);
            }
        }
        // Stale entries were dropped on the way (2000 scheduled, a heap
        // bounded by a few per particle and twice the live ones).
        assert!(
            cal.len() < 2 * (expected.len() + 4 * 64),
            "{} entries",
            cal.len()
        );
        expected.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut got = Vec::new();
        while let Some(e) = cal.pop() {
            if cal.partner_current(&e) {
                got.push((e.time, e.i as usize, e.j as usize));
            }
        }
        assert_eq!(got.len(), expected.len());
        for (g, e) in got.iter().zip(&expected) {
            assert_eq!(g.0, e.0);
        }
        assert!(cal.is_empty());
    }

    /// Shifting the origin keeps the order and subtracts the offset.
    #[test]
    fn shift_keeps_order() {
        let mut cal = Calendar::new(3);
        cal.schedule(1000.5, EventKind::Collision, 0, 1);
        cal.schedule(1000.25, EventKind::Collision, 1, 2);
        cal.schedule(1001.0, EventKind::Collision, 0, 2);
        cal.invalidate(2);
        cal.shift_times(1000.0);
        // Events stale only in their partner stay: their first particle's
        // search may have ended there.
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
