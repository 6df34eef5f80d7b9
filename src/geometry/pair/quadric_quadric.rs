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
    // Most pairs that get this far are apart, and F at the sphere optimum
    // λ = p/(p + q), p = √(rᵀM_A r), q = √(rᵀM_B r), already says so (it
    // is exact for aligned equal bodies): one solve before the
    // coefficients of the whole function. There C(λ) = C′/(p + q) with
    // C′ = q M_A + p M_B, so F = pq/(p + q) · rᵀ adj C′ r / det C′: tested
    // without a division, on the six entries of the symmetric C′.
    let (p, q) = scaled_reaches(ma, mb, r);
    if separated_at(&(ma * q + mb * p), r, p * q, p + q) {
        return false;
    }
    maximum_within_contact(ma, mb, r, sphere_optimum_of(p, q))
}

/// λ = p/(p + q), ½ for coincident centres.
#[inline]
fn sphere_optimum_of(p: f64, q: f64) -> f64 {
    if p + q > 0.0 { p / (p + q) } else { 0.5 }
}

/// Whether max F ≤ 1, by the safeguarded Newton search from `l`.
fn maximum_within_contact(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vector3<f64>, l: f64) -> bool {
    let contact = ContactFunction::new(ma, mb, r);
    let decided = contact.maximise(l, 200, |step| {
        if step.f > 1.0 {
            Some(false)
        } else if step.f + step.f1.abs() * step.width <= 1.0 {
            Some(true)
        } else if step.width <= 4.0 * f64::EPSILON || step.next == step.lambda {
            // λ pinned down (by the bracket, or Newton's step rounds to
            // nothing): F there is the maximum.
            Some(step.f <= 1.0)
        } else {
            None
        }
    });
    // Singular C (degenerate) or undecided: treat as overlap.
    !matches!(decided, Some((false, _)))
}

/// A spheroid as placed: M = e I + k u uᵀ, with `axis` u its axis of
/// symmetry (unit, lab frame), `equatorial_sq` e the square of its
/// equatorial semi-axis and `excess` k the square of the polar one less e
/// (negative for an oblate body). Nine numbers of M in five, and the
/// contact function's first test in a third of the arithmetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spheroid {
    /// Axis of symmetry (unit).
    pub axis: Vector3<f64>,
    /// Equatorial semi-axis squared.
    pub equatorial_sq: f64,
    /// Polar semi-axis squared less the equatorial one squared.
    pub excess: f64,
}

impl Spheroid {
    /// Its shape matrix e I + k u uᵀ.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::from_diagonal_element(self.equatorial_sq)
            + self.axis * self.axis.transpose() * self.excess
    }
}

/// [`perram_wertheim`] for two spheroids. The first test at the sphere
/// optimum needs C′ = q M_A + p M_B = αI + β u uᵀ + γ v vᵀ (α = q e_A +
/// p e_B, β = q k_A, γ = p k_B) only through x = u·r, y = v·r, c = u·v and
/// |r|² = ρ: with s = 1 − c² and D = α² + α(β + γ) + βγs, det C′ = αD and
/// rᵀ adj C′ r = Dρ − β(α + γ)x² − γ(α + β)y² + 2βγcxy (from
/// adj C = C² − tr C · C + σ₂ I, σ₂ the sum of C's principal 2×2 minors).
pub fn spheroid_overlap(a: &Spheroid, b: &Spheroid, r: &Vector3<f64>) -> bool {
    let (x, y, c, rho) = (
        a.axis.dot(r),
        b.axis.dot(r),
        a.axis.dot(&b.axis),
        r.norm_squared(),
    );
    let p = (a.equatorial_sq * rho + a.excess * x * x).sqrt();
    let q = (b.equatorial_sq * rho + b.excess * y * y).sqrt();
    let alpha = q * a.equatorial_sq + p * b.equatorial_sq;
    let (beta, gamma) = (q * a.excess, p * b.excess);
    let d = alpha * alpha + alpha * (beta + gamma) + beta * gamma * (1.0 - c * c);
    let det = alpha * d;
    let form = d * rho - beta * (alpha + gamma) * x * x - gamma * (alpha + beta) * y * y
        + 2.0 * beta * gamma * c * x * y;
    if det > 0.0 && p * q * form > (p + q) * det {
        return false;
    }
    maximum_within_contact(&a.matrix(), &b.matrix(), r, sphere_optimum_of(p, q))
}

