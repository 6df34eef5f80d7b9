//! Jacobi's elliptic functions and the integral of the third kind that a
//! free asymmetric top turns by, for one parameter at many arguments: what
//! depends on the parameter alone is worked out once (a top is built once
//! per event and asked for its pose many times per search).

/// Steps of the arithmetic-geometric mean kept (enough for any 1 − m of
/// a double).
const MEAN_STEPS: usize = 16;

/// The descending Landen sequence of a parameter m = k² (Bulirsch,
/// Numer. Math. 7, 78 (1965)): the arithmetic-geometric mean of 1 and k′,
/// from which sn, cn and dn of any argument take one sine and cosine at
/// the last step, then products and quotients back up the sequence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Landen {
    m: f64,
    m_complement: f64,
    /// a_j and b_j of the mean, a₀ = 1, b₀ = k′.
    a: [f64; MEAN_STEPS],
    b: [f64; MEAN_STEPS],
    /// 1/a_j.
    a_inverse: [f64; MEAN_STEPS],
    steps: usize,
    /// The mean itself, π/(2K).
    mean: f64,
}

impl Landen {
    /// The sequence of the parameter `m` in [0, 1] and its complement
    /// `m_complement` = 1 − m (given apart: near 1 it carries the digits).
    pub(crate) fn new(m: f64, m_complement: f64) -> Self {
        let mut landen = Self {
            m,
            m_complement,
            a: [0.0; MEAN_STEPS],
            b: [0.0; MEAN_STEPS],
            a_inverse: [0.0; MEAN_STEPS],
            steps: 0,
            mean: 1.0,
        };
        if m_complement <= 0.0 || m == 0.0 {
            return landen;
        }
        let (mut a, mut b) = (1.0, m_complement.sqrt());
        loop {
            landen.a[landen.steps] = a;
            landen.b[landen.steps] = b;
            landen.a_inverse[landen.steps] = 1.0 / a;
            landen.steps += 1;
            let mean = 0.5 * (a + b);
            if (a - b).abs() <= 1.5e-8 * a || landen.steps == MEAN_STEPS {
                a = mean;
                break;
            }
            b = (a * b).sqrt();
            a = mean;
        }
        landen.mean = a;
        landen
    }

    /// sn, cn and dn of `u`, with the sine and cosine of u π/(2K) (the
    /// angle of the last step).
    #[inline]
    pub(crate) fn at(&self, u: f64) -> ([f64; 3], (f64, f64)) {
        if self.m_complement <= 0.0 {
            let sech = 1.0 / u.cosh();
            return ([u.tanh(), sech, sech], (0.0, 1.0));
        }
        let (sin, cos) = (u * self.mean).sin_cos();
        if self.m == 0.0 || sin == 0.0 {
            return ([sin, cos, 1.0], (sin, cos));
        }
        // c_j = cot-like ratios carried back down the sequence.
        let mut ratio = cos / sin;
        let mut c = self.mean * ratio;
        let mut dn = 1.0;
        for j in (0..self.steps).rev() {
            ratio *= c;
            c *= dn;
            dn = (self.b[j] + ratio) / (self.a[j] + ratio);
            ratio = c * self.a_inverse[j];
        }
        let sn = (1.0 / (c * c + 1.0).sqrt()).copysign(sin);
        ([sn, c * sn, dn], (sin, cos))
    }

    /// sn, cn and dn of `r` in [−K, K] (`quarter` = K), with the sine and
    /// cosine of x = r π/(2K): beyond K/2 from the quarter-period shift
    /// sn(K − v) = cd v, cn(K − v) = k′ sd v, dn(K − v) = k′ nd v (A&S
    /// 16.8), so that cn keeps its relative precision where it is small
    /// (near the separatrix, for most of a period).
    #[inline]
    pub(crate) fn reduced(&self, r: f64, quarter: f64) -> ([f64; 3], (f64, f64)) {
        if r.abs() <= 0.5 * quarter {
            return self.at(r);
        }
        let v = quarter - r.abs();
        let ([s, c, d], (sin, cos)) = self.at(v);
        let k_complement = self.m_complement.sqrt();
        (
            [(c / d).copysign(r), k_complement * s / d, k_complement / d],
            // x = ±(π/2 − v π/(2K)).
            (cos.copysign(r), sin),
        )
    }
}

/// Terms of the θ₄ series kept (q^(k²) e^(2ky) falls below 1e-18 by the
/// eighth wherever the series is used).
const THETA_TERMS: usize = 8;

