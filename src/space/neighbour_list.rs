//! Symmetric neighbour lists: body i lists body j iff j lists i. The
//! event-driven dynamics links two bodies when their neighbour regions
//! overlap (Donev et al.; De Michele Sec. 3.3) and predicts collisions only
//! between linked bodies. Fixed-capacity slots per body (no allocation while
//! running), doubled when a list fills.

use super::slots::Slots;

/// Per-body lists of neighbours, kept symmetric.
#[derive(Debug, Clone)]
pub struct NeighbourLists {
    lists: FlatLists,
}

impl NeighbourLists {
    /// Empty lists for `n` bodies with room for `capacity` neighbours each
    /// (more is made when needed).
    pub fn new(n: usize, capacity: usize) -> Self {
        Self {
            lists: FlatLists::new(n, capacity),
        }
    }

    /// The neighbours of body `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        self.lists.of(i)
    }

    /// The longest list.
    pub fn longest(&self) -> usize {
        self.lists.longest()
    }

    /// The memory of body `i`'s list, its unused room included (to fetch
    /// it ahead, without reading how long the list is).
    #[inline]
    pub fn room_of(&self, i: usize) -> &[u32] {
        self.lists.room_of(i)
    }

    /// Unlinks body `i` from every neighbour (its list empties, and it
    /// leaves theirs).
    pub fn unlink_all(&mut self, i: usize) {
        for k in 0..self.lists.of(i).len() {
            let j = self.lists.of(i)[k] as usize;
            self.lists.remove(j, i as u32);
        }
        self.lists.clear(i);
    }

    /// Moves entry `at` of body `i`'s list to the front (the order within
    /// a list is free: it is a set).
    #[inline]
    pub fn to_front(&mut self, i: usize, at: usize) {
        self.lists.to_front(i, at);
    }

    /// Room for at least `capacity` neighbours per body.
    pub fn reserve(&mut self, capacity: usize) {
        self.lists.reserve(capacity);
    }

    /// The room per body before a list must grow.
    pub fn capacity(&self) -> usize {
        self.lists.capacity
    }

    /// From now on a list that would outgrow its room panics instead of
    /// growing (see [`FlatLists::fix_capacity`]).
    pub fn fix_capacity(&mut self) {
        self.lists.fix_capacity();
    }

    /// Links bodies `i` and `j` (not already linked, `i` ≠ `j`).
    pub fn link(&mut self, i: usize, j: usize) {
        debug_assert!(i != j && !self.of(i).contains(&(j as u32)));
        self.lists.push(i, j as u32);
        self.lists.push(j, i as u32);
    }

    /// Makes `near` (distinct, without `i`) body `i`'s list, in its order,
    /// as [`NeighbourLists::unlink_all`] and a [`NeighbourLists::link`] to
    /// each would; but a neighbour that stays keeps `i` where it is in its
    /// own list, so that only those that leave or arrive are touched.
    pub fn relink(&mut self, i: usize, near: &[u32], marks: &mut Marks) {
        let arriving = marks.next();
        for &j in near {
            debug_assert!(j as usize != i);
            marks.stamps[j as usize] = arriving;
        }
        for k in 0..self.lists.of(i).len() {
            let j = self.lists.of(i)[k] as usize;
            if marks.stamps[j] == arriving {
                marks.stamps[j] = STAYING;
            } else {
                self.lists.remove(j, i as u32);
            }
        }
        self.lists.clear(i);
        for &j in near {
            self.lists.push(i, j);
            if marks.stamps[j as usize] == arriving {
                self.lists.push(j as usize, i as u32);
            }
        }
    }
}

/// Per body, a stamp for [`NeighbourLists::relink`]: which bodies it is
/// asked to link, without clearing anything between calls.
#[derive(Debug, Clone)]
pub struct Marks {
    stamps: Vec<u32>,
    last: u32,
}

/// The mark of a neighbour that was linked and stays (no call's stamp).
const STAYING: u32 = 0;

impl Marks {
    /// Marks for `n` bodies.
    pub fn new(n: usize) -> Self {
        Self {
            stamps: vec![STAYING; n],
            last: STAYING,
        }
    }

