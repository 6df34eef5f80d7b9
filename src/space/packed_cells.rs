//! Cells for Monte Carlo's hot loop: as wide as the interaction range, each
//! holding its members' positions beside their indices, so that scanning a
//! neighbour cell reads one contiguous run of memory and never looks a
//! position up elsewhere. Cells are cut in the box's unsheared coordinates
//! (see [`PeriodicBox`]), counted by its heights. The separation handed to
//! the caller is `(rⱼ − r) + s` with `s` the image shift of the neighbour
//! cell (whole lattice vectors, known from the cell offset), the same
//! arithmetic as
//! [`PeriodicBox::minimum_image_near`] and bit-identical to it for every
//! pair within range. Boxes fewer than three cells wide along a periodic
//! axis (where neighbour cells repeat) take the deduplicated cells and the
//! box's minimum image instead.
//!
//! Storage is flat: each cell owns `capacity` slots, each slot a member's
//! position and radius (empty slots hold NaN, which compares false with
//! everything); when a cell overflows the capacity doubles and everything is
//! re-binned. For spheres, [`PackedCells::sphere_overlaps`] scans every slot
//! of the 27 cells without a data-dependent branch: the trip counts are the
//! same for every query, which is what keeps a dense hard-sphere move cheap
//! (a loop over a cell's 0–3 members mispredicts its exit about once per
//! cell).

use nalgebra::Vector3;

use super::PeriodicBox;
use super::slots::Slots;

type V3 = Vector3<f64>;

/// Particle positions binned into cells at least as wide as a range.
#[derive(Debug, Clone)]
pub struct PackedCells {
    box_: PeriodicBox,
    dims: [usize; 3],
    capacity: usize,
    /// Growing is a bug: the storage is shared by threads that each hold
    /// a copy of this header (see [`PackedCells::fix_capacity`]).
    fixed: bool,
    /// Slot-major: `slots[c · capacity + k]` is member k of cell c, as
    /// (x, y, z, radius); NaN where empty.
    slots: Slots<[f64; 4]>,
    members: Slots<u32>,
    counts: Slots<u32>,
    /// Per particle: its slot.
    slot_of: Slots<u32>,
    /// Every periodic axis is at least three cells wide: neighbour cells
    /// are distinct and carry exact image shifts.
    shifted: bool,
    /// Deduplicated neighbour cells (27 per cell) for the other case.
    neighbours: Vec<u32>,
    neighbour_counts: Vec<u8>,
    /// For a cell away from the box faces, the flat index offsets of the 27
    /// cells around it in [`NEAREST_FIRST`] order, per octant of the cell
    /// the query lies in (bit k set: above the centre along axis k).
    interior_offsets: Box<[[isize; 27]; 8]>,
}

impl PackedCells {
    /// Bins `positions` (in the box) into cells of width ≥ `range`; each
    /// particle carries its radius (for [`PackedCells::sphere_overlaps`]).
    pub fn new(box_: &PeriodicBox, range: f64, positions: &[V3], radii: &[f64]) -> Self {
        Self::with_members(
            box_,
            range,
            positions.len(),
            positions
                .iter()
                .zip(radii)
                .map(|(p, &r)| (*p, r))
                .enumerate(),
        )
    }

