//! The simulation box: a parallelepiped spanned by a₁ = (Lx, 0, 0),
//! a₂ = (xy·Ly, Ly, 0), a₃ = (xz·Lz, yz·Lz, Lz) (HOOMD-blue's edges and
//! tilt factors), periodic along each lattice vector unless that axis is
//! closed by hard walls (then no periodic image is taken along it, and
//! bodies must keep inside the walls; only an orthorhombic box has walls).
//!
//! Everything periodic is done in the box's unsheared coordinates
//! u = T⁻¹r, where T is the unit upper-triangular tilt matrix: in u the
//! box is the orthorhombic [−L/2, L/2)³ and every image shift is whole
//! edges Lₖ along axis k. In a zero-tilt box the map is the identity,
//! which `shear` and `unshear` return without the zero products (the same
//! values; a predictable branch in the hot loops instead of six
//! multiply-adds).

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// A periodic box with edge lengths `lengths` and tilt factors `tilts`
/// (xy, xz, yz), walls along none, some or all axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicBox {
    lengths: V3,
    /// Tilt factors (xy, xz, yz).
    tilts: V3,
    /// Whether any tilt is not zero (the shear maps are then the
    /// identity, and skipped).
    tilted: bool,
    /// Per axis: hard walls at ±L/2 (true) or periodic (false).
    walls: [bool; 3],
    /// Per axis: L/2 where periodic, ∞ where walled (image thresholds).
    half: V3,
    /// Per axis: 1/L where periodic, 0 where walled (image counts).
    inverse: V3,
}

/// A box that cannot hold a simulation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BoxError {
    /// A non-positive or non-finite edge.
    #[error("box edge lengths must be finite and > 0, got {0:?}")]
    Edges([f64; 3]),
    /// A non-finite tilt factor.
    #[error("box tilt factors (xy, xz, yz) must be finite, got {0:?}")]
    Tilts([f64; 3]),
    /// Walls on a tilted box.
    #[error("walls close an orthorhombic box only: tilts {tilts:?} with walls {walls:?}")]
    TiltedWithWalls {
        /// Tilt factors (xy, xz, yz).
        tilts: [f64; 3],
        /// Walled axes.
        walls: [bool; 3],
    },
}

impl PeriodicBox {
    /// An orthorhombic box with edges `lengths`.
    pub fn new(lengths: V3) -> Result<Self, BoxError> {
        Self::triclinic(lengths, V3::zeros())
    }

    /// A box with edges `lengths` and tilt factors `tilts` (xy, xz, yz).
    pub fn triclinic(lengths: V3, tilts: V3) -> Result<Self, BoxError> {
        if !lengths.iter().all(|l| l.is_finite() && *l > 0.0) {
            return Err(BoxError::Edges(lengths.into()));
        }
        if !tilts.iter().all(|t| t.is_finite()) {
            return Err(BoxError::Tilts(tilts.into()));
        }
        Ok(Self::build(lengths, tilts, [false; 3]))
    }

    fn build(lengths: V3, tilts: V3, walls: [bool; 3]) -> Self {
        Self {
            lengths,
            tilts,
            tilted: tilts != V3::zeros(),
            walls,
            half: V3::from_fn(|k, _| {
                if walls[k] {
                    f64::INFINITY
                } else {
                    0.5 * lengths[k]
                }
            }),
            inverse: V3::from_fn(|k, _| if walls[k] { 0.0 } else { 1.0 / lengths[k] }),
        }
    }

    /// The same box with hard walls at ±L/2 along the axes marked true.
    /// Walls close orthorhombic boxes only: a tilted box with walls is
    /// refused.
    pub fn with_walls(self, walls: [bool; 3]) -> Result<Self, BoxError> {
        if walls.contains(&true) && self.is_tilted() {
            return Err(BoxError::TiltedWithWalls {
                tilts: self.tilts.into(),
                walls,
            });
        }
        Ok(Self::build(self.lengths, self.tilts, walls))
    }

    /// The same walls and tilt factors with other edge lengths.
    pub fn with_lengths(&self, lengths: V3) -> Result<Self, BoxError> {
        Self::triclinic(lengths, self.tilts)?.with_walls(self.walls)
    }

