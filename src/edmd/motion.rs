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

/// The free rotation of a rigid body whose angular velocity is
/// ω(t) = `lab` + R(t) `body`, with `lab` fixed in space and `body` fixed in
/// the body: a symmetric top (I₁ = I₂ ≠ I₃ about body axis ê₃) has
/// `lab` = L/I₁ and `body` = ω₃ (1 − I₃/I₁) ê₃, since then
/// Ṙ = \[ω\]×R with R(t) = exp(t \[lab\]×) R(0) exp(t \[body\]×) (the body turns
/// about the fixed angular momentum at |L|/I₁ and about its own axis); a
/// spherical top has `lab` = ω and `body` = 0 (eqs. 4–6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spin {
    /// The part of ω fixed in the lab frame.
    pub lab: V3,
    /// The part of ω fixed in the body frame (body coordinates).
    pub body: V3,
}

impl Spin {
    /// Constant angular velocity `omega` (a spherical top).
    pub fn constant(omega: V3) -> Self {
        Self {
            lab: omega,
            body: V3::zeros(),
        }
    }

    /// The orientation after `dt`, from `orientation` now.
    #[inline]
    pub fn orientation_after(
        &self,
        orientation: &UnitQuaternion<f64>,
        dt: f64,
    ) -> UnitQuaternion<f64> {
        if dt == 0.0 {
            return *orientation;
        }
        let mut q = orientation_after(orientation, &self.lab, dt);
        if self.body != V3::zeros() {
            q *= UnitQuaternion::from_scaled_axis(self.body * dt);
            q.renormalize_fast();
        }
        q
    }

    /// ω (lab frame) at the orientation `orientation`.
    #[inline]
    pub fn angular_velocity(&self, orientation: &UnitQuaternion<f64>) -> V3 {
        self.lab + orientation * self.body
    }
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

    /// A symmetric top's closed form against Euler's equations integrated
    /// by fourth-order Runge–Kutta: same orientation, same ω.
    #[test]
    fn symmetric_top_matches_euler_equations() {
        let (i1, i3) = (0.7, 0.25);
        let inertia = V3::new(i1, i1, i3);
        let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.4, -0.3, 1.1));
        let omega0 = V3::new(1.3, -0.4, 2.2);
        let e3 = q0 * V3::z();
        let w3 = omega0.dot(&e3);
        let spin = Spin {
            lab: omega0 + e3 * ((i3 / i1 - 1.0) * w3),
            body: V3::z() * (w3 * (1.0 - i3 / i1)),
        };
        // State: quaternion (4) and body-frame ω (3); Euler's equations.
        let deriv = |q: &nalgebra::Quaternion<f64>, w: &V3| {
            let wq = nalgebra::Quaternion::new(0.0, w.x, w.y, w.z);
            let dq = q * wq * 0.5;
            let dw = V3::new(
                (inertia.y - inertia.z) * w.y * w.z / inertia.x,
                (inertia.z - inertia.x) * w.z * w.x / inertia.y,
                (inertia.x - inertia.y) * w.x * w.y / inertia.z,
            );
            (dq, dw)
        };
        let (mut q, mut w) = (*q0.quaternion(), q0.inverse_transform_vector(&omega0));
        let (t, steps) = (2.5, 20_000);
        let h = t / steps as f64;
        for _ in 0..steps {
            let (k1q, k1w) = deriv(&q, &w);
            let (k2q, k2w) = deriv(&(q + k1q * (h / 2.0)), &(w + k1w * (h / 2.0)));
            let (k3q, k3w) = deriv(&(q + k2q * (h / 2.0)), &(w + k2w * (h / 2.0)));
            let (k4q, k4w) = deriv(&(q + k3q * h), &(w + k3w * h));
            q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
            w += (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
        }
        let q_rk = UnitQuaternion::from_quaternion(q);
        let q_closed = spin.orientation_after(&q0, t);
        assert!(
            q_rk.angle_to(&q_closed) < 1e-9,
            "{}",
            q_rk.angle_to(&q_closed)
        );
        let w_closed = spin.angular_velocity(&q_closed);
        assert!((w_closed - q_rk * w).norm() < 1e-9);
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
