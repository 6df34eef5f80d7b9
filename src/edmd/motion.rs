//! Free motion between events (De Michele Sec. 2.2): the centre moves in a
//! straight line (eq. 6a), and the body turns as a free rigid body with its
//! own principal moments, in closed form (Landau & Lifshitz, Mechanics §37;
//! van Zon & Schofield, J. Chem. Phys. 128, 154119 (2008)). The angular
//! momentum L is fixed in the lab; in the body it moves on Jacobi elliptic
//! functions,
//!
//!   L_a = A cn τ,  L_b = B sn τ,  L_c = C dn τ,  τ = ω_p t + τ₀,
//!
//! about the polar axis c (the largest moment when L² > 2E I_mid, else the
//! smallest) with b the middle axis; and the body turns about L by the
//! angle α whose rate, with Euler angles (α, θ, ψ) about L,
//!
//!   α̇ = L (L_a²/I_a + L_b²/I_b)/(L_a² + L_b²)
//!      = L/I_c + L (I_c − I_a)/(I_a I_c) / (1 + n sn² τ),
//!
//! integrates to an elliptic integral of the third kind: a linear term
//! plus ± arg θ₄ (`elliptic::ThetaTurn`), or Carlson's R_J where that
//! series would converge slowly. The characteristic n = I_c (I_b − I_a)/(I_a (I_c − I_b)) depends on the
//! moments alone. A symmetric top is the case m = k² = 0 and n = 0 (sn and
//! cn are sine and cosine, α̇ = L/I_a); a spherical top (De Michele's
//! eqs. 4–6b) also has ω_p = 0. Every case is set up by the same formulas;
//! where L stays put in the body (ω_p = 0) they reduce to a turn about L
//! at the constant rate α̇, evaluated as such.

use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

use super::elliptic::{Landen, ThetaTurn, carlson_rf, carlson_rj};

type V3 = Vector3<f64>;

/// The centre after a time `dt` of free flight (eq. 6a).
#[inline]
pub fn position_after(position: &V3, velocity: &V3, dt: f64) -> V3 {
    position + velocity * dt
}

/// (cos θ/2, sin θ/2) times a factor > 0, for the angle θ in (−π, π]
/// with (sin θ, cos θ) = (`s`, `c`)/`r`: (r + c, s) = 2r cos(θ/2) (cos θ/2,
/// sin θ/2), or where that cancels (c < 0) (s, r − c) = 2r sin(θ/2) (…),
/// its sign taken out. No root and no quotient: the pose they build is
/// normalised once, at the end.
#[inline]
fn half_angle(s: f64, c: f64, r: f64) -> (f64, f64) {
    if c >= 0.0 {
        (r + c, s)
    } else if s < 0.0 {
        (-s, c - r)
    } else {
        (s, r - c)
    }
}

/// (sin x, cos x). A search asks for poses a short step apart, so the
/// half-turns are mostly small: up to |x| = 1/4 by the Taylor series to
/// x¹³ and x¹² (truncation below 3·10⁻¹⁸ absolute, under 0.1 ulp), beyond
/// by the library.
#[inline]
fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() > 0.25 {
        return x.sin_cos();
    }
    let y = x * x;
    let sin = x
        * (1.0
            + y * (-1.0 / 6.0
                + y * (1.0 / 120.0
                    + y * (-1.0 / 5040.0
                        + y * (1.0 / 362_880.0
                            + y * (-1.0 / 39_916_800.0 + y * (1.0 / 6_227_020_800.0)))))));
    let cos = 1.0
        + y * (-0.5
            + y * (1.0 / 24.0
                + y * (-1.0 / 720.0
                    + y * (1.0 / 40_320.0
                        + y * (-1.0 / 3_628_800.0 + y * (1.0 / 479_001_600.0))))));
    (sin, cos)
}