    /// This box stretched by `factor` along lab axis `axis` (H ↦ D·H, D
    /// diagonal with `factor` at `axis`): edge `axis` scales, and the tilt
    /// factors follow so that the same lattice of any cell of this box is
    /// stretched the same way (the stretch commutes with reduction).
    pub fn stretched_along(&self, axis: usize, factor: f64) -> Result<Self, BoxError> {
        let mut lengths = self.lengths;
        lengths[axis] *= factor;
        let t = self.tilts;
        let tilts = match axis {
            0 => V3::new(t.x * factor, t.y * factor, t.z),
            1 => V3::new(t.x / factor, t.y, t.z * factor),
            _ => V3::new(t.x, t.y / factor, t.z / factor),
        };
        Self::triclinic(lengths, tilts)?.with_walls(self.walls)
    }

    /// The same walls and edges with other tilt factors.
    pub fn with_tilts(&self, tilts: V3) -> Result<Self, BoxError> {
        Self::triclinic(self.lengths, tilts)?.with_walls(self.walls)
    }

    /// Per axis: whether hard walls close it.
    pub fn walls(&self) -> [bool; 3] {
        self.walls
    }

    /// Whether any axis has walls.
    pub fn has_walls(&self) -> bool {
        self.walls.iter().any(|&w| w)
    }

    /// Edge lengths (Lx, Ly, Lz).
    pub fn lengths(&self) -> V3 {
        self.lengths
    }

    /// Tilt factors (xy, xz, yz).
    pub fn tilts(&self) -> V3 {
        self.tilts
    }

    /// Whether any tilt factor is not zero.
    pub fn is_tilted(&self) -> bool {
        self.tilted
    }

    /// The lattice vectors a₁, a₂, a₃ as columns.
    pub fn matrix(&self) -> nalgebra::Matrix3<f64> {
        let (l, t) = (self.lengths, self.tilts);
        nalgebra::Matrix3::new(
            l.x,
            t.x * l.y,
            t.y * l.z,
            0.0,
            l.y,
            t.z * l.z,
            0.0,
            0.0,
            l.z,
        )
    }

    /// Volume (Lx·Ly·Lz: tilts shear the box without changing it).
    pub fn volume(&self) -> f64 {
        self.lengths.product()
    }

    /// The distances between opposite faces: the face normal to the
    /// reciprocal vector k sits hₖ = Lₖ / |row k of T⁻¹| from its partner.
    /// A body fits its own periodic images when it is thinner than the
    /// smallest; cells of width w along k take w ≤ hₖ.
    pub fn heights(&self) -> V3 {
        let (xy, xz, yz) = (self.tilts.x, self.tilts.y, self.tilts.z);
        let l = self.lengths;
        V3::new(
            l.x / (1.0 + xy * xy + (xy * yz - xz).powi(2)).sqrt(),
            l.y / (1.0 + yz * yz).sqrt(),
            l.z,
        )
    }

    /// The unsheared coordinates T⁻¹r of `r` (the box is [−L/2, L/2)³ in
    /// them).
    #[inline(always)]
    pub fn unshear(&self, r: &V3) -> V3 {
        if !self.tilted {
            return *r;
        }
        let (xy, xz, yz) = (self.tilts.x, self.tilts.y, self.tilts.z);
        let uy = r.y - yz * r.z;
        V3::new(r.x - xy * uy - xz * r.z, uy, r.z)
    }

    /// Half extents, in unsheared coordinates, of a box that holds the
    /// axis-aligned box ± `half_extents` once unsheared (|T⁻¹| applied
    /// entry by entry).
    #[inline]
    pub fn unshear_half_extents(&self, half_extents: &V3) -> V3 {
        let (xy, xz, yz) = (self.tilts.x, self.tilts.y, self.tilts.z);
        let h = half_extents;
        V3::new(
            h.x + xy.abs() * h.y + (xy * yz - xz).abs() * h.z,
            h.y + yz.abs() * h.z,
            h.z,
        )
    }

    /// The position T·u of unsheared coordinates `u`.
    #[inline(always)]
    pub fn shear(&self, u: &V3) -> V3 {
        if !self.tilted {
            return *u;
        }
        let (xy, xz, yz) = (self.tilts.x, self.tilts.y, self.tilts.z);
        V3::new(u.x + xy * u.y + xz * u.z, u.y + yz * u.z, u.z)
    }