    /// Cells of width ≥ `range` holding only the listed particles (index,
    /// (position, radius)) of `count` in all: one species' grid.
    pub fn with_members(
        box_: &PeriodicBox,
        range: f64,
        count: usize,
        members: impl Iterator<Item = (usize, (V3, f64))> + Clone,
    ) -> Self {
        let dims = super::cell_grid(&box_.heights(), range, members.clone().count().max(1));
        let walls = box_.walls();
        let shifted = (0..3).all(|k| walls[k] || dims[k] >= 3);
        let cells = dims[0] * dims[1] * dims[2];
        let (mut neighbours, mut neighbour_counts) = (Vec::new(), Vec::new());
        if !shifted {
            neighbours = vec![0u32; 27 * cells];
            neighbour_counts = vec![0u8; cells];
            for c in 0..cells {
                let at = [
                    c % dims[0],
                    (c / dims[0]) % dims[1],
                    c / (dims[0] * dims[1]),
                ];
                let list = &mut neighbours[27 * c..27 * c + 27];
                let mut used = 0;
                for d in STENCIL {
                    let n = (0..3)
                        .map(|k| (at[k] as i64 + d[k]).rem_euclid(dims[k] as i64) as usize)
                        .collect::<Vec<_>>();
                    let n = (n[0] + dims[0] * (n[1] + dims[1] * n[2])) as u32;
                    if !list[..used].contains(&n) {
                        list[used] = n;
                        used += 1;
                    }
                }
                neighbour_counts[c] = used as u8;
            }
        }
        let mut this = Self {
            box_: *box_,
            dims,
            capacity: 4,
            fixed: false,
            slots: Slots::default(),
            members: Slots::default(),
            counts: vec![0; dims[0] * dims[1] * dims[2]].into(),
            slot_of: vec![0; count].into(),
            shifted,
            neighbours,
            neighbour_counts,
            interior_offsets: Box::new([[0; 27]; 8]),
        };
        for (octant, offsets) in this.interior_offsets.iter_mut().enumerate() {
            for (slot, rank) in offsets.iter_mut().zip(NEAREST_FIRST) {
                let step = |k: usize| -> isize {
                    let up = if octant >> k & 1 == 1 { 1 } else { -1 };
                    [0, up, -up][rank[k]]
                };
                *slot = step(0) + dims[0] as isize * (step(1) + dims[1] as isize * step(2));
            }
        }
        let placed: Vec<(usize, usize, [f64; 4])> = members
            .map(|(i, (p, r))| (i, this.cell_index(&p), [p.x, p.y, p.z, r]))
            .collect();
        this.rebin(&placed);
        this
    }

    /// Room for at least `capacity` members per cell (doubled until it
    /// fits).
    pub fn reserve(&mut self, capacity: usize) {
        if self.capacity >= capacity {
            return;
        }
        let placed = self.placed();
        while self.capacity < capacity {
            self.capacity *= 2;
        }
        self.rebin(&placed);
    }

    /// The room per cell before the cells must grow.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// From now on a cell that would outgrow its room panics instead of
    /// growing: for a copy of these cells' header whose storage other
    /// threads share, where growing would move the storage from under
    /// them. (The room is reserved beforehand for the most members the
    /// physics allows.)
    pub fn fix_capacity(&mut self) {
        self.fixed = true;
    }

    /// Every member as (particle, cell, slot).
    fn placed(&self) -> Vec<(usize, usize, [f64; 4])> {
        let mut placed = Vec::with_capacity(self.slot_of.len());
        for c in 0..self.counts.len() {
            let base = c * self.capacity;
            for s in base..base + self.counts[c] as usize {
                placed.push((self.members[s] as usize, c, self.slots[s]));
            }
        }
        placed
    }

