//! The elastic collision of two smooth hard rigid bodies (De Michele
//! Sec. 2.5, eqs. (40)–(41), derived again here: eq. (41) as printed lacks
//! the projection on n̂ in the numerator and the squares in the denominator).
//!
//! With n̂ the unit normal at the contact point x_C, pointing from A to B,
//! and the arms a = x_C − r_A, b = x_C − r_B, smooth surfaces exchange an
//! impulse J n̂ only (B gets +J n̂, A gets −J n̂):
//!
//! ```text
//! v_A' = v_A − (J/m_A) n̂            ω_A' = ω_A − J I_A⁻¹ (a × n̂)
//! v_B' = v_B + (J/m_B) n̂            ω_B' = ω_B + J I_B⁻¹ (b × n̂)
//! ```
//!
//! which conserves momentum, and angular momentum about any point (the
//! impulses are equal and opposite along one line through x_C). The normal
//! velocity of approach of the contact points, u = (v_A + ω_A × a − v_B −
//! ω_B × b)·n̂, changes to u − J D with
//! D = 1/m_A + 1/m_B + (a × n̂)·I_A⁻¹(a × n̂) + (b × n̂)·I_B⁻¹(b × n̂);
//! energy is conserved iff u' = −u, that is J = 2u / D.

use crate::geometry::pair::MAX_PATCH;
use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;

/// The velocities of a body and its inverse inertia, in the lab frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kinetics {
    /// Centre-of-mass velocity.
    pub velocity: V3,
    /// Angular velocity.
    pub angular_velocity: V3,
    /// 1/m.
    pub inverse_mass: f64,
    /// I⁻¹ in the lab frame (zero for a body that does not rotate).
    pub inverse_inertia: Matrix3<f64>,
}

impl Kinetics {
    /// Kinetic energy, translational plus rotational.
    pub fn energy(&self) -> f64 {
        let trans = 0.5 * self.velocity.norm_squared() / self.inverse_mass;
        let rot = match self.inverse_inertia.try_inverse() {
            Some(inertia) if self.angular_velocity != V3::zeros() => {
                0.5 * self
                    .angular_velocity
                    .dot(&(inertia * self.angular_velocity))
            }
            _ => 0.0,
        };
        trans + rot
    }
}

/// The impulse J ≥ 0 that B receives along `normal` (A → B) in the elastic
/// collision at the contact point with arms `arm_a` = x_C − r_A and
/// `arm_b` = x_C − r_B; applies it to both bodies. Bodies whose contact
/// points do not approach (u ≤ 0, a grazing touch) exchange nothing.
/// `growth` is what the bodies' growth adds to the approach speed u of the
/// contact points (0 for rigid bodies): the rule reverses u with it, so
/// that growing bodies separate after touching (Lubachevsky–Stillinger).
pub fn collide(
    a: &mut Kinetics,
    b: &mut Kinetics,
    arm_a: &V3,
    arm_b: &V3,
    normal: &V3,
    growth: f64,
) -> f64 {
    let ta = arm_a.cross(normal);
    let tb = arm_b.cross(normal);
    let u = (a.velocity + a.angular_velocity.cross(arm_a)
        - b.velocity
        - b.angular_velocity.cross(arm_b))
    .dot(normal)
        + growth;
    if u <= 0.0 {
        return 0.0;
    }
    let ia_ta = a.inverse_inertia * ta;
    let ib_tb = b.inverse_inertia * tb;
    let d = a.inverse_mass + b.inverse_mass + ta.dot(&ia_ta) + tb.dot(&ib_tb);
    let j = 2.0 * u / d;
    a.velocity -= normal * (j * a.inverse_mass);
    b.velocity += normal * (j * b.inverse_mass);
    a.angular_velocity -= ia_ta * j;
    b.angular_velocity += ib_tb * j;
    j
}

