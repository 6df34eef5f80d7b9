//! The support mapping of each shape: the point of the body farthest
//! along a direction, in closed form (the superellipsoid's from its KKT
//! conditions).

use nalgebra::Vector3;

use super::{Cuboid, Ellipsoid, Shape, Sphere, Spherocylinder, Superellipsoid};
use crate::geometry::roots::{power, solve_power_sum};

/// A convex body described by its support mapping (body frame).
pub trait Support {
    /// The point of the body farthest along `dir` (`dir` ≠ 0).
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64>;
}

impl Support for Shape {
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        Shape::support(self, dir)
    }
}

impl Support for Sphere {
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        let n = dir.norm();
        if n > 0.0 {
            dir * (self.radius / n)
        } else {
            Vector3::new(self.radius, 0.0, 0.0)
        }
    }
}

impl Support for Ellipsoid {
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        // x = A² d / sqrt(dᵀ A² d), A = diag(a, b, c).
        let a2d = self
            .semi_axes
            .component_mul(&self.semi_axes)
            .component_mul(dir);
        let q = dir.dot(&a2d);
        if q > 0.0 {
            a2d / q.sqrt()
        } else {
            Vector3::new(self.semi_axes.x, 0.0, 0.0)
        }
    }
}

impl Support for Cuboid {
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.half_extents.x.copysign(dir.x),
            self.half_extents.y.copysign(dir.y),
            self.half_extents.z.copysign(dir.z),
        )
    }
}

impl Support for Spherocylinder {
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        // The segment's end farthest along `dir` plus the sphere's support.
        let end = Vector3::new(0.0, 0.0, self.half_length.copysign(dir.z));
        let n = dir.norm();
        if n > 0.0 {
            end + dir * (self.radius / n)
        } else {
            end + Vector3::new(self.radius, 0.0, 0.0)
        }
    }
}

impl Support for Superellipsoid {
    fn support(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        // Maximise Σ eᵢ yᵢ over Σ |yᵢ|^{nᵢ} ≤ 1 with yᵢ = xᵢ/aᵢ, eᵢ = aᵢ dᵢ.
        // KKT: |yᵢ| = (t |eᵢ| / nᵢ)^{1/(nᵢ-1)} with t fixed by the constraint
        // Σ (t |eᵢ|/nᵢ)^{qᵢ} = 1, qᵢ = nᵢ/(nᵢ-1).
        let e = self.semi_axes.component_mul(dir).abs();
        let emax = e.max();
        if emax <= 0.0 {
            return Vector3::new(self.semi_axes.x, 0.0, 0.0);
        }
        let e = e / emax; // scale-free
        let n = self.exponents;
        if n.x == n.y && n.y == n.z {
            // Equal exponents, closed form: yᵢ ∝ eᵢ^{1/(n−1)} normalised so
            // that Σ yᵢⁿ = 1 (yᵢⁿ = eᵢ yᵢ).
            let r = 1.0 / (n.x - 1.0);
            let y = e.map(|v| if v > 0.0 { power(v, r) } else { 0.0 });
            let norm = power(e.dot(&y), -1.0 / n.x);
            return Vector3::new(
                (self.semi_axes.x * y.x * norm).copysign(dir.x),
                (self.semi_axes.y * y.y * norm).copysign(dir.y),
                (self.semi_axes.z * y.z * norm).copysign(dir.z),
            );
        }
        let q = n.map(|n| n / (n - 1.0));
        let c = Vector3::new(
            power(e.x / n.x, q.x),
            power(e.y / n.y, q.y),
            power(e.z / n.z, q.z),
        );
        let t = solve_power_sum(&c, &q);
        let mut x = Vector3::zeros();
        for i in 0..3 {
            let y = power(t * e[i] / n[i], 1.0 / (n[i] - 1.0));
            x[i] = (self.semi_axes[i] * y).copysign(dir[i]);
        }
        x
    }
}