/// One free rigid body's rotation from a given pose: the orientation and
/// the angular velocity at any later time, exact to rounding.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeTop {
    /// The orientation at t = 0 (body → lab).
    start: UnitQuaternion<f64>,
    /// L in the lab frame, fixed.
    momentum: V3,
    /// A spherical top's ω, fixed, kept as given: it survives a restart
    /// to the bit (L/I would round it).
    steady_omega: Option<V3>,
    /// I along the body axes.
    body_moments: V3,
    /// |L|.
    size: f64,
    /// The lab frame with z along L, at α = 0.
    frame: UnitQuaternion<f64>,
    /// From the body axes to the ordered principal axes (a, b, c).
    from_body: Quaternion<f64>,
    /// The ordered moments (I_a, I_b, I_c).
    moments: V3,
    /// ω_p: the rate of τ.
    rate: f64,
    /// τ₀.
    phase: f64,
    /// The parameter m = k² and 1 − m.
    m: f64,
    m_complement: f64,
    /// m's Landen sequence, for sn, cn and dn.
    landen: Landen,
    /// The turn about L as a θ-series, where it converges fast (else
    /// each pose takes an R_J).
    theta: Option<ThetaTurn>,
    /// The characteristic n.
    n: f64,
    /// A, B, C (B and C signed).
    amplitude: V3,
    /// (A, B, C)/|L|.
    unit_amplitude: V3,
    /// α̇ = a + b/(1 + n sn²): (a, b) = (L/I_c, L (I_c − I_a)/(I_a I_c)).
    alpha_rates: (f64, f64),
    /// (A, B)/|(A, B)| from the moments alone, so that ψ stays defined
    /// where L lies along the polar axis.
    direction: (f64, f64),
    /// The quarter period K and H(K) = R_J(0, k′², 1, 1 + n)/3, finite
    /// (1 − m is kept positive).
    quarter: f64,
    half_turn: f64,
    /// H(τ₀).
    turned_at_start: f64,
    /// With the θ-series: θ₄ at τ₀, and the rate α̇ of α's part linear
    /// in t.
    theta_at_start: (f64, f64),
    theta_rate: f64,
    /// Where L stays put in the body (ω_p = 0: a spherical top, or L along
    /// a principal axis) the body turns about the fixed L at the constant
    /// rate α̇: (α̇, L/|L|), for a spherical top (|ω|, ω/|ω|).
    steady: Option<(f64, V3)>,
    /// A symmetric top (two moments equal, not the third): its turn in
    /// closed form without elliptic functions.
    symmetric: Option<SymmetricTurn>,
    /// The largest |ω| and |ω̇| (body frame) over the motion.
    max_speed: f64,
    max_acceleration: f64,
}