/// The turn of an asymmetric top as a θ-function: for n > 0 and 0 < m < 1,
///
///   ∫₀^τ dv/(1 + n sn² v) = ⟨f⟩ τ + w arg θ₄(x + i y | q),
///
/// with x = π τ/(2K), the nome q = exp(−π K′/K), y = π b/(2K) where
/// sn²(b | 1 − m) = n/(m + n), and w = √(n/((m + n)(1 + n))): Jacobi's
/// form of the integral of the third kind, Π(u, a) = u Z(a) + ½ ln
/// Θ(u − a)/Θ(u + a) (Whittaker & Watson §22.74), at the imaginary
/// a = i b where 1 + n sn² has its zero. The θ₄ series converges as
/// q^(k²) e^(2ky), so a handful of terms replace an R_J per pose; the
/// linear part ⟨f⟩ = Π(−n | m)/K is the complete integral's mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ThetaTurn {
    /// ⟨f⟩.
    pub(crate) mean: f64,
    /// w.
    pub(crate) weight: f64,
    /// Re θ₄ = 1 + Σ re_k cos 2kx, Im θ₄ = Σ im_k sin 2kx.
    re: [f64; THETA_TERMS],
    im: [f64; THETA_TERMS],
    terms: usize,
}

impl ThetaTurn {
    /// The series for the parameter `m` (complement `m_complement`), the
    /// characteristic `n`, the quarter period `quarter` = K and
    /// `complete` = ∫₀^K dv/(1 + n sn² v) = Π(−n | m); None where it
    /// would need more than [`THETA_TERMS`] terms or where θ₄ comes near
    /// zero on the line (Re θ₄ ≥ 1 − Σ |re_k| is kept ≥ 1/4, which keeps
    /// the argument on its principal branch and its digits): near the
    /// separatrix, or where n is large.
    pub(crate) fn new(
        m: f64,
        m_complement: f64,
        n: f64,
        quarter: f64,
        complete: f64,
    ) -> Option<Self> {
        if !(m > 0.0 && n > 0.0 && m_complement > 0.0) {
            return None;
        }
        let co_quarter = carlson_rf(0.0, m, 1.0);
        let log_nome = -std::f64::consts::PI * co_quarter / quarter;
        // b = F(arcsin s | 1 − m) with s² = n/(m + n).
        let (s2, c2, d2) = (n / (m + n), m / (m + n), m * (1.0 + n) / (m + n));
        let b = s2.sqrt() * carlson_rf(c2, d2, 1.0);
        let y2 = std::f64::consts::PI * b / quarter;
        let mut turn = Self {
            mean: complete / quarter,
            weight: (n / ((m + n) * (1.0 + n))).sqrt(),
            re: [0.0; THETA_TERMS],
            im: [0.0; THETA_TERMS],
            terms: 0,
        };
        let mut spread = 0.0;
        for k in 1..=THETA_TERMS {
            let kf = k as f64;
            let up = (log_nome * kf * kf + y2 * kf).exp();
            let down = (log_nome * kf * kf - y2 * kf).exp();
            let sign = if k % 2 == 1 { -1.0 } else { 1.0 };
            // 2 (−1)^k q^(k²) cosh 2ky and −2 (−1)^k q^(k²) sinh 2ky.
            turn.re[k - 1] = sign * (up + down);
            turn.im[k - 1] = -sign * (up - down);
            spread += turn.re[k - 1].abs();
            turn.terms = k;
            if up < 1e-18 {
                return (spread <= 0.75 && turn.weight.is_finite() && turn.mean.is_finite())
                    .then_some(turn);
            }
        }
        None
    }

    /// θ₄(x + i y) from the sine and cosine of x (Re θ₄ > 0).
    #[inline]
    pub(crate) fn theta4(&self, (sin, cos): (f64, f64)) -> (f64, f64) {
        // e^(2ix), then its powers.
        let step = (cos * cos - sin * sin, 2.0 * sin * cos);
        let mut power = step;
        let (mut re, mut im) = (1.0, 0.0);
        for k in 0..self.terms {
            re += self.re[k] * power.0;
            im += self.im[k] * power.1;
            power = (
                power.0 * step.0 - power.1 * step.1,
                power.1 * step.0 + power.0 * step.1,
            );
        }
        (re, im)
    }

    /// The periodic part w arg θ₄(x + i y).
    #[cfg(test)]
    pub(crate) fn periodic(&self, angle: (f64, f64)) -> f64 {
        let (re, im) = self.theta4(angle);
        self.weight * im.atan2(re)
    }
}

/// Carlson's R_F, or NaN where its arguments are out of its domain.
pub(crate) fn carlson_rf(x: f64, y: f64, z: f64) -> f64 {
    ellip::elliprf(x, y, z).unwrap_or(f64::NAN)
}