    /// Bins (particle, cell, position), growing the capacity until every
    /// cell fits.
    fn rebin(&mut self, placed: &[(usize, usize, [f64; 4])]) {
        assert!(
            !self.fixed,
            "a cell outgrew the room reserved for a parallel sweep"
        );
        'grow: loop {
            let slots = self.capacity * self.counts.len();
            self.slots = vec![[f64::NAN; 4]; slots].into();
            self.members = vec![0; slots].into();
            self.counts.iter_mut().for_each(|c| *c = 0);
            for &(i, c, p) in placed {
                let k = self.counts[c] as usize;
                if k == self.capacity {
                    self.capacity *= 2;
                    continue 'grow;
                }
                let slot = c * self.capacity + k;
                self.slots[slot] = p;
                self.members[slot] = i as u32;
                self.counts[c] += 1;
                self.slot_of[i] = slot as u32;
            }
            return;
        }
    }

    /// Cells along each axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Integer cell coordinates of unsheared coordinates `u` (of a
    /// position in the box, or within a box length of it).
    #[inline]
    fn coords(&self, u: &V3) -> [usize; 3] {
        let lengths = self.box_.lengths();
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
        idx
    }

    #[inline]
    fn cell_index(&self, r: &V3) -> usize {
        let c = self.coords(&self.box_.unshear(r));
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// Gives particle `i` the radius `radius` (within the range the cells
    /// were built for).
    pub fn set_radius(&mut self, i: usize, radius: f64) {
        self.slots[self.slot_of[i] as usize][3] = radius;
    }

    /// Records that particle `i` now sits at `r` (in the box).
    #[inline]
    pub fn update(&mut self, i: usize, r: &V3) {
        let new = self.cell_index(r);
        let slot = self.slot_of[i] as usize;
        let old = slot / self.capacity;
        let entry = [r.x, r.y, r.z, self.slots[slot][3]];
        if new == old {
            self.slots[slot] = entry;
            return;
        }
        // Out of the old cell: its last member takes the freed slot.
        let last = old * self.capacity + self.counts[old] as usize - 1;
        if last != slot {
            self.slots[slot] = self.slots[last];
            self.members[slot] = self.members[last];
            self.slot_of[self.members[slot] as usize] = slot as u32;
        }
        self.slots[last] = [f64::NAN; 4];
        self.counts[old] -= 1;
        if self.counts[new] as usize == self.capacity {
            let mut placed = self.placed();
            placed.push((i, new, entry));
            self.capacity *= 2;
            self.rebin(&placed);
            return;
        }
        let slot = new * self.capacity + self.counts[new] as usize;
        self.slots[slot] = entry;
        self.members[slot] = i as u32;
        self.slot_of[i] = slot as u32;
        self.counts[new] += 1;
    }

    /// Calls `f(j, d)` for every particle j in the cells around `r` (the
    /// particle at `r` itself included if listed), d its separation from `r`
    /// (the image nearest `r` for every j within range); stops early and
    /// returns true as soon as `f` does.
    #[inline]
    pub fn any_near(&self, r: &V3, f: impl FnMut(usize, &V3) -> bool) -> bool {
        // Two instances, so that an untilted box's hot loop carries no
        // shear at all (u = r, shifts along the axes).
        if self.box_.is_tilted() {
            self.any_near_in::<true>(r, f)
        } else {
            self.any_near_in::<false>(r, f)
        }
    }

    #[inline(always)]
    fn any_near_in<const TILTED: bool>(
        &self,
        r: &V3,
        mut f: impl FnMut(usize, &V3) -> bool,
    ) -> bool {
        let u = if TILTED { self.box_.unshear(r) } else { *r };
        let at = self.coords(&u);
        if !self.shifted {
            return self.repeated_cells(&at).iter().any(|&n| {
                self.range_of(n as usize).any(|s| {
                    let d = self
                        .box_
                        .minimum_image_near_as::<TILTED>(&(position(&self.slots[s]) - r));
                    f(self.members[s] as usize, &d)
                })
            });
        }
        self.any_shifted_cell::<TILTED>(&at, &u, |slots, members, shift| {
            slots.iter().zip(members).any(|(e, &j)| {
                let d = (position(e) - r) + shift;
                f(j as usize, &d)
            })
        })
    }

    /// Whether a sphere of `radius` at `r` overlaps (|d| ≤ the sum of radii)
    /// any listed particle but `exclude`, each taken as its sphere.
    #[inline]
    pub fn sphere_overlaps(&self, r: &V3, radius: f64, exclude: usize) -> bool {
        let exclude = exclude as u32;
        self.sphere_overlaps_where(r, radius, |j| j != exclude)
    }

    /// As [`PackedCells::sphere_overlaps`], against the listed particles j
    /// with `keep(j)` only (asked only of those within reach).
    #[inline]
    pub fn sphere_overlaps_where(&self, r: &V3, radius: f64, keep: impl Fn(u32) -> bool) -> bool {
        if self.box_.is_tilted() {
            self.sphere_overlaps_in::<true>(r, radius, keep)
        } else {
            self.sphere_overlaps_in::<false>(r, radius, keep)
        }
    }

    #[inline(always)]
    fn sphere_overlaps_in<const TILTED: bool>(
        &self,
        r: &V3,
        radius: f64,
        keep: impl Fn(u32) -> bool,
    ) -> bool {
        let u = if TILTED { self.box_.unshear(r) } else { *r };
        let at = self.coords(&u);
        if !self.shifted {
            return self.any_near(r, |j, d| {
                let reach = radius + self.slots[self.slot_of[j] as usize][3];
                d.norm_squared() <= reach * reach && keep(j as u32)
            });
        }
        self.any_shifted_cell::<TILTED>(&at, &u, |slots, members, shift| {
            slots.iter().zip(members).any(|(e, &j)| {
                let d = (position(e) - r) + shift;
                let reach = radius + e[3];
                d.norm_squared() <= reach * reach && keep(j)
            })
        })
    }

    /// Calls `visit(slots, members, shift)` with the occupied slots of each
    /// distinct cell around a position (unsheared coordinates `u`, at cell
    /// coordinates `at`) and the cell's image shift (sheared with the box
    /// when `TILTED`), the eight cells of the 2×2×2 block nearest it first (an
    /// overlap, when there is one, is most likely there, and a rejected move
    /// stops at it); stops early and returns true as soon as `visit` does.
    /// Only when every periodic axis is at least three cells wide.
    #[inline(always)]
    fn any_shifted_cell<const TILTED: bool>(
        &self,
        at: &[usize; 3],
        u: &V3,
        mut visit: impl FnMut(&[[f64; 4]], &[u32], &V3) -> bool,
    ) -> bool {
        let interior = (0..3).all(|k| at[k] >= 1 && at[k] + 1 < self.dims[k]);
        if interior {
            // No image shifts and no wrapping: the 27 cells are fixed
            // offsets from this one.
            let centre = at[0] + self.dims[0] * (at[1] + self.dims[1] * at[2]);
            let lengths = self.box_.lengths();
            let mut octant = 0;
            for k in 0..3 {
                let width = lengths[k] / self.dims[k] as f64;
                let middle = (at[k] as f64 + 0.5) * width - 0.5 * lengths[k];
                octant |= ((u[k] >= middle) as usize) << k;
            }
            let zero = V3::zeros();
            for &offset in &self.interior_offsets[octant] {
                let range = self.range_of(centre.wrapping_add_signed(offset));
                if visit(&self.slots[range.clone()], &self.members[range], &zero) {
                    return true;
                }
            }
            return false;
        }
        let (xs, xt, nx) = self.axis_cells(0, at, u);
        let (ys, yt, ny) = self.axis_cells(1, at, u);
        let (zs, zt, nz) = self.axis_cells(2, at, u);
        for [a, b, c] in NEAREST_FIRST {
            if a >= nx || b >= ny || c >= nz {
                continue;
            }
            let cell = xs[a] + self.dims[0] * (ys[b] + self.dims[1] * zs[c]);
            let range = self.range_of(cell);
            if visit(
                &self.slots[range.clone()],
                &self.members[range],
                &if TILTED {
                    self.box_.shear(&V3::new(xt[a], yt[b], zt[c]))
                } else {
                    V3::new(xt[a], yt[b], zt[c])
                },
            ) {
                return true;
            }
        }
        false
    }

    /// Calls `f(j, d)` for every listed particle j whose centre may lie
    /// within `reach` of `r` (all in the cells the box r ± reach touches),
    /// d its separation from `r` (the image nearest `r` for every j within
    /// reach, which must not exceed half the box); stops early and returns
    /// true as soon as `f` does. For reaches beyond one cell: a large body
    /// among a grid of small ones.
    pub fn any_within(&self, r: &V3, reach: f64, mut f: impl FnMut(usize, &V3) -> bool) -> bool {
        let lengths = self.box_.lengths();
        let heights = self.box_.heights();
        let u = self.box_.unshear(r);
        let walls = self.box_.walls();
        // Per axis: the first unwrapped cell and how many, by the formula
        // `coords` bins with (monotone in x; the reach grown by 1e-9 of
        // the box covers rounding at cell faces); a periodic axis the box
        // covers whole is walked once, its members by the minimum image.
        let mut first = [0i64; 3];
        let mut count = [0i64; 3];
        let mut whole = false;
        for k in 0..3 {
            let n = self.dims[k] as i64;
            // A reach across the faces is lengths/heights as far in
            // unsheared coordinates.
            let grown = reach * (lengths[k] / heights[k]) + 1e-9 * lengths[k];
            let cell = |x: f64| {
                let t = (x / lengths[k] + 0.5) * n as f64;
                let i = t as i64;
                if (i as f64) > t { i - 1 } else { i }
            };
            let (mut lo, mut hi) = (cell(u[k] - grown), cell(u[k] + grown));
            if walls[k] {
                lo = lo.max(0);
                hi = hi.min(n - 1);
            } else if hi - lo + 1 >= n || !self.shifted {
                (lo, hi) = (0, n - 1);
                whole = true;
            }
            first[k] = lo;
            count[k] = hi - lo + 1;
        }
        for cz in first[2]..first[2] + count[2] {
            for cy in first[1]..first[1] + count[1] {
                for cx in first[0]..first[0] + count[0] {
                    let unwrapped = [cx, cy, cz];
                    let mut shift = V3::zeros();
                    let mut at = [0usize; 3];
                    for k in 0..3 {
                        let n = self.dims[k] as i64;
                        at[k] = unwrapped[k].rem_euclid(n) as usize;
                        if !walls[k] {
                            shift[k] = unwrapped[k].div_euclid(n) as f64 * lengths[k];
                        }
                    }
                    let shift = self.box_.shear(&shift);
                    let cell = at[0] + self.dims[0] * (at[1] + self.dims[1] * at[2]);
                    for s in self.range_of(cell) {
                        let raw = position(&self.slots[s]) - r;
                        let d = if whole {
                            self.box_.minimum_image_near(&raw)
                        } else {
                            raw + shift
                        };
                        if f(self.members[s] as usize, &d) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }

    /// The occupied slots of `cell`.
    #[inline]
    fn range_of(&self, cell: usize) -> std::ops::Range<usize> {
        let base = cell * self.capacity;
        base..base + self.counts[cell] as usize
    }

    /// The deduplicated cells around cell coordinates `at` (boxes with a
    /// periodic axis narrower than three cells).
    fn repeated_cells(&self, at: &[usize; 3]) -> &[u32] {
        let c = at[0] + self.dims[0] * (at[1] + self.dims[1] * at[2]);
        &self.neighbours[27 * c..27 * c + self.neighbour_counts[c] as usize]
    }

    /// Along axis `k`, the distinct cells around coordinate `at[k]` with
    /// their image shifts (unsheared) and how many there are: own cell, then
    /// the neighbour on the side of `u` within its cell, then the far one
    /// (walled axes narrower than three cells have fewer). Only when every
    /// periodic axis is at least three cells wide.
    #[inline]
    fn axis_cells(&self, k: usize, at: &[usize; 3], u: &V3) -> ([usize; 3], [f64; 3], usize) {
        let n = self.dims[k];
        let c = at[k];
        match n {
            1 => ([c; 3], [0.0; 3], 1),
            2 => ([c, 1 - c, c], [0.0; 3], 2),
            _ => {
                let length = self.box_.lengths()[k];
                let l = if self.box_.walls()[k] { 0.0 } else { length };
                let (below, s_below) = if c == 0 { (n - 1, -l) } else { (c - 1, 0.0) };
                let (above, s_above) = if c + 1 == n { (0, l) } else { (c + 1, 0.0) };
                let centre = (c as f64 + 0.5) * (length / n as f64) - 0.5 * length;
                if u[k] < centre {
                    ([c, below, above], [0.0, s_below, s_above], 3)
                } else {
                    ([c, above, below], [0.0, s_above, s_below], 3)
                }
            }
        }
    }
}

#[inline]
fn position(slot: &[f64; 4]) -> V3 {
    V3::new(slot[0], slot[1], slot[2])
}

/// The 27 (x, y, z) ranks of the cells around a position (0 its own cell,
/// 1 the neighbour on its side, 2 the far one), the 2×2×2 block of ranks 0
/// and 1 first.
const NEAREST_FIRST: [[usize; 3]; 27] = {
    let mut order = [[0usize; 3]; 27];
    let mut next = 0;
    let mut pass = 0;
    while pass < 2 {
        let mut i = 0;
        while i < 27 {
            let r = [i % 3, (i / 3) % 3, i / 9];
            let far = r[0] == 2 || r[1] == 2 || r[2] == 2;
            if far == (pass == 1) {
                order[next] = r;
                next += 1;
            }
            i += 1;
        }
        pass += 1;
    }
    order
};

/// The 27 cell offsets.
const STENCIL: [[i64; 3]; 27] = {
    let mut s = [[0i64; 3]; 27];
    let mut i = 0;
    while i < 27 {
        s[i] = [
            (i % 3) as i64 - 1,
            ((i / 3) % 3) as i64 - 1,
            (i / 9) as i64 - 1,
        ];
        i += 1;
    }
    s
};

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of small particles queried from far beyond one cell (a large
    /// body among them): every particle within the reach is handed over
    /// with its minimum-image separation, in periodic and walled boxes.
    #[test]
    fn box_queries_find_everything_within_reach() {
        let mut uniform = crate::test_support::uniform(12);
        let mut u = || uniform() - 0.5;
        let tilted = Vector3::new(0.2, 0.1, -0.15);
        for (tilts, walls) in [
            (V3::zeros(), [false; 3]),
            (V3::zeros(), [false, false, true]),
            (tilted, [false; 3]),
        ] {
            let box_ = PeriodicBox::triclinic(Vector3::new(9.0, 10.0, 11.0), tilts)
                .unwrap()
                .with_walls(walls)
                .unwrap();
            let pos: Vec<V3> = (0..3000)
                .map(|_| box_.from_fractional(&Vector3::new(u(), u(), u())))
                .collect();
            // Every other particle is in the grid (a species of its own).
            let cells = PackedCells::with_members(
                &box_,
                0.4,
                pos.len(),
                pos.iter()
                    .map(|p| (*p, 0.2))
                    .enumerate()
                    .filter(|(i, _)| i % 2 == 0),
            );
            for _ in 0..200 {
                let r = box_.from_fractional(&Vector3::new(u(), u(), u()));
                let reach = 0.3 + 4.0 * (u() + 0.5);
                let mut seen = Vec::new();
                cells.any_within(&r, reach, |j, d| {
                    if d.norm() <= reach {
                        seen.push((j, *d));
                    }
                    false
                });
                for (j, p) in pos.iter().enumerate() {
                    let d = box_.minimum_image(&(p - r));
                    let listed = seen.iter().filter(|x| x.0 == j).count();
                    if j % 2 == 0 && d.norm() <= reach * (1.0 - 1e-12) {
                        assert_eq!(listed, 1, "{j} at {} within {reach} missed", d.norm());
                    } else if j % 2 == 1 {
                        assert_eq!(listed, 0, "{j} is not in the grid");
                    }
                }
                for (_, d) in &seen {
                    assert!(d.norm() <= reach);
                }
            }
        }
    }

    /// Every pair within range is found once, with the separation the box's
    /// minimum image gives bit for bit, and the sphere test agrees with all
    /// pairs, in boxes of 2 to 7 cells, with and without walls, tilted or
    /// not, after moves that overflow cells too.
    #[test]
    fn finds_every_pair_within_range_with_the_minimum_image() {
        let mut uniform = crate::test_support::uniform(5);
        let mut u = || uniform() - 0.5;
        let range = 1.2;
        let tilted = V3::new(0.35, -0.2, 0.3);
        for (len, walls, tilts) in [
            (2.5, [false; 3], V3::zeros()),
            (4.0, [false; 3], V3::zeros()),
            (5.5, [false, true, false], V3::zeros()),
            (8.7, [false; 3], V3::zeros()),
            (8.7, [true; 3], V3::zeros()),
            (4.0, [false; 3], tilted),
            (8.7, [false; 3], tilted),
        ] {
            let box_ = PeriodicBox::triclinic(Vector3::new(len, len * 1.1, len * 0.95), tilts)
                .unwrap()
                .with_walls(walls)
                .unwrap();
            let mut pos: Vec<V3> = (0..150)
                .map(|_| box_.from_fractional(&Vector3::new(u(), u(), u())))
                .collect();
            let radii: Vec<f64> = (0..pos.len())
                .map(|i| 0.3 + 0.05 * (i % 3) as f64)
                .collect();
            let mut cells = PackedCells::new(&box_, range, &pos, &radii);
            for round in 0..2 {
                for i in 0..pos.len() {
                    let mut near: Vec<(usize, V3)> = Vec::new();
                    cells.any_near(&pos[i], |j, d| {
                        near.push((j, *d));
                        false
                    });
                    let mut ids: Vec<usize> = near.iter().map(|x| x.0).collect();
                    ids.sort();
                    ids.dedup();
                    assert_eq!(ids.len(), near.len(), "a particle listed twice");
                    assert!(ids.contains(&i), "a particle is not near itself");
                    let overlapping = (0..pos.len()).any(|j| {
                        let d = box_.minimum_image_near(&(pos[j] - pos[i]));
                        j != i && d.norm() <= radii[i] + radii[j]
                    });
                    assert_eq!(
                        cells.sphere_overlaps(&pos[i], radii[i], i),
                        overlapping,
                        "sphere test of {i} in box {len}"
                    );
                    for (j, p) in pos.iter().enumerate() {
                        let d = box_.minimum_image_near(&(p - pos[i]));
                        if d.norm() < range {
                            let found = near.iter().find(|x| x.0 == j);
                            let Some((_, got)) = found else {
                                panic!("round {round}, box {len}: pair {i}-{j} missed");
                            };
                            assert_eq!(*got, d, "separation differs from the minimum image");
                        }
                    }
                }
                // Crowd everything towards a corner, one move at a time.
                for (i, p) in pos.iter_mut().enumerate() {
                    *p = box_.wrap(&(*p * 0.3 + Vector3::new(u(), u(), u()) * 0.4));
                    cells.update(i, p);
                }
            }
            assert!(cells.capacity > 4, "no cell overflowed in box {len}");
        }
    }
}