/// Whether the symmetric matrix `c` (positive definite: det > 0) has
/// `scale` · rᵀ adj(c) r > `det_scale` · det c: for c ∝ C(λ) as in
/// [`perram_wertheim`], F(λ) > 1.
#[inline]
fn separated_at(c: &Matrix3<f64>, r: &Vector3<f64>, scale: f64, det_scale: f64) -> bool {
    let (c00, c01, c02) = (c[(0, 0)], c[(0, 1)], c[(0, 2)]);
    let (c11, c12, c22) = (c[(1, 1)], c[(1, 2)], c[(2, 2)]);
    // The cofactors of a symmetric matrix: adj is symmetric too.
    let a00 = c11 * c22 - c12 * c12;
    let a01 = c02 * c12 - c01 * c22;
    let a02 = c01 * c12 - c02 * c11;
    let a11 = c00 * c22 - c02 * c02;
    let a12 = c01 * c02 - c00 * c12;
    let a22 = c00 * c11 - c01 * c01;
    let det = c00 * a00 + c01 * a01 + c02 * a02;
    let (x, y, z) = (r.x, r.y, r.z);
    let form =
        a00 * x * x + a11 * y * y + a22 * z * z + 2.0 * (a01 * x * y + a02 * x * z + a12 * y * z);
    det > 0.0 && scale * form > det_scale * det
}

/// The Perram–Wertheim contact point as a start for the distance solver:
/// at the maximiser λ* of F the point
/// x = (1−λ*) M_A C(λ*)⁻¹ r (A at the origin) is where A and B, each
/// scaled by μ = √F(λ*) about its centre, touch; scaled back, x/μ on A and
/// r + (x − r)/μ on B are surface points whose normals are both along
/// C⁻¹r (scaling about the centre keeps normals), so the pair is close to
/// the solution of the distance equations when the bodies are close.
/// Returns (point on A, point on B), both in A's frame; `None` for
/// coincident centres or a singular C.
pub fn contact_points_guess(
    a: &Shape,
    b: &Shape,
    rel: &Relative,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let ma = shape_matrix(a);
    let r = &rel.rotation;
    let mb = r * shape_matrix(b) * r.transpose();
    let t = &rel.translation;
    let contact = ContactFunction::new(&ma, &mb, t);
    // To convergence of λ.
    let (_, l) = contact.maximise(sphere_optimum(&ma, &mb, t), 50, |step| {
        ((step.next - step.lambda).abs() <= 1e-12 || step.width <= 1e-12).then_some(())
    })?;
    let (f, _, _) = contact.eval(l)?;
    let mu = f.sqrt();
    let c = ma * (1.0 - l) + mb * l;
    let x = ma * c.lu().solve(t)? * (1.0 - l);
    if !(mu > 0.0 && x.iter().all(|v| v.is_finite())) {
        return None;
    }
    Some((x / mu, t + (x - t) / mu))
}

/// The contact function F(λ) = λ(1−λ) rᵀ C(λ)⁻¹ r with C(λ) = (1−λ)M_A +
/// λM_B, as the rational function it is: C⁻¹ = adj C / det C, with C
/// linear in λ, so det C a cubic and rᵀ adj C r a quadratic. They are
/// expanded about the middle, C = M + sD with M = (M_A + M_B)/2, D = M_B −
/// M_A, s = λ − ½ (|s| ≤ ½: no cancellation between large coefficients at
/// either end). The coefficients cost two adjugates and their mixed term
/// once per pair; every evaluation after that is a few multiplications
/// instead of a Cholesky factorisation and two solves.
#[derive(Debug, Clone, Copy)]
struct ContactFunction {
    /// rᵀ adj C r = q₀ + q₁s + q₂s².
    q: [f64; 3],
    /// det C = p₀ + p₁s + p₂s² + p₃s³.
    p: [f64; 4],
}

