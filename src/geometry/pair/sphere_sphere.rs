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

/// [`contact_time_from_products`] for two pairs at once, the same to the
/// bit: in one SSE2 register on x86-64, where the compiler otherwise
/// splits the lanes and branches on whether each pair meets (to skip its
/// division), mispredicted about one pair in two.
#[inline(always)]
pub fn contact_times_from_products(
    d_dot_v: [f64; 2],
    d_squared: [f64; 2],
    v_squared: [f64; 2],
    sigma: [f64; 2],
) -> [f64; 2] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_add_pd, _mm_and_pd, _mm_andnot_pd, _mm_cmpge_pd, _mm_cmplt_pd, _mm_div_pd,
            _mm_loadu_pd, _mm_max_pd, _mm_mul_pd, _mm_or_pd, _mm_set1_pd, _mm_setzero_pd,
            _mm_sqrt_pd, _mm_storeu_pd, _mm_sub_pd,
        };
        // SAFETY: SSE2 is part of the x86_64 baseline; the loads and the
        // store touch two-element arrays.
        unsafe {
            let b = _mm_loadu_pd(d_dot_v.as_ptr());
            let dd = _mm_loadu_pd(d_squared.as_ptr());
            let v2 = _mm_loadu_pd(v_squared.as_ptr());
            let sigma = _mm_loadu_pd(sigma.as_ptr());
            let zero = _mm_setzero_pd();
            let c = _mm_sub_pd(dd, _mm_mul_pd(sigma, sigma));
            let disc = _mm_sub_pd(_mm_mul_pd(b, b), _mm_mul_pd(v2, c));
            // maxpd yields its second operand when either is NaN, as
            // `f64::max` yields the number: NaN, and 0/0, become 0.
            let root = _mm_sqrt_pd(_mm_max_pd(disc, zero));
            let t = _mm_max_pd(_mm_div_pd(c, _mm_add_pd(_mm_sub_pd(zero, b), root)), zero);
            let meets = _mm_and_pd(_mm_cmplt_pd(b, zero), _mm_cmpge_pd(disc, zero));
            let never = _mm_set1_pd(f64::INFINITY);
            let times = _mm_or_pd(_mm_and_pd(meets, t), _mm_andnot_pd(meets, never));
            let mut out = [0.0; 2];
            _mm_storeu_pd(out.as_mut_ptr(), times);
            out
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    std::array::from_fn(|k| {
        contact_time_from_products(d_dot_v[k], d_squared[k], v_squared[k], sigma[k])
    })
}

