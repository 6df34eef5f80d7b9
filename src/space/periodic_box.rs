//! An orthorhombic box, positions in [−L/2, L/2): periodic along each axis
//! unless that axis is closed by hard walls at ±L/2 (then no periodic
//! image is taken along it, and bodies must keep inside the walls).

use nalgebra::Vector3;

/// An orthorhombic box with edge lengths `lengths`, periodic along every
/// axis without walls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicBox {
    lengths: Vector3<f64>,
    /// Per axis: hard walls at ±L/2 (true) or periodic (false).
    walls: [bool; 3],
    /// Per axis: 1 where periodic, 0 where walled (masks image shifts).
    periodic: Vector3<f64>,
    /// Per axis: L/2 where periodic, ∞ where walled (image thresholds).
    half: Vector3<f64>,
    /// Per axis: 1/L where periodic, 0 where walled (image counts).
    inverse: Vector3<f64>,
}

/// A box with a non-positive or non-finite edge.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("box edge lengths must be finite and > 0, got {0:?}")]
pub struct BoxError(pub [f64; 3]);

impl PeriodicBox {
    /// A box with edges `lengths`.
    pub fn new(lengths: Vector3<f64>) -> Result<Self, BoxError> {
        if lengths.iter().all(|l| l.is_finite() && *l > 0.0) {
            Ok(Self::build(lengths, [false; 3]))
        } else {
            Err(BoxError(lengths.into()))
        }
    }

    fn build(lengths: Vector3<f64>, walls: [bool; 3]) -> Self {
        Self {
            lengths,
            walls,
            periodic: Vector3::from_fn(|k, _| if walls[k] { 0.0 } else { 1.0 }),
            half: Vector3::from_fn(|k, _| {
                if walls[k] {
                    f64::INFINITY
                } else {
                    0.5 * lengths[k]
                }
            }),
            inverse: Vector3::from_fn(|k, _| if walls[k] { 0.0 } else { 1.0 / lengths[k] }),
        }
    }

    /// The same box with hard walls at ±L/2 along the axes marked true.
    pub fn with_walls(self, walls: [bool; 3]) -> Self {
        Self::build(self.lengths, walls)
    }

    /// The same walls with other edge lengths.
    pub fn with_lengths(&self, lengths: Vector3<f64>) -> Result<Self, BoxError> {
        Ok(Self::new(lengths)?.with_walls(self.walls))
    }

    /// Per axis: whether hard walls close it.
    pub fn walls(&self) -> [bool; 3] {
        self.walls
    }

    /// Whether any axis has walls.
    pub fn has_walls(&self) -> bool {
        self.walls.iter().any(|&w| w)
    }

    /// Edge lengths.
    pub fn lengths(&self) -> Vector3<f64> {
        self.lengths
    }

    /// Volume.
    pub fn volume(&self) -> f64 {
        self.lengths.product()
    }

    /// The shortest periodic image of the separation `d` (see
    /// [`PeriodicBox::image_shift`] for the rounding).
    #[inline]
    pub fn minimum_image(&self, d: &Vector3<f64>) -> Vector3<f64> {
        d + self.image_shift(d)
    }

    /// What [`PeriodicBox::minimum_image`] adds to `d` (whole box lengths
    /// on periodic axes): to carry the image chosen for one separation
    /// over to another (the same pair at another time).
    /// Rounds halfway cases to even (the adding-2⁵² trick, exact for |dₖ| <
    /// 2⁵¹ Lₖ: no library call where the CPU baseline lacks a rounding
    /// instruction; the hot loop of the hard-sphere dynamics calls this).
    #[inline]
    pub fn image_shift(&self, d: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.image_shift_along(0, d.x),
            self.image_shift_along(1, d.y),
            self.image_shift_along(2, d.z),
        )
    }

    /// Component `axis` of [`PeriodicBox::image_shift`] for a separation
    /// whose component on that axis is `x` (written for loops the compiler
    /// vectorises).
    #[inline(always)]
    pub fn image_shift_along(&self, axis: usize, x: f64) -> f64 {
        const SHIFTER: f64 = 6_755_399_441_055_744.0; // 1.5 × 2⁵²
        -self.lengths[axis] * ((x * self.inverse[axis] + SHIFTER) - SHIFTER)
    }

    /// The shortest periodic image of `d` when |dₖ| < 3Lₖ/2, as for the
    /// separation of two positions in the box or one slightly outside it:
    /// one compare-and-shift per axis instead of a rounding call.
    #[inline]
    pub fn minimum_image_near(&self, d: &Vector3<f64>) -> Vector3<f64> {
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

    /// `r` wrapped into [−L/2, L/2) when it lies within a box of it (a
    /// particle just moved): one compare-and-shift per axis.
    #[inline]
    pub fn wrap_near(&self, r: &Vector3<f64>) -> Vector3<f64> {
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

    /// `r` wrapped into [−L/2, L/2).
    #[inline]
    pub fn wrap(&self, r: &Vector3<f64>) -> Vector3<f64> {
        let mut w = self.minimum_image(r);
        for i in 0..3 {
            if w[i] >= self.half[i] {
                w[i] -= self.lengths[i];
            }
        }
        w
    }

    /// How far a body reaching `extent` from its centre `r` along each axis
    /// stays inside the walls: the smallest gap L/2 − |rₖ| − extentₖ over
    /// the walled axes (∞ without walls); not positive when it touches or
    /// crosses one.
    pub fn wall_gap(&self, r: &Vector3<f64>, extent: &Vector3<f64>) -> f64 {
        (0..3)
            .filter(|&k| self.walls[k])
            .map(|k| 0.5 * self.lengths[k] - r[k].abs() - extent[k])
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
        let near = Vector3::new(13.0, -5.0, 2.9);
        assert!((b.minimum_image_near(&near) - b.minimum_image(&near)).norm() < 1e-12);
        let moved = Vector3::new(5.5, -4.5, 2.0);
        assert!((b.wrap_near(&moved) - b.wrap(&moved)).norm() < 1e-12);
    }

    #[test]
    fn walled_axes_take_no_image() {
        let b = PeriodicBox::new(Vector3::new(10.0, 8.0, 6.0))
            .unwrap()
            .with_walls([false, false, true]);
        let d = Vector3::new(9.0, -7.0, 5.5);
        assert_eq!(b.minimum_image(&d), Vector3::new(-1.0, 1.0, 5.5));
        assert_eq!(b.minimum_image_near(&d), Vector3::new(-1.0, 1.0, 5.5));
        assert_eq!(
            b.wrap_near(&Vector3::new(5.5, 0.0, 2.9)),
            Vector3::new(-4.5, 0.0, 2.9)
        );
        // 3 - 2.5 - 0.25 from the wall at z = 3.
        assert_eq!(
            b.wall_gap(&Vector3::new(4.9, 0.0, -2.5), &Vector3::repeat(0.25)),
            0.25
        );
        assert_eq!(
            PeriodicBox::new(Vector3::repeat(2.0))
                .unwrap()
                .wall_gap(&Vector3::zeros(), &Vector3::zeros()),
            f64::INFINITY
        );
        assert_eq!(
            b.with_lengths(Vector3::repeat(4.0)).unwrap().walls(),
            [false, false, true]
        );
    }
}