impl FreeTop {
    /// The free rotation of a body with principal moments `moments` (along
    /// its body axes, each > 0) that has orientation `start` and lab-frame
    /// angular velocity `omega` at t = 0.
    pub fn new(moments: V3, start: UnitQuaternion<f64>, omega: V3) -> Self {
        let body_l = moments.component_mul(&start.inverse_transform_vector(&omega));
        let spherical = moments.x == moments.y && moments.y == moments.z;
        let momentum = if spherical {
            omega * moments.x
        } else {
            start * body_l
        };
        let size = body_l.norm();
        let mut top = Self {
            start,
            momentum,
            steady_omega: spherical.then_some(omega),
            body_moments: moments,
            size,
            frame: start,
            from_body: Quaternion::identity(),
            moments,
            rate: 0.0,
            phase: 0.0,
            m: 0.0,
            m_complement: 1.0,
            landen: Landen::new(0.0, 1.0),
            theta: None,
            n: 0.0,
            amplitude: V3::zeros(),
            unit_amplitude: V3::zeros(),
            alpha_rates: (0.0, 0.0),
            direction: (1.0, 1.0),
            quarter: std::f64::consts::FRAC_PI_2,
            half_turn: 0.0,
            turned_at_start: 0.0,
            theta_at_start: (1.0, 0.0),
            theta_rate: 0.0,
            steady: None,
            symmetric: None,
            max_speed: 0.0,
            max_acceleration: 0.0,
        };
        if size == 0.0 {
            return top;
        }
        // The axes ordered by moment, and the polar axis from the sign of
        // L² − 2E I_mid = Σ L_i² (1 − I_mid/I_i) (ties: the odd moment).
        let mut order = [0usize, 1, 2];
        order.sort_by(|&i, &j| moments[i].total_cmp(&moments[j]));
        let [lo, mid, hi] = order;
        let lsq = body_l.component_mul(&body_l);
        let beyond_mid: f64 = (0..3)
            .map(|i| lsq[i] * (1.0 - moments[mid] / moments[i]))
            .sum();
        let polar_hi = beyond_mid > 0.0 || (beyond_mid == 0.0 && moments[mid] != moments[hi]);
        let (a, c) = if polar_hi { (lo, hi) } else { (hi, lo) };
        let b = mid;
        // A proper rotation from (a, b, c) to the body axes.
        let mut axes = Matrix3::zeros();
        axes[(a, 0)] = 1.0;
        axes[(b, 1)] = 1.0;
        axes[(c, 2)] = 1.0;
        if axes.determinant() < 0.0 {
            axes[(c, 2)] = -1.0;
        }
        let abc_to_body =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(axes));
        let l = abc_to_body.inverse_transform_vector(&body_l);
        let (ia, ib, ic) = (moments[a], moments[b], moments[c]);
        top.moments = V3::new(ia, ib, ic);
        top.from_body = abc_to_body.inverse().into_inner();
        let (la2, lb2, lc2) = (l.x * l.x, l.y * l.y, l.z * l.z);
        if ia != ic {
            // P = 2E I_c − L² and Q = L² − 2E I_a, as sums of terms of one
            // sign (that of I_c − I_a).
            let p = la2 * (ic - ia) / ia + lb2 * (ic - ib) / ib;
            let q = lb2 * (ib - ia) / ib + lc2 * (ic - ia) / ic;
            // A² = I_a P/(I_c − I_a), B² = I_b P/(I_c − I_b) and
            // C² = I_c Q/(I_c − I_a), each written as L_i² plus a term of
            // its sign.
            let amp_a = (la2 + lb2 * (ia * (ic - ib)) / (ib * (ic - ia))).sqrt();
            let amp_b = (lb2 + la2 * (ib * (ic - ia)) / (ia * (ic - ib))).sqrt();
            let amp_c = (lc2 + lb2 * (ic * (ib - ia)) / (ib * (ic - ia))).sqrt();
            // ω_p B = (1/I_a − 1/I_c) A C: B carries sign(I_c − I_a) sign(C).
            let sign_c = if l.z < 0.0 { -1.0 } else { 1.0 };
            let sign_b = sign_c * (ic - ia).signum();
            top.amplitude = V3::new(amp_a, sign_b * amp_b, sign_c * amp_c);
            let (da, db) = ((ia * (ic - ib)).abs().sqrt(), (ib * (ic - ia)).abs().sqrt());
            let norm = (da * da + db * db).sqrt();
            top.direction = (da / norm, sign_b * db / norm);
            top.rate = (q * (ic - ib) / (ia * ib * ic)).max(0.0).sqrt();
            top.n = ic * (ib - ia) / (ia * (ic - ib));
            let (num, den) = ((ib - ia) * p, (ic - ib) * q);
            // 1 − m = (I_c − I_a)(L² − 2E I_b)/((I_c − I_b) Q), read off
            // sums as well; on the separatrix itself 1 − m is kept the
            // smallest positive number, so that the period stays finite.
            let beyond = la2 * (ia - ib) / ia + lc2 * (ic - ib) / ic;
            if num == 0.0 || den == 0.0 {
                (top.m, top.m_complement) = (0.0, 1.0);
            } else {
                top.m = (num / den).clamp(0.0, 1.0);
                top.m_complement = ((ic - ia) * beyond / den).clamp(f64::MIN_POSITIVE, 1.0);
            }
            if la2 == 0.0 && lc2 == 0.0 && ia != ib && ib != ic {
                // L along the middle axis: a steady (unstable) turn about
                // it, written with sn = ±1 at m = 0.
                (top.m, top.m_complement, top.rate) = (0.0, 1.0, 0.0);
                top.amplitude = V3::new(0.0, sign_b * l.y.abs(), 0.0);
            }
        } else {
            let perp = (la2 + lb2).sqrt();
            top.amplitude = V3::new(perp, perp, l.z);
        }
        // K and F(φ|m), which for m = 0 are π/2 and φ.
        top.quarter = if top.m == 0.0 {
            std::f64::consts::FRAC_PI_2
        } else {
            carlson_rf(0.0, top.m_complement, 1.0)
        };
        if top.n != 0.0 {
            top.half_turn = carlson_rj(0.0, top.m_complement, 1.0, 1.0 + top.n) / 3.0;
        }
        top.landen = Landen::new(top.m, top.m_complement);
        top.unit_amplitude = top.amplitude / size;
        let (ia, ic) = (top.moments.x, top.moments.z);
        top.alpha_rates = (size / ic, size * (ic - ia) / (ia * ic));
        if top.rate > 0.0 {
            // Π(−n | m) = K − n H(K).
            let complete = top.quarter - top.n * top.half_turn;
            top.theta = ThetaTurn::new(top.m, top.m_complement, top.n, top.quarter, complete);
            if let Some(theta) = &top.theta {
                top.theta_rate = top.alpha_rates.0 + top.alpha_rates.1 * theta.mean;
            }
        }
        // τ₀ = F(φ₀) from the amplitude φ₀ = am τ₀ = atan2(sn, cn).
        let (amp_a, amp_b) = (top.amplitude.x, top.amplitude.y);
        // (sn, cn) as read off L (not through the angle, which would
        // lose cn's relative precision where it is small).
        let (sn0, cn0) = match (amp_a > 0.0, amp_b != 0.0) {
            (true, true) => (l.y / amp_b, l.x / amp_a),
            (false, true) => ((l.y / amp_b).signum(), 0.0),
            _ => (0.0, 1.0),
        };
        let norm = (sn0 * sn0 + cn0 * cn0).sqrt();
        let (s, c) = (sn0 / norm, cn0 / norm);
        // φ₀ − turns π in [−π/2, π/2].
        let (turns, s, c) = if c >= 0.0 {
            (0.0, s, c)
        } else {
            (if s < 0.0 { -1.0 } else { 1.0 }, -s, -c)
        };
        let partial = if top.m == 0.0 {
            s.atan2(c)
        } else {
            s * carlson_rf(c * c, top.m_complement + top.m * c * c, 1.0)
        };
        top.phase = 2.0 * turns * top.quarter + partial;
        let (sn0, cn0, dn0, h0, theta0) = top.elliptic(top.phase);
        (top.turned_at_start, top.theta_at_start) = (h0, theta0);
        let tilt = top.tilt(sn0, cn0, dn0).normalize();
        top.frame = UnitQuaternion::new_normalize(
            start.quaternion() * abc_to_body.quaternion() * tilt.conjugate(),
        );
        (top.max_speed, top.max_acceleration) = top.polhode_extremes();
        if top.rate == 0.0 {
            let (ia, ic) = (top.moments.x, top.moments.z);
            let slowed = 1.0 / (1.0 + top.n * sn0 * sn0);
            let alpha_rate = size * (1.0 / ic + (ic - ia) / (ia * ic) * slowed);
            // frame · Rz(α) · frame⁻¹ is the turn by α about L.
            top.steady = Some(match top.steady_omega {
                Some(omega) => (omega.norm(), omega / omega.norm()),
                None => (alpha_rate, momentum / momentum.norm()),
            });
        } else if let Some(k) = odd_moment(&moments) {
            top.symmetric = Some(SymmetricTurn::new(&top, k, &body_l));
        }
        top
    }

    /// sn, cn, dn at τ and H(τ) = ∫₀^τ sn²/(1 + n sn²), or with the
    /// θ-series θ₄(x + i y) (see [`ThetaTurn`]) in its place.
    #[inline]
    fn elliptic(&self, tau: f64) -> (f64, f64, f64, f64, (f64, f64)) {
        let half_periods = (tau / (2.0 * self.quarter)).round();
        let r = tau - 2.0 * self.quarter * half_periods;
        let ([s, c, d], angle) = self.landen.reduced(r, self.quarter);
        let odd = (0.5 * half_periods).fract() != 0.0;
        let sign = if odd { -1.0 } else { 1.0 };
        if let Some(theta) = &self.theta {
            return (sign * s, sign * c, d, 0.0, theta.theta4(angle));
        }
        let turned = if self.n == 0.0 || s == 0.0 {
            2.0 * half_periods * self.half_turn
        } else {
            let h = s * s * s * carlson_rj(c * c, d * d, 1.0, 1.0 + self.n * s * s) / 3.0;
            2.0 * half_periods * self.half_turn + h
        };
        (sign * s, sign * c, d, turned, (1.0, 0.0))
    }

    /// The rotation Rx(θ) Rz(ψ) taking L/|L| in the (a, b, c) frame to z,
    /// at the phase with these sn, cn, dn, times a factor > 0.
    #[inline]
    fn tilt(&self, sn: f64, cn: f64, dn: f64) -> Quaternion<f64> {
        let (la, lb, lc) = (
            self.unit_amplitude.x * cn,
            self.unit_amplitude.y * sn,
            self.unit_amplitude.z * dn,
        );
        let perp = (la * la + lb * lb).sqrt();
        let (w, x) = half_angle(perp, lc, 1.0);
        let (dir_a, dir_b) = self.direction;
        let (s, c) = (dir_a * cn, dir_b * sn);
        let (w2, z) = half_angle(s, c, (s * s + c * c).sqrt());
        // (w + x i)(w2 + z k).
        Quaternion::new(w * w2, x * w2, -x * z, w * z)
    }

    /// The orientation a time `t` after the start.
    pub fn orientation_after(&self, t: f64) -> UnitQuaternion<f64> {
        if t == 0.0 || self.size == 0.0 {
            return self.start;
        }
        if let Some((alpha_rate, axis)) = self.steady {
            let (sin, cos) = sin_cos(0.5 * alpha_rate * t);
            let turn = Quaternion::from_parts(cos, axis * sin);
            return UnitQuaternion::new_normalize(turn * self.start.quaternion());
        }
        if let Some(symmetric) = &self.symmetric {
            return symmetric.orientation_after(self.start.quaternion(), t);
        }
        let tau = self.phase + self.rate * t;
        let (sn, cn, dn, turned, theta) = self.elliptic(tau);
        let precession = if self.theta.is_some() {
            // α = α̇ t ± (arg θ₄(τ) − arg θ₄(τ₀)), the sign of I_c − I_a:
            // e^(iα/2) from the square root of θ₄(τ) θ₄(τ₀)* or its
            // conjugate, on its principal branch (Re θ₄ > 0).
            let (re0, im0) = self.theta_at_start;
            let (re, im) = (theta.0 * re0 + theta.1 * im0, theta.1 * re0 - theta.0 * im0);
            let im = if self.alpha_rates.1 < 0.0 { -im } else { im };
            let (w, z) = half_angle(im, re, (re * re + im * im).sqrt());
            let (sin, cos) = sin_cos(0.5 * self.theta_rate * t);
            Quaternion::new(cos * w - sin * z, 0.0, 0.0, sin * w + cos * z)
        } else {
            // ∫ dt/(1 + n sn²) = t − (n/ω_p) (H(τ) − H(τ₀)).
            let slowed = if self.n == 0.0 {
                t
            } else if self.rate == 0.0 {
                t / (1.0 + self.n * sn * sn)
            } else {
                t - self.n / self.rate * (turned - self.turned_at_start)
            };
            let alpha = self.alpha_rates.0 * t + self.alpha_rates.1 * slowed;
            let (sin, cos) = sin_cos(0.5 * alpha);
            Quaternion::new(cos, 0.0, 0.0, sin)
        };
        let q = self.frame.quaternion() * precession * self.tilt(sn, cn, dn) * self.from_body;
        UnitQuaternion::new_unchecked(q * (1.0 / q.norm()))
    }

    /// ω (lab frame) at the orientation `orientation` of this motion:
    /// I⁻¹ L, with L fixed.
    #[inline]
    pub fn angular_velocity(&self, orientation: &UnitQuaternion<f64>) -> V3 {
        match self.steady_omega {
            Some(omega) => omega,
            None => orientation * self.body_angular_velocity(orientation),
        }
    }

    /// ω (body frame) at `orientation`.
    #[inline]
    pub fn body_angular_velocity(&self, orientation: &UnitQuaternion<f64>) -> V3 {
        orientation
            .inverse_transform_vector(&self.momentum)
            .component_div(&self.body_moments)
    }

    /// The orientation at t = 0.
    pub fn start(&self) -> UnitQuaternion<f64> {
        self.start
    }

    /// L (lab frame).
    pub fn momentum(&self) -> V3 {
        self.momentum
    }

    /// L in the body frame a time `t` after the start, from the elliptic
    /// functions alone (not through the orientation): with
    /// `orientation_after`, an independent check that L stays fixed.
    pub fn body_momentum_after(&self, t: f64) -> V3 {
        if self.size == 0.0 {
            return V3::zeros();
        }
        let (sn, cn, dn, _, _) = self.elliptic(self.phase + self.rate * t);
        let abc = self.amplitude.component_mul(&V3::new(cn, sn, dn));
        UnitQuaternion::new_unchecked(self.from_body).inverse_transform_vector(&abc)
    }

    /// A body of unit moments (a spherical top) at `start` turning at the
    /// constant lab angular velocity `omega`.
    pub fn spherical(start: UnitQuaternion<f64>, omega: V3) -> Self {
        Self::new(V3::repeat(1.0), start, omega)
    }

    /// The angular velocity's largest size over the motion (on the
    /// polhode, the body's energy and angular-momentum surface), rounded
    /// up.
    #[inline]
    pub fn max_angular_speed(&self) -> f64 {
        self.max_speed
    }

    /// The largest |ω̇| (body frame) over the motion, rounded up.
    #[inline]
    pub fn max_body_acceleration(&self) -> f64 {
        self.max_acceleration
    }

    /// The largest |ω| and |ω̇| (body frame) on the polhode. With
    /// s = sn² τ, which sweeps [0, 1], and ω_i = L_i/I_i,
    ///
    ///   |ω|² = A²(1 − s)/I_a² + B² s/I_b² + C²(1 − m s)/I_c²
    ///
    /// is linear in s, and from Euler's I ω̇ = L × ω,
    ///
    ///   |ω̇|² = k_a s(1 − m s) + k_b (1 − s)(1 − m s) + k_c s(1 − s),
    ///   k_a = (B C (1/I_c − 1/I_b)/I_a)², and so on cyclically,
    ///
    /// is quadratic: each is largest at an end or at the vertex. Each is
    /// capped by the bounds that need no polhode, |ω|² ≤ min(L²/I_min²,
    /// 2E/I_min) and |ω̇| ≤ L² (1/I_min − 1/I_max)/(2 I_min) (from
    /// L × I⁻¹ L = L × (I⁻¹ − c) L for the mean c of the extreme 1/I), and
    /// both are rounded up by far more than their rounding.
    fn polhode_extremes(&self) -> (f64, f64) {
        const UP: f64 = 1.0 + 1e-12;
        if let Some(omega) = self.steady_omega {
            // |ω| itself: only its own rounding to cover.
            return (omega.norm() * (1.0 + 8.0 * f64::EPSILON), 0.0);
        }
        let least = self.body_moments.min();
        let body_l = self.start.inverse_transform_vector(&self.momentum);
        let energy2 = body_l
            .component_mul(&body_l)
            .component_div(&self.body_moments)
            .sum();
        let speed_cap = (self.size / least).min((energy2 / least).sqrt());
        let hi = 1.0 / least;
        let lo = 1.0 / self.body_moments.max();
        let acceleration_cap = self.size * self.size * 0.5 * (hi - lo) * hi;
        let (ia, ib, ic) = (self.moments.x, self.moments.y, self.moments.z);
        let (a, b, c) = (self.amplitude.x, self.amplitude.y, self.amplitude.z);
        let m = self.m;
        let (wa, wb, wc) = ((a / ia).powi(2), (b / ib).powi(2), (c / ic).powi(2));
        let speed2 = (wa + wc).max(wb + (1.0 - m) * wc);
        let ka = (b * c * (1.0 / ic - 1.0 / ib) / ia).powi(2);
        let kb = (c * a * (1.0 / ia - 1.0 / ic) / ib).powi(2);
        let kc = (a * b * (1.0 / ib - 1.0 / ia) / ic).powi(2);
        // g(s) = kb + c1 s + c2 s².
        let c1 = ka - kb * (1.0 + m) + kc;
        let c2 = m * (kb - ka) - kc;
        let mut acceleration2 = kb.max(ka * (1.0 - m));
        if c2 < 0.0 {
            let vertex = -c1 / (2.0 * c2);
            if vertex > 0.0 && vertex < 1.0 {
                acceleration2 = acceleration2.max(kb - c1 * c1 / (4.0 * c2));
            }
        }
        (
            speed2.sqrt().min(speed_cap) * UP,
            acceleration2.sqrt().min(acceleration_cap) * UP,
        )
    }
}

