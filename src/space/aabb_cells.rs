//! Cells for elongated or size-asymmetric particles: each particle is
//! registered in every cell its axis-aligned bounding box (AABB) touches,
//! and a query visits the cells of the query's AABB. Two bodies can overlap
//! only if their AABBs share a point, and the cell holding that point lists
//! both, so no pair is missed; a particle listed in several visited cells is
//! tested once (a visit stamp). Cells can then be much smaller than the
//! largest bounding sphere, which is what makes needles and 1:10 mixtures
//! cheap.

use std::cell::RefCell;

use nalgebra::Vector3;

use super::PeriodicBox;
use super::neighbour_list::FlatLists;

/// AABB cell registry over a periodic box, cut in its unsheared
/// coordinates (a tilted box registers the unsheared box that holds each
/// AABB).
#[derive(Debug, Clone)]
pub struct AabbCells {
    dims: [usize; 3],
    width: Vector3<f64>,
    box_: PeriodicBox,
    /// Per cell: its members, each once (a cell-major flat array: a query
    /// reads each visited cell's members from one contiguous run).
    cells: FlatLists,
    /// Per particle: the (unwrapped) first and last cell index per axis.
    spans: Vec<[[i64; 2]; 3]>,
}

thread_local! {
    /// Visit stamps per particle and the current stamp, per thread, so that
    /// queries need no `&mut` and run from many threads at once.
    static STAMPS: RefCell<(u32, Vec<u32>)> = const { RefCell::new((0, Vec::new())) };
}

impl AabbCells {
    /// Cells of width ≥ `width` in `box_`, with particle i registered for
    /// the AABB `centres[i] ± half_extents[i]`.
    pub fn new(
        box_: &PeriodicBox,
        width: f64,
        centres: &[Vector3<f64>],
        half_extents: &[Vector3<f64>],
    ) -> Self {
        let lengths = box_.lengths();
        let dims = super::cell_grid(&lengths, width, centres.len());
        let cell_width = Vector3::new(
            lengths.x / dims[0] as f64,
            lengths.y / dims[1] as f64,
            lengths.z / dims[2] as f64,
        );
        let mut this = Self {
            dims,
            width: cell_width,
            box_: *box_,
            cells: FlatLists::new(dims[0] * dims[1] * dims[2], 8),
            spans: Vec::with_capacity(centres.len()),
        };
        let mut cells = std::mem::take(&mut this.cells);
        for (i, (c, h)) in centres.iter().zip(half_extents).enumerate() {
            let span = this.span(c, h);
            this.for_cells(&span, |cell| push_once(&mut cells, cell, i));
            this.spans.push(span);
        }
        this.cells = cells;
        this
    }

    /// Cells along each axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Unwrapped cell index range of the AABB per axis.
    fn span(&self, c: &Vector3<f64>, h: &Vector3<f64>) -> [[i64; 2]; 3] {
        let (c, h) = (self.box_.unshear(c), self.box_.unshear_half_extents(h));
        let mut s = [[0i64; 2]; 3];
        for k in 0..3 {
            let origin = -0.5 * self.box_.lengths()[k];
            s[k][0] = ((c[k] - h[k] - origin) / self.width[k]).floor() as i64;
            s[k][1] = ((c[k] + h[k] - origin) / self.width[k]).floor() as i64;
        }
        s
    }

    /// Calls `f` once with every (wrapped) cell of the span.
    fn for_cells(&self, span: &[[i64; 2]; 3], mut f: impl FnMut(usize)) {
        let range = |k: usize| {
            let n = self.dims[k] as i64;
            let (lo, hi) = (span[k][0], span[k][1]);
            let (lo, hi) = if hi - lo + 1 >= n {
                (0, n - 1)
            } else {
                (lo, hi)
            };
            // One division per axis, then a compare per step.
            let n = n as usize;
            let mut i = lo.rem_euclid(n as i64) as usize;
            (0..=hi - lo).map(move |_| {
                let at = i;
                i = if i + 1 == n { 0 } else { i + 1 };
                at
            })
        };
        for z in range(2) {
            for y in range(1) {
                let row = self.dims[0] * (y + self.dims[1] * z);
                for x in range(0) {
                    f(x + row);
                }
            }
        }
    }