    /// Fractional coordinates H⁻¹r (in [−1/2, 1/2) in the box).
    pub fn fractional(&self, r: &V3) -> V3 {
        self.unshear(r).component_div(&self.lengths)
    }

    /// The position H·s of fractional coordinates `s`.
    pub fn from_fractional(&self, s: &V3) -> V3 {
        self.shear(&s.component_mul(&self.lengths))
    }

    /// Where `r`, a position in box `old`, goes when the box becomes this
    /// one: the same fractional coordinates (an affine map of the box).
    #[inline]
    pub fn map_from(&self, old: &PeriodicBox, r: &V3) -> V3 {
        let factor = self.lengths.component_div(&old.lengths);
        self.shear(&old.unshear(r).component_mul(&factor))
    }

    /// The smallest factor by which the map from box `old` to this one
    /// (same fractional coordinates) stretches any separation: the
    /// smallest singular value of H·H₀⁻¹ (the smallest edge ratio when
    /// neither box is tilted).
    pub fn smallest_stretch_from(&self, old: &PeriodicBox) -> f64 {
        let factor = self.lengths.component_div(&old.lengths);
        if !self.is_tilted() && !old.is_tilted() {
            return factor.min();
        }
        let map = self.matrix()
            * old
                .matrix()
                .try_inverse()
                .unwrap_or_else(nalgebra::Matrix3::zeros);
        (map.transpose() * map)
            .symmetric_eigenvalues()
            .min()
            .max(0.0)
            .sqrt()
    }

    /// Whether the map from box `old` to this one scales every separation
    /// by the same factor, at least 1 (an isotropic expansion: no convex
    /// bodies that were apart can touch after it).
    pub fn expands_uniformly_from(&self, old: &PeriodicBox) -> bool {
        let f = self.lengths.component_div(&old.lengths);
        self.tilts == old.tilts && f.x >= 1.0 && f.x == f.y && f.y == f.z
    }

    /// The shortest periodic image of the separation `d` (see
    /// [`PeriodicBox::image_shift`] for the rounding).
    #[inline]
    pub fn minimum_image(&self, d: &V3) -> V3 {
        d + self.image_shift(d)
    }

    /// What [`PeriodicBox::minimum_image`] adds to `d` (whole lattice
    /// vectors along periodic axes): to carry the image chosen for one
    /// separation over to another (the same pair at another time). The
    /// image with unsheared coordinates in [−L/2, L/2] per axis: the
    /// shortest one for every separation shorter than half the smallest
    /// height (it is then the only image that short).
    /// Rounds halfway cases to even (the adding-2⁵² trick, exact for |uₖ| <
    /// 2⁵¹ Lₖ: no library call where the CPU baseline lacks a rounding
    /// instruction; the hot loop of the hard-sphere dynamics calls this).
    #[inline]
    pub fn image_shift(&self, d: &V3) -> V3 {
        if !self.tilted {
            return V3::new(
                self.image_shift_along(0, d.x),
                self.image_shift_along(1, d.y),
                self.image_shift_along(2, d.z),
            );
        }
        let u = self.unshear(d);
        self.shear(&V3::new(
            self.image_shift_along(0, u.x),
            self.image_shift_along(1, u.y),
            self.image_shift_along(2, u.z),
        ))
    }

    /// Component `axis` of [`PeriodicBox::image_shift`] in unsheared
    /// coordinates, for a separation whose unsheared component on that
    /// axis is `x` (in an orthorhombic box, the component itself; written
    /// for loops the compiler vectorises).
    #[inline(always)]
    pub fn image_shift_along(&self, axis: usize, x: f64) -> f64 {
        const SHIFTER: f64 = 6_755_399_441_055_744.0; // 1.5 × 2⁵²
        -self.lengths[axis] * ((x * self.inverse[axis] + SHIFTER) - SHIFTER)
    }

    /// The shortest periodic image of `d` when |uₖ| < 3Lₖ/2 in unsheared
    /// coordinates, as for the separation of two positions in the box or
    /// one slightly outside it: one compare-and-shift per axis instead of a
    /// rounding call.
    #[inline]
    pub fn minimum_image_near(&self, d: &V3) -> V3 {
        if self.tilted {
            return self.minimum_image_near_tilted(d);
        }
        self.minimum_image_near_as::<false>(d)
    }

