//! Free motion between events (De Michele Sec. 2.2): the centre moves in a
//! straight line (eq. 6a) and a spherical top turns at constant angular
//! velocity ω, the body rotating by the angle |ω| t about ω (eqs. 4–6b;
//! here as a quaternion, which stays a rotation to round-off).

use nalgebra::{UnitQuaternion, Vector3};

type V3 = Vector3<f64>;

/// The centre after a time `dt` of free flight (eq. 6a).
#[inline]
pub fn position_after(position: &V3, velocity: &V3, dt: f64) -> V3 {
    position + velocity * dt
}

/// The orientation (body → lab) after a time `dt` of free rotation at the
/// lab-frame angular velocity `omega` (eqs. 4–6b).
#[inline]
pub fn orientation_after(
    orientation: &UnitQuaternion<f64>,
    omega: &V3,
    dt: f64,
) -> UnitQuaternion<f64> {
    if dt == 0.0 {
        return *orientation;
    }
    let turn = UnitQuaternion::from_scaled_axis(omega * dt);
    let mut q = turn * orientation;
    q.renormalize_fast();
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// The quaternion form equals eq. (4)–(5): R(t) = (I + M) R(0) with
    /// M = sin(wt)/w Ω + (1 − cos(wt))/w² Ω² for the lab-frame Ω (the paper
    /// writes the body-frame form, R acting on row vectors).
    #[test]
    fn equals_the_rodrigues_closed_form() {
        let omega = V3::new(0.3, -1.2, 0.7);
        let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.5, 0.1, -0.9));
        let t = 1.7;
        let w = omega.norm();
        let big_omega = omega.cross_matrix();
        let m = big_omega * ((w * t).sin() / w)
            + big_omega * big_omega * ((1.0 - (w * t).cos()) / (w * w));
        let expected = (Matrix3::identity() + m) * q0.to_rotation_matrix().into_inner();
        let got = orientation_after(&q0, &omega, t)
            .to_rotation_matrix()
            .into_inner();
        assert!((got - expected).norm() < 1e-14, "{got} vs {expected}");
        assert_eq!(orientation_after(&q0, &V3::zeros(), t), q0);
    }

    /// A point of the body moves with velocity ω × (x − r) at the start.
    #[test]
    fn points_move_with_omega_cross_arm() {
        let omega = V3::new(0.3, -1.2, 0.7);
        let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.5, 0.1, -0.9));
        let body_point = V3::new(1.0, 0.5, -0.25);
        let h = 1e-6;
        let x = |t: f64| orientation_after(&q0, &omega, t) * body_point;
        let numeric = (x(h) - x(-h)) / (2.0 * h);
        assert!((numeric - omega.cross(&(q0 * body_point))).norm() < 1e-9);
    }
}
