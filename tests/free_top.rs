//! The free rotation of a single rigid body in closed form (`FreeTop`,
//! Jacobi elliptic functions and Carlson's R_J) against physics: the
//! orientation against Euler's equations integrated to a precision the
//! test measures, the lab angular momentum and the energy over 10⁴
//! periods (read off the closed form, and carried through a restart at
//! every step as the dynamics restarts a body at each event), and the
//! intermediate-axis instability with the period Landau's solution gives.

use hardbody::edmd::motion::FreeTop;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

type V3 = Vector3<f64>;

/// Euler's equations (body frame) and q̇ = q ω/2, by fourth-order
/// Runge–Kutta in `steps` steps: the orientation and the lab ω after `t`.
fn euler_equations(
    moments: V3,
    q0: UnitQuaternion<f64>,
    omega0: V3,
    t: f64,
    steps: usize,
) -> (UnitQuaternion<f64>, V3) {
    let deriv = |q: &Quaternion<f64>, w: &V3| {
        let dq = q * Quaternion::new(0.0, w.x, w.y, w.z) * 0.5;
        let dw = V3::new(
            (moments.y - moments.z) * w.y * w.z / moments.x,
            (moments.z - moments.x) * w.z * w.x / moments.y,
            (moments.x - moments.y) * w.x * w.y / moments.z,
        );
        (dq, dw)
    };
    let (mut q, mut w) = (*q0.quaternion(), q0.inverse_transform_vector(&omega0));
    let h = t / steps as f64;
    for _ in 0..steps {
        let (k1q, k1w) = deriv(&q, &w);
        let (k2q, k2w) = deriv(&(q + k1q * (h / 2.0)), &(w + k1w * (h / 2.0)));
        let (k3q, k3w) = deriv(&(q + k2q * (h / 2.0)), &(w + k2w * (h / 2.0)));
        let (k4q, k4w) = deriv(&(q + k3q * h), &(w + k3w * h));
        q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
        w += (k1w + k2w * 2.0 + k3w * 2.0 + k4w) * (h / 6.0);
    }
    let q = UnitQuaternion::from_quaternion(q);
    (q, q * w)
}

/// The angle between two orientations (q and −q are one rotation), from
/// the vector part of a⁻¹b, which keeps its digits for small angles.
fn angle(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    let turn = a.inverse() * b;
    2.0 * turn.imag().norm().min(1.0).asin()
}

/// Landau's period of the body-frame motion, 4K(m)/ω_p, from the moments
/// and L, E (I₁ < I₂ < I₃ along x, y, z; L² > 2E I₂).
fn landau_period(moments: V3, l2: f64, e2: f64) -> f64 {
    let (i1, i2, i3) = (moments.x, moments.y, moments.z);
    let rate = ((i3 - i2) * (l2 - e2 * i1) / (i1 * i2 * i3)).sqrt();
    let m = (i2 - i1) * (e2 * i3 - l2) / ((i3 - i2) * (l2 - e2 * i1));
    4.0 * ellip::ellipk(m).unwrap() / rate
}

/// Asymmetric tops in both regimes (L² above and below 2E I_mid), their
/// moments in any order along the body axes, symmetric tops (oblate and
/// prolate) and a spherical top: the closed form's orientation and ω
/// against Euler's equations over several periods, within 1e-10. The
/// reference's own error is measured by halving its step.
#[test]
fn the_closed_form_follows_euler_equations_to_1e_10() {
    let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.9, -0.2, 0.4));
    let cases = [
        (V3::new(1.0, 0.6, 0.3), V3::new(0.4, -1.1, 2.5)),
        (V3::new(1.0, 0.6, 0.3), V3::new(2.2, 0.9, -0.3)),
        (V3::new(0.45, 0.2, 0.8), V3::new(-1.3, 0.8, 1.0)),
        (V3::new(0.6, 0.3, 1.0), V3::new(-0.2, 0.5, 3.0)),
        (V3::new(0.7, 0.7, 0.2), V3::new(1.0, 2.0, 3.0)),
        (V3::new(0.25, 0.7, 0.7), V3::new(1.3, -0.4, 2.2)),
        (V3::new(0.5, 0.5, 0.5), V3::new(1.3, -0.4, 2.2)),
    ];
    for (moments, omega) in cases {
        let top = FreeTop::new(moments, q0, omega);
        let t = 12.0;
        let (q_ref, w_ref) = euler_equations(moments, q0, omega, t, 120_000);
        let (q_half, _) = euler_equations(moments, q0, omega, t, 60_000);
        // RK4: the error of the finer run is the difference over 15.
        let reference_error = angle(&q_ref, &q_half) / 15.0;
        assert!(reference_error < 1e-12, "reference {reference_error:e}");
        let q = top.orientation_after(t);
        let error = angle(&q, &q_ref);
        eprintln!(
            "moments {moments:?}: closed form vs Euler {error:.1e} (reference {reference_error:.1e})"
        );
        assert!(error < 1e-10, "{moments:?} {omega:?}: {error:e}");
        assert!((top.angular_velocity(&q) - w_ref).norm() < 1e-10 * w_ref.norm());
    }
}

