//! De Michele's Newton–Raphson distance between two smooth convex bodies
//! (Sec. 2.3): the 8-equation system (eqs. 9, 12, 15), the reduced
//! 5-equation system (eqs. 23–25), the damped step (eqs. 26–29), the
//! centre-line initial guess with semi-axis scaling (Sec. 3.2, eqs. 49–51)
//! and steepest-descent refinement of a poor guess (Sec. 2.3.2).
//!
//! Frame: everything is in A's body frame; B's centre is `rel.translation`
//! and its axes are the columns of `rel.rotation`.
//!
//! The sign of eq. (14) is wrong in the paper: the Newton step solves
//! J δ = −F.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use super::contact::{Contact, Failure, Method, Relative, Status, WarmStart};
use super::implicit::{Implicit, SmoothSurface};

type V3 = Vector3<f64>;

/// Which system of equations Newton–Raphson solves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum NewtonSystem {
    /// Unknowns (x_A, x_B, α, β), eqs. (9) with Jacobian (15).
    Full8,
    /// Unknowns (x_A, α, β) with x_B = x_A + β∇f, eqs. (23) with Jacobian (24).
    Reduced5,
}

/// When to refine the centre-line guess by steepest descent (Sec. 2.3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum SteepestDescent {
    /// When the guess is poor: its normals are far from the line joining
    /// the guess points.
    Auto,
    /// Always.
    Always,
    /// Never.
    Never,
}

/// Knobs of the Newton–Raphson distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Convergence when the step in the contact points is below
    /// `tolerance` × the smaller body's smallest semi-axis.
    pub tolerance: f64,
    /// Iteration cap for Newton–Raphson.
    pub max_iterations: u32,
    /// System solved.
    pub system: NewtonSystem,
    /// ε_r of eqs. (27)–(29): the largest relative change of α and of the
    /// contact points (in units of the smallest semi-axis) per step.
    pub damping: f64,
    /// Steepest-descent refinement policy.
    pub steepest_descent: SteepestDescent,
    /// Iteration cap for steepest descent.
    pub max_descent_steps: u32,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-12,
            max_iterations: 60,
            system: NewtonSystem::Reduced5,
            damping: 0.5,
            steepest_descent: SteepestDescent::Auto,
            max_descent_steps: 200,
        }
    }
}

/// f, ∇f, ∇∇f of B at `x` given in A's frame.
#[inline]
fn implicit_in_a<B: SmoothSurface>(b: &B, rel: &Relative, x: &V3) -> Implicit {
    let r = &rel.rotation;
    let local = r.tr_mul(&(x - rel.translation));
    let i = b.implicit(&local);
    Implicit {
        value: i.value,
        gradient: r * i.gradient,
        hessian: r * i.hessian * r.transpose(),
    }
}

/// The centre-line guess with the semi-axis scaling of Sec. 3.2 (eqs. 49–51):
/// the direction to the other centre, in each body's frame, is scaled
/// component-wise by that body's semi-axes before it is intersected with the
/// surface.
pub fn centre_line_guess<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
) -> (V3, V3) {
    let t = rel.translation;
    let xa = a.ray_to_surface(&a.semi_axes().component_mul(&t));
    let towards_a = rel.rotation.tr_mul(&-t);
    let xb_local = b.ray_to_surface(&b.semi_axes().component_mul(&towards_a));
    (xa, rel.rotation * xb_local + t)
}

/// How far the guess is from the optimality conditions: 1 − the smaller of
/// the cosines between each normal and the line to the other point (0 at the
/// solution).
fn misalignment(na: &V3, nb: &V3, xa: &V3, xb: &V3) -> f64 {
    let d = xb - xa;
    let len = d.norm();
    if len == 0.0 {
        return 1.0;
    }
    let u = d / len;
    1.0 - (na.dot(&u) / na.norm()).min(-nb.dot(&u) / nb.norm())
}

