//! Known equations of state to check measured ones against.

/// βPσ³ of hard spheres of diameter σ at packing fraction φ by
/// Carnahan–Starling: (6φ/π)(1 + φ + φ² − φ³)/(1 − φ)³.
pub fn carnahan_starling_pressure(phi: f64) -> f64 {
    6.0 * phi / std::f64::consts::PI * (1.0 + phi + phi * phi - phi.powi(3)) / (1.0 - phi).powi(3)
}

/// The packing fraction at which Carnahan–Starling gives βPσ³ =
/// `reduced_pressure` (> 0): the pressure rises monotonically from 0 at
/// φ = 0 to infinity at φ = 1, so bisection finds it to round-off.
pub fn carnahan_starling_packing_fraction(reduced_pressure: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if carnahan_starling_pressure(mid) < reduced_pressure {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// βPσ³ of the hard-sphere fcc crystal at packing fraction φ by Speedy's
/// fit to simulations (R. J. Speedy, J. Phys.: Condens. Matter 10, 4387
/// (1998), Eq. 2 and Table 1): Z = 3/(1 − z) − a(z − b)/(z − c) with
/// z = φ/φ_cp, φ_cp = π/√18, a = 0.5921, b = 0.7072, c = 0.601; fitted
/// from melting (φ ≈ 0.545) to close packing.
pub fn speedy_fcc_pressure(phi: f64) -> f64 {
    let z = phi / (std::f64::consts::PI / 18f64.sqrt());
    let compressibility = 3.0 / (1.0 - z) - 0.5921 * (z - 0.7072) / (z - 0.601);
    6.0 * phi / std::f64::consts::PI * compressibility
}

/// The packing fraction at which Speedy's fcc equation of state gives
/// βPσ³ = `reduced_pressure`, by bisection on [0.545, π/√18) where it
/// rises monotonically (from about 11.5 to infinity).
pub fn speedy_fcc_packing_fraction(reduced_pressure: f64) -> f64 {
    let (mut lo, mut hi) = (0.545_f64, std::f64::consts::PI / 18f64.sqrt());
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if speedy_fcc_pressure(mid) < reduced_pressure {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Speedy's crystal pressure diverges as 3/(1 − z) at close packing
    /// (free volume), and the inverse inverts.
    #[test]
    fn speedy_diverges_at_close_packing_and_inverts() {
        let cp = std::f64::consts::PI / 18f64.sqrt();
        for phi in [0.55, 0.6, 0.65, 0.7, 0.73] {
            let p = speedy_fcc_pressure(phi);
            assert!((speedy_fcc_packing_fraction(p) - phi).abs() < 1e-12);
        }
        let phi = cp * (1.0 - 1e-6);
        let free_volume = 3.0 / 1e-6 * 6.0 * phi / std::f64::consts::PI;
        assert!((speedy_fcc_pressure(phi) / free_volume - 1.0).abs() < 1e-5);
    }

    #[test]
    fn the_inverse_inverts_and_the_low_density_limit_is_ideal() {
        for phi in [0.01, 0.1, 0.3, 0.45, 0.55] {
            let p = carnahan_starling_pressure(phi);
            assert!((carnahan_starling_packing_fraction(p) - phi).abs() < 1e-14);
        }
        // Ideal gas plus the second virial coefficient: Z = 1 + 4φ + ...
        let phi = 1e-6;
        let z = carnahan_starling_pressure(phi) / (6.0 * phi / std::f64::consts::PI);
        assert!((z - 1.0 - 4.0 * phi).abs() < 1e-10);
    }
}
