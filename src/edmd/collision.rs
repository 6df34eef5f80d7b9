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
pub fn collide(a: &mut Kinetics, b: &mut Kinetics, arm_a: &V3, arm_b: &V3, normal: &V3) -> f64 {
    let ta = arm_a.cross(normal);
    let tb = arm_b.cross(normal);
    let u = (a.velocity + a.angular_velocity.cross(arm_a)
        - b.velocity
        - b.angular_velocity.cross(arm_b))
    .dot(normal);
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

/// The impulse between two spheres (arms along the normal, no torque):
/// J = 2 u / (1/m_A + 1/m_B), applied to the velocities.
#[inline]
pub fn collide_spheres(
    v_a: &mut V3,
    v_b: &mut V3,
    inverse_mass_a: f64,
    inverse_mass_b: f64,
    normal: &V3,
) -> f64 {
    let u = (*v_a - *v_b).dot(normal);
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
            let momentum = |a: &Kinetics, b: &Kinetics| {
                a.velocity / a.inverse_mass + b.velocity / b.inverse_mass
            };
            let angular = |a: &Kinetics, b: &Kinetics| {
                let la = ra.cross(&(a.velocity / a.inverse_mass))
                    + a.inverse_inertia.try_inverse().unwrap() * a.angular_velocity;
                let lb = rb.cross(&(b.velocity / b.inverse_mass))
                    + b.inverse_inertia.try_inverse().unwrap() * b.angular_velocity;
                la + lb
            };
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
            let j = collide(&mut a, &mut b, &arm_a, &arm_b, &normal);
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

    /// Equal spheres head-on exchange their velocities.
    #[test]
    fn equal_spheres_exchange_normal_velocities() {
        let mut va = V3::new(1.0, 0.5, 0.0);
        let mut vb = V3::new(-2.0, 0.0, 0.25);
        let j = collide_spheres(&mut va, &mut vb, 1.0, 1.0, &V3::x());
        assert_eq!(j, 3.0);
        assert_eq!(va, V3::new(-2.0, 0.5, 0.0));
        assert_eq!(vb, V3::new(1.0, 0.0, 0.25));
    }
}