/// Steepest descent on ‖x_A − x_B‖² with the points held on the surfaces
/// (Sec. 2.3.2). The correction back to the surface is radial (exact and
/// cheap for these star-shaped bodies) rather than along the normal.
/// Returns the refined points and the steps taken.
fn steepest_descent<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
    mut xa: V3,
    mut xb: V3,
    length: f64,
    max_steps: u32,
) -> (V3, V3, u32) {
    let on_a = |x: &V3| a.ray_to_surface(x);
    let on_b = |x: &V3| {
        let local = rel.rotation.tr_mul(&(x - rel.translation));
        rel.rotation * b.ray_to_surface(&local) + rel.translation
    };
    let mut step = 0.1 * length;
    let mut taken = 0;
    while taken < max_steps {
        let na = a.implicit(&xa).gradient;
        let nb = implicit_in_a(b, rel, &xb).gradient;
        if misalignment(&na, &nb, &xa, &xb) < 1e-4 {
            break;
        }
        let (na, nb) = (na.normalize(), nb.normalize());
        let h = xa - xb;
        let d2 = h.norm_squared();
        // Eqs. (17)–(19): gradient of D and its parts tangent to the surfaces.
        let ha = h - na * na.dot(&h);
        let hb = -h - nb * nb.dot(&-h);
        let g = (ha.norm_squared() + hb.norm_squared()).sqrt();
        if g == 0.0 {
            break;
        }
        loop {
            let ya = on_a(&(xa - ha * (step / g)));
            let yb = on_b(&(xb - hb * (step / g)));
            if (ya - yb).norm_squared() < d2 {
                xa = ya;
                xb = yb;
                step = (step * 1.5).min(length);
                break;
            }
            step *= 0.5;
            if step < 1e-9 * length {
                return (xa, xb, taken);
            }
        }
        taken += 1;
    }
    (xa, xb, taken)
}

/// The signed distance between two smooth convex bodies by Newton–Raphson.
///
/// Starts from `warm` if given, else from the scaled centre-line guess,
/// refined by steepest descent where that guess is poor. Reports how the
/// solve ended in `status`; a solution that is not the distance (a spurious
/// extremum of eqs. 9) is reported as `Failed`, never returned as a distance.
pub fn newton_distance<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
    opts: &NewtonOptions,
    warm: Option<&WarmStart>,
) -> Contact {
    let length = a.semi_axes().min().min(b.semi_axes().min());
    let (mut xa, mut xb) = match warm {
        Some(w) => (w.point_a, rel.rotation * w.point_b + rel.translation),
        None => centre_line_guess(a, b, rel),
    };
    let mut descent_steps = 0;
    let refine = match opts.steepest_descent {
        SteepestDescent::Never => false,
        SteepestDescent::Always => warm.is_none(),
        SteepestDescent::Auto => {
            warm.is_none() && {
                let na = a.implicit(&xa).gradient;
                let nb = implicit_in_a(b, rel, &xb).gradient;
                misalignment(&na, &nb, &xa, &xb) > 0.02
            }
        }
    };
    // Descent only makes sense for bodies apart: for overlapping ones the
    // guess points lie inside the other body.
    if refine && implicit_in_a(b, rel, &xa).value > 0.0 && a.implicit(&xb).value > 0.0 {
        let (ra, rb, steps) = steepest_descent(a, b, rel, xa, xb, length, opts.max_descent_steps);
        xa = ra;
        xb = rb;
        descent_steps = steps;
    }
    let fa = a.implicit(&xa);
    let gb = implicit_in_a(b, rel, &xb);
    let mut alpha = match warm {
        Some(w) => w.alpha,
        None => (fa.gradient.norm() / gb.gradient.norm()).sqrt(),
    };
    let mut beta = (xb - xa).dot(&fa.gradient) / fa.gradient.norm_squared();
    let mut result = match opts.system {
        NewtonSystem::Reduced5 => solve_reduced(a, b, rel, opts, length, xa, &mut alpha, &mut beta),
        NewtonSystem::Full8 => solve_full(a, b, rel, opts, length, xa, xb, &mut alpha, &mut beta),
    };
    if let Status::Converged { iterations } | Status::IterationCap { iterations } =
        &mut result.status
    {
        *iterations += descent_steps;
    }
    result
}

