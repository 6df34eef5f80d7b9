//! Linked cells for a periodic orthorhombic box: cells at least as wide as
//! the interaction range, so that every pair within range lies in the same
//! or an adjacent cell. In a box fewer than three cells wide along an axis
//! the neighbour cells repeat; they are deduplicated, never skipped.

use nalgebra::Vector3;

/// Particle indices binned into cells.
#[derive(Debug, Clone)]
pub struct CellList {
    dims: [usize; 3],
    lengths: Vector3<f64>,
    cells: Vec<Vec<u32>>,
    cell_of: Vec<u32>,
    /// For each cell, the distinct cells within one step (itself included).
    neighbours: Vec<Vec<u32>>,
}

impl CellList {
    /// Bins `positions` (in [−L/2, L/2)) into cells of width ≥ `range`.
    pub fn new(lengths: Vector3<f64>, range: f64, positions: &[Vector3<f64>]) -> Self {
        let dims = [0, 1, 2].map(|k| ((lengths[k] / range).floor() as usize).max(1));
        let count = dims[0] * dims[1] * dims[2];
        let mut neighbours = Vec::with_capacity(count);
        for c in 0..count {
            let (x, y, z) = (
                c % dims[0],
                (c / dims[0]) % dims[1],
                c / (dims[0] * dims[1]),
            );
            let mut list = Vec::with_capacity(27);
            for dz in [-1i64, 0, 1] {
                for dy in [-1i64, 0, 1] {
                    for dx in [-1i64, 0, 1] {
                        let wrap = |v: usize, d: i64, n: usize| {
                            ((v as i64 + d).rem_euclid(n as i64)) as usize
                        };
                        let n = wrap(x, dx, dims[0])
                            + dims[0] * (wrap(y, dy, dims[1]) + dims[1] * wrap(z, dz, dims[2]));
                        if !list.contains(&(n as u32)) {
                            list.push(n as u32);
                        }
                    }
                }
            }
            neighbours.push(list);
        }
        let mut this = Self {
            dims,
            lengths,
            cells: vec![Vec::new(); count],
            cell_of: Vec::with_capacity(positions.len()),
            neighbours,
        };
        for (i, p) in positions.iter().enumerate() {
            let c = this.cell_index(p);
            this.cells[c].push(i as u32);
            this.cell_of.push(c as u32);
        }
        this
    }

    /// Cells along each axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The cell holding position `r` (wrapped into the box).
    #[inline]
    pub fn cell_index(&self, r: &Vector3<f64>) -> usize {
        let mut idx = [0usize; 3];
        for k in 0..3 {
            let f = r[k] / self.lengths[k] + 0.5;
            let f = f - f.floor();
            idx[k] = ((f * self.dims[k] as f64) as usize).min(self.dims[k] - 1);
        }
        idx[0] + self.dims[0] * (idx[1] + self.dims[1] * idx[2])
    }

    /// Records that particle `i` now sits at `r`.
    #[inline]
    pub fn update(&mut self, i: usize, r: &Vector3<f64>) {
        let new = self.cell_index(r);
        let old = self.cell_of[i] as usize;
        if new != old {
            let cell = &mut self.cells[old];
            let at = cell
                .iter()
                .position(|&j| j as usize == i)
                .expect("particle in its cell");
            cell.swap_remove(at);
            self.cells[new].push(i as u32);
            self.cell_of[i] = new as u32;
        }
    }

    /// Calls `f` with every particle in the cells around `r` (including the
    /// particle at `r` itself if it is listed); stops early and returns true
    /// as soon as `f` does.
    #[inline]
    pub fn any_near(&self, r: &Vector3<f64>, mut f: impl FnMut(usize) -> bool) -> bool {
        let c = self.cell_index(r);
        for &n in &self.neighbours[c] {
            for &j in &self.cells[n as usize] {
                if f(j as usize) {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair closer than the range is found, in boxes of 1 to 5 cells.
    #[test]
    fn finds_every_pair_within_range() {
        let mut uniform = crate::test_support::uniform(3);
        let mut u = || uniform() - 0.5;
        for &len in &[2.5, 4.0, 5.5, 7.2] {
            let lengths = Vector3::new(len, len * 1.3, len * 0.9);
            let pos: Vec<Vector3<f64>> = (0..200)
                .map(|_| Vector3::new(u() * lengths.x, u() * lengths.y, u() * lengths.z))
                .collect();
            let cl = CellList::new(lengths, 1.2, &pos);
            for i in 0..pos.len() {
                let mut near = Vec::new();
                cl.any_near(&pos[i], |j| {
                    near.push(j);
                    false
                });
                let mut sorted = near.clone();
                sorted.sort();
                sorted.dedup();
                assert_eq!(sorted.len(), near.len(), "a particle listed twice");
                for j in 0..pos.len() {
                    let mut d = pos[j] - pos[i];
                    for k in 0..3 {
                        d[k] -= lengths[k] * (d[k] / lengths[k]).round();
                    }
                    if d.norm() < 1.2 {
                        assert!(
                            near.contains(&j),
                            "pair {i}-{j} at {} missed (box {len})",
                            d.norm()
                        );
                    }
                }
            }
        }
    }
}