    /// A stamp no body carries yet.
    fn next(&mut self) -> u32 {
        self.last = self.last.wrapping_add(1);
        if self.last == STAYING {
            self.stamps.fill(STAYING);
            self.last = STAYING + 1;
        }
        self.last
    }
}

/// Lists of indices in one flat array, `capacity` slots per list (no
/// allocation while running; doubled, everything moved, when one fills):
/// a list is one contiguous run of memory, found without a pointer chase.
#[derive(Debug, Clone, Default)]
pub struct FlatLists {
    capacity: usize,
    /// Growing is a bug: the storage is shared by threads that each hold
    /// a copy of this header (see [`FlatLists::fix_capacity`]).
    fixed: bool,
    counts: Slots<u32>,
    /// List-major: `slots[i · capacity + k]`, the first `counts[i]` used.
    slots: Slots<u32>,
}

impl FlatLists {
    /// `n` empty lists with room for `capacity` entries each.
    pub fn new(n: usize, capacity: usize) -> Self {
        let capacity = capacity.max(4);
        Self {
            capacity,
            fixed: false,
            counts: vec![0; n].into(),
            slots: vec![0; n * capacity].into(),
        }
    }

    /// List `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        let base = i * self.capacity;
        &self.slots[base..base + self.counts[i] as usize]
    }

    /// The longest list.
    pub fn longest(&self) -> usize {
        self.counts.iter().copied().max().unwrap_or(0) as usize
    }

    /// All of list `i`'s slots, used or not.
    #[inline]
    pub fn room_of(&self, i: usize) -> &[u32] {
        let base = i * self.capacity;
        &self.slots[base..base + self.capacity]
    }

    /// Appends `j` to list `i`.
    pub fn push(&mut self, i: usize, j: u32) {
        if self.counts[i] as usize == self.capacity {
            self.grow();
        }
        self.slots[i * self.capacity + self.counts[i] as usize] = j;
        self.counts[i] += 1;
    }

    /// Removes `j` from list `i` if there (the last entry takes its place).
    pub fn remove(&mut self, i: usize, j: u32) {
        let base = i * self.capacity;
        let n = self.counts[i] as usize;
        if let Some(at) = self.slots[base..base + n].iter().position(|&k| k == j) {
            self.slots[base + at] = self.slots[base + n - 1];
            self.counts[i] -= 1;
        }
    }

    /// Swaps entry `at` of list `i` with its first.
    #[inline]
    pub fn to_front(&mut self, i: usize, at: usize) {
        let base = i * self.capacity;
        debug_assert!(at < self.counts[i] as usize);
        self.slots.swap(base, base + at);
    }

    /// Empties list `i`.
    pub fn clear(&mut self, i: usize) {
        self.counts[i] = 0;
    }

    /// Room for at least `capacity` entries per list (doubled until it
    /// fits).
    pub fn reserve(&mut self, capacity: usize) {
        let mut room = self.capacity;
        while room < capacity {
            room *= 2;
        }
        if room > self.capacity {
            self.grow_to(room);
        }
    }

    /// From now on a list that would outgrow its room panics instead of
    /// growing: for a copy of these lists' header whose storage other
    /// threads share, where growing would move the storage from under
    /// them. (The room is reserved beforehand for the most entries the
    /// physics allows.)
    pub fn fix_capacity(&mut self) {
        self.fixed = true;
    }

    /// Twice the room per list.
    fn grow(&mut self) {
        self.grow_to(2 * self.capacity);
    }

    /// Room for `capacity` entries per list (more than now), every list
    /// moved once.
    fn grow_to(&mut self, capacity: usize) {
        assert!(
            !self.fixed,
            "a list outgrew the room reserved for a parallel sweep"
        );
        let mut slots = vec![0; self.counts.len() * capacity];
        for (i, &count) in self.counts.iter().enumerate() {
            let n = count as usize;
            slots[i * capacity..i * capacity + n]
                .copy_from_slice(&self.slots[i * self.capacity..i * self.capacity + n]);
        }
        self.capacity = capacity;
        self.slots = slots.into();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Flat lists through growth: every list keeps exactly its entries
    /// (as a set), removed or not there.
    #[test]
    fn flat_lists_keep_their_entries_through_growth() {
        let mut u = crate::test_support::uniform(4);
        let mut flat = FlatLists::new(5, 8);
        let mut model: Vec<Vec<u32>> = vec![Vec::new(); 5];
        for _ in 0..3000 {
            let list = (u() * 5.0) as usize;
            let i = (u() * 40.0) as u32;
            if u() < 0.6 {
                if !model[list].contains(&i) {
                    flat.push(list, i);
                    model[list].push(i);
                }
            } else {
                flat.remove(list, i);
                model[list].retain(|&j| j != i);
            }
        }
        assert!(flat.capacity > 8, "never grew: {}", flat.capacity);
        for (list, expected) in model.iter_mut().enumerate() {
            let mut got = flat.of(list).to_vec();
            got.sort_unstable();
            expected.sort_unstable();
            assert_eq!(&got, expected, "list {list}");
        }
    }

    /// Random links and unlinks against a brute-force set of pairs: the
    /// lists stay symmetric and hold exactly the linked pairs, also through
    /// growth.
    #[test]
    fn lists_stay_symmetric_and_exact() {
        let mut u = crate::test_support::uniform(11);
        let n = 30;
        let mut lists = NeighbourLists::new(n, 2);
        let mut pairs = std::collections::BTreeSet::new();
        for step in 0..3000 {
            let i = (u() * n as f64) as usize;
            if step % 5 == 0 {
                lists.unlink_all(i);
                pairs.retain(|&(a, b)| a != i && b != i);
            } else {
                let j = (u() * n as f64) as usize;
                if i != j && !pairs.contains(&(i.min(j), i.max(j))) {
                    lists.link(i, j);
                    pairs.insert((i.min(j), i.max(j)));
                }
            }
            if step % 100 == 0 {
                for a in 0..n {
                    let mut got: Vec<usize> = lists.of(a).iter().map(|&k| k as usize).collect();
                    got.sort_unstable();
                    let want: Vec<usize> = pairs
                        .iter()
                        .filter_map(|&(p, q)| (p == a).then_some(q).or((q == a).then_some(p)))
                        .collect();
                    let mut want = want;
                    want.sort_unstable();
                    assert_eq!(got, want, "body {a} at step {step}");
                }
            }
        }
        assert!(
            lists.longest() > 2,
            "the lists grew past their first capacity"
        );
    }

    /// Relinking against a brute-force set of pairs, with the marks
    /// wrapping round on the way: the lists stay symmetric and exact, and
    /// the relinked body's list is the one asked for, in its order.
    #[test]
    fn relinking_keeps_the_lists_symmetric_and_exact() {
        let mut u = crate::test_support::uniform(12);
        let n = 30;
        let mut lists = NeighbourLists::new(n, 2);
        let mut marks = Marks::new(n);
        marks.last = u32::MAX - 40;
        let mut pairs = std::collections::BTreeSet::new();
        for step in 0..600 {
            let i = (u() * n as f64) as usize;
            let mut near: Vec<u32> = Vec::new();
            for _ in 0..(u() * 12.0) as usize {
                let j = (u() * n as f64) as u32;
                if j as usize != i && !near.contains(&j) {
                    near.push(j);
                }
            }
            lists.relink(i, &near, &mut marks);
            pairs.retain(|&(a, b)| a != i && b != i);
            pairs.extend(near.iter().map(|&j| (i.min(j as usize), i.max(j as usize))));
            assert_eq!(lists.of(i), &near[..], "body {i}'s list at step {step}");
            for a in 0..n {
                let mut got: Vec<usize> = lists.of(a).iter().map(|&k| k as usize).collect();
                got.sort_unstable();
                let mut want: Vec<usize> = pairs
                    .iter()
                    .filter_map(|&(p, q)| (p == a).then_some(q).or((q == a).then_some(p)))
                    .collect();
                want.sort_unstable();
                assert_eq!(got, want, "body {a} at step {step}");
            }
        }
        assert!(marks.last < 600, "the marks wrapped round");
    }
}