/// Carlson's R_J, or NaN where its arguments are out of its domain.
pub(crate) fn carlson_rj(x: f64, y: f64, z: f64, p: f64) -> f64 {
    ellip::elliprj(x, y, z, p).unwrap_or(f64::NAN)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jacobi(u: f64, m: f64, m_complement: f64) -> (f64, f64, f64) {
        let ([s, c, d], _) = Landen::new(m, m_complement).at(u);
        (s, c, d)
    }

    #[test]
    fn jacobi_functions_meet_their_identities_and_limits() {
        for &m in &[0.0, 1e-12, 0.3, 0.7, 0.99, 0.999999, 1.0] {
            for &u in &[-7.3, -1.0, 0.0, 0.4, 1.2, 3.9, 25.0] {
                let (s, c, d) = jacobi(u, m, 1.0 - m);
                assert!((s * s + c * c - 1.0).abs() < 1e-15);
                assert!((d * d + m * s * s - 1.0).abs() < 1e-14, "m {m} u {u}");
                // d sn/du = cn dn, by central differences.
                let h = 1e-6;
                let slope = (jacobi(u + h, m, 1.0 - m).0 - jacobi(u - h, m, 1.0 - m).0) / (2.0 * h);
                assert!((slope - c * d).abs() < 1e-8, "m {m} u {u}");
            }
        }
        let (s, c, d) = jacobi(0.8, 0.0, 1.0);
        assert_eq!((s, c, d), (0.8f64.sin(), 0.8f64.cos(), 1.0));
        // sn(K) = 1 and the period 4K.
        for &m in &[0.2, 0.9] {
            let k = carlson_rf(0.0, 1.0 - m, 1.0);
            let (s, c, d) = jacobi(k, m, 1.0 - m);
            assert!((s - 1.0).abs() < 1e-15 && c.abs() < 1e-15);
            assert!((d - (1.0 - m).sqrt()).abs() < 1e-15);
            let (s1, c1, _) = jacobi(0.37 + 4.0 * k, m, 1.0 - m);
            let (s0, c0, _) = jacobi(0.37, m, 1.0 - m);
            assert!((s1 - s0).abs() < 1e-14 && (c1 - c0).abs() < 1e-14);
            // F(am u) = u.
            let u = 0.9 * k;
            let (s, c, _) = jacobi(u, m, 1.0 - m);
            let f = s * carlson_rf(c * c, 1.0 - m * s * s, 1.0);
            assert!((f - u).abs() < 1e-15);
        }
    }

    /// ∫₀^τ dv/(1 + n sn² v) by composite Gauss–Legendre quadrature.
    fn quadrature(tau: f64, m: f64, n: f64) -> f64 {
        let nodes = [
            (-0.906179845938664, 0.236926885056189),
            (-0.538469310105683, 0.478628670499366),
            (0.0, 0.568888888888889),
            (0.538469310105683, 0.478628670499366),
            (0.906179845938664, 0.236926885056189),
        ];
        let landen = Landen::new(m, 1.0 - m);
        let pieces = 4000;
        let h = tau / pieces as f64;
        (0..pieces)
            .map(|k| {
                let mid = (k as f64 + 0.5) * h;
                nodes
                    .iter()
                    .map(|&(x, w)| {
                        let ([s, _, _], _) = landen.at(mid + 0.5 * h * x);
                        w * 0.5 * h / (1.0 + n * s * s)
                    })
                    .sum::<f64>()
            })
            .sum()
    }

    /// The θ-series of the turn against two independent routes: Carlson's
    /// R_J (τ − n H(τ)) and direct quadrature, over a period, for the
    /// parameters and characteristics tops give; and it declines where it
    /// would converge slowly (near the separatrix, large n).
    #[test]
    fn the_theta_turn_matches_the_integral_of_the_third_kind() {
        let mut used = 0;
        for &m in &[1e-6, 0.05, 0.3, 0.5, 0.8, 0.95, 0.999] {
            for &n in &[0.02, 0.14, 1.0, 7.16, 40.0] {
                let quarter = carlson_rf(0.0, 1.0 - m, 1.0);
                let half = carlson_rj(0.0, 1.0 - m, 1.0, 1.0 + n) / 3.0;
                let landen = Landen::new(m, 1.0 - m);
                let Some(theta) = ThetaTurn::new(m, 1.0 - m, n, quarter, quarter - n * half) else {
                    continue;
                };
                used += 1;
                for k in -6..=6 {
                    let r = quarter * k as f64 / 6.0;
                    let ([s, c, d], angle) = landen.reduced(r, quarter);
                    let x = std::f64::consts::FRAC_PI_2 * r / quarter;
                    assert!((angle.0 - x.sin()).abs() < 1e-15 && (angle.1 - x.cos()).abs() < 1e-15);
                    let series = theta.mean * r + theta.periodic(angle);
                    let h = if s == 0.0 {
                        0.0
                    } else {
                        s * s * s * carlson_rj(c * c, d * d, 1.0, 1.0 + n * s * s) / 3.0
                    };
                    let carlson = r - n * h;
                    assert!(
                        (series - carlson).abs() < 4e-15 * quarter,
                        "m {m} n {n} r {r}: {series} {carlson}"
                    );
                    if k % 3 == 0 {
                        let direct = quadrature(r, m, n);
                        assert!(
                            (series - direct).abs() < 1e-13,
                            "m {m} n {n} r {r}: {series} {direct}"
                        );
                    }
                }
            }
        }
        eprintln!("theta series taken for {used} of 35 (m, n)");
        assert!(used >= 20, "{used}");
        // Near the separatrix the nome nears 1: left to R_J.
        let m = 1.0 - 1e-9;
        let quarter = carlson_rf(0.0, 1e-9, 1.0);
        let half = carlson_rj(0.0, 1e-9, 1.0, 2.0) / 3.0;
        assert!(ThetaTurn::new(m, 1e-9, 1.0, quarter, quarter - half).is_none());
    }
}