/// The elastic impact of two bodies touching at several points at once (a
/// face on a face, an edge on a face), all with the same `normal` (A → B);
/// `arms` holds each point's (x − r_A, x − r_B). Sequential point impulses
/// cannot end such an impact: each one sets the body turning about the
/// point it acted at, and the next corner comes in (resting cubes hit
/// face to face stalled the run so). Here, as in Poisson's law with
/// restitution 1: the impulses Pₖ ≥ 0 of the compression phase solve the
/// linear complementarity problem w = u − W P ≤ 0, P ≥ 0, Pₖ wₖ = 0 (u the
/// approach speeds, W the Delassus matrix of the points: how an impulse at
/// one changes the approach at another), and the bodies receive 2P. The
/// kinetic energy changes by −2P·w = 0 exactly, momentum and angular
/// momentum are conserved (equal and opposite impulses along one line
/// each), and every point that carried an impulse separates as fast as it
/// approached. W has rank 3 at most (the impulses enter through their sum
/// and moment), so a solution with at most 3 points carrying impulse
/// exists (Carathéodory); the sets of up to 3 points are tried in turn.
/// Returns the total impulse ΣJ that B receives along the normal; zero if
/// no point approaches. `growth` is added to every point's approach speed
/// (as in [`collide`]: the same at every point, since the growth moves the
/// two contact points apart along n at a rate set by r_B − r_A alone).
pub fn collide_patch(
    a: &mut Kinetics,
    b: &mut Kinetics,
    arms: &[(V3, V3)],
    normal: &V3,
    growth: f64,
) -> f64 {
    let m = arms.len().min(MAX_PATCH);
    let mut ta = [V3::zeros(); MAX_PATCH];
    let mut tb = [V3::zeros(); MAX_PATCH];
    let mut ia_ta = [V3::zeros(); MAX_PATCH];
    let mut ib_tb = [V3::zeros(); MAX_PATCH];
    let mut u = [0.0; MAX_PATCH];
    for k in 0..m {
        let (arm_a, arm_b) = arms[k];
        ta[k] = arm_a.cross(normal);
        tb[k] = arm_b.cross(normal);
        ia_ta[k] = a.inverse_inertia * ta[k];
        ib_tb[k] = b.inverse_inertia * tb[k];
        u[k] = (a.velocity + a.angular_velocity.cross(&arm_a)
            - b.velocity
            - b.angular_velocity.cross(&arm_b))
        .dot(normal)
            + growth;
    }
    if u[..m].iter().all(|&x| x <= 0.0) {
        return 0.0;
    }
    let w = |k: usize, l: usize| {
        a.inverse_mass + b.inverse_mass + ta[k].dot(&ia_ta[l]) + tb[k].dot(&ib_tb[l])
    };
    let scale = u[..m].iter().fold(0.0f64, |s, x| s.max(x.abs()));
    let slack = 1e-12 * scale;
    // Every set of one, two or three points, smallest first.
    let mut best: Option<([f64; MAX_PATCH], f64)> = None;
    let mut try_set = |set: &[usize]| -> bool {
        let n = set.len();
        let mut mat = nalgebra::Matrix3::<f64>::identity();
        let mut rhs = V3::zeros();
        for (r, &k) in set.iter().enumerate() {
            rhs[r] = u[k];
            for (c, &l) in set.iter().enumerate() {
                mat[(r, c)] = w(k, l);
            }
        }
        let solved = match n {
            1 => (mat[(0, 0)] > 0.0).then(|| V3::new(rhs[0] / mat[(0, 0)], 0.0, 0.0)),
            2 => {
                let m2 = mat.fixed_view::<2, 2>(0, 0).into_owned();
                let det = m2.determinant();
                (det.abs() > 1e-12 * m2.norm_squared()).then(|| {
                    let x = m2.try_inverse().expect("checked") * rhs.fixed_rows::<2>(0);
                    V3::new(x[0], x[1], 0.0)
                })
            }
            _ => {
                let det = mat.determinant();
                (det.abs() > 1e-12 * mat.norm_squared() * mat.norm())
                    .then(|| mat.try_inverse().expect("checked") * rhs)
            }
        };
        let Some(x) = solved else {
            return false;
        };
        if x.iter().take(n).any(|&p| p < 0.0) {
            return false;
        }
        let mut p = [0.0; MAX_PATCH];
        for (r, &k) in set.iter().enumerate() {
            p[k] = x[r];
        }
        // Every point, after the compression phase, does not approach.
        let worst = (0..m)
            .map(|k| u[k] - (0..m).map(|l| w(k, l) * p[l]).sum::<f64>())
            .fold(f64::NEG_INFINITY, f64::max);
        if worst <= slack {
            best = Some((p, worst));
            return true;
        }
        if best.is_none_or(|(_, w)| worst < w) {
            best = Some((p, worst));
        }
        false
    };
    'search: {
        for k in 0..m {
            if try_set(&[k]) {
                break 'search;
            }
        }
        for k in 0..m {
            for l in k + 1..m {
                if try_set(&[k, l]) {
                    break 'search;
                }
            }
        }
        for k in 0..m {
            for l in k + 1..m {
                for n in l + 1..m {
                    if try_set(&[k, l, n]) {
                        break 'search;
                    }
                }
            }
        }
    }
    let Some((p, _)) = best else {
        return 0.0;
    };
    let mut total = 0.0;
    for k in 0..m {
        let j = 2.0 * p[k];
        if j == 0.0 {
            continue;
        }
        total += j;
        a.angular_velocity -= ia_ta[k] * j;
        b.angular_velocity += ib_tb[k] * j;
    }
    a.velocity -= normal * (total * a.inverse_mass);
    b.velocity += normal * (total * b.inverse_mass);
    total
}