impl ContactFunction {
    fn new(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vector3<f64>) -> Self {
        let m = (ma + mb) * 0.5;
        let d = mb - ma;
        let (adj_m, adj_d) = (adjugate(&m), adjugate(&d));
        let form = |x: &Matrix3<f64>| r.dot(&(x * r));
        // adj(M + sD) = adj M + s·(its derivative, bilinear in M and D) + s² adj D.
        let q = [form(&adj_m), form(&mixed_adjugate(&m, &d)), form(&adj_d)];
        let det = |x: &Matrix3<f64>, adj: &Matrix3<f64>| {
            x[(0, 0)] * adj[(0, 0)] + x[(0, 1)] * adj[(1, 0)] + x[(0, 2)] * adj[(2, 0)]
        };
        // det(M + sD) = det M + s tr(adj M · D) + s² tr(M · adj D) + s³ det D.
        let trace = |x: &Matrix3<f64>, y: &Matrix3<f64>| x.component_mul(&y.transpose()).sum();
        let p = [
            det(&m, &adj_m),
            trace(&adj_m, &d),
            trace(&m, &adj_d),
            det(&d, &adj_d),
        ];
        Self { q, p }
    }

    /// F(λ), F′(λ), F″(λ); `None` where C(λ) is singular.
    #[inline]
    /// Newton's method on F′ from λ = `start`, kept inside the bracket of
    /// the maximiser (F is concave on [0, 1]; bisection where Newton leaves
    /// it), for at most `steps` evaluations: after each, `stop` may end the
    /// search with its answer. Returns that answer and the λ it came at;
    /// `None` if C is singular or `stop` never answered.
    fn maximise<T>(
        &self,
        start: f64,
        steps: usize,
        mut stop: impl FnMut(MaximiserStep) -> Option<T>,
    ) -> Option<(T, f64)> {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut l = start;
        for _ in 0..steps {
            let (f, f1, f2) = self.eval(l)?;
            if f1 > 0.0 {
                lo = l;
            } else {
                hi = l;
            }
            let newton = if f2 < 0.0 { l - f1 / f2 } else { f64::NAN };
            // A Newton step that rounds to λ itself: λ is the maximiser to
            // the resolution of λ. It stays (bisecting from there would
            // jump half the bracket away and take some forty halvings to
            // come back).
            let next = if newton == l || (newton > lo && newton < hi) {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let step = MaximiserStep {
                lambda: l,
                f,
                f1,
                width: hi - lo,
                next,
            };
            if let Some(answer) = stop(step) {
                return Some((answer, l));
            }
            l = next;
        }
        None
    }

    fn eval(&self, l: f64) -> Option<(f64, f64, f64)> {
        let [q0, q1, q2] = self.q;
        let [p0, p1, p2, p3] = self.p;
        let s = l - 0.5;
        let p = p0 + s * (p1 + s * (p2 + s * p3));
        if p.is_nan() || p <= 0.0 {
            return None;
        }
        let dp = p1 + s * (2.0 * p2 + 3.0 * s * p3);
        let ddp = 2.0 * p2 + 6.0 * s * p3;
        let q = q0 + s * (q1 + s * q2);
        let dq = q1 + 2.0 * s * q2;
        let ddq = 2.0 * q2;
        // g = q/p and its derivatives, from q = g p.
        let g = q / p;
        let g1 = (dq - g * dp) / p;
        let g2 = (ddq - 2.0 * g1 * dp - g * ddp) / p;
        let w = l * (1.0 - l);
        Some((
            w * g,
            (1.0 - 2.0 * l) * g + w * g1,
            -2.0 * g + 2.0 * (1.0 - 2.0 * l) * g1 + w * g2,
        ))
    }
}

/// d/ds adj(M + sD) at s = 0: each 2 × 2 cofactor's derivative.
#[inline]
fn mixed_adjugate(m: &Matrix3<f64>, d: &Matrix3<f64>) -> Matrix3<f64> {
    // cof(i, j, k, l) = x_ij x_kl − x_il x_kj, differentiated.
    let c = |i: usize, j: usize, k: usize, l: usize| {
        d[(i, j)] * m[(k, l)] + m[(i, j)] * d[(k, l)]
            - d[(i, l)] * m[(k, j)]
            - m[(i, l)] * d[(k, j)]
    };
    Matrix3::new(
        c(1, 1, 2, 2),
        c(0, 2, 2, 1),
        c(0, 1, 1, 2),
        c(1, 2, 2, 0),
        c(0, 0, 2, 2),
        c(0, 2, 1, 0),
        c(1, 0, 2, 1),
        c(0, 1, 2, 0),
        c(0, 0, 1, 1),
    )
}

/// The adjugate (transposed cofactor matrix) of a 3 × 3 matrix.
#[inline]
fn adjugate(m: &Matrix3<f64>) -> Matrix3<f64> {
    let e = |i: usize, j: usize| m[(i, j)];
    Matrix3::new(
        e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1),
        e(0, 2) * e(2, 1) - e(0, 1) * e(2, 2),
        e(0, 1) * e(1, 2) - e(0, 2) * e(1, 1),
        e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2),
        e(0, 0) * e(2, 2) - e(0, 2) * e(2, 0),
        e(0, 2) * e(1, 0) - e(0, 0) * e(1, 2),
        e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0),
        e(0, 1) * e(2, 0) - e(0, 0) * e(2, 1),
        e(0, 0) * e(1, 1) - e(0, 1) * e(1, 0),
    )
}