/// Newton on the reduced system (23) with Jacobian (24).
#[allow(clippy::too_many_arguments)]
fn solve_reduced<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
    opts: &NewtonOptions,
    length: f64,
    mut x: V3,
    alpha: &mut f64,
    beta: &mut f64,
) -> Contact {
    let eye = Matrix3::identity();
    for it in 1..=opts.max_iterations {
        let fa = a.implicit(&x);
        let xb = x + fa.gradient * *beta;
        let gb = implicit_in_a(b, rel, &xb);
        let a2 = *alpha * *alpha;
        let grow = eye + fa.hessian * *beta; // ∂x_B/∂x_A
        let mut j = SMatrix::<f64, 5, 5>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(fa.hessian + gb.hessian * grow * a2));
        j.fixed_view_mut::<3, 1>(0, 3)
            .copy_from(&(gb.gradient * (2.0 * *alpha)));
        j.fixed_view_mut::<3, 1>(0, 4)
            .copy_from(&(gb.hessian * fa.gradient * a2));
        j.fixed_view_mut::<1, 3>(3, 0)
            .copy_from(&fa.gradient.transpose());
        j.fixed_view_mut::<1, 3>(4, 0)
            .copy_from(&(grow * gb.gradient).transpose());
        j[(4, 4)] = gb.gradient.dot(&fa.gradient);
        let residual = fa.gradient + gb.gradient * a2;
        let f = SVector::<f64, 5>::new(residual.x, residual.y, residual.z, fa.value, gb.value);
        let Some(step) = solve_blocked(&j, &-f) else {
            return failed(Failure::SingularJacobian, it);
        };
        let dx = step.fixed_rows::<3>(0).into_owned();
        let (dalpha, dbeta) = (step[3], step[4]);
        if !(dx.norm().is_finite() && dalpha.is_finite() && dbeta.is_finite()) {
            return failed(Failure::NonFinite, it);
        }
        // Damped step (eqs. 26–29): bound the change of α relative to α and
        // the motion of both contact points relative to the body size.
        let grad_norm = fa.gradient.norm();
        let xi = damping(
            opts.damping,
            &[
                (dx.norm(), length),
                (dbeta.abs() * grad_norm, length),
                (dalpha.abs(), alpha.abs()),
            ],
        );
        x += dx * xi;
        *alpha += dalpha * xi;
        *beta += dbeta * xi;
        let tol = opts.tolerance * length;
        let round_off = gap_round_off(&x, &xb);
        let settled = |dx: &V3| gap_settled(dx, &fa, &gb, tol, length, round_off);
        if xi == 1.0 && dbeta.abs() * grad_norm <= tol && settled(&dx) {
            return finish(
                a,
                b,
                rel,
                x,
                x + a.implicit(&x).gradient * *beta,
                *alpha,
                *beta,
                it,
                length,
            );
        }
    }
    let fa = a.implicit(&x);
    let mut c = finish(
        a,
        b,
        rel,
        x,
        x + fa.gradient * *beta,
        *alpha,
        *beta,
        opts.max_iterations,
        length,
    );
    if matches!(c.status, Status::Converged { .. }) {
        c.status = Status::IterationCap {
            iterations: opts.max_iterations,
        };
    }
    c
}

/// Newton on the full system (9) with Jacobian (15).
#[allow(clippy::too_many_arguments)]
fn solve_full<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
    opts: &NewtonOptions,
    length: f64,
    mut xa: V3,
    mut xb: V3,
    alpha: &mut f64,
    beta: &mut f64,
) -> Contact {
    let eye = Matrix3::identity();
    for it in 1..=opts.max_iterations {
        let fa = a.implicit(&xa);
        let gb = implicit_in_a(b, rel, &xb);
        let a2 = *alpha * *alpha;
        let mut j = SMatrix::<f64, 8, 8>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&fa.hessian);
        j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(gb.hessian * a2));
        j.fixed_view_mut::<3, 1>(0, 6)
            .copy_from(&(gb.gradient * (2.0 * *alpha)));
        j.fixed_view_mut::<1, 3>(3, 0)
            .copy_from(&fa.gradient.transpose());
        j.fixed_view_mut::<1, 3>(4, 3)
            .copy_from(&gb.gradient.transpose());
        j.fixed_view_mut::<3, 3>(5, 0)
            .copy_from(&(eye + fa.hessian * *beta));
        j.fixed_view_mut::<3, 3>(5, 3).copy_from(&-eye);
        j.fixed_view_mut::<3, 1>(5, 7).copy_from(&fa.gradient);
        let r1 = fa.gradient + gb.gradient * a2;
        let r4 = xa + fa.gradient * *beta - xb;
        let f = SVector::<f64, 8>::from_column_slice(&[
            r1.x, r1.y, r1.z, fa.value, gb.value, r4.x, r4.y, r4.z,
        ]);
        let Some(step) = solve_pivoted(j, -f) else {
            return failed(Failure::SingularJacobian, it);
        };
        let dxa = step.fixed_rows::<3>(0).into_owned();
        let dxb = step.fixed_rows::<3>(3).into_owned();
        let (dalpha, dbeta) = (step[6], step[7]);
        if !(dxa.norm().is_finite()
            && dxb.norm().is_finite()
            && dalpha.is_finite()
            && dbeta.is_finite())
        {
            return failed(Failure::NonFinite, it);
        }
        let grad_norm = fa.gradient.norm();
        let xi = damping(
            opts.damping,
            &[
                (dxa.norm(), length),
                (dxb.norm(), length),
                (dbeta.abs() * grad_norm, length),
                (dalpha.abs(), alpha.abs()),
            ],
        );
        xa += dxa * xi;
        xb += dxb * xi;
        *alpha += dalpha * xi;
        *beta += dbeta * xi;
        let tol = opts.tolerance * length;
        let round_off = gap_round_off(&xa, &xb);
        let settled = |dx: &V3| gap_settled(dx, &fa, &gb, tol, length, round_off);
        if xi == 1.0 && settled(&dxa) && settled(&dxb) {
            return finish(a, b, rel, xa, xb, *alpha, *beta, it, length);
        }
    }
    let mut c = finish(
        a,
        b,
        rel,
        xa,
        xb,
        *alpha,
        *beta,
        opts.max_iterations,
        length,
    );
    if matches!(c.status, Status::Converged { .. }) {
        c.status = Status::IterationCap {
            iterations: opts.max_iterations,
        };
    }
    c
}