/// The impulse between two spheres (arms along the normal, no torque):
/// J = 2 u / (1/m_A + 1/m_B), applied to the velocities; `growth` as in
/// [`collide`] (for spheres: the rate at which their radii sum grows).
#[inline]
pub fn collide_spheres(
    v_a: &mut V3,
    v_b: &mut V3,
    inverse_mass_a: f64,
    inverse_mass_b: f64,
    normal: &V3,
    growth: f64,
) -> f64 {
    let u = (*v_a - *v_b).dot(normal) + growth;
    if u <= 0.0 {
        return 0.0;
    }
    let j = 2.0 * u / (inverse_mass_a + inverse_mass_b);
    *v_a -= normal * (j * inverse_mass_a);
    *v_b += normal * (j * inverse_mass_b);
    j
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn random_body(u: &mut impl FnMut() -> f64) -> (V3, Kinetics) {
        let v = |u: &mut dyn FnMut() -> f64| V3::new(u() - 0.5, u() - 0.5, u() - 0.5);
        let centre = v(u) * 4.0;
        let rot = UnitQuaternion::from_scaled_axis(v(u) * 6.0).to_rotation_matrix();
        let principal = Matrix3::from_diagonal(&V3::new(0.3 + u(), 0.3 + u(), 0.3 + u()));
        let lab_inverse = rot * principal.try_inverse().unwrap() * rot.transpose();
        let k = Kinetics {
            velocity: v(u) * 3.0,
            angular_velocity: v(u) * 5.0,
            inverse_mass: 1.0 / (0.5 + u()),
            inverse_inertia: lab_inverse,
        };
        (centre, k)
    }

    /// Total momentum of two bodies.
    fn momentum(a: &Kinetics, b: &Kinetics) -> V3 {
        a.velocity / a.inverse_mass + b.velocity / b.inverse_mass
    }

    /// Total angular momentum about the origin of two bodies centred at
    /// `ra` and `rb`.
    fn angular_momentum(ra: &V3, a: &Kinetics, rb: &V3, b: &Kinetics) -> V3 {
        let spin = |k: &Kinetics| k.inverse_inertia.try_inverse().unwrap() * k.angular_velocity;
        ra.cross(&(a.velocity / a.inverse_mass))
            + spin(a)
            + rb.cross(&(b.velocity / b.inverse_mass))
            + spin(b)
    }

    /// The simultaneous impacts of a flat contact conserve momentum,
    /// angular momentum and energy; every point that approached separates
    /// at least as fast; and a square face meeting a face head on without
    /// turning (all corners approaching alike) bounces without spin, as
    /// two spheres would (equal masses exchange their normal velocities).
    #[test]
    fn patch_impacts_conserve_and_separate() {
        let mut u = crate::test_support::uniform(23);
        let mut collided = 0;
        for case in 0..400 {
            let (ra, mut a) = random_body(&mut u);
            let (rb, mut b) = random_body(&mut u);
            let normal = (V3::new(u() - 0.5, u() - 0.5, u() - 0.5) + (rb - ra)).normalize();
            // 2 to 16 points on a plane normal to n, between the centres.
            let e1 = normal.cross(&V3::new(0.3, -0.7, 0.2)).normalize();
            let e2 = normal.cross(&e1);
            let mid = (ra + rb) * 0.5;
            let m = 2 + case % 15;
            let mut arms = [(V3::zeros(), V3::zeros()); MAX_PATCH];
            for arm in arms.iter_mut().take(m) {
                let x = mid + e1 * (u() - 0.5) * 2.0 + e2 * (u() - 0.5) * 2.0;
                *arm = (x - ra, x - rb);
            }
            let arms = &arms[..m];
            let angular = |a: &Kinetics, b: &Kinetics| angular_momentum(&ra, a, &rb, b);
            let approach = |a: &Kinetics, b: &Kinetics| {
                arms.iter()
                    .map(|(arm_a, arm_b)| {
                        (a.velocity + a.angular_velocity.cross(arm_a)
                            - b.velocity
                            - b.angular_velocity.cross(arm_b))
                        .dot(&normal)
                    })
                    .collect::<Vec<_>>()
            };
            let (p0, l0, e0, u0) = (
                momentum(&a, &b),
                angular(&a, &b),
                a.energy() + b.energy(),
                approach(&a, &b),
            );
            let j = collide_patch(&mut a, &mut b, arms, &normal, 0.0);
            let u1 = approach(&a, &b);
            if u0.iter().all(|&x| x <= 0.0) {
                assert_eq!(j, 0.0);
                continue;
            }
            collided += 1;
            assert!(j > 0.0, "case {case}");
            assert!(
                (momentum(&a, &b) - p0).norm() < 1e-12 * (1.0 + p0.norm()),
                "case {case}: momentum"
            );
            assert!(
                (angular(&a, &b) - l0).norm() < 1e-11 * (1.0 + l0.norm()),
                "case {case}: angular momentum"
            );
            let e1 = a.energy() + b.energy();
            assert!(
                (e1 - e0).abs() < 1e-12 * e0,
                "case {case}: energy {e0} -> {e1}"
            );
            for (k, (&before, &after)) in u0.iter().zip(&u1).enumerate() {
                if before > 0.0 {
                    assert!(
                        after <= -before + 1e-9 * (1.0 + before),
                        "case {case}, point {k}: {before} -> {after}"
                    );
                }
            }
        }
        assert!(collided > 100, "{collided}");
        // Head on, no turning: a cube's face on another's, four corners.
        let body = |v: V3| Kinetics {
            velocity: v,
            angular_velocity: V3::zeros(),
            inverse_mass: 1.0,
            inverse_inertia: Matrix3::from_diagonal_element(6.0),
        };
        let (mut a, mut b) = (body(V3::new(0.3, 0.1, 1.0)), body(V3::new(0.0, -0.2, -0.5)));
        let corners = [(-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5), (0.5, 0.5)]
            .map(|(x, y)| (V3::new(x, y, 0.5), V3::new(x, y, -0.5)));
        let j = collide_patch(&mut a, &mut b, &corners, &V3::z(), 0.0);
        assert!((j - 1.5).abs() < 1e-12, "{j}");
        assert!(
            (a.velocity - V3::new(0.3, 0.1, -0.5)).norm() < 1e-12,
            "{:?}",
            a.velocity
        );
        assert!(
            (b.velocity - V3::new(0.0, -0.2, 1.0)).norm() < 1e-12,
            "{:?}",
            b.velocity
        );
        assert!(a.angular_velocity.norm() < 1e-12 && b.angular_velocity.norm() < 1e-12);
    }

    /// Momentum, angular momentum (about the origin) and energy are
    /// conserved, and the contact points separate as fast as they approached.
    #[test]
    fn conserves_momentum_angular_momentum_and_energy() {
        let mut u = crate::test_support::uniform(17);
        let mut collided = 0;
        for _ in 0..500 {
            let (ra, mut a) = random_body(&mut u);
            let (rb, mut b) = random_body(&mut u);
            let xc = (ra + rb) * 0.5 + V3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 0.3;
            let normal = (V3::new(u() - 0.5, u() - 0.5, u() - 0.5) + (rb - ra)).normalize();
            let (arm_a, arm_b) = (xc - ra, xc - rb);
            let angular = |a: &Kinetics, b: &Kinetics| angular_momentum(&ra, a, &rb, b);
            let approach = |a: &Kinetics, b: &Kinetics| {
                (a.velocity + a.angular_velocity.cross(&arm_a)
                    - b.velocity
                    - b.angular_velocity.cross(&arm_b))
                .dot(&normal)
            };
            let (p0, l0, e0, u0) = (
                momentum(&a, &b),
                angular(&a, &b),
                a.energy() + b.energy(),
                approach(&a, &b),
            );
            let j = collide(&mut a, &mut b, &arm_a, &arm_b, &normal, 0.0);
            let (p1, l1, e1, u1) = (
                momentum(&a, &b),
                angular(&a, &b),
                a.energy() + b.energy(),
                approach(&a, &b),
            );
            assert!((p1 - p0).norm() < 1e-12 * (1.0 + p0.norm()));
            assert!((l1 - l0).norm() < 1e-11 * (1.0 + l0.norm()), "{l0} {l1}");
            assert!((e1 - e0).abs() < 1e-12 * e0);
            if u0 > 0.0 {
                collided += 1;
                assert!(j > 0.0);
                assert!((u1 + u0).abs() < 1e-12 * (1.0 + u0.abs()));
            } else {
                assert_eq!(j, 0.0);
            }
        }
        assert!(collided > 100, "too few approaching pairs: {collided}");
    }

    /// Growing bodies: the approach with the growth's share is reversed
    /// (they separate after touching, faster than they grow apart), even
    /// when the rigid parts alone recede; momentum and angular momentum
    /// are conserved.
    #[test]
    fn growth_is_reversed_with_the_approach() {
        let mut u = crate::test_support::uniform(19);
        for k in 0..300 {
            let (ra, mut a) = random_body(&mut u);
            let (rb, mut b) = random_body(&mut u);
            let xc = (ra + rb) * 0.5;
            let normal = (rb - ra).normalize();
            let (arm_a, arm_b) = (xc - ra, xc - rb);
            let approach = |a: &Kinetics, b: &Kinetics| {
                (a.velocity + a.angular_velocity.cross(&arm_a)
                    - b.velocity
                    - b.angular_velocity.cross(&arm_b))
                .dot(&normal)
            };
            let growth = 0.5 + u();
            let (p0, l0, u0) = (
                momentum(&a, &b),
                angular_momentum(&ra, &a, &rb, &b),
                approach(&a, &b) + growth,
            );
            let patch = k % 2 == 0;
            let j = if patch {
                collide_patch(&mut a, &mut b, &[(arm_a, arm_b)], &normal, growth)
            } else {
                collide(&mut a, &mut b, &arm_a, &arm_b, &normal, growth)
            };
            let u1 = approach(&a, &b) + growth;
            if u0 > 0.0 {
                assert!(j > 0.0);
                assert!((u1 + u0).abs() < 1e-11 * (1.0 + u0.abs()), "{u0} {u1}");
            }
            assert!((momentum(&a, &b) - p0).norm() < 1e-12 * (1.0 + p0.norm()));
            let l1 = angular_momentum(&ra, &a, &rb, &b);
            assert!((l1 - l0).norm() < 1e-11 * (1.0 + l0.norm()));
        }
        let mut va = V3::new(0.1, 0.0, 0.0);
        let mut vb = V3::new(0.0, 0.0, 0.0);
        // Closing at 0.1, the radii's sum growing at 1: the approach 1.1
        // reversed, the centres part at 1.1 + 1.
        let j = collide_spheres(&mut va, &mut vb, 1.0, 1.0, &V3::x(), 1.0);
        assert!((j - 1.1).abs() < 1e-15);
        assert!(((vb - va).x - 2.1).abs() < 1e-15, "{va} {vb}");
    }

    /// Equal spheres head-on exchange their velocities.
    #[test]
    fn equal_spheres_exchange_normal_velocities() {
        let mut va = V3::new(1.0, 0.5, 0.0);
        let mut vb = V3::new(-2.0, 0.0, 0.25);
        let j = collide_spheres(&mut va, &mut vb, 1.0, 1.0, &V3::x(), 0.0);
        assert_eq!(j, 3.0);
        assert_eq!(va, V3::new(-2.0, 0.5, 0.0));
        assert_eq!(vb, V3::new(1.0, 0.0, 0.25));
    }
}