/// Over 10⁴ periods of the body-frame motion, L (lab) and the energy stay
/// fixed to 1e-12, read from the closed form at the end (the body-frame L
/// from the elliptic functions, turned to the lab by the orientation).
/// Restarted from its pose and ω seven times a period, as the dynamics
/// restarts a body at every event, each restart's round trip ω → L → ω
/// rounds L and E by about 1e-17 on average (measured 8e-13 after
/// 7 × 10⁴ restarts): 7 × 10⁴ restarts stay within 5e-12.
#[test]
fn angular_momentum_and_energy_hold_for_ten_thousand_periods() {
    let moments = V3::new(0.3, 0.6, 1.0);
    let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.3, 1.2, -0.7));
    let body_omega = V3::new(1.4, 1.1, 0.9);
    let omega = q0 * body_omega;
    let l_body = moments.component_mul(&body_omega);
    let (l2, e2) = (
        l_body.norm_squared(),
        l_body.component_mul(&body_omega).sum(),
    );
    assert!(l2 > e2 * moments.y);
    let period = landau_period(moments, l2, e2);
    let top = FreeTop::new(moments, q0, omega);
    let l_lab = top.momentum();
    let energy = |l: &V3| l.component_div(&moments).dot(l);
    for periods in [1.0, 10.0, 1e2, 1e3, 1e4] {
        let t = periods * period + 0.37;
        let q = top.orientation_after(t);
        let l = top.body_momentum_after(t);
        let l_error = (q * l - l_lab).norm() / l_lab.norm();
        let e_error = (energy(&l) / e2 - 1.0).abs();
        assert!(
            l_error < 1e-12 && e_error < 1e-12,
            "{periods} periods: L {l_error:e}, E {e_error:e}"
        );
    }
    // The body-frame motion has Landau's period.
    let l_period = top.body_momentum_after(period + 0.37);
    assert!((l_period - top.body_momentum_after(0.37)).norm() < 1e-12 * l2.sqrt());
    // Restarted seven times a period.
    let step = period / 7.0;
    let (mut q, mut w) = (q0, omega);
    let mut worst: f64 = 0.0;
    for k in 1..=70_000 {
        let top = FreeTop::new(moments, q, w);
        q = top.orientation_after(step);
        w = top.angular_velocity(&q);
        if k % 7_000 == 0 {
            let l = moments.component_mul(&q.inverse_transform_vector(&w));
            let drift = ((q * l - l_lab).norm() / l_lab.norm()).max((energy(&l) / e2 - 1.0).abs());
            worst = worst.max(drift);
        }
    }
    eprintln!("restarted 7 x 10^4 times: worst drift of L and E {worst:.1e}");
    assert!(worst < 5e-12, "{worst:e}");
}