/// The axis whose moment differs from the two others, which are equal:
/// the symmetry axis of a symmetric top (None for spherical and asymmetric
/// tops).
fn odd_moment(moments: &V3) -> Option<usize> {
    let (x, y, z) = (moments.x, moments.y, moments.z);
    match (x == y, y == z, x == z) {
        (true, false, _) => Some(2),
        (false, true, _) => Some(0),
        (false, false, true) => Some(1),
        _ => None,
    }
}

/// The free turn of a symmetric top (Landau & Lifshitz, Mechanics §33):
/// ω = L/I⊥ + L_s (1/I_s − 1/I⊥) s, so the body precesses about the fixed
/// L at the rate |L|/I⊥ and spins about its symmetry axis s at
/// Ω_s = L_s (1/I_s − 1/I⊥), L_s = L·s being fixed:
///
///   q(t) = R_L(|L| t/I⊥) q(0) R_s(Ω_s t).
///
/// The two turns commute with what they act on (R_s leaves s, so L_s, as
/// it is; R_L leaves L), and differentiating gives q̇ = ½ ω q.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SymmetricTurn {
    /// L/|L|, lab frame.
    momentum_axis: V3,
    /// |L|/I⊥.
    precession_rate: f64,
    /// The symmetry axis in the body frame (a unit vector along it).
    body_axis: V3,
    /// Ω_s.
    spin_rate: f64,
}

