//! Small scalar root finders shared by the shape kernels.

use nalgebra::Vector3;

/// x^p for x ≥ 0, by multiplications where p is a small integer and by
/// square and cube roots for ±1/2, ±1/4 and 1/3 (the superellipsoid
/// exponents users give are nearly always integers: 4, 6, 8, 10), else by
/// `powf`, which is far slower (the superellipsoid kernels call this in
/// their innermost loops).
#[inline]
pub fn power(x: f64, p: f64) -> f64 {
    // (p as i32) as f64 == p rather than p.trunc() == p: without SSE4.1
    // trunc is a library call.
    if p.abs() <= 32.0 && (p as i32) as f64 == p {
        x.powi(p as i32)
    } else if p == 0.5 {
        x.sqrt()
    } else if p == -0.5 {
        1.0 / x.sqrt()
    } else if p == 0.25 {
        x.sqrt().sqrt()
    } else if p == -0.25 {
        1.0 / x.sqrt().sqrt()
    } else if p == 1.0 / 3.0 {
        cube_root(x)
    } else {
        x.powf(p)
    }
}

/// x^{1/3} for x ≥ 0 (exponent 4's support map), by the scheme of
/// FreeBSD's `s_cbrt.c`: a guess from the exponent bits, a polynomial step
/// to about 23 bits, rounding to 32 bits (so that t³ is exact), one
/// Newton step in the form t + t (x/t² − t)/(2t + x/t²). Two divisions; the
/// correctly rounded `cbrt` the toolchain links took a fifth of a
/// superellipsoid search, and Halley's iteration from the bit guess a half.
#[inline]
pub fn cube_root(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x.cbrt();
    }
    // Scale subnormal and tiny inputs up so that the bit guess holds.
    let (x, scale) = if x < 1e-270 {
        (x * 2f64.powi(270), 2f64.powi(-90))
    } else {
        (x, 1.0)
    };
    const P0: f64 = 1.875_951_824_271_77;
    const P1: f64 = -1.884_979_795_433_771_7;
    const P2: f64 = 1.621_429_720_105_354_5;
    const P3: f64 = -0.758_397_934_778_766;
    const P4: f64 = 0.145_996_192_886_612_45;
    let high = (x.to_bits() >> 32) as u32;
    let t = f64::from_bits((u64::from(high / 3 + 715_094_163)) << 32);
    let r = (t * t) * (t / x);
    let t = t * ((P0 + r * (P1 + r * P2)) + ((r * r) * r) * (P3 + r * P4));
    let t = f64::from_bits((t.to_bits() + 0x8000_0000) & 0xffff_ffff_c000_0000);
    let s = t * t;
    let r = x / s;
    let r = (r - t) / (t + t + r);
    (t + t * r) * scale
}

