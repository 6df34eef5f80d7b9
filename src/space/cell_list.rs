//! Linked cells for a periodic box: cells at least as wide as the
//! interaction range across their faces, so that every pair within range
//! lies in the same or an adjacent cell. Cells are cut in the box's
//! unsheared coordinates (see [`PeriodicBox`]), so a tilted box takes the
//! same cells as an orthorhombic one, counted by its heights. In a box fewer than three cells wide along an axis
//! the neighbour cells repeat; they are deduplicated, never skipped.
//!
//! Storage is flat: each cell owns `capacity` slots of one array (no
//! per-cell allocation, no pointer chasing in the 27-cell loop); when a cell
//! overflows, the capacity doubles and everything is re-binned.

use nalgebra::Vector3;

use super::PeriodicBox;

/// Particle indices binned into cells.
#[derive(Debug, Clone)]
pub struct CellList {
    dims: [usize; 3],
    box_: PeriodicBox,
    capacity: usize,
    slots: Vec<u32>,
    counts: Vec<u32>,
    cell_of: Vec<u32>,
    /// In a box narrower than three cells along an axis, for each cell
    /// the distinct cells within one step (itself included), 27 slots per
    /// cell, `neighbour_counts` of them used; else empty.
    neighbours: Vec<u32>,
    neighbour_counts: Vec<u8>,
}

impl CellList {
    /// Bins `positions` (in the box) into cells of width ≥ `range`.
    pub fn new(box_: &PeriodicBox, range: f64, positions: &[Vector3<f64>]) -> Self {
        let dims = super::cell_grid(&box_.heights(), range, positions.len());
        let count = dims[0] * dims[1] * dims[2];
        let mut this = Self {
            dims,
            box_: *box_,
            capacity: 4,
            slots: Vec::new(),
            counts: vec![0; count],
            cell_of: vec![0; positions.len()],
            neighbours: Vec::new(),
            neighbour_counts: Vec::new(),
        };
        // Only a box narrower than three cells along an axis needs the
        // table (its neighbour cells repeat, and are kept once each);
        // elsewhere they are computed, which keeps 108 bytes a cell out of
        // the caches.
        if dims.iter().any(|&n| n < 3) {
            let mut neighbours = vec![0u32; 27 * count];
            let mut neighbour_counts = vec![0u8; count];
            for c in 0..count {
                let list = &mut neighbours[27 * c..27 * c + 27];
                let mut used = 0;
                for n in this.steps_around(c) {
                    if !list[..used].contains(&n) {
                        list[used] = n;
                        used += 1;
                    }
                }
                neighbour_counts[c] = used as u8;
            }
            (this.neighbours, this.neighbour_counts) = (neighbours, neighbour_counts);
        }
        this.rebin(
            positions
                .iter()
                .enumerate()
                .map(|(i, p)| (i, this.cell_index(p)))
                .collect(),
        );
        this
    }

    /// Bins (particle, cell) pairs, growing the capacity until every cell fits.
    fn rebin(&mut self, placed: Vec<(usize, usize)>) {
        loop {
            self.slots = vec![0; self.capacity * self.counts.len()];
            self.counts.iter_mut().for_each(|c| *c = 0);
            let mut fits = true;
            for &(i, c) in &placed {
                let k = self.counts[c] as usize;
                if k == self.capacity {
                    fits = false;
                    break;
                }
                self.slots[c * self.capacity + k] = i as u32;
                self.counts[c] += 1;
                self.cell_of[i] = c as u32;
            }
            if fits {
                return;
            }
            self.capacity *= 2;
        }
    }

    /// Cells along each axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The cell holding position `r` (wrapped into the box).
    #[inline]
    pub fn cell_index(&self, r: &Vector3<f64>) -> usize {
        let (u, lengths) = (self.box_.unshear(r), self.box_.lengths());
        let mut idx = [0usize; 3];
        for k in 0..3 {
            let mut f = u[k] / lengths[k] + 0.5;
            // One shift for positions within a box of the box. A position in
            // it whose quotient rounds to just outside [0, 1) (the sheared
            // coordinates of a wrapped position, or a crystal site on a face)
            // stays in the cell at that face, not the one across the box.
            const ROUNDING: f64 = 1e-12;
            if f < -ROUNDING {
                f += 1.0;
            } else if f >= 1.0 + ROUNDING {
                f -= 1.0;
            }
            idx[k] = ((f * self.dims[k] as f64) as usize).min(self.dims[k] - 1);
        }
        idx[0] + self.dims[0] * (idx[1] + self.dims[1] * idx[2])
    }

