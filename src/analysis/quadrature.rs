//! Gauss–Legendre quadrature: the n nodes and weights on [−1, 1] that
//! integrate every polynomial of degree up to 2n − 1 exactly.

/// The `n` nodes (ascending) and weights of Gauss–Legendre quadrature on
/// [−1, 1], found as the roots of Pₙ by Newton's method from
/// cos(π (i − ¼)/(n + ½)), with weights 2 / ((1 − x²) Pₙ′(x)²)
/// (Abramowitz & Stegun 25.4.29).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut rule = Vec::with_capacity(n);
    for i in 1..=n {
        let mut x = (std::f64::consts::PI * (i as f64 - 0.25) / (n as f64 + 0.5)).cos();
        let mut slope = 0.0;
        for _ in 0..100 {
            let (p, dp) = legendre_with_slope(n, x);
            slope = dp;
            let step = p / dp;
            x -= step;
            if step.abs() < 1e-16 {
                break;
            }
        }
        rule.push((-x, 2.0 / ((1.0 - x * x) * slope * slope)));
    }
    rule.sort_by(|a, b| a.0.total_cmp(&b.0));
    rule
}

/// Pₙ(x) and Pₙ′(x) by the three-term recurrence.
fn legendre_with_slope(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

/// The nodes and weights of `n`-point Gauss–Legendre quadrature mapped
/// onto [a, b].
pub fn gauss_legendre_on(n: usize, a: f64, b: f64) -> Vec<(f64, f64)> {
    let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
    gauss_legendre(n)
        .into_iter()
        .map(|(x, w)| (mid + half * x, half * w))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// n points integrate x^k exactly for k ≤ 2n − 1 and not for k = 2n;
    /// the 5-point nodes are the tabulated ones (A&S Table 25.4).
    #[test]
    fn gauss_legendre_is_exact_to_degree_2n_minus_1() {
        for n in 1..=20 {
            let rule = gauss_legendre(n);
            assert!((rule.iter().map(|r| r.1).sum::<f64>() - 2.0).abs() < 1e-13);
            for k in 0..2 * n {
                let exact = if k % 2 == 0 {
                    2.0 / (k + 1) as f64
                } else {
                    0.0
                };
                let sum: f64 = rule.iter().map(|(x, w)| w * x.powi(k as i32)).sum();
                assert!((sum - exact).abs() < 1e-13, "n {n} k {k}: {sum}");
            }
            // The error at degree 2n falls like 4⁻ⁿ: seen up to n = 8.
            let k = 2 * n;
            let sum: f64 = rule.iter().map(|(x, w)| w * x.powi(k as i32)).sum();
            assert!(n > 8 || (sum - 2.0 / (k + 1) as f64).abs() > 1e-8, "n {n}");
        }
        let five = gauss_legendre(5);
        for (x, known) in five.iter().zip([
            -0.906179845938664,
            -0.538469310105683,
            0.0,
            0.538469310105683,
            0.906179845938664,
        ]) {
            assert!((x.0 - known).abs() < 1e-14);
        }
        let on = gauss_legendre_on(4, 1.0, 3.0);
        let cubic: f64 = on.iter().map(|(x, w)| w * x * x * x).sum();
        assert!((cubic - 20.0).abs() < 1e-12);
    }
}