/// The t > 0 with Σᵢ cᵢ t^{qᵢ} = 1, for cᵢ ≥ 0 (not all zero) and qᵢ > 0.
///
/// Newton's method in s = ln t on ψ(s) = Σ cᵢ e^{qᵢ s} − 1, which is convex
/// and increasing; started where ψ ≥ 0 it converges monotonically. The
/// start is the smallest sᵢ = −ln cᵢ / qᵢ (where one term alone is 1, so
/// ψ ≥ 0): the root lies below every sᵢ, and starting from the largest, as
/// once done, a tiny cᵢ put the start so far out that 100 steps did not
/// come back.
pub fn solve_power_sum(c: &Vector3<f64>, q: &Vector3<f64>) -> f64 {
    if q.x == q.y && q.y == q.z {
        // Equal exponents, closed form: t = (Σcᵢ)^{-1/q}.
        return power(c.sum(), -1.0 / q.x);
    }
    let mut s = f64::INFINITY;
    for i in 0..3 {
        if c[i] > 0.0 {
            s = s.min(-c[i].ln() / q[i]);
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
    fn cube_root_matches_cbrt() {
        let mut x = 1e-310;
        while x < 1e300 {
            for f in [1.0, 1.37, 2.9, 7.77] {
                let (got, want) = (cube_root(x * f), (x * f).cbrt());
                assert!(
                    ((got - want) / want).abs() < 1e-15,
                    "{}: {got} {want}",
                    x * f
                );
            }
            x *= 10.0;
        }
        assert_eq!(cube_root(0.0), 0.0);
        assert_eq!(cube_root(8.0), 2.0);
    }

    #[test]
    fn power_matches_powf() {
        for &x in &[0.0, 1e-300, 1e-9, 0.37, 1.0, 2.5, 1e12] {
            for &p in &[
                0.0,
                1.0,
                2.0,
                3.0,
                4.0,
                6.0,
                8.0,
                10.0,
                -1.0,
                -3.0,
                0.5,
                -0.5,
                0.25,
                -0.25,
                1.0 / 3.0,
                0.7,
                2.5,
                1.25,
                40.0,
            ] {
                // powf(x, 1/3) carries the rounding of 1/3 times ln x (1e-14
                // at x = 1e-300); cbrt is the more exact one.
                let (got, want) = (power(x, p), f64::powf(x, p));
                let scale = want.abs().max(f64::MIN_POSITIVE);
                assert!(
                    got == want || ((got - want) / scale).abs() < 1e-13,
                    "{x}^{p}: {got} against {want}"
                );
            }
        }
    }

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
        // A direction almost along an axis: one c underflows towards 0, and
        // the start must not follow the tiny c far out.
        let c = Vector3::new(1.3e-65, 0.4, 1e-300);
        let q = Vector3::new(4.0, 4.0, 6.0);
        let t = solve_power_sum(&c, &q);
        assert!((t - 0.4f64.powf(-0.25)).abs() < 1e-14, "{t}");
    }
}

/// Brent's minimisation of a unimodal `f` on [lo, hi] (golden section with
/// parabolic steps; Brent 1973, ch. 5): returns (x, f(x)) with x located to
/// about `tol` (absolute) and the number of evaluations.
pub fn brent_minimize(
    mut f: impl FnMut(f64) -> f64,
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

/// A sign change of `f` narrowed down: `f(lo) > 0 > f(hi)` on entry,
/// `f(lo) ≥ 0 > f(hi)` on return. Stops when `f(lo) ≤ tol` (the point just before the root, where
/// `f` is still non-negative), when the bracket is as narrow as floating
/// point allows, or after `max_evals` evaluations. Illinois regula falsi
/// (superlinear on smooth `f`) with a bisection whenever an interpolated
/// point would shrink the bracket by less than half.
///
/// Returns `(lo, f(lo), hi, f(hi), evaluations)`.
pub fn narrow_sign_change(
    mut f: impl FnMut(f64) -> f64,
    (mut lo, mut f_lo): (f64, f64),
    (mut hi, mut f_hi): (f64, f64),
    tol: f64,
    max_evals: u32,
) -> (f64, f64, f64, f64, u32) {
    debug_assert!(f_lo > 0.0 && f_hi < 0.0 && lo < hi);
    let mut evals = 0;
    // Which end was kept last time (Illinois halves its value if kept twice).
    let mut kept = 0i8;
    while f_lo > tol && evals < max_evals {
        let width = hi - lo;
        if width <= 4.0 * f64::EPSILON * lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE) {
            break;
        }
        let (mut wl, mut wh) = (f_lo, f_hi);
        if kept == 1 {
            wh *= 0.5;
        } else if kept == -1 {
            wl *= 0.5;
        }
        let mut t = lo + width * wl / (wl - wh);
        if !(t > lo && t < hi) {
            t = 0.5 * (lo + hi);
        }
        let ft = f(t);
        evals += 1;
        if ft >= 0.0 {
            lo = t;
            f_lo = ft;
            kept = if kept == 1 { 2 } else { 1 };
        } else {
            hi = t;
            f_hi = ft;
            kept = if kept == -1 { -2 } else { -1 };
        }
        // A point kept twice in a row: bisect once to guarantee progress.
        if kept.abs() == 2 && f_lo > tol {
            let m = 0.5 * (lo + hi);
            let fm = f(m);
            evals += 1;
            if fm >= 0.0 {
                lo = m;
                f_lo = fm;
            } else {
                hi = m;
                f_hi = fm;
            }
            kept = 0;
        }
    }
    (lo, f_lo, hi, f_hi, evals)
}

#[cfg(test)]
mod sign_change_tests {
    use super::*;

    /// Finds the point just before the root of smooth, steep and flat
    /// functions, always keeping the bracket.
    #[test]
    fn narrows_to_the_root_from_above() {
        type Case = (fn(f64) -> f64, f64);
        let cases: [Case; 3] = [
            (|t| 1.0 - t * t, 1.0),
            (|t| (0.3 - t).powi(3), 0.3),
            (|t| (-(t - 0.7)).tanh() * 1e-3, 0.7),
        ];
        for (f, root) in cases {
            let (lo, flo, hi, fhi, evals) =
                narrow_sign_change(f, (0.0, f(0.0)), (2.0, f(2.0)), 1e-14, 200);
            assert!(flo >= 0.0 && fhi < 0.0 && lo < hi, "{flo} {fhi} {lo} {hi}");
            assert!(lo <= root && hi >= root, "{lo} {hi} vs {root}");
            assert!(
                flo <= 1e-14 || hi - lo < 1e-14,
                "{flo} {lo} {hi} after {evals}"
            );
            assert!(evals < 200);
        }
    }
}