impl SymmetricTurn {
    /// The turn of `top` (L ≠ 0), whose odd moment is along body axis `k`,
    /// with body-frame angular momentum `body_l` at t = 0.
    fn new(top: &FreeTop, k: usize, body_l: &V3) -> Self {
        let moments = top.body_moments;
        let (axial, perpendicular) = (moments[k], moments[(k + 1) % 3]);
        Self {
            momentum_axis: top.momentum / top.momentum.norm(),
            precession_rate: top.size / perpendicular,
            body_axis: V3::ith(k, 1.0),
            spin_rate: body_l[k] * (1.0 / axial - 1.0 / perpendicular),
        }
    }

    /// The orientation a time `t` after `start`.
    #[inline]
    fn orientation_after(&self, start: &Quaternion<f64>, t: f64) -> UnitQuaternion<f64> {
        let (sin_p, cos_p) = sin_cos(0.5 * self.precession_rate * t);
        let (sin_s, cos_s) = sin_cos(0.5 * self.spin_rate * t);
        let precession = Quaternion::from_parts(cos_p, self.momentum_axis * sin_p);
        let spin = Quaternion::from_parts(cos_s, self.body_axis * sin_s);
        UnitQuaternion::new_normalize(precession * start * spin)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn small_turns_have_the_library_sine_and_cosine_to_an_ulp() {
        let mut worst: f64 = 0.0;
        for k in -10_000..=10_000 {
            // Up to the switch, and a hair past it.
            let x = 0.2500001 * k as f64 / 10_000.0;
            let (s, c) = sin_cos(x);
            let (s_lib, c_lib) = x.sin_cos();
            let ulp = |v: f64| f64::EPSILON * v.abs().max(f64::MIN_POSITIVE);
            worst = worst.max((s - s_lib).abs() / ulp(s_lib));
            worst = worst.max((c - c_lib).abs() / ulp(c_lib));
        }
        assert!(worst <= 1.0, "{worst} ulp");
        // A series one term short is off by more.
        let x = 0.25f64;
        let y = x * x;
        let short = 1.0 + y * (-0.5 + y * (1.0 / 24.0 + y * (-1.0 / 720.0)));
        assert!((short - x.cos()).abs() > f64::EPSILON);
    }

    /// The same top with its turn taken by R_J at every pose.
    fn by_carlson(top: &FreeTop) -> FreeTop {
        let mut plain = *top;
        plain.theta = None;
        plain.turned_at_start = plain.elliptic(plain.phase).3;
        // θ-series and R_J turn alike only if the series' weight w is the
        // reciprocal of L (I_c − I_a)/(I_a I_c ω_p), as the algebra says.
        let gain = top.alpha_rates.1 / top.rate * top.theta.unwrap().weight;
        assert!((gain.abs() - 1.0).abs() < 1e-13, "{gain}");
        plain
    }

    /// Thermal tops of a triaxial ellipsoid (1 : 0.6 : 0.3) and of a brick,
    /// their moments in every order: the θ-series and R_J give the same
    /// orientation within 1e-12 over a hundred turns, and the series is
    /// taken for nearly all of them (what makes a pose cheap).
    #[test]
    fn the_theta_series_and_carlson_turn_a_top_alike() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let shapes = [V3::new(0.45, 1.09, 1.36), V3::new(0.2225, 0.4225, 0.52)];
        let (mut tops, mut series) = (0, 0);
        for moments in shapes {
            for turn in 0..3 {
                let moments = V3::from_fn(|i, _| moments[(i + turn) % 3]);
                for _ in 0..200 {
                    let body_omega = V3::from_fn(|i, _| {
                        let g: f64 = rng.sample(rand_distr::StandardNormal);
                        g / moments[i].sqrt()
                    });
                    let start = UnitQuaternion::from_scaled_axis(V3::from_fn(|_, _| {
                        rng.gen_range(-2.0..2.0)
                    }));
                    let top = FreeTop::new(moments, start, start * body_omega);
                    tops += 1;
                    if top.theta.is_none() {
                        continue;
                    }
                    series += 1;
                    let plain = by_carlson(&top);
                    let period = 2.0 * std::f64::consts::PI / body_omega.norm();
                    for k in 1..=20 {
                        let t = period * 5.0 * k as f64 + 0.37 * k as f64;
                        let (a, b) = (top.orientation_after(t), plain.orientation_after(t));
                        let angle = a.angle_to(&b);
                        assert!(angle < 1e-12, "{moments} {body_omega} t {t}: {angle:e}");
                    }
                }
            }
        }
        eprintln!("θ-series taken for {series} of {tops} thermal tops");
        assert!(series as f64 > 0.9 * tops as f64, "{series} of {tops}");
    }