/// The tennis-racket theorem: a body turning nearly about its middle axis
/// flips over, again and again. Started 1e-3 off the middle axis, the
/// closed form's ω along it changes sign at intervals of half of Landau's
/// period (the phase of sn moves by 2K between sign changes), as Euler's
/// equations say; about the largest and smallest axes it stays put.
#[test]
fn a_top_about_its_middle_axis_flips_over() {
    let moments = V3::new(0.3, 0.6, 1.0);
    let q0 = UnitQuaternion::identity();
    let body_omega = V3::new(1e-3, 2.0, 1e-3);
    let top = FreeTop::new(moments, q0, q0 * body_omega);
    let l_body = moments.component_mul(&body_omega);
    let (l2, e2) = (
        l_body.norm_squared(),
        l_body.component_mul(&body_omega).sum(),
    );
    // Landau's formula needs L² > 2E I₂ (else the roles of x and z swap).
    let period = if l2 > e2 * moments.y {
        landau_period(moments, l2, e2)
    } else {
        landau_period(V3::new(moments.z, moments.y, moments.x), l2, e2)
    };
    let dt = 1e-3;
    let mut flips = Vec::new();
    let mut last = body_omega.y;
    for k in 1..=((3.2 * period) / dt) as usize {
        let t = k as f64 * dt;
        let w = top.body_angular_velocity(&top.orientation_after(t));
        if w.y.signum() != last.signum() {
            flips.push(t);
        }
        last = w.y;
    }
    assert!(flips.len() >= 5, "{flips:?} (period {period})");
    for pair in flips.windows(2) {
        let gap = pair[1] - pair[0];
        assert!(
            (gap - 0.5 * period).abs() < 2.0 * dt,
            "flips {flips:?}, period {period}"
        );
    }
    // Euler's equations flip at the same times.
    let t = flips[2] + 0.1;
    let (q_ref, _) = euler_equations(moments, q0, q0 * body_omega, t, 200_000);
    assert!(angle(&top.orientation_after(t), &q_ref) < 1e-8);
    // About the largest and smallest axes, the same offset stays small.
    for axis in [0, 2] {
        let mut w0 = V3::repeat(1e-3);
        w0[axis] = 2.0;
        let top = FreeTop::new(moments, q0, w0);
        let worst = (1..2000)
            .map(|k| top.body_angular_velocity(&top.orientation_after(k as f64 * 0.01)))
            .map(|w| (w[axis] - 2.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3, "axis {axis}: {worst}");
    }
}

/// L along each principal axis, the unstable middle one included: a
/// steady turn about it at |ω|, to rounding.
#[test]
fn a_top_about_a_principal_axis_turns_steadily() {
    let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.4, -0.3, 1.1));
    let moments = V3::new(1.0, 0.6, 0.3);
    for axis in 0..3 {
        let omega = q0 * V3::ith(axis, 1.7);
        let top = FreeTop::new(moments, q0, omega);
        let t = 2.0;
        let expected = UnitQuaternion::from_scaled_axis(omega * t) * q0;
        let error = angle(&top.orientation_after(t), &expected);
        assert!(error < 1e-13, "axis {axis}: {error:e}");
    }
}

/// The turn bounds the contact search steps by: the largest |ω| and the
/// largest body-frame |ω̇| over the motion hold at every time of two
/// periods, and are reached there (within the sampling's reach), for
/// tops in both regimes with their moments in any order; ω̇ is read off
/// Euler's equations, I ω̇ = L × ω, at each sample, apart from the
/// polhode algebra the bounds come from.
#[test]
fn the_turn_bounds_hold_and_are_reached() {
    let cases = [
        (V3::new(0.45, 1.09, 1.36), V3::new(1.4, 1.1, 0.9)),
        (V3::new(0.45, 1.09, 1.36), V3::new(0.2, 1.9, 0.3)),
        (V3::new(1.0, 0.3, 0.6), V3::new(-0.7, 2.5, 0.4)),
        (V3::new(0.6, 1.0, 0.3), V3::new(1.2, -0.2, 3.0)),
        (V3::new(0.2, 0.2, 1.0), V3::new(0.5, 1.0, -2.0)),
        (V3::new(2.0, 2.0, 1.0), V3::new(0.5, 1.0, -2.0)),
    ];
    for (moments, body_omega) in cases {
        let q0 = UnitQuaternion::from_scaled_axis(V3::new(0.3, 1.2, -0.7));
        let top = FreeTop::new(moments, q0, q0 * body_omega);
        let (speed, acceleration) = (top.max_angular_speed(), top.max_body_acceleration());
        let l_body = moments.component_mul(&body_omega);
        let e2 = l_body.component_mul(&body_omega).sum();
        // Two periods of the slowest body-frame motion there is.
        let span =
            4.0 * std::f64::consts::PI * moments.max() / (e2.sqrt() * moments.min().sqrt()) * 20.0;
        let (mut top_speed, mut top_acceleration): (f64, f64) = (0.0, 0.0);
        for k in 0..=200_000 {
            let t = span * k as f64 / 200_000.0;
            let q = top.orientation_after(t);
            let w = top.body_angular_velocity(&q);
            let l = moments.component_mul(&w);
            let w_dot = l.cross(&w).component_div(&moments);
            assert!(
                w.norm() <= speed,
                "{moments} t {t}: |ω| {} > {speed}",
                w.norm()
            );
            assert!(
                w_dot.norm() <= acceleration,
                "{moments} t {t}: |ω̇| {} > {acceleration}",
                w_dot.norm()
            );
            top_speed = top_speed.max(w.norm());
            top_acceleration = top_acceleration.max(w_dot.norm());
        }
        assert!(
            top_speed > speed * (1.0 - 1e-6),
            "{moments}: {top_speed} of {speed}"
        );
        assert!(
            top_acceleration > acceleration * (1.0 - 1e-4),
            "{moments}: {top_acceleration} of {acceleration}"
        );
    }
}
