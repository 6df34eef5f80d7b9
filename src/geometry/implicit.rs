//! Implicit description of the smooth shapes (sphere, ellipsoid,
//! superellipsoid), as De Michele's Newton–Raphson distance needs it: a
//! function f that is negative inside, zero on the surface and positive
//! outside, with its gradient and Hessian (Sec. 2.3, eq. 7).

use nalgebra::{Matrix3, Vector3};

use super::roots::{power, solve_power_sum};
use super::shape::{Ellipsoid, Sphere, Superellipsoid};

/// Value, gradient and Hessian of an implicit surface function at a point.
#[derive(Debug, Clone, Copy)]
pub struct Implicit {
    /// f(x): < 0 inside, 0 on the surface, > 0 outside.
    pub value: f64,
    /// ∂f/∂x.
    pub gradient: Vector3<f64>,
    /// ∂²f/∂x².
    pub hessian: Matrix3<f64>,
}

/// A smooth convex body given by an implicit function in its body frame.
pub trait SmoothSurface: Copy {
    /// f, ∇f and ∇∇f at `x` (body frame).
    fn implicit(&self, x: &Vector3<f64>) -> Implicit;

    /// The point where the ray from the centre along `dir` (≠ 0) leaves the
    /// body.
    fn ray_to_surface(&self, dir: &Vector3<f64>) -> Vector3<f64>;

    /// Semi-axes along body x, y, z (the scaling of the initial guess,
    /// De Michele eq. 51).
    fn semi_axes(&self) -> Vector3<f64>;
}

impl SmoothSurface for Sphere {
    #[inline]
    fn implicit(&self, x: &Vector3<f64>) -> Implicit {
        let inv = 1.0 / (self.radius() * self.radius());
        Implicit {
            value: x.norm_squared() * inv - 1.0,
            gradient: x * (2.0 * inv),
            hessian: Matrix3::from_diagonal_element(2.0 * inv),
        }
    }
    fn ray_to_surface(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        dir * (self.radius() / dir.norm())
    }
    fn semi_axes(&self) -> Vector3<f64> {
        Vector3::repeat(self.radius())
    }
}

impl SmoothSurface for Ellipsoid {
    #[inline]
    fn implicit(&self, x: &Vector3<f64>) -> Implicit {
        // f = xᵀ X x − 1 with X = diag(1/a², 1/b², 1/c²) (eq. 42, 44 with the
        // squares the paper drops).
        let a = self.semi_axes();
        let inv = Vector3::new(1.0 / (a.x * a.x), 1.0 / (a.y * a.y), 1.0 / (a.z * a.z));
        let xi = x.component_mul(&inv);
        Implicit {
            value: x.dot(&xi) - 1.0,
            gradient: xi * 2.0,
            hessian: Matrix3::from_diagonal(&(inv * 2.0)),
        }
    }
    fn ray_to_surface(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        let a = self.semi_axes();
        let q = (dir.x / a.x).powi(2) + (dir.y / a.y).powi(2) + (dir.z / a.z).powi(2);
        dir / q.sqrt()
    }
    fn semi_axes(&self) -> Vector3<f64> {
        Ellipsoid::semi_axes(self)
    }
}

impl SmoothSurface for Superellipsoid {
    #[inline]
    fn implicit(&self, x: &Vector3<f64>) -> Implicit {
        // f = Σ |xᵢ/aᵢ|^{nᵢ} − 1 (eq. 77).
        let a = self.semi_axes();
        let n = self.exponents();
        let mut value = -1.0;
        let mut gradient = Vector3::zeros();
        let mut diag = Vector3::zeros();
        for i in 0..3 {
            let u = (x[i] / a[i]).abs();
            // u^{n-2} computed once; u^{n-1} and u^n from it.
            let un2 = power(u, n[i] - 2.0);
            let un1 = un2 * u;
            value += un1 * u;
            gradient[i] = (n[i] * un1 / a[i]).copysign(x[i]);
            diag[i] = n[i] * (n[i] - 1.0) * un2 / (a[i] * a[i]);
        }
        Implicit {
            value,
            gradient,
            hessian: Matrix3::from_diagonal(&diag),
        }
    }
    fn ray_to_surface(&self, dir: &Vector3<f64>) -> Vector3<f64> {
        let a = self.semi_axes();
        let n = self.exponents();
        let c = Vector3::new(
            power((dir.x / a.x).abs(), n.x),
            power((dir.y / a.y).abs(), n.y),
            power((dir.z / a.z).abs(), n.z),
        );
        dir * solve_power_sum(&c, &n)
    }
    fn semi_axes(&self) -> Vector3<f64> {
        Superellipsoid::semi_axes(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_derivatives<S: SmoothSurface>(s: &S, x: Vector3<f64>) {
        let h = 1e-6;
        let at = s.implicit(&x);
        for i in 0..3 {
            let mut e = Vector3::zeros();
            e[i] = h;
            let (p, m) = (s.implicit(&(x + e)), s.implicit(&(x - e)));
            let g = (p.value - m.value) / (2.0 * h);
            assert!(
                (g - at.gradient[i]).abs() < 1e-6 * (1.0 + g.abs()),
                "grad {i}"
            );
            let hcol = (p.gradient - m.gradient) / (2.0 * h);
            assert!((hcol - at.hessian.column(i)).norm() < 1e-5 * (1.0 + hcol.norm()));
        }
    }

    #[test]
    fn gradients_and_hessians_match_finite_differences() {
        let x = Vector3::new(0.31, -0.42, 0.27);
        check_derivatives(&Sphere::new(0.7).unwrap(), x);
        check_derivatives(&Ellipsoid::new(1.0, 0.5, 0.3).unwrap(), x);
        check_derivatives(
            &Superellipsoid::new(1.0, 0.5, 0.3, (2.0, 4.5, 8.0)).unwrap(),
            x,
        );
    }

    #[test]
    fn ray_points_lie_on_the_surface() {
        let q = Superellipsoid::new(1.0, 0.5, 0.3, (3.0, 4.5, 8.0)).unwrap();
        let e = Ellipsoid::new(1.0, 0.5, 0.3).unwrap();
        let d = Vector3::new(0.2, -0.9, 0.4);
        assert!(q.implicit(&q.ray_to_surface(&d)).value.abs() < 1e-13);
        assert!(e.implicit(&e.ray_to_surface(&d)).value.abs() < 1e-13);
    }
}
