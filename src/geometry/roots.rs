//! Small scalar root finders shared by the shape kernels.

use nalgebra::Vector3;

/// The t > 0 with Σᵢ cᵢ t^{qᵢ} = 1, for cᵢ ≥ 0 (not all zero) and qᵢ > 0.
///
/// Newton's method in s = ln t on ψ(s) = Σ cᵢ e^{qᵢ s} − 1, which is convex
/// and increasing; started where ψ ≥ 0 it converges monotonically.
pub fn solve_power_sum(c: &Vector3<f64>, q: &Vector3<f64>) -> f64 {
    let mut s = f64::NEG_INFINITY;
    for i in 0..3 {
        if c[i] > 0.0 {
            s = s.max(-c[i].ln() / q[i]);
        }
    }
    debug_assert!(s.is_finite(), "solve_power_sum needs some c > 0");
    for _ in 0..100 {
        let mut psi = -1.0;
        let mut dpsi = 0.0;
        for i in 0..3 {
            if c[i] > 0.0 {
                let term = c[i] * (q[i] * s).exp();
                psi += term;
                dpsi += q[i] * term;
            }
        }
        let step = psi / dpsi;
        s -= step;
        if step.abs() <= 1e-15 * (1.0 + s.abs()) || psi <= 0.0 {
            break;
        }
    }
    s.exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_sum_matches_closed_forms() {
        // Equal exponents: t = (Σc)^{-1/q}.
        let t = solve_power_sum(&Vector3::new(0.2, 0.5, 0.0), &Vector3::repeat(3.0));
        assert!((t - 0.7f64.powf(-1.0 / 3.0)).abs() < 1e-14);
        let c = Vector3::new(1e-8, 3.0, 0.25);
        let q = Vector3::new(2.0, 8.0, 1.2);
        let t = solve_power_sum(&c, &q);
        let sum: f64 = (0..3).map(|i| c[i] * t.powf(q[i])).sum();
        assert!((sum - 1.0).abs() < 1e-14);
    }
}

/// Brent's minimisation of a unimodal `f` on [lo, hi] (golden section with
/// parabolic steps; Brent 1973, ch. 5): returns (x, f(x)) with x located to
/// about `tol` (absolute) and the number of evaluations.
pub fn brent_minimize(
    f: impl Fn(f64) -> f64,
    lo: f64,
    hi: f64,
    tol: f64,
    max_evals: u32,
) -> (f64, f64, u32) {
    const GOLD: f64 = 0.381_966_011_250_105_1; // (3 − √5)/2
    let (mut a, mut b) = (lo.min(hi), lo.max(hi));
    let mut x = a + GOLD * (b - a);
    let (mut w, mut v) = (x, x);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let mut evals = 1;
    let (mut d, mut e) = (0.0f64, 0.0f64);
    while evals < max_evals {
        let m = 0.5 * (a + b);
        let tol1 = tol + 1e-15 * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - m).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            // Parabola through (v, fv), (w, fw), (x, fx).
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            if p.abs() < (0.5 * q * e).abs() && p > q * (a - x) && p < q * (b - x) {
                e = d;
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(m - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x < m { b - x } else { a - x };
            d = GOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        evals += 1;
        if fu <= fx {
            if u < x {
                b = x;
            } else {
                a = x;
            }
            (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, fv, w, fw) = (w, fw, u, fu);
            } else if fu <= fv || v == x || v == w {
                (v, fv) = (u, fu);
            }
        }
    }
    (x, fx, evals)
}

#[cfg(test)]
mod brent_tests {
    use super::*;

    #[test]
    fn brent_finds_minima_of_smooth_and_kinked_functions() {
        let (x, fx, n) = brent_minimize(|x| (x - 0.3).powi(2) + 1.0, -2.0, 5.0, 1e-10, 100);
        // x is found to ~√ε: beyond that a quadratic is flat in floating point.
        assert!(
            (x - 0.3).abs() < 1e-7 && (fx - 1.0).abs() < 1e-14 && n < 40,
            "{x} {n}"
        );
        let (x, _, _) = brent_minimize(|x| (x - 1.7).abs(), 0.0, 2.0, 1e-12, 200);
        assert!((x - 1.7).abs() < 1e-10);
        // Minimum at the boundary.
        let (x, _, _) = brent_minimize(|x| x, 1.0, 2.0, 1e-12, 200);
        assert!((x - 1.0).abs() < 1e-10);
    }
}