    /// Re-registers particle `i` for its new AABB.
    pub fn update(&mut self, i: usize, c: &Vector3<f64>, h: &Vector3<f64>) {
        let new = self.span(c, h);
        let old = self.spans[i];
        if new == old {
            return;
        }
        let mut cells = std::mem::take(&mut self.cells);
        self.for_cells(&old, |cell| cells.remove(cell, i as u32));
        self.for_cells(&new, |cell| push_once(&mut cells, cell, i));
        self.cells = cells;
        self.spans[i] = new;
    }

    /// Calls `f` once with every particle whose registered cells meet the
    /// AABB `c ± h`; stops early and returns true as soon as `f` does.
    pub fn any_near(
        &self,
        c: &Vector3<f64>,
        h: &Vector3<f64>,
        mut f: impl FnMut(usize) -> bool,
    ) -> bool {
        STAMPS.with(|cell| {
            let mut guard = cell.borrow_mut();
            let (stamp, stamps) = &mut *guard;
            if stamps.len() < self.spans.len() {
                stamps.resize(self.spans.len(), 0);
            }
            *stamp = stamp.wrapping_add(1);
            if *stamp == 0 {
                // Wrapped around: clear, so that no particle looks visited.
                stamps.iter_mut().for_each(|s| *s = 0);
                *stamp = 1;
            }
            let current = *stamp;
            let span = self.span(c, h);
            let mut found = false;
            self.for_cells(&span, |cell| {
                if found {
                    return;
                }
                for &j in self.cells.of(cell) {
                    let s = &mut stamps[j as usize];
                    if *s != current {
                        *s = current;
                        if f(j as usize) {
                            found = true;
                            return;
                        }
                    }
                }
            });
            found
        })
    }
}

/// Adds `i` to `cell` unless already there (a span wider than the box
/// visits a cell twice).
fn push_once(cells: &mut FlatLists, cell: usize, i: usize) {
    if !cells.of(cell).contains(&(i as u32)) {
        cells.push(cell, i as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair whose periodic AABBs intersect (any lattice image) is
    /// found, after moves too, in an orthorhombic and a tilted box.
    #[test]
    fn finds_every_pair_of_intersecting_boxes() {
        let mut u = crate::test_support::uniform(9);
        let lengths = Vector3::new(10.0, 12.0, 9.0);
        for tilts in [Vector3::zeros(), Vector3::new(0.3, -0.45, 0.2)] {
            let box_ = PeriodicBox::triclinic(lengths, tilts).unwrap();
            let n = 150;
            let mut c: Vec<Vector3<f64>> = (0..n)
                .map(|_| box_.from_fractional(&Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5)))
                .collect();
            let h: Vec<Vector3<f64>> = (0..n)
                .map(|i| {
                    if i % 10 == 0 {
                        Vector3::new(2.5, 0.4, 1.0)
                    } else {
                        Vector3::repeat(0.3)
                    }
                })
                .collect();
            let mut cells = AabbCells::new(&box_, 0.8, &c, &h);
            for round in 0..2 {
                for i in 0..n {
                    let mut seen = Vec::new();
                    cells.any_near(&c[i], &h[i], |j| {
                        seen.push(j);
                        false
                    });
                    for j in 0..n {
                        let touching = (0..27).any(|s| {
                            let m = Vector3::new(s % 3, (s / 3) % 3, s / 9).map(|x| x as f64 - 1.0);
                            let d = box_.minimum_image(&(c[j] - c[i])) + box_.matrix() * m;
                            (0..3).all(|k| d[k].abs() <= h[i][k] + h[j][k])
                        });
                        if touching {
                            assert!(seen.contains(&j), "round {round}: {i}-{j} missed");
                        }
                    }
                    let mut unique = seen.clone();
                    unique.sort();
                    unique.dedup();
                    assert_eq!(unique.len(), seen.len(), "a particle reported twice");
                }
                // Move everything and re-register.
                for i in 0..n {
                    c[i] = box_.wrap(&(c[i] + Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 2.0));
                    cells.update(i, &c[i], &h[i]);
                }
            }
        }
    }
}