    /// [`PeriodicBox::minimum_image_near`] for a box known to be tilted
    /// (`TILTED`) or not, so that a loop over many separations asks once
    /// (`if b.is_tilted() { loop::<true> } else { loop::<false> }`) and
    /// its untilted form carries no test per separation.
    #[inline(always)]
    pub fn minimum_image_near_as<const TILTED: bool>(&self, d: &V3) -> V3 {
        debug_assert_eq!(TILTED, self.tilted);
        if TILTED {
            return self.minimum_image_near_tilted(d);
        }
        // Branch-free: the shifts are selected, not jumped to (separations
        // are random, so branches would mispredict).
        let mut r = *d;
        for k in 0..3 {
            let (l, h) = (self.lengths[k], self.half[k]);
            let up = if r[k] < -h { l } else { 0.0 };
            let down = if r[k] > h { l } else { 0.0 };
            r[k] += up - down;
        }
        r
    }

    /// [`PeriodicBox::minimum_image_near`] in a tilted box: the shifts
    /// chosen in unsheared coordinates (kept out of line, so that the
    /// untilted form stays small enough to inline in the hot loops).
    #[inline(never)]
    fn minimum_image_near_tilted(&self, d: &V3) -> V3 {
        let u = self.unshear(d);
        let mut shift = V3::zeros();
        for k in 0..3 {
            let (l, h) = (self.lengths[k], self.half[k]);
            let up = if u[k] < -h { l } else { 0.0 };
            let down = if u[k] > h { l } else { 0.0 };
            shift[k] = up - down;
        }
        d + self.shear(&shift)
    }

    /// `r` wrapped into the box when it lies within a box of it (a
    /// particle just moved): one compare-and-shift per axis.
    #[inline]
    pub fn wrap_near(&self, r: &V3) -> V3 {
        if self.tilted {
            return self.wrap_near_tilted(r);
        }
        let mut w = *r;
        for k in 0..3 {
            let (l, h) = (self.lengths[k], self.half[k]);
            if w[k] >= h {
                w[k] -= l;
            } else if w[k] < -h {
                w[k] += l;
            }
        }
        w
    }

    /// [`PeriodicBox::wrap_near`] in a tilted box: whole lattice vectors
    /// chosen in unsheared coordinates (out of line, as
    /// `minimum_image_near_tilted`).
    #[inline(never)]
    fn wrap_near_tilted(&self, r: &V3) -> V3 {
        let u = self.unshear(r);
        let mut w = *r;
        for k in 0..3 {
            if u[k] >= self.half[k] {
                w -= self.lattice_vector(k);
            } else if u[k] < -self.half[k] {
                w += self.lattice_vector(k);
            }
        }
        w
    }

    /// `r` wrapped into the box (unsheared coordinates in [−L/2, L/2)).
    #[inline]
    pub fn wrap(&self, r: &V3) -> V3 {
        if self.tilted {
            return self.wrap_tilted(r);
        }
        let mut w = self.minimum_image(r);
        for k in 0..3 {
            if w[k] >= self.half[k] {
                w[k] -= self.lengths[k];
            }
        }
        w
    }

    /// [`PeriodicBox::wrap`] in a tilted box (out of line, as
    /// `minimum_image_near_tilted`).
    #[inline(never)]
    fn wrap_tilted(&self, r: &V3) -> V3 {
        let w = self.minimum_image(r);
        let u = self.unshear(&w);
        let mut shift = V3::zeros();
        for k in 0..3 {
            if u[k] >= self.half[k] {
                shift[k] = -self.lengths[k];
            }
        }
        w + self.shear(&shift)
    }

    /// Lattice vector aₖ.
    #[inline]
    pub fn lattice_vector(&self, k: usize) -> V3 {
        let (l, t) = (self.lengths, self.tilts);
        match k {
            0 => V3::new(l.x, 0.0, 0.0),
            1 => V3::new(t.x * l.y, l.y, 0.0),
            _ => V3::new(t.y * l.z, t.z * l.z, l.z),
        }
    }