/// One evaluation of [`ContactFunction::maximise`]: λ, F(λ), F′(λ), the
/// width of the bracket on the maximiser, and the λ it goes to next.
#[derive(Debug, Clone, Copy)]
struct MaximiserStep {
    lambda: f64,
    f: f64,
    f1: f64,
    width: f64,
    next: f64,
}

/// The maximiser of F for two spheres of the radii along r,
/// λ = ρ_A/(ρ_A + ρ_B): the start of the search.
#[inline]
fn sphere_optimum(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vector3<f64>) -> f64 {
    let (p, q) = scaled_reaches(ma, mb, r);
    sphere_optimum_of(p, q)
}

/// √(rᵀM_A r) and √(rᵀM_B r): the λ of [`sphere_optimum`] is p/(p + q).
#[inline]
fn scaled_reaches(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vector3<f64>) -> (f64, f64) {
    (r.dot(&(ma * r)).sqrt(), r.dot(&(mb * r)).sqrt())
}

/// A lower bound on the distance of two spheres/ellipsoids (frame: see the
/// `pair` module docs), from the contact function: every F(λ) is at most
/// μ² = max F, the factor by which both bodies must be scaled about their
/// centres to touch; a body scaled by μ holds the body grown by (μ − 1)
/// times its smallest semi-axis (it holds that ball about its centre), so
/// the distance is at least (μ − 1)(s_A + s_B). A few Newton steps on F′
/// from the sphere optimum (exact for spheres, and for ellipsoids side by
/// side); negative when the bodies may overlap. With it, the direction
/// C(λ)⁻¹r (unit, A to B) of the common normal of the two scaled bodies at
/// their Perram–Wertheim contact: near contact, the normal of the bodies.
pub fn distance_lower_bound(a: &Shape, b: &Shape, rel: &Relative) -> (f64, Vector3<f64>) {
    let ma = shape_matrix(a);
    let r = &rel.rotation;
    let mb = r * shape_matrix(b) * r.transpose();
    let t = &rel.translation;
    let contact = ContactFunction::new(&ma, &mb, t);
    let start = sphere_optimum(&ma, &mb, t);
    // Two evaluations (every F(λ) bounds max F from below), the best kept.
    let (mut best, mut best_l) = (0.0f64, start);
    let mut evaluations = 0;
    contact.maximise(start, 2, |step| {
        if step.f > best {
            (best, best_l) = (step.f, step.lambda);
        }
        evaluations += 1;
        (evaluations == 2).then_some(())
    });
    // adj C r ∝ C⁻¹ r (det C > 0): no division needed for a direction.
    let normal = (adjugate(&(ma * (1.0 - best_l) + mb * best_l)) * t)
        .try_normalize(0.0)
        .unwrap_or_else(|| t.try_normalize(0.0).unwrap_or_else(Vector3::x));
    (
        (best.sqrt() - 1.0) * (a.min_half_extent() + b.min_half_extent()),
        normal,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The centre distance along `dir` (unit) at which the ellipsoids touch,
    /// by bisection on the overlap test below `upper` (the smallest
    /// distance found apart).
    fn contact_distance_along(
        ma: &Matrix3<f64>,
        mb: &Matrix3<f64>,
        dir: &Vector3<f64>,
        upper: f64,
    ) -> f64 {
        let (mut lo, mut hi) = (0.0, upper);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if perram_wertheim(ma, mb, &(dir * mid)) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }

    /// The spheroid form of the test answers as the matrix form on prolate,
    /// oblate and round bodies turned at random, at 1 ± 1e-9 of the contact
    /// distance along a random direction (found by bisection on the matrix
    /// form) and at random distances; the spheroid's matrix is R diag(a²)
    /// Rᵀ of the same body.
    #[test]
    fn spheroids_answer_as_their_matrices() {
        let mut u = crate::test_support::uniform(21);
        let unit = crate::test_support::unit_vector;
        let semi = [(2.5, 0.5), (0.5, 1.0), (0.3, 0.3), (1.0, 0.2)];
        let mut apart = 0;
        for case in 0..2000 {
            let spheroid = |k: usize, axis: Vector3<f64>| {
                let (polar, equatorial) = semi[k];
                Spheroid {
                    axis,
                    equatorial_sq: equatorial * equatorial,
                    excess: polar * polar - equatorial * equatorial,
                }
            };
            let a = spheroid(case % 4, unit(&mut u));
            let b = spheroid((case / 4) % 4, unit(&mut u));
            // The matrix from the rotation taking x to the axis.
            let rotated = |s: &Spheroid| {
                let r = nalgebra::Rotation3::rotation_between(&Vector3::x(), &s.axis)
                    .unwrap_or_else(nalgebra::Rotation3::identity);
                let polar = (s.equatorial_sq + s.excess).sqrt();
                let e = s.equatorial_sq.sqrt();
                let d = Vector3::new(polar * polar, e * e, e * e);
                r.matrix() * Matrix3::from_diagonal(&d) * r.matrix().transpose()
            };
            assert!((rotated(&a) - a.matrix()).norm() < 1e-12);
            let (ma, mb) = (a.matrix(), b.matrix());
            let dir = unit(&mut u);
            let hi = contact_distance_along(&ma, &mb, &dir, 6.0);
            for f in [1.0 - 1e-9, 1.0 + 1e-9, 0.5 + 2.0 * u(), 0.2 * u()] {
                let r = dir * hi * f;
                let want = perram_wertheim(&ma, &mb, &r);
                assert_eq!(spheroid_overlap(&a, &b, &r), want, "case {case} at {f}");
                apart += usize::from(!want);
            }
        }
        assert!(apart > 2500, "{apart} of 8000 apart");
    }

    /// The cold start's maximiser of F (to |Δλ| ≤ 10⁻¹² from the sphere
    /// optimum) converges as Newton does: ellipsoid pairs up to aspect 4
    /// turned at random, at 1 ± 10⁻⁶ of their contact distance (where the
    /// dynamics asks near a jam), never take more than eight evaluations.
    /// Where Newton's step rounded to nothing it used to bisect away from
    /// the maximiser and back, some forty evaluations.
    #[test]
    fn the_maximiser_converges_near_contact_in_a_few_steps() {
        let mut u = crate::test_support::uniform(5);
        let unit = crate::test_support::unit_vector;
        let mut most = 0;
        for case in 0..4000 {
            let axes = |u: &mut dyn FnMut() -> f64| {
                Vector3::new(0.25 + 0.75 * u(), 0.25 + 0.75 * u(), 0.25 + 0.75 * u())
            };
            let (ha, hb) = (axes(&mut u), axes(&mut u));
            let turn = |u: &mut dyn FnMut() -> f64| {
                nalgebra::UnitQuaternion::from_euler_angles(7.0 * u(), 7.0 * u(), 7.0 * u())
            };
            let matrix = |h: Vector3<f64>, q: nalgebra::UnitQuaternion<f64>| {
                let r = q.to_rotation_matrix();
                r.matrix() * Matrix3::from_diagonal(&h.component_mul(&h)) * r.matrix().transpose()
            };
            let (ma, mb) = (matrix(ha, turn(&mut u)), matrix(hb, turn(&mut u)));
            let dir = unit(&mut u);
            let hi = contact_distance_along(&ma, &mb, &dir, 4.0);
            let r = dir
                * hi
                * if case % 2 == 0 {
                    1.0 + 1e-6
                } else {
                    1.0 - 1e-6
                };
            let contact = ContactFunction::new(&ma, &mb, &r);
            let mut evaluations = 0;
            let (f1, l) = contact
                .maximise(sphere_optimum(&ma, &mb, &r), 50, |step| {
                    evaluations += 1;
                    ((step.next - step.lambda).abs() <= 1e-12 || step.width <= 1e-12)
                        .then_some(step.f1)
                })
                .expect("converged");
            assert!(f1.abs() < 1e-9, "case {case}: F'({l}) = {f1}");
            most = most.max(evaluations);
        }
        assert!(most <= 8, "up to {most} evaluations");
    }

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

    /// The rational form agrees with F(λ) = λ(1−λ) rᵀ C⁻¹ r evaluated by a
    /// Cholesky solve, derivatives by central differences, over random
    /// ellipsoid pairs up to aspect 40 (measured worst: 2e-12 of F(½)).
    #[test]
    fn rational_contact_function_matches_the_direct_evaluation() {
        let mut u = crate::test_support::uniform(21);
        for _ in 0..500 {
            let axes =
                |u: &mut dyn FnMut() -> f64| Vector3::new(0.05 + u(), 0.05 + u(), 0.05 + 2.0 * u());
            let (ha, hb) = (axes(&mut u), axes(&mut u));
            let q = nalgebra::UnitQuaternion::from_euler_angles(7.0 * u(), 7.0 * u(), 7.0 * u());
            let rot = q.to_rotation_matrix().into_inner();
            let ma = Matrix3::from_diagonal(&ha.component_mul(&ha));
            let mb = rot * Matrix3::from_diagonal(&hb.component_mul(&hb)) * rot.transpose();
            let r = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 6.0;
            let contact = ContactFunction::new(&ma, &mb, &r);
            let direct = |l: f64| {
                let c = ma * (1.0 - l) + mb * l;
                l * (1.0 - l) * r.dot(&c.cholesky().unwrap().solve(&r))
            };
            for l in [0.01, 0.2, 0.5, 0.77, 0.99] {
                let (f, f1, f2) = contact.eval(l).unwrap();
                let scale = direct(0.5).abs().max(1e-3);
                assert!(
                    (f - direct(l)).abs() <= 1e-11 * scale,
                    "F({l}): {f} vs {}",
                    direct(l)
                );
                let h = 1e-5;
                let d1 = (direct(l + h) - direct(l - h)) / (2.0 * h);
                let d2 = (direct(l + h) - 2.0 * direct(l) + direct(l - h)) / (h * h);
                assert!(
                    (f1 - d1).abs() <= 1e-6 * scale.max(f1.abs()),
                    "F'({l}): {f1} vs {d1}"
                );
                assert!(
                    (f2 - d2).abs() <= 1e-3 * scale.max(f2.abs()),
                    "F''({l}): {f2} vs {d2}"
                );
            }
        }
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