    /// Symmetric tops (prolate and oblate, the symmetry axis along each body
    /// axis in turn): the closed form of precession and spin gives the
    /// orientation the elliptic-function route gives, within 1e-12 over a
    /// hundred turns; and it is taken for every one of them.
    #[test]
    fn a_symmetric_top_turns_as_the_elliptic_route_says() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        for (axial, perpendicular) in [(0.2, 0.65), (0.65, 0.4)] {
            for k in 0..3 {
                let moments = V3::from_fn(|i, _| if i == k { axial } else { perpendicular });
                for _ in 0..100 {
                    let body_omega = V3::from_fn(|i, _| {
                        let g: f64 = rng.sample(rand_distr::StandardNormal);
                        g / moments[i].sqrt()
                    });
                    let start = UnitQuaternion::from_scaled_axis(V3::from_fn(|_, _| {
                        rng.gen_range(-2.0..2.0)
                    }));
                    let top = FreeTop::new(moments, start, start * body_omega);
                    assert!(top.symmetric.is_some(), "{moments}");
                    let mut elliptic = top;
                    elliptic.symmetric = None;
                    let period = 2.0 * std::f64::consts::PI / body_omega.norm();
                    for j in 1..=20 {
                        let t = period * 5.0 * j as f64 + 0.37 * j as f64;
                        let (a, b) = (top.orientation_after(t), elliptic.orientation_after(t));
                        let angle = a.angle_to(&b);
                        assert!(angle < 1e-12, "{moments} {body_omega} t {t}: {angle:e}");
                    }
                }
            }
        }
    }
}
