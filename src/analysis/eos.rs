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

#[cfg(test)]
mod tests {
    use super::*;

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