    /// The cell at integer coordinates `c` (each below its `dims`).
    #[inline]
    pub fn index_of(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// The integer coordinates of cell `cell`.
    #[inline]
    pub fn coords_of(&self, cell: usize) -> [usize; 3] {
        [
            cell % self.dims[0],
            (cell / self.dims[0]) % self.dims[1],
            cell / (self.dims[0] * self.dims[1]),
        ]
    }

    /// Cell edge lengths (the box divided by `dims`, in unsheared
    /// coordinates).
    pub fn cell_lengths(&self) -> Vector3<f64> {
        let l = self.box_.lengths();
        Vector3::new(
            l.x / self.dims[0] as f64,
            l.y / self.dims[1] as f64,
            l.z / self.dims[2] as f64,
        )
    }

    /// The cell particle `i` is listed in.
    #[inline]
    pub fn cell_of(&self, i: usize) -> usize {
        self.cell_of[i] as usize
    }

    /// The distinct cells within one step of `cell`, itself included,
    /// with the step along x changing fastest, then y, then z.
    #[inline]
    pub fn neighbour_cells(&self, cell: usize) -> NeighbourCells {
        if !self.neighbours.is_empty() {
            let used = self.neighbour_counts[cell];
            let mut cells = [0; 27];
            cells[..used as usize].copy_from_slice(&self.neighbours[27 * cell..][..used as usize]);
            return NeighbourCells { cells, used };
        }
        NeighbourCells {
            cells: self.steps_around(cell),
            used: 27,
        }
    }

    /// The cell one step down, none or one step up from `cell` along each
    /// axis, across the periodic boundary, in the order of
    /// [`CellList::neighbour_cells`]; in a box narrower than three cells
    /// along an axis, some more than once.
    #[inline]
    fn steps_around(&self, cell: usize) -> [u32; 27] {
        let [nx, ny, _] = self.dims;
        let c = self.coords_of(cell);
        let [xs, ys, zs] = std::array::from_fn(|a| {
            let (at, n) = (c[a], self.dims[a]);
            [
                if at == 0 { n - 1 } else { at - 1 },
                at,
                if at + 1 == n { 0 } else { at + 1 },
            ]
        });
        std::array::from_fn(|k| (xs[k % 3] + nx * (ys[(k / 3) % 3] + ny * zs[k / 9])) as u32)
    }

    /// In a box at least three cells wide along every axis: the cells of
    /// [`CellList::neighbour_cells`], in its order, each with the whole
    /// box lengths (−1, 0 or 1 along each axis) that bring its members'
    /// positions next to `cell` (across the periodic boundary). `None` in
    /// a narrower box, where a neighbour cell may be next to `cell` on
    /// both sides.
    #[inline]
    pub fn neighbour_images(&self, cell: usize) -> Option<[(u32, [i8; 3]); 27]> {
        if self.dims.iter().any(|&n| n < 3) {
            return None;
        }
        let c = self.coords_of(cell);
        let near = self.neighbour_cells(cell);
        Some(std::array::from_fn(|k| {
            // The order of `new`: dx fastest, then dy, then dz.
            let step = [k % 3, (k / 3) % 3, k / 9];
            let wrap = std::array::from_fn(|a| match (step[a], c[a]) {
                (0, 0) => -1,
                (2, at) if at + 1 == self.dims[a] => 1,
                _ => 0,
            });
            (near[k], wrap)
        }))
    }

    /// Which of the cells of [`CellList::neighbour_images`] (bit k for its
    /// step k) come within `limit` of `centre`, a point in `cell` (in
    /// [−L/2, L/2)). In a tilted box every one of the 27 (distances in
    /// unsheared coordinates are not distances).
    pub fn neighbours_within(&self, cell: usize, centre: &Vector3<f64>, limit: f64) -> u32 {
        if self.box_.is_tilted() {
            return (1 << 27) - 1;
        }
        let c = self.coords_of(cell);
        let (l, cl) = (self.box_.lengths(), self.cell_lengths());
        // Per axis, the squared distance to the cells one step below, level
        // with and one step above `cell`.
        let gaps: [[f64; 3]; 3] = std::array::from_fn(|a| {
            let u = centre[a] + 0.5 * l[a] - c[a] as f64 * cl[a];
            // By a box length if rounding binned the centre in the far cell.
            let u = if u > 0.5 * l[a] { u - l[a] } else { u };
            let u = u.clamp(0.0, cl[a]);
            [u * u, 0.0, (cl[a] - u) * (cl[a] - u)]
        });
        let mut within = 0;
        for (z, gz) in gaps[2].iter().enumerate() {
            for (y, gy) in gaps[1].iter().enumerate() {
                for (x, gx) in gaps[0].iter().enumerate() {
                    within |= u32::from(gx + gy + gz <= limit * limit) << (9 * z + 3 * y + x);
                }
            }
        }
        within
    }

    /// The members of `cells`, one after another in `into`, and how many;
    /// `None` if they do not fit. Each cell's whole room is copied and
    /// only its members counted, without a branch on how many a cell
    /// holds (which varies at random); rooms of more than 16 slots go
    /// member by member.
    #[inline]
    pub fn gather(&self, cells: impl Iterator<Item = usize>, into: &mut [u32]) -> Option<usize> {
        match self.capacity {
            4 => self.gather_rooms::<4>(cells, into),
            8 => self.gather_rooms::<8>(cells, into),
            16 => self.gather_rooms::<16>(cells, into),
            _ => {
                let mut count = 0;
                for c in cells {
                    for &j in self.members(c) {
                        *into.get_mut(count)? = j;
                        count += 1;
                    }
                }
                Some(count)
            }
        }
    }

    /// [`CellList::gather`] with rooms of `ROOM` slots.
    #[inline(always)]
    fn gather_rooms<const ROOM: usize>(
        &self,
        cells: impl Iterator<Item = usize>,
        into: &mut [u32],
    ) -> Option<usize> {
        let mut count = 0;
        for c in cells {
            let base = c * ROOM;
            let room: &[u32; ROOM] = self.slots[base..base + ROOM].try_into().ok()?;
            let to: &mut [u32; ROOM] = into.get_mut(count..count + ROOM)?.try_into().ok()?;
            *to = *room;
            count += self.counts[c] as usize;
        }
        Some(count)
    }

    /// The particles listed in `cell`.
    #[inline]
    pub fn members(&self, cell: usize) -> &[u32] {
        let base = cell * self.capacity;
        &self.slots[base..base + self.counts[cell] as usize]
    }

    /// Records that particle `i` now sits at `r`.
    #[inline]
    pub fn update(&mut self, i: usize, r: &Vector3<f64>) {
        let new = self.cell_index(r);
        self.move_to(i, new);
    }

    /// Lists particle `i` in cell `new` (event-driven dynamics moves
    /// particles between cells at their crossing events, not by position,
    /// so that round-off at a boundary cannot disagree with the calendar).
    #[inline]
    pub fn move_to(&mut self, i: usize, new: usize) {
        let old = self.cell_of[i] as usize;
        if new == old {
            return;
        }
        let base = old * self.capacity;
        let n = self.counts[old] as usize;
        let at = self.slots[base..base + n]
            .iter()
            .position(|&j| j as usize == i)
            .expect("particle in its cell");
        self.slots[base + at] = self.slots[base + n - 1];
        self.counts[old] -= 1;
        if self.counts[new] as usize == self.capacity {
            let placed = (0..self.cell_of.len())
                .map(|j| {
                    (
                        j,
                        if j == i {
                            new
                        } else {
                            self.cell_of[j] as usize
                        },
                    )
                })
                .collect();
            self.capacity *= 2;
            self.rebin(placed);
            return;
        }
        self.slots[new * self.capacity + self.counts[new] as usize] = i as u32;
        self.counts[new] += 1;
        self.cell_of[i] = new as u32;
    }

    /// Calls `f(i, j)` once for every pair i < j whose cells are
    /// neighbours: every pair closer than the range, and some farther.
    pub fn for_each_near_pair(&self, mut f: impl FnMut(usize, usize)) {
        for i in 0..self.cell_of.len() {
            for n in self.neighbour_cells(self.cell_of[i] as usize) {
                let base = n as usize * self.capacity;
                for &j in &self.slots[base..base + self.counts[n as usize] as usize] {
                    if (j as usize) > i {
                        f(i, j as usize);
                    }
                }
            }
        }
    }

    /// Calls `f` with every particle in the cells around `r` (including the
    /// particle at `r` itself if it is listed); stops early and returns true
    /// as soon as `f` does.
    #[inline]
    pub fn any_near(&self, r: &Vector3<f64>, mut f: impl FnMut(usize) -> bool) -> bool {
        for n in self.neighbour_cells(self.cell_index(r)) {
            let base = n as usize * self.capacity;
            for &j in &self.slots[base..base + self.counts[n as usize] as usize] {
                if f(j as usize) {
                    return true;
                }
            }
        }
        false
    }
}

/// The cells of [`CellList::neighbour_cells`], held by value.
#[derive(Debug, Clone, Copy)]
pub struct NeighbourCells {
    cells: [u32; 27],
    used: u8,
}

impl std::ops::Deref for NeighbourCells {
    type Target = [u32];
    #[inline]
    fn deref(&self) -> &[u32] {
        &self.cells[..self.used as usize]
    }
}

impl IntoIterator for NeighbourCells {
    type Item = u32;
    type IntoIter = std::iter::Take<std::array::IntoIter<u32, 27>>;
    #[inline]
    fn into_iter(self) -> Self::IntoIter {
        self.cells.into_iter().take(self.used as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only cells out of reach are left out: from centres anywhere,
    /// also one just below the upper face (kept in the last cell), every
    /// neighbour cell whose box (its nearest image) comes within the limit
    /// is kept; and some are skipped.
    #[test]
    fn only_cells_out_of_reach_are_left_out() {
        let l = Vector3::repeat(12.0);
        let mut u = crate::test_support::uniform(3);
        let mut centres: Vec<Vector3<f64>> = (0..2000)
            .map(|_| Vector3::from_fn(|_, _| 12.0 * (u() - 0.5)))
            .collect();
        let below_half = f64::from_bits(6.0f64.to_bits() - 1);
        centres.push(Vector3::repeat(below_half));
        centres.push(Vector3::repeat(-6.0));
        let cells = CellList::new(&PeriodicBox::new(l).unwrap(), 2.5, &centres);
        let (cl, dims) = (cells.cell_lengths(), cells.dims());
        let last = dims.map(|n| n - 1);
        assert_eq!(
            cells.coords_of(cells.cell_of(2000)),
            last,
            "kept at its face"
        );
        let mut skipped = 0;
        for (i, centre) in centres.iter().enumerate() {
            let cell = cells.cell_of(i);
            let c = cells.coords_of(cell);
            for limit in [1.0, 2.5, 3.5] {
                let within = cells.neighbours_within(cell, centre, limit);
                for k in 0..27 {
                    let step = [k % 3, (k / 3) % 3, k / 9];
                    let gap = |a: usize| {
                        let lo = -6.0 + ((c[a] + step[a] + dims[a] - 1) % dims[a]) as f64 * cl[a];
                        [-12.0, 0.0, 12.0]
                            .map(|shift| {
                                let (from, to) = (lo + shift, lo + shift + cl[a]);
                                (from - centre[a]).max(centre[a] - to).max(0.0)
                            })
                            .into_iter()
                            .fold(f64::INFINITY, f64::min)
                    };
                    let nearest = (0..3).map(|a| gap(a) * gap(a)).sum::<f64>().sqrt();
                    if within & (1 << k) == 0 {
                        skipped += 1;
                        assert!(
                            nearest > limit,
                            "body {i} at {centre:?}, step {step:?}: {nearest} within {limit}"
                        );
                    }
                }
            }
        }
        assert!(skipped > 10_000, "{skipped} cells skipped");
    }

    /// A cell's neighbours are the distinct cells within one step of it
    /// across the periodic boundary, each once, in the order of the steps
    /// (x fastest), whether computed (boxes three cells wide or more) or
    /// tabled (narrower ones).
    #[test]
    fn neighbour_cells_are_the_distinct_cells_one_step_away_in_order() {
        for dims in [
            [3, 3, 3],
            [4, 5, 6],
            [7, 3, 4],
            [2, 4, 5],
            [1, 3, 2],
            [5, 1, 1],
        ] {
            let lengths = Vector3::from_fn(|a, _| dims[a] as f64 * 1.01);
            let cl = CellList::new(
                &PeriodicBox::new(lengths).unwrap(),
                1.0,
                &[Vector3::zeros(); 64],
            );
            assert_eq!(cl.dims(), dims);
            for cell in 0..dims.iter().product() {
                let c = cl.coords_of(cell);
                let mut expected = Vec::new();
                for step in 0..27 {
                    let d = [step % 3, (step / 3) % 3, step / 9];
                    let near = std::array::from_fn(|a| (c[a] + dims[a] + d[a] - 1) % dims[a]);
                    let n = cl.index_of(near) as u32;
                    if !expected.contains(&n) {
                        expected.push(n);
                    }
                }
                assert_eq!(
                    &cl.neighbour_cells(cell)[..],
                    &expected[..],
                    "{dims:?} cell {cell}"
                );
                let listed: Vec<u32> = cl.neighbour_cells(cell).into_iter().collect();
                assert_eq!(listed, expected);
            }
        }
    }

    /// Every pair closer than the range is found, in boxes of 1 to 5 cells,
    /// orthorhombic and tilted.
    #[test]
    fn finds_every_pair_within_range() {
        let mut uniform = crate::test_support::uniform(3);
        let mut u = || uniform() - 0.5;
        for tilts in [Vector3::zeros(), Vector3::new(0.4, -0.3, 0.25)] {
            for &len in &[2.5, 4.0, 5.5, 7.2] {
                let lengths = Vector3::new(len, len * 1.3, len * 0.9);
                let box_ = PeriodicBox::triclinic(lengths, tilts).unwrap();
                let pos: Vec<Vector3<f64>> = (0..200)
                    .map(|_| box_.from_fractional(&Vector3::new(u(), u(), u())))
                    .collect();
                let cl = CellList::new(&box_, 1.2, &pos);
                for i in 0..pos.len() {
                    let mut near = Vec::new();
                    cl.any_near(&pos[i], |j| {
                        near.push(j);
                        false
                    });
                    let mut sorted = near.clone();
                    assert!(near.contains(&i), "a particle is not near itself");
                    sorted.sort();
                    sorted.dedup();
                    assert_eq!(sorted.len(), near.len(), "a particle listed twice");
                    for j in 0..pos.len() {
                        // The shortest image, by brute force over lattice shifts.
                        let mut d = f64::INFINITY;
                        for s in 0..125 {
                            let n =
                                Vector3::new(s % 5, (s / 5) % 5, s / 25).map(|c| c as f64 - 2.0);
                            d = d.min((pos[j] - pos[i] + box_.matrix() * n).norm());
                        }
                        if d < 1.2 {
                            assert!(near.contains(&j), "pair {i}-{j} at {d} missed (box {len})");
                        }
                    }
                }
            }
        }
    }

    /// The cells around each cell gathered at once are their members in
    /// order, for rooms of 4, 8, 16 and more slots, and a gathering that does
    /// not fit says so.
    #[test]
    fn gathering_around_a_cell_lists_its_neighbours_members_in_order() {
        let mut u = crate::test_support::uniform(10);
        let lengths = Vector3::new(6.0, 6.0, 6.0);
        let mut capacities = Vec::new();
        for (n, spread) in [(150, 1.0), (400, 1.0), (1200, 1.0), (400, 0.2)] {
            // A narrow spread crowds the cells, whose rooms then grow.
            let pos: Vec<Vector3<f64>> = (0..n)
                .map(|_| Vector3::from_fn(|_, _| (u() - 0.5) * 6.0 * spread))
                .collect();
            let cl = CellList::new(&PeriodicBox::new(lengths).unwrap(), 1.0, &pos);
            capacities.push(cl.capacity);
            for cell in 0..cl.counts.len() {
                let expected: Vec<u32> = cl
                    .neighbour_cells(cell)
                    .into_iter()
                    .flat_map(|nc| cl.members(nc as usize).iter().copied())
                    .collect();
                let around = || cl.neighbour_cells(cell).into_iter().map(|nc| nc as usize);
                let mut into = vec![0; 27 * cl.capacity];
                let count = cl.gather(around(), &mut into).unwrap();
                assert_eq!(&into[..count], &expected[..], "cell {cell}");
                if !expected.is_empty() {
                    let mut small = vec![0; expected.len() - 1];
                    assert_eq!(cl.gather(around(), &mut small), None);
                }
            }
        }
        assert_eq!(capacities[..3], [4, 8, 16]);
        assert!(capacities[3] > 16, "{capacities:?}");
    }

    /// A neighbour cell's image brings each of its members within two cell
    /// lengths of every particle of the cell along each axis, also across
    /// the boundary; boxes narrower than three cells have no images.
    #[test]
    fn neighbour_images_bring_members_next_to_the_cell() {
        let mut u = crate::test_support::uniform(9);
        for (lengths, range) in [
            (Vector3::new(6.0, 7.5, 9.0), 1.0),
            (Vector3::new(2.5, 2.5, 2.5), 1.0),
        ] {
            let pos: Vec<Vector3<f64>> = (0..300)
                .map(|_| Vector3::from_fn(|k, _| (u() - 0.5) * lengths[k]))
                .collect();
            let cl = CellList::new(&PeriodicBox::new(lengths).unwrap(), range, &pos);
            let w = cl.cell_lengths();
            let mut wrapped = 0;
            for (i, r) in pos.iter().enumerate() {
                let Some(images) = cl.neighbour_images(cl.cell_of(i)) else {
                    assert!(cl.dims().iter().any(|&n| n < 3), "{:?}", cl.dims());
                    wrapped += 1;
                    continue;
                };
                for (nc, wrap) in images {
                    for &j in cl.members(nc as usize) {
                        let image = Vector3::from_fn(|k, _| f64::from(wrap[k]) * lengths[k]);
                        let d = pos[j as usize] + image - r;
                        assert!((0..3).all(|k| d[k].abs() < 2.0 * w[k]), "{i} {j}: {d}");
                        wrapped += usize::from(wrap != [0; 3]);
                    }
                }
            }
            // Members across the boundary, or every particle without images.
            assert!(wrapped >= 300, "{wrapped}");
        }
    }

    /// Particles moved one by one (cells overflow and grow on the way) are
    /// found where they now are and nowhere else.
    #[test]
    fn updates_follow_moves() {
        let mut u = crate::test_support::uniform(8);
        let lengths = Vector3::new(6.0, 6.0, 6.0);
        let mut pos: Vec<Vector3<f64>> = (0..60)
            .map(|_| Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 6.0)
            .collect();
        let mut cl = CellList::new(&PeriodicBox::new(lengths).unwrap(), 1.0, &pos);
        for step in 0..3000 {
            let i = step % pos.len();
            // Drift everything towards one corner so that cells overflow.
            let mut p = pos[i] * 0.9 + Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 0.2;
            for k in 0..3 {
                if p[k] >= 3.0 {
                    p[k] -= 6.0;
                } else if p[k] < -3.0 {
                    p[k] += 6.0;
                }
            }
            pos[i] = p;
            cl.update(i, &p);
        }
        for (i, p) in pos.iter().enumerate() {
            let mut seen = 0;
            cl.any_near(p, |j| {
                seen += (j == i) as usize;
                false
            });
            assert_eq!(seen, 1, "particle {i} listed {seen} times near itself");
        }
        assert!(cl.capacity > 8, "the test did not make any cell overflow");
    }
}