    /// The same lattice with the shortest tilts: each lattice vector
    /// reduced by whole earlier ones until |xy·Ly| ≤ Lx/2, |yz·Lz| ≤ Ly/2
    /// and |xz·Lz| ≤ Lx/2 (the same periodic system; positions must be
    /// wrapped again). Heights then stay within a factor of the edges, so
    /// cells stay valid however far a crystal shears.
    pub fn reduced(&self) -> Self {
        let l = self.lengths;
        let (mut xy, mut xz, mut yz) = (self.tilts.x, self.tilts.y, self.tilts.z);
        // a₂ ← a₂ − m a₁
        let m = (xy * l.y / l.x).round();
        xy -= m * l.x / l.y;
        // a₃ ← a₃ − n a₂, then − m a₁
        let n = (yz * l.z / l.y).round();
        yz -= n * l.y / l.z;
        xz -= n * xy * l.y / l.z;
        let m = (xz * l.z / l.x).round();
        xz -= m * l.x / l.z;
        Self::build(l, V3::new(xy, xz, yz), self.walls)
    }

    /// How far a body reaching `up` from its centre `r` along each axis
    /// and `down` against it stays inside the walls: the smallest gap,
    /// L/2 − rₖ − upₖ or L/2 + rₖ − downₖ, over the walled axes (∞ without
    /// walls); not positive when it touches or crosses one.
    pub fn wall_gap(&self, r: &V3, (up, down): (&V3, &V3)) -> f64 {
        (0..3)
            .filter(|&k| self.walls[k])
            .map(|k| {
                (0.5 * self.lengths[k] - r[k] - up[k]).min(0.5 * self.lengths[k] + r[k] - down[k])
            })
            .fold(f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shift lands the separation in the shortest image, many boxes
    /// away too, and is whole box lengths.
    #[test]
    fn image_shift_gives_the_minimum_image() {
        let b = PeriodicBox::new(Vector3::new(3.0, 4.5, 16.1)).unwrap();
        let mut u = crate::test_support::uniform(3);
        for _ in 0..10_000 {
            let d = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 200.0;
            let s = b.image_shift(&d);
            let m = d + s;
            for k in 0..3 {
                let l = b.lengths()[k];
                assert!(m[k].abs() <= 0.5 * l * (1.0 + 1e-12), "{d} -> {m}");
                let whole = s[k] / l;
                assert!((whole - whole.round()).abs() < 1e-9, "{s}");
            }
            assert!((m - b.minimum_image(&d)).norm() < 1e-9);
        }
    }

    #[test]
    fn minimum_image_is_shortest() {
        let b = PeriodicBox::new(Vector3::new(10.0, 8.0, 6.0)).unwrap();
        let d = b.minimum_image(&Vector3::new(9.0, -7.0, 3.5));
        assert!((d - Vector3::new(-1.0, 1.0, -2.5)).norm() < 1e-12);
        let w = b.wrap(&Vector3::new(5.0, -4.0, 13.0));
        assert!((w - Vector3::new(-5.0, -4.0, 1.0)).norm() < 1e-12);
        assert!(PeriodicBox::new(Vector3::new(1.0, 0.0, 1.0)).is_err());
        assert!(
            PeriodicBox::triclinic(Vector3::repeat(1.0), Vector3::new(0.0, f64::NAN, 0.0)).is_err()
        );
        let near = Vector3::new(13.0, -5.0, 2.9);
        assert!((b.minimum_image_near(&near) - b.minimum_image(&near)).norm() < 1e-12);
        let moved = Vector3::new(5.5, -4.5, 2.0);
        assert!((b.wrap_near(&moved) - b.wrap(&moved)).norm() < 1e-12);
    }

    #[test]
    fn walls_on_a_tilted_box_are_refused() {
        let tilted =
            PeriodicBox::triclinic(Vector3::repeat(8.0), Vector3::new(0.2, 0.0, 0.0)).unwrap();
        assert_eq!(
            tilted.with_walls([false, false, true]),
            Err(BoxError::TiltedWithWalls {
                tilts: [0.2, 0.0, 0.0],
                walls: [false, false, true]
            })
        );
        assert!(tilted.with_walls([false; 3]).is_ok());
        let walled = PeriodicBox::new(Vector3::repeat(8.0))
            .unwrap()
            .with_walls([true; 3])
            .unwrap();
        assert!(walled.with_tilts(Vector3::new(0.0, 0.1, 0.0)).is_err());
    }

    #[test]
    fn walled_axes_take_no_image() {
        let b = PeriodicBox::new(Vector3::new(10.0, 8.0, 6.0))
            .unwrap()
            .with_walls([false, false, true])
            .unwrap();
        let d = Vector3::new(9.0, -7.0, 5.5);
        assert_eq!(b.minimum_image(&d), Vector3::new(-1.0, 1.0, 5.5));
        assert_eq!(b.minimum_image_near(&d), Vector3::new(-1.0, 1.0, 5.5));
        assert_eq!(
            b.wrap_near(&Vector3::new(5.5, 0.0, 2.9)),
            Vector3::new(-4.5, 0.0, 2.9)
        );
        // 3 - 2.5 - 0.25 from the wall at z = -3; reaching 0.25 down, 0.1
        // up: the wall below sees the 0.25.
        let (up, down) = (Vector3::repeat(0.1), Vector3::repeat(0.25));
        assert_eq!(
            b.wall_gap(&Vector3::new(4.9, 0.0, -2.5), (&up, &down)),
            0.25
        );
        // Reaching 0.1 down: 0.4 from the wall below, 5.4 from the one above.
        assert!((b.wall_gap(&Vector3::new(4.9, 0.0, -2.5), (&down, &up)) - 0.4).abs() < 1e-15);
        assert_eq!(
            PeriodicBox::new(Vector3::repeat(2.0))
                .unwrap()
                .wall_gap(&Vector3::zeros(), (&Vector3::zeros(), &Vector3::zeros())),
            f64::INFINITY
        );
        assert_eq!(
            b.with_lengths(Vector3::repeat(4.0)).unwrap().walls(),
            [false, false, true]
        );
    }

    fn tilted() -> PeriodicBox {
        PeriodicBox::triclinic(Vector3::new(7.0, 6.0, 8.0), Vector3::new(0.4, -0.3, 0.25)).unwrap()
    }

    /// In a tilted box the minimum image is the shortest of all images
    /// (brute force over 5³ lattice shifts) for every separation shorter
    /// than half the smallest height, and a whole lattice vector away.
    #[test]
    fn tilted_minimum_image_is_the_shortest_image() {
        let b = tilted();
        let h = b.heights().min();
        let mut u = crate::test_support::uniform(5);
        let mut short = 0;
        for _ in 0..20_000 {
            let d = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 40.0;
            let m = b.minimum_image(&d);
            let mut best = f64::INFINITY;
            for i in -6..=6 {
                for j in -6..=6 {
                    for k in -6..=6 {
                        let s = b.matrix() * Vector3::new(i as f64, j as f64, k as f64);
                        best = best.min((d + s).norm());
                    }
                }
            }
            let whole = b.matrix().try_inverse().unwrap() * (m - d);
            assert!(
                whole.iter().all(|w| (w - w.round()).abs() < 1e-9),
                "{whole}"
            );
            if best < 0.5 * h {
                short += 1;
                assert!(
                    (m.norm() - best).abs() < 1e-9,
                    "{d}: {} vs {best}",
                    m.norm()
                );
            }
            let near = b.wrap(&(d * 0.01)) - b.wrap(&(d * 0.013));
            assert!((b.minimum_image_near(&near) - b.minimum_image(&near)).norm() < 1e-9);
        }
        assert!(short > 1000, "{short}");
    }

    /// Wrapped positions have fractional coordinates in [−1/2, 1/2) and
    /// differ from the original by whole lattice vectors; `wrap_near`
    /// agrees with `wrap` one box away.
    #[test]
    fn tilted_wrap_lands_in_the_parallelepiped() {
        let b = tilted();
        let mut u = crate::test_support::uniform(6);
        for _ in 0..10_000 {
            let r = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 30.0;
            let w = b.wrap(&r);
            let s = b.fractional(&w);
            assert!(s.iter().all(|&x| (-0.5..0.5).contains(&x)), "{s}");
            let whole = b.fractional(&(w - r));
            assert!(whole.iter().all(|x| (x - x.round()).abs() < 1e-9));
            let moved = w + Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 2.0;
            assert!((b.wrap_near(&moved) - b.wrap(&moved)).norm() < 1e-9);
            assert!((b.from_fractional(&s) - w).norm() < 1e-12);
        }
    }

    /// Heights are the volume over the area of the opposite face.
    #[test]
    fn heights_are_volume_over_face_area() {
        let b = tilted();
        let a = [0, 1, 2].map(|k| b.lattice_vector(k));
        for k in 0..3 {
            let face = a[(k + 1) % 3].cross(&a[(k + 2) % 3]).norm();
            assert!((b.heights()[k] - b.volume() / face).abs() < 1e-12);
        }
        assert!((b.matrix().determinant() - b.volume()).abs() < 1e-9);
        let cube = PeriodicBox::new(Vector3::new(3.0, 4.0, 5.0)).unwrap();
        assert_eq!(cube.heights(), cube.lengths());
    }

    /// Reduction keeps the lattice (the new vectors are integer
    /// combinations of the old, and back) and brings every tilt within
    /// half an edge.
    #[test]
    fn reduction_keeps_the_lattice_and_bounds_the_tilts() {
        for tilts in [[1.7, -2.2, 0.9], [0.3, 0.1, -0.2], [-0.6, 3.1, -1.4]] {
            let b =
                PeriodicBox::triclinic(Vector3::new(5.0, 6.0, 7.0), Vector3::from(tilts)).unwrap();
            let r = b.reduced();
            let l = r.lengths();
            let t = r.tilts();
            assert!((t.x * l.y).abs() <= 0.5 * l.x + 1e-12);
            assert!((t.z * l.z).abs() <= 0.5 * l.y + 1e-12);
            assert!((t.y * l.z).abs() <= 0.5 * l.x + 1e-12);
            let m = b.matrix().try_inverse().unwrap() * r.matrix();
            assert!(m.iter().all(|x| (x - x.round()).abs() < 1e-9), "{m}");
            assert!((m.determinant().abs() - 1.0).abs() < 1e-9);
        }
    }

    /// A stretch along a lab axis is D·H for any cell of the lattice: the
    /// stretched box and the stretched reduced box are the same lattice.
    #[test]
    fn stretches_commute_with_reduction() {
        let b = PeriodicBox::triclinic(Vector3::new(5.0, 6.0, 7.0), Vector3::new(1.3, -0.8, 0.9))
            .unwrap();
        for axis in 0..3 {
            let stretch = nalgebra::Matrix3::from_diagonal(&Vector3::from_fn(|k, _| {
                if k == axis { 1.3 } else { 1.0 }
            }));
            let s = b.stretched_along(axis, 1.3).unwrap();
            assert!((s.matrix() - stretch * b.matrix()).norm() < 1e-12);
            let r = b.reduced().stretched_along(axis, 1.3).unwrap();
            let m = s.matrix().try_inverse().unwrap() * r.matrix();
            assert!(m.iter().all(|x| (x - x.round()).abs() < 1e-9), "{m}");
        }
    }

    /// A box change keeps fractional coordinates, and no separation
    /// shrinks by more than the smallest stretch (some by just that).
    #[test]
    fn map_from_keeps_fractional_coordinates() {
        let b = tilted();
        let c = b
            .with_lengths(Vector3::new(8.0, 5.0, 9.0))
            .unwrap()
            .with_tilts(Vector3::new(-0.1, 0.2, 0.0))
            .unwrap();
        let r = Vector3::new(1.0, -2.0, 3.0);
        assert!((c.fractional(&c.map_from(&b, &r)) - b.fractional(&r)).norm() < 1e-12);
        let stretch = c.smallest_stretch_from(&b);
        let mut u = crate::test_support::uniform(2);
        let mut least = f64::INFINITY;
        for _ in 0..20_000 {
            let d = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            let moved = c.map_from(&b, &d) - c.map_from(&b, &Vector3::zeros());
            let ratio = moved.norm() / d.norm();
            assert!(ratio >= stretch * (1.0 - 1e-12));
            least = least.min(ratio);
        }
        assert!(least < stretch * 1.01, "{least} vs {stretch}");
        let plain = PeriodicBox::new(Vector3::new(2.0, 3.0, 4.0)).unwrap();
        let scaled = plain.with_lengths(Vector3::new(2.2, 2.7, 4.0)).unwrap();
        assert_eq!(scaled.smallest_stretch_from(&plain), 0.9);
        assert!(!scaled.expands_uniformly_from(&plain));
        let grown = plain.with_lengths(plain.lengths() * 1.5).unwrap();
        assert!(grown.expands_uniformly_from(&plain));
    }
}
