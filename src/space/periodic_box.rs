//! An orthorhombic box, periodic in every direction, positions in [−L/2, L/2).

use nalgebra::Vector3;

/// An orthorhombic periodic box with edge lengths `lengths`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeriodicBox {
    lengths: Vector3<f64>,
}

/// A box with a non-positive or non-finite edge.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("box edge lengths must be finite and > 0, got {0:?}")]
pub struct BoxError(pub [f64; 3]);

impl PeriodicBox {
    /// A box with edges `lengths`.
    pub fn new(lengths: Vector3<f64>) -> Result<Self, BoxError> {
        if lengths.iter().all(|l| l.is_finite() && *l > 0.0) {
            Ok(Self { lengths })
        } else {
            Err(BoxError(lengths.into()))
        }
    }

    /// Edge lengths.
    pub fn lengths(&self) -> Vector3<f64> {
        self.lengths
    }

    /// Volume.
    pub fn volume(&self) -> f64 {
        self.lengths.product()
    }

    /// The shortest periodic image of the separation `d`.
    #[inline]
    pub fn minimum_image(&self, d: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            d.x - self.lengths.x * (d.x / self.lengths.x).round(),
            d.y - self.lengths.y * (d.y / self.lengths.y).round(),
            d.z - self.lengths.z * (d.z / self.lengths.z).round(),
        )
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
            let l = self.lengths[k];
            let up = if r[k] < -0.5 * l { l } else { 0.0 };
            let down = if r[k] > 0.5 * l { l } else { 0.0 };
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
            let l = self.lengths[k];
            if w[k] >= 0.5 * l {
                w[k] -= l;
            } else if w[k] < -0.5 * l {
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
            if w[i] >= 0.5 * self.lengths[i] {
                w[i] -= self.lengths[i];
            }
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