/// x with J x = b for the reduced system's 5 × 5 Jacobian, by its 3 + 2
/// blocks: the 3 × 3 block H (the Hessians) inverted through its
/// adjugate, then the 2 × 2 Schur complement: no branches, one division
/// each. Where H or the complement is nearly singular (overlapping bodies
/// can make H indefinite), the pivoted elimination instead.
#[inline]
fn solve_blocked(j: &SMatrix<f64, 5, 5>, b: &SVector<f64, 5>) -> Option<SVector<f64, 5>> {
    let h = j.fixed_view::<3, 3>(0, 0).into_owned();
    let c = j.fixed_view::<3, 2>(0, 3).into_owned();
    let p = j.fixed_view::<2, 3>(3, 0).into_owned();
    let d = j.fixed_view::<2, 2>(3, 3).into_owned();
    let adj = Matrix3::new(
        h.m22 * h.m33 - h.m23 * h.m32,
        h.m13 * h.m32 - h.m12 * h.m33,
        h.m12 * h.m23 - h.m13 * h.m22,
        h.m23 * h.m31 - h.m21 * h.m33,
        h.m11 * h.m33 - h.m13 * h.m31,
        h.m13 * h.m21 - h.m11 * h.m23,
        h.m21 * h.m32 - h.m22 * h.m31,
        h.m12 * h.m31 - h.m11 * h.m32,
        h.m11 * h.m22 - h.m12 * h.m21,
    );
    let det = h.m11 * adj.m11 + h.m12 * adj.m21 + h.m13 * adj.m31;
    let scale = h.abs().max();
    // (NaN entries fail the test too.)
    if det.is_nan() || det.abs() <= 1e-10 * scale * scale * scale {
        return solve_pivoted(*j, *b);
    }
    let inv = adj / det;
    let r1 = b.fixed_rows::<3>(0).into_owned();
    let r2 = b.fixed_rows::<2>(3).into_owned();
    let inv_c = inv * c;
    let inv_r1 = inv * r1;
    let schur = d - p * inv_c;
    let rhs = r2 - p * inv_r1;
    let det_s = schur.m11 * schur.m22 - schur.m12 * schur.m21;
    let scale_s = schur
        .abs()
        .max()
        .max(d.abs().max())
        .max((p * inv_c).abs().max());
    if det_s.is_nan() || det_s.abs() <= 1e-10 * scale_s * scale_s {
        return solve_pivoted(*j, *b);
    }
    let y = nalgebra::Vector2::new(
        (schur.m22 * rhs.x - schur.m12 * rhs.y) / det_s,
        (schur.m11 * rhs.y - schur.m21 * rhs.x) / det_s,
    );
    let x = inv_r1 - inv_c * y;
    Some(SVector::<f64, 5>::new(x.x, x.y, x.z, y.x, y.y))
}