/// The earliest time t ≥ 0 at which two growing spheres touch: contact
/// distance `sigma` now, growing at `sigma_rate` (Lubachevsky–Stillinger
/// growth), separation `d + v t`; +∞ if never. |d + v t|² = (σ + σ̇ t)²
/// is a′t² + 2b′t + c′ = 0 with a′ = v² − σ̇², b′ = d·v − σσ̇, c′ = |d|² − σ²:
/// a pair apart (c′ > 0) meets at c′ / (−b′ + √(b′² − a′c′)) if that is
/// positive; a pair touching by round-off meets now if it closes (b′ < 0),
/// and a receding one again at the later root if the growth outruns the
/// separation (a′ < 0), as after a collision.
#[inline]
pub fn grown_contact_time_from_products(
    d_dot_v: f64,
    d_squared: f64,
    v_squared: f64,
    sigma: f64,
    sigma_rate: f64,
) -> f64 {
    let a = v_squared - sigma_rate * sigma_rate;
    let b = d_dot_v - sigma * sigma_rate;
    let c = d_squared - sigma * sigma;
    let disc = b * b - a * c;
    if c > 0.0 {
        let denominator = -b + disc.max(0.0).sqrt();
        if disc >= 0.0 && denominator > 0.0 {
            c / denominator
        } else {
            f64::INFINITY
        }
    } else if b < 0.0 {
        0.0
    } else if a < 0.0 {
        (-b - disc.max(0.0).sqrt()) / a
    } else {
        f64::INFINITY
    }
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

    /// Growing spheres: a finite time is where |d + v t| = σ + σ̇ t with
    /// the gap closing there; +∞ only where the gap never closes (checked
    /// on a fine grid of times); no growth gives the rigid answer; a pair
    /// that has just collided and recedes slower than it grows meets again.
    #[test]
    fn grown_contact_times_match_the_growing_line() {
        let mut u = crate::test_support::uniform(8);
        let (mut met, mut never) = (0, 0);
        for k in 0..20_000 {
            let d = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 4.0;
            let v = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            let sigma = if k % 5 == 0 { d.norm() } else { 1.0 };
            let rate = if k % 3 == 0 { 0.0 } else { 0.3 * u() };
            if d.norm() < sigma && k % 5 != 0 {
                // Overlapping: not a state the dynamics has.
                continue;
            }
            let t = grown_contact_time_from_products(
                d.dot(&v),
                d.norm_squared(),
                v.norm_squared(),
                sigma,
                rate,
            );
            let gap = |t: f64| (d + v * t).norm() - (sigma + rate * t);
            if rate == 0.0 && d.norm_squared() > sigma * sigma {
                assert_eq!(t, contact_time_or_never(&d, &v, sigma), "{d} {v}");
            }
            if t.is_finite() {
                met += 1;
                assert!(t >= 0.0);
                if t > 0.0 {
                    assert!(
                        gap(t).abs() < 1e-10 * (1.0 + d.norm()),
                        "{d} {v}: {}",
                        gap(t)
                    );
                    // Apart before it (bar round-off at a start touching).
                    let mid = 0.5 * t;
                    assert!(gap(mid) > -1e-12, "{d} {v} {sigma} {rate}: {}", gap(mid));
                }
            } else {
                never += 1;
                for step in 1..400 {
                    let s = step as f64 * 0.05;
                    assert!(gap(s) > 0.0, "{d} {v} {sigma} {rate}: meets by {s}");
                }
            }
        }
        assert!(met > 2_000 && never > 2_000, "{met} met, {never} never");
        // Touching (|d| = σ = 1), growing at 0.5: receding along the normal
        // faster than that (0.6), never again (|d + v t| ≥ n·(d + v t)
        // outruns σ + σ̇ t); slower (0.1), closing now.
        let t = grown_contact_time_from_products(0.6, 1.0, 0.36, 1.0, 0.5);
        assert!(t.is_infinite(), "{t}");
        let t = grown_contact_time_from_products(0.1, 1.0, 0.01, 1.0, 0.5);
        assert_eq!(t, 0.0);
        // Sideways (d·v = 0), growing at 0.05: closing now.
        let t = grown_contact_time_from_products(0.0, 1.0, 0.01, 1.0, 0.05);
        assert_eq!(t, 0.0);
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

    /// Two pairs at once are each pair alone, to the bit: approaches,
    /// recessions, misses, grazes, touching and overlapping pairs, pairs
    /// at rest, and zeros of either sign.
    #[test]
    fn two_pairs_at_once_are_each_pair_alone() {
        let mut u = crate::test_support::uniform(9);
        let mut pick = |k: usize| match k % 6 {
            0 => 0.0,
            1 => -0.0,
            _ => 4.0 * (u() - 0.5),
        };
        let (mut met, mut never) = (0, 0);
        for k in 0..200_000 {
            let b = [pick(k / 3), pick(k / 7)];
            let dd = [pick(k / 11).abs(), pick(k / 13).abs()];
            let v2 = [pick(k / 17).abs(), pick(k / 19).abs()];
            let sigma = [1.0, if k % 5 == 0 { dd[1].sqrt() } else { 0.9 }];
            let both = contact_times_from_products(b, dd, v2, sigma);
            for lane in 0..2 {
                let alone = contact_time_from_products(b[lane], dd[lane], v2[lane], sigma[lane]);
                assert_eq!(
                    both[lane].to_bits(),
                    alone.to_bits(),
                    "lane {lane}: {b:?} {dd:?} {v2:?} {sigma:?}"
                );
                if alone.is_finite() {
                    met += 1;
                } else {
                    never += 1;
                }
            }
        }
        assert!(met > 50_000 && never > 50_000, "{met} met, {never} never");
    }
}
