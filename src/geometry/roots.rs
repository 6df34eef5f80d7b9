//! Small scalar root finders shared by the shape kernels.

use nalgebra::Vector3;

/// The t > 0 with Σᵢ cᵢ t^{qᵢ} = 1, for cᵢ ≥ 0 (not all zero) and qᵢ > 0.
///
/// Newton's method in s = ln t on ψ(s) = Σ cᵢ e^{qᵢ s} − 1, which is convex
/// and increasing; started where ψ ≥ 0 it converges monotonically.
pub fn solve_power_sum(c: &Vector3<f64>, q: &Vector3<f64>) -> f64 {
    let mut s = f64::NEG_INFINITY;
    for i in 0..3 {
        if c[i] > 0.0 {
            s = s.max(-c[i].ln() / q[i]);
        }
    }
    debug_assert!(s.is_finite(), "solve_power_sum needs some c > 0");
    for _ in 0..100 {
        let mut psi = -1.0;
        let mut dpsi = 0.0;
        for i in 0..3 {
            if c[i] > 0.0 {
                let term = c[i] * (q[i] * s).exp();
                psi += term;
                dpsi += q[i] * term;
            }
        }
        let step = psi / dpsi;
        s -= step;
        if step.abs() <= 1e-15 * (1.0 + s.abs()) || psi <= 0.0 {
            break;
        }
    }
    s.exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_sum_matches_closed_forms() {
        // Equal exponents: t = (Σc)^{-1/q}.
        let t = solve_power_sum(&Vector3::new(0.2, 0.5, 0.0), &Vector3::repeat(3.0));
        assert!((t - 0.7f64.powf(-1.0 / 3.0)).abs() < 1e-14);
        let c = Vector3::new(1e-8, 3.0, 0.25);
        let q = Vector3::new(2.0, 8.0, 1.2);
        let t = solve_power_sum(&c, &q);
        let sum: f64 = (0..3).map(|i| c[i] * t.powf(q[i])).sum();
        assert!((sum - 1.0).abs() < 1e-14);
    }
}