/// x with J x = b by Gaussian elimination with partial pivoting, on the
/// stack and unrolled for the small Newton systems (a general LU costs a
/// sizeable share of a body collision); `None` when a pivot is
/// exactly zero, as for the general LU.
#[inline]
fn solve_pivoted<const N: usize>(
    j: SMatrix<f64, N, N>,
    b: SVector<f64, N>,
) -> Option<SVector<f64, N>> {
    // Rows as arrays, so that an exchange moves one array.
    let mut m = [[0.0; N]; N];
    let mut x = [0.0; N];
    for r in 0..N {
        for c in 0..N {
            m[r][c] = j[(r, c)];
        }
        x[r] = b[r];
    }
    let mut inverse_pivots = [0.0; N];
    for k in 0..N {
        let mut pivot = k;
        for r in k + 1..N {
            if m[r][k].abs() > m[pivot][k].abs() {
                pivot = r;
            }
        }
        if m[pivot][k] == 0.0 {
            return None;
        }
        m.swap(k, pivot);
        x.swap(k, pivot);
        let row = m[k];
        let inv = 1.0 / row[k];
        inverse_pivots[k] = inv;
        for r in k + 1..N {
            let factor = m[r][k] * inv;
            for c in k + 1..N {
                m[r][c] -= factor * row[c];
            }
            x[r] -= factor * x[k];
        }
    }
    for k in (0..N).rev() {
        let mut sum = x[k];
        for c in k + 1..N {
            sum -= m[k][c] * x[c];
        }
        x[k] = sum * inverse_pivots[k];
    }
    Some(SVector::from(x))
}

/// Whether a full Newton step `dx` of a contact point leaves the distance
/// as settled as a step within `tol` would. Such a step leaves the points
/// within about tol²/length of the solution (Newton converges
/// quadratically). A longer step does as well if its part along the
/// normal is within `tol` and its part along the surfaces (t) changes the
/// gap through their curvatures, ½ (κ_A + κ_B) t² with
/// κ = tᵀ∇∇f t / |∇f| t² (the gap is stationary along the surfaces at the
/// solution), by at most tol²/length or by less than the gap's own
/// round-off, `round_off`. On nearly flat faces (superellipsoids of high
/// exponent) the place of the contact along the faces is fixed only to
/// where their curvature changes the gap by round-off, far coarser than
/// `tol`, while the distance is fixed to the bit. The part along the
/// surfaces stays below √tol so that the curvatures where the step starts
/// hold over it.
#[inline]
fn gap_settled(
    dx: &V3,
    fa: &Implicit,
    gb: &Implicit,
    tol: f64,
    length: f64,
    round_off: f64,
) -> bool {
    let step = dx.norm();
    if step <= tol {
        return true;
    }
    let along = dx.dot(&fa.gradient) / fa.gradient.norm_squared();
    let normal_part = along.abs() * fa.gradient.norm();
    let t = dx - fa.gradient * along;
    let bending = |i: &Implicit| t.dot(&(i.hessian * t)).abs() / i.gradient.norm();
    normal_part <= tol
        && t.norm() <= (tol * length).sqrt()
        && 0.5 * (bending(fa) + bending(gb)) <= (tol * tol / length).max(round_off)
}

/// The round-off of a gap between contact points at `xa` and `xb` (in A's
/// frame): one ulp of their distance from A's centre.
#[inline]
fn gap_round_off(xa: &V3, xb: &V3) -> f64 {
    f64::EPSILON * (xa.norm() + xb.norm())
}

/// The damping factor ξ ∈ (0, 1]: the largest step such that no
/// (change, scale) pair moves by more than ε_r × scale.
fn damping(eps_r: f64, bounds: &[(f64, f64)]) -> f64 {
    let mut xi: f64 = 1.0;
    for &(change, scale) in bounds {
        if change > eps_r * scale {
            xi = xi.min(eps_r * scale / change);
        }
    }
    xi
}

fn failed(why: Failure, iterations: u32) -> Contact {
    Contact {
        distance: f64::NAN,
        point_a: V3::repeat(f64::NAN),
        point_b: V3::repeat(f64::NAN),
        normal: V3::repeat(f64::NAN),
        status: Status::Failed { why, iterations },
        method: Method::Newton,
        warm_start: None,
    }
}

