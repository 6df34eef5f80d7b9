//! How fast a turning pair can close: the growth of a body's support
//! value along a fixed lab direction as it turns, and the first time the
//! resulting lower bound on the separation of the support planes reaches
//! zero. The contact search steps by these.

use nalgebra::{UnitQuaternion, Vector3};

use super::motion::FreeTop;
use crate::geometry::Shape;

type V3 = Vector3<f64>;

/// What the support-growth bound needs of a body's free rotation, fixed
/// over a search: the largest |ω| over the motion, and the bound on |ü|
/// for a fixed lab direction's body-frame image u (|ü| ≤ |ω|² + |ω̇_body|;
/// both from `FreeTop`, which bounds them on the body's energy and
/// angular-momentum surface, so they hold however far the search goes).
#[derive(Debug, Clone, Copy)]
pub(super) struct TurnBound {
    pub(super) speed: f64,
    accel: f64,
}

impl TurnBound {
    pub(super) fn new(top: &FreeTop) -> Self {
        let speed = top.max_angular_speed();
        Self {
            speed,
            accel: speed * speed + top.max_body_acceleration(),
        }
    }

    /// `Shape::support_growth` along the body-frame direction `u` of the
    /// body at orientation `q` (u̇ = u × ω_body).
    #[inline]
    pub(super) fn support_growth(
        &self,
        shape: &Shape,
        top: &FreeTop,
        q: &UnitQuaternion<f64>,
        u: &V3,
    ) -> crate::geometry::shape::SupportGrowth {
        let body_omega = top.body_angular_velocity(q);
        shape.support_growth(u, &u.cross(&body_omega), self.speed, self.accel)
    }
}

/// The first τ > 0 at which the concave bound
/// φ + slope τ − Σ w (|c + rτ| − |c|) − ½ curvature τ² reaches 0 (φ > 0;
/// the kinks are a cuboid's support value, see `Shape::support_growth`):
/// between consecutive kinks it is a parabola, solved exactly.
pub(super) fn first_zero(
    phi: f64,
    slope: f64,
    kinks: &[(f64, f64, f64); 6],
    curvature: f64,
) -> f64 {
    // The bound's slope from the kinks just after τ = 0, Σ w r sign(c + rτ)
    // (sign(r) where c = 0), and where the kinks ahead bend it down (c and
    // r of opposite signs: at τ = −c/r the term's slope rises by 2 w |r|).
    let mut bend = 0.0;
    let mut breaks = [(f64::INFINITY, 0.0); 6];
    let mut ahead = 0;
    for &(w, c, r) in kinks {
        let sign = if c != 0.0 { c.signum() } else { r.signum() };
        bend += w * r * sign;
        if w > 0.0 && c * r < 0.0 {
            breaks[ahead] = (-c / r, 2.0 * w * r.abs());
            ahead += 1;
        }
    }
    if !bend.is_finite() {
        return 0.0;
    }
    // In order (insertion sort: at most six).
    for k in 1..ahead {
        let mut m = k;
        while m > 0 && breaks[m - 1].0 > breaks[m].0 {
            breaks.swap(m - 1, m);
            m -= 1;
        }
    }
    let (mut lo, mut f_lo) = (0.0, phi);
    for &(hi, rise) in &breaks[..ahead] {
        let x = time_to_zero(f_lo, slope - bend - curvature * lo, curvature);
        if lo + x <= hi {
            return lo + x;
        }
        f_lo = kinked_bound(phi, slope, kinks, curvature, hi);
        lo = hi;
        if f_lo <= 0.0 {
            // Rounding at the kink: the bound is down to zero there.
            return lo;
        }
        bend += rise;
    }
    lo + time_to_zero(f_lo, slope - bend - curvature * lo, curvature)
}

/// φ + slope τ − Σ w (|c + rτ| − |c|) − ½ curvature τ² at τ.
#[inline]
pub(super) fn kinked_bound(
    phi: f64,
    slope: f64,
    kinks: &[(f64, f64, f64); 6],
    curvature: f64,
    tau: f64,
) -> f64 {
    let bent: f64 = kinks
        .iter()
        .map(|&(w, c, r)| w * ((c + r * tau).abs() - c.abs()))
        .sum();
    phi + slope * tau - bent - 0.5 * curvature * tau * tau
}

/// The first τ > 0 at which φ + slope τ − ½ curvature τ² reaches 0 (φ > 0,
/// curvature ≥ 0), infinite if never; written without cancellation.
pub(super) fn time_to_zero(phi: f64, slope: f64, curvature: f64) -> f64 {
    if curvature > 0.0 {
        let root = (slope * slope + 2.0 * curvature * phi).sqrt();
        if slope < 0.0 {
            2.0 * phi / (root - slope)
        } else {
            (slope + root) / curvature
        }
    } else if slope < 0.0 {
        phi / -slope
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first zero of the kinked bound against a fine scan of it: the
    /// bound is positive before the time returned and zero there.
    #[test]
    fn first_zero_of_the_kinked_bound_matches_a_scan() {
        let mut u = crate::test_support::uniform(31);
        for case in 0..3000 {
            let phi = 1e-3 + u();
            let slope = 4.0 * (u() - 0.5);
            let curvature = if case % 3 == 0 { 0.0 } else { 3.0 * u() };
            let mut kinks = [(0.0, 0.0, 0.0); 6];
            for kink in kinks.iter_mut().take(1 + case % 6) {
                *kink = (u(), 2.0 * (u() - 0.5), 4.0 * (u() - 0.5));
            }
            let bound = |tau: f64| kinked_bound(phi, slope, &kinks, curvature, tau);
            let tau = first_zero(phi, slope, &kinks, curvature);
            let horizon = if tau.is_finite() { tau } else { 50.0 };
            for k in 0..2000 {
                let s = horizon * k as f64 / 2000.0;
                assert!(
                    bound(s) > -1e-12,
                    "case {case}: bound {} at {s} before {tau}",
                    bound(s)
                );
            }
            if tau.is_finite() {
                assert!(
                    bound(tau).abs() < 1e-9,
                    "case {case}: bound {} at {tau}",
                    bound(tau)
                );
            } else {
                // Never zero: the bound does not turn down at all.
                assert!(curvature == 0.0 && bound(1e3) > 0.0, "case {case}");
            }
        }
    }
}
