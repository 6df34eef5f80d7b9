//! Sphere–sphere: closed form.

use nalgebra::Vector3;

use super::{Contact, Method, Relative, Status};
use crate::geometry::shape::Sphere;

/// Overlap iff |r_AB| ≤ R_A + R_B (frame: see the module docs of `pair`).
#[inline]
pub fn overlap(a: &Sphere, b: &Sphere, rel: &Relative) -> bool {
    overlap_at(a.radius(), b.radius(), &rel.translation)
}

/// Overlap of spheres of radii `ra`, `rb` with centres `d` apart.
#[inline]
pub fn overlap_at(ra: f64, rb: f64, d: &Vector3<f64>) -> bool {
    let reach = ra + rb;
    d.norm_squared() <= reach * reach
}

/// Signed distance |r_AB| − R_A − R_B, with the points on the centre line.
pub fn distance(a: &Sphere, b: &Sphere, rel: &Relative) -> Contact {
    let r = rel.translation;
    let len = r.norm();
    let normal = if len > 0.0 { r / len } else { Vector3::x() };
    Contact {
        distance: len - a.radius() - b.radius(),
        point_a: normal * a.radius(),
        point_b: r - normal * b.radius(),
        normal,
        status: Status::Converged { iterations: 0 },
        method: Method::Analytic,
        warm_start: None,
    }
}

/// The earliest time t ≥ 0 at which two spheres with contact distance
/// `sigma` = R_A + R_B touch, their separation being `d + v t` (`d` = r_B −
/// r_A, `v` = v_B − v_A); `None` if they do not approach or miss. A pair
/// already touching or overlapping by round-off and approaching gives 0.
///
/// |d + v t|² = σ² gives t = (−b − √(b² − v² c)) / v² with b = d·v,
/// c = |d|² − σ²; written as c / (−b + √(b² − v² c)), which does not
/// cancel when the pair is close (c small).
#[inline]
pub fn contact_time(d: &Vector3<f64>, v: &Vector3<f64>, sigma: f64) -> Option<f64> {
    let t = contact_time_or_never(d, v, sigma);
    (t < f64::INFINITY).then_some(t)
}

/// [`contact_time`] without branches on the pair: +∞ where that is
/// `None`. For scans over many partners (the event-driven dynamics' sphere
/// searches), where whether a pair approaches is a coin toss the branch
/// predictor loses half the time.
#[inline(always)]
pub fn contact_time_or_never(d: &Vector3<f64>, v: &Vector3<f64>, sigma: f64) -> f64 {
    contact_time_from_products(d.dot(v), d.norm_squared(), v.norm_squared(), sigma)
}

/// [`contact_time_or_never`] from the products `d·v`, `|d|²` and `|v|²`:
/// for callers that compute them for several pairs side by side (the
/// dynamics' sphere searches, whose compiler then keeps the pairs in
/// vector registers; a separate loop over pairs here was not vectorised).
#[inline(always)]
pub fn contact_time_from_products(d_dot_v: f64, d_squared: f64, v_squared: f64, sigma: f64) -> f64 {
    let b = d_dot_v;
    let c = d_squared - sigma * sigma;
    let disc = b * b - v_squared * c;
    // Computed whatever the signs (a receding or missing pair gives a
    // meaningless number, or NaN), then selected.
    let t = (c / (-b + disc.max(0.0).sqrt())).max(0.0);
    let meets = (b < 0.0) & (disc >= 0.0);
    select(meets, t, f64::INFINITY)
}

/// `if pick { a } else { b }` by bit masks: no branch.
#[inline(always)]
fn select(pick: bool, a: f64, b: f64) -> f64 {
    let mask = (pick as u64).wrapping_neg();
    f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over random approaches, recessions, misses, grazes, touching and
    /// overlapping pairs, checked against the straight line itself: a
    /// finite time is where |d + v t| = σ and the pair closes (0 for a pair
    /// already within σ and closing); +∞ only for a pair that recedes, or
    /// whose closest approach, |d|² − (d·v)²/|v|², stays beyond σ.
    #[test]
    fn contact_times_match_the_straight_line() {
        let mut u = crate::test_support::uniform(5);
        let (mut met, mut never) = (0, 0);
        for k in 0..20_000 {
            let d = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 4.0;
            let mut v = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            if k % 7 == 0 {
                v = Vector3::zeros();
            }
            let sigma = if k % 5 == 0 { d.norm() } else { 1.0 };
            let t = contact_time_or_never(&d, &v, sigma);
            let b = d.dot(&v);
            if t.is_finite() {
                met += 1;
                assert!(t >= 0.0 && b < 0.0, "{d} {v} {sigma}: t = {t}");
                if d.norm_squared() > sigma * sigma {
                    let gap = (d + v * t).norm() - sigma;
                    assert!(gap.abs() < 1e-12 * (1.0 + d.norm()), "{d} {v}: gap {gap}");
                } else {
                    assert_eq!(t, 0.0, "{d} {v} {sigma}");
                }
            } else {
                never += 1;
                assert_eq!(t, f64::INFINITY);
                let closest = d.norm_squared() - b * b / v.norm_squared();
                assert!(
                    b >= 0.0 || closest > sigma * sigma * (1.0 - 1e-12),
                    "{d} {v} {sigma}: closes to {}",
                    closest.sqrt()
                );
                assert_eq!(contact_time(&d, &v, sigma), None);
            }
        }
        assert!(met > 2_000 && never > 2_000, "{met} met, {never} never");
    }

    /// Head-on and oblique approaches touch exactly at the predicted time;
    /// receding and missing pairs never do.
    #[test]
    fn contact_time_is_exact() {
        let sigma = 1.5;
        let d = Vector3::new(3.0, 0.4, 0.0);
        let v = Vector3::new(-1.0, 0.0, 0.0);
        let t = contact_time(&d, &v, sigma).unwrap();
        assert!(((d + v * t).norm() - sigma).abs() < 1e-14);
        assert!((t - (3.0 - (sigma * sigma - 0.16f64).sqrt())).abs() < 1e-14);
        assert_eq!(contact_time(&d, &-v, sigma), None);
        let miss = Vector3::new(3.0, 1.6, 0.0);
        assert_eq!(contact_time(&miss, &v, sigma), None);
        // Overlapping by round-off and approaching: now.
        let touching = Vector3::new(sigma * (1.0 - 1e-15), 0.0, 0.0);
        assert_eq!(contact_time(&touching, &v, sigma), Some(0.0));
    }
}