/// Checks a converged point against the conditions that make it the distance
/// and builds the contact. Eqs. (9) also hold at spurious extrema: with
/// β < 0 (a "negative distance") each contact point must lie inside the other
/// body; otherwise the solution is a far-side extremum, not an overlap.
#[allow(clippy::too_many_arguments)]
fn finish<A: SmoothSurface, B: SmoothSurface>(
    a: &A,
    b: &B,
    rel: &Relative,
    xa: V3,
    xb: V3,
    alpha: f64,
    beta: f64,
    iterations: u32,
    length: f64,
) -> Contact {
    let fa = a.implicit(&xa);
    let gb = implicit_in_a(b, rel, &xb);
    let na = fa.gradient.normalize();
    let nb = gb.gradient.normalize();
    let d = xb - xa;
    let distance = d.norm().copysign(beta);
    let surface_tol = 1e-8;
    let on_surfaces = fa.value.abs() < surface_tol && gb.value.abs() < surface_tol;
    // Normals antiparallel and the displacement along them (eqs. 9a, 9d).
    let aligned =
        na.dot(&nb) < -1.0 + 1e-8 && d.norm() <= 1e-8 * length + d.dot(&na).abs() * (1.0 + 1e-8);
    if !(on_surfaces && aligned && distance.is_finite()) {
        return failed(Failure::NotASolution, iterations);
    }
    if beta < 0.0 {
        let a_in_b = implicit_in_a(b, rel, &xa).value <= 1e-12;
        let b_in_a = a.implicit(&xb).value <= 1e-12;
        if !(a_in_b && b_in_a) {
            return failed(Failure::SpuriousSolution, iterations);
        }
    }
    Contact {
        distance,
        point_a: xa,
        point_b: xb,
        normal: na,
        status: Status::Converged { iterations },
        method: Method::Newton,
        warm_start: Some(WarmStart {
            point_a: xa,
            point_b: rel.rotation.tr_mul(&(xb - rel.translation)),
            alpha,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pivoted elimination and the blocked solve find what nalgebra's
    /// LU finds (random systems, ones that need row exchanges, ones whose
    /// Hessian block is singular), and refuse a singular matrix.
    #[test]
    fn pivoted_elimination_solves_the_newton_systems() {
        let mut u = crate::test_support::uniform(41);
        for case in 0..500 {
            let mut j = SMatrix::<f64, 5, 5>::from_fn(|_, _| u() - 0.5);
            if case % 5 == 0 {
                j[(0, 0)] = 0.0; // the first pivot must come from below
            }
            if case % 7 == 0 {
                // A singular 3 × 3 block: the blocked solve falls back.
                j.fixed_view_mut::<1, 3>(2, 0).fill(0.0);
            }
            let x = SVector::<f64, 5>::from_fn(|_, _| u() - 0.5);
            let b = j * x;
            let ours = solve_pivoted(j, b).expect("regular");
            let theirs = j.lu().solve(&b).expect("regular");
            let cond = j.norm() * j.try_inverse().unwrap().norm();
            assert!((ours - x).norm() <= 1e-13 * cond * x.norm(), "case {case}");
            assert!(
                (ours - theirs).norm() <= 1e-13 * cond * x.norm(),
                "case {case}"
            );
            let blocked = solve_blocked(&j, &b).expect("regular");
            assert!(
                (blocked - x).norm() <= 1e-12 * cond * x.norm(),
                "case {case}: blocked"
            );
            let j8 = SMatrix::<f64, 8, 8>::from_fn(|_, _| u() - 0.5);
            let x8 = SVector::<f64, 8>::from_fn(|_, _| u() - 0.5);
            let cond8 = j8.norm() * j8.try_inverse().unwrap().norm();
            let ours8 = solve_pivoted(j8, j8 * x8).expect("regular");
            assert!(
                (ours8 - x8).norm() <= 1e-13 * cond8 * x8.norm(),
                "case {case}"
            );
        }
        let mut singular = SMatrix::<f64, 5, 5>::identity();
        singular.set_row(3, &singular.row(1).clone_owned());
        assert_eq!(
            solve_pivoted(singular, SVector::<f64, 5>::repeat(1.0)),
            None
        );
        assert_eq!(
            solve_blocked(&singular, &SVector::<f64, 5>::repeat(1.0)),
            None
        );
    }
}
