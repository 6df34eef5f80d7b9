//! Sphere–ellipsoid and ellipsoid–ellipsoid overlap by the Perram–Wertheim
//! contact function (J. Comput. Phys. 58, 409 (1985)):
//! F(λ) = λ(1−λ) rᵀ [(1−λ) M_A + λ M_B]⁻¹ r with M = R diag(a², b², c²) Rᵀ;
//! the bodies overlap iff max_{λ∈[0,1]} F(λ) ≤ 1. F is concave, so a
//! safeguarded Newton search on F′ with certificates on both sides is exact.

use nalgebra::{Matrix3, Vector3};

use super::Relative;
use crate::geometry::shape::Shape;

/// diag(a², b², c²) of a sphere or ellipsoid.
fn shape_matrix(s: &Shape) -> Matrix3<f64> {
    let h = s.obb_half_extents();
    Matrix3::from_diagonal(&h.component_mul(&h))
}

/// Overlap of two spheres/ellipsoids (frame: see the `pair` module docs).
pub fn overlap(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let ma = shape_matrix(a);
    let r = &rel.rotation;
    let mb = r * shape_matrix(b) * r.transpose();
    perram_wertheim(&ma, &mb, &rel.translation)
}

/// Whether ellipsoids with shape matrices `ma`, `mb` (M = R diag(a²) Rᵀ) whose
/// centres are `r` apart overlap: max F ≤ 1.
///
/// Stops as soon as some λ has F(λ) > 1 (separated) or concavity bounds the
/// maximum below 1 (F(λ*) ≤ F(λ) + |F′(λ)| · bracket width).
pub fn perram_wertheim(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vector3<f64>) -> bool {
    let diff = mb - ma;
    let eval = |l: f64| contact_function(ma, mb, &diff, r, l);
    let mut l = sphere_optimum(ma, mb, r);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..200 {
        let Some((f, f1, f2)) = eval(l) else {
            return true; // singular C: degenerate, treat as overlap
        };
        if f > 1.0 {
            return false;
        }
        if f1 > 0.0 {
            lo = l;
        } else {
            hi = l;
        }
        if f + f1.abs() * (hi - lo) <= 1.0 {
            return true;
        }
        if hi - lo <= 4.0 * f64::EPSILON {
            return f <= 1.0;
        }
        let newton = if f2 < 0.0 { l - f1 / f2 } else { f64::NAN };
        l = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    true
}

/// F(λ), F′(λ), F″(λ); `None` where C(λ) is singular.
#[inline]
fn contact_function(
    ma: &Matrix3<f64>,
    mb: &Matrix3<f64>,
    diff: &Matrix3<f64>,
    r: &Vector3<f64>,
    l: f64,
) -> Option<(f64, f64, f64)> {
    let c = ma * (1.0 - l) + mb * l;
    let chol = c.cholesky()?;
    let x = chol.solve(r);
    let dx = diff * x;
    let y = chol.solve(&dx);
    let g = r.dot(&x);
    let g1 = -x.dot(&dx);
    let g2 = 2.0 * dx.dot(&y);
    let w = l * (1.0 - l);
    Some((
        w * g,
        (1.0 - 2.0 * l) * g + w * g1,
        -2.0 * g + 2.0 * (1.0 - 2.0 * l) * g1 + w * g2,
    ))
}

/// The maximiser of F for two spheres of the radii along r,
/// λ = ρ_A/(ρ_A + ρ_B): the start of the search.
#[inline]
fn sphere_optimum(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vector3<f64>) -> f64 {
    let rho_a = r.dot(&(ma * r)).sqrt();
    let rho_b = r.dot(&(mb * r)).sqrt();
    if rho_a + rho_b > 0.0 {
        rho_a / (rho_a + rho_b)
    } else {
        0.5
    }
}

/// A lower bound on the distance of two spheres/ellipsoids (frame: see the
/// `pair` module docs), from the contact function: every F(λ) is at most
/// μ² = max F, the factor by which both bodies must be scaled about their
/// centres to touch; a body scaled by μ holds the body grown by (μ − 1)
/// times its smallest semi-axis (it holds that ball about its centre), so
/// the distance is at least (μ − 1)(s_A + s_B). A few Newton steps on F′
/// from the sphere optimum (exact for spheres, and for ellipsoids side by
/// side); negative when the bodies may overlap.
pub fn distance_lower_bound(a: &Shape, b: &Shape, rel: &Relative) -> f64 {
    let ma = shape_matrix(a);
    let r = &rel.rotation;
    let mb = r * shape_matrix(b) * r.transpose();
    let t = &rel.translation;
    let diff = mb - ma;
    let mut l = sphere_optimum(&ma, &mb, t);
    let mut best = 0.0f64;
    for _ in 0..2 {
        let Some((f, f1, f2)) = contact_function(&ma, &mb, &diff, t, l) else {
            break;
        };
        best = best.max(f);
        if f2 >= 0.0 {
            break;
        }
        l = (l - f1 / f2).clamp(1e-6, 1.0 - 1e-6);
    }
    (best.sqrt() - 1.0) * (a.min_half_extent() + b.min_half_extent())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spheres_reduce_to_the_radius_sum() {
        let ma = Matrix3::from_diagonal_element(1.0);
        let mb = Matrix3::from_diagonal_element(4.0);
        assert!(perram_wertheim(
            &ma,
            &mb,
            &Vector3::new(3.0 - 1e-9, 0.0, 0.0)
        ));
        assert!(!perram_wertheim(
            &ma,
            &mb,
            &Vector3::new(3.0 + 1e-9, 0.0, 0.0)
        ));
    }

    #[test]
    fn aligned_ellipsoids_tip_to_tip() {
        let m = Matrix3::from_diagonal(&Vector3::new(4.0, 1.0, 1.0));
        assert!(perram_wertheim(
            &m,
            &m,
            &Vector3::new(4.0 - 1e-10, 0.0, 0.0)
        ));
        assert!(!perram_wertheim(
            &m,
            &m,
            &Vector3::new(4.0 + 1e-10, 0.0, 0.0)
        ));
        assert!(!perram_wertheim(
            &m,
            &m,
            &Vector3::new(0.0, 2.0 + 1e-10, 0.0)
        ));
    }
}
