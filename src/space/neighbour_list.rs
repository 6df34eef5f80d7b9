//! Symmetric neighbour lists: body i lists body j iff j lists i. The
//! event-driven dynamics links two bodies when their neighbour regions
//! overlap (Donev et al.; De Michele Sec. 3.3) and predicts collisions only
//! between linked bodies. Fixed-capacity slots per body (no allocation while
//! running), doubled when a list fills.

/// Per-body lists of neighbours, kept symmetric.
#[derive(Debug, Clone)]
pub struct NeighbourLists {
    capacity: usize,
    counts: Vec<u32>,
    slots: Vec<u32>,
}

impl NeighbourLists {
    /// Empty lists for `n` bodies with room for `capacity` neighbours each
    /// (more is made when needed).
    pub fn new(n: usize, capacity: usize) -> Self {
        let capacity = capacity.max(4);
        Self {
            capacity,
            counts: vec![0; n],
            slots: vec![0; n * capacity],
        }
    }

    /// The neighbours of body `i`.
    #[inline]
    pub fn of(&self, i: usize) -> &[u32] {
        let base = i * self.capacity;
        &self.slots[base..base + self.counts[i] as usize]
    }

    /// The longest list.
    pub fn longest(&self) -> usize {
        self.counts.iter().copied().max().unwrap_or(0) as usize
    }

    /// Unlinks body `i` from every neighbour (its list empties, and it
    /// leaves theirs).
    pub fn unlink_all(&mut self, i: usize) {
        let base = i * self.capacity;
        for k in 0..self.counts[i] as usize {
            let j = self.slots[base + k] as usize;
            self.remove(j, i as u32);
        }
        self.counts[i] = 0;
    }

    /// Links bodies `i` and `j` (not already linked, `i` ≠ `j`).
    pub fn link(&mut self, i: usize, j: usize) {
        debug_assert!(i != j && !self.of(i).contains(&(j as u32)));
        self.push(i, j as u32);
        self.push(j, i as u32);
    }

    fn push(&mut self, i: usize, j: u32) {
        if self.counts[i] as usize == self.capacity {
            self.grow();
        }
        self.slots[i * self.capacity + self.counts[i] as usize] = j;
        self.counts[i] += 1;
    }

    /// Removes `j` from `i`'s list (order not kept).
    fn remove(&mut self, i: usize, j: u32) {
        let base = i * self.capacity;
        let n = self.counts[i] as usize;
        if let Some(at) = self.slots[base..base + n].iter().position(|&k| k == j) {
            self.slots[base + at] = self.slots[base + n - 1];
            self.counts[i] -= 1;
        }
    }

    /// Twice the room per body.
    fn grow(&mut self) {
        let capacity = 2 * self.capacity;
        let mut slots = vec![0; self.counts.len() * capacity];
        for (i, &count) in self.counts.iter().enumerate() {
            let n = count as usize;
            slots[i * capacity..i * capacity + n]
                .copy_from_slice(&self.slots[i * self.capacity..i * self.capacity + n]);
        }
        self.capacity = capacity;
        self.slots = slots;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
