//! Means and honest errors of correlated time series, and where they
//! become stationary.
//!
//! Successive samples of a Monte Carlo or dynamics run are correlated: the
//! standard error of their mean is σ √(g / n), with g the statistical
//! inefficiency, g = 1 + 2 Σ_{t≥1} (1 − t/n) C(t), C the normalised
//! autocorrelation (Flyvbjerg & Petersen, J. Chem. Phys. 91, 461 (1989);
//! Chodera, J. Chem. Theory Comput. 12, 1799 (2016), Eq. 6). The sum is
//! cut where C first falls to zero or below, past which it is noise.
//!
//! Equilibration is detected as Chodera proposes (Sec. 2.4): of the
//! candidate starts t₀ in the first half, the one that leaves the most
//! effectively uncorrelated samples, (n − t₀) / g(t₀). A series that
//! leaves few of them, or whose kept part still drifts (its halves'
//! means disagree), has not equilibrated.

/// Fewest effective samples a series must keep for its mean to count as
/// equilibrium: a series that is still drifting, however long, keeps one
/// or two (its autocorrelation stays near 1 over its whole length).
pub const MIN_EFFECTIVE_SAMPLES: f64 = 5.0;

/// Effective samples below which an error is itself uncertain by more
/// than about 15 % (its relative error is about 1/√(2 N_eff)).
pub const FEW_EFFECTIVE_SAMPLES: f64 = 20.0;

/// The statistical inefficiency g ≥ 1 of `x` (1 for fewer than three
/// samples or no variance).
pub fn statistical_inefficiency(x: &[f64]) -> f64 {
    let n = x.len();
    if n < 3 {
        return 1.0;
    }
    let mean = x.iter().sum::<f64>() / n as f64;
    let d: Vec<f64> = x.iter().map(|v| v - mean).collect();
    let variance = d.iter().map(|v| v * v).sum::<f64>() / n as f64;
    if variance <= 0.0 || !variance.is_finite() {
        return 1.0;
    }
    let mut g = 1.0;
    for t in 1..n - 1 {
        let c = d[..n - t]
            .iter()
            .zip(&d[t..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / ((n - t) as f64 * variance);
        if c <= 0.0 {
            break;
        }
        g += 2.0 * c * (1.0 - t as f64 / n as f64);
    }
    g.max(1.0)
}

/// Mean, its standard error, and how it was obtained, of the stationary
/// part of a series.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// Mean of the samples from `start` on.
    pub mean: f64,
    /// Its standard error, σ √(g / n).
    pub error: f64,
    /// Index of the first sample counted (those before are equilibration).
    pub start: usize,
    /// Samples counted.
    pub samples: usize,
    /// Statistical inefficiency g of the samples counted.
    pub statistical_inefficiency: f64,
    /// samples / g.
    pub effective_samples: f64,
    /// Whether the series equilibrated: at least
    /// [`MIN_EFFECTIVE_SAMPLES`] effective samples kept, and the means of
    /// the two halves of what is kept agreeing within three combined
    /// errors (no drift left).
    pub equilibrated: bool,
}

/// Mean, error, inefficiency and effective samples of `kept`.
fn moments(kept: &[f64]) -> (f64, f64, f64, f64) {
    let n = kept.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, 1.0, 0.0);
    }
    let mean = kept.iter().sum::<f64>() / n as f64;
    let g = statistical_inefficiency(kept);
    // Unbiased variance of the samples; the error of the mean is √(g s²/n).
    let variance = if n > 1 {
        kept.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64
    } else {
        f64::NAN
    };
    (mean, (variance * g / n as f64).sqrt(), g, n as f64 / g)
}

/// The estimate from the samples of `x` from `start` on.
pub fn estimate_from(x: &[f64], start: usize) -> Estimate {
    let kept = &x[start.min(x.len())..];
    let (mean, error, g, effective) = moments(kept);
    let (older, newer) = kept.split_at(kept.len() / 2);
    let ((m1, e1, _, _), (m2, e2, _, _)) = (moments(older), moments(newer));
    let no_drift = (m2 - m1).abs() <= 3.0 * (e1 * e1 + e2 * e2).sqrt();
    Estimate {
        mean,
        error,
        start,
        samples: kept.len(),
        statistical_inefficiency: g,
        effective_samples: effective,
        equilibrated: effective >= MIN_EFFECTIVE_SAMPLES && no_drift,
    }
}

/// Where `x` equilibrated, and its estimate from there: of up to
/// `candidates` starts evenly spaced over the first half of the series,
/// the one that keeps the most effective samples. (Starts in the second
/// half are not tried: a short tail can show a small inefficiency by
/// chance, and a series that needs more than half its length to settle
/// has not shown that it did.)
pub fn detect_equilibration(x: &[f64], candidates: usize) -> Estimate {
    let n = x.len();
    if n < 4 {
        return estimate_from(x, 0);
    }
    let last = n / 2;
    let stride = (last / candidates.max(1)).max(1);
    let mut best = estimate_from(x, 0);
    for start in (stride..=last).step_by(stride) {
        let e = estimate_from(x, start);
        if e.effective_samples > best.effective_samples {
            best = e;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// An AR(1) series x_{t+1} = a x_t + ε, whose statistical inefficiency
    /// is (1 + a) / (1 − a) exactly.
    fn ar1(a: f64, n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let noise = Normal::new(0.0, 1.0).unwrap();
        let mut x = noise.sample(&mut rng) / (1.0 - a * a).sqrt();
        (0..n)
            .map(|_| {
                x = a * x + noise.sample(&mut rng);
                x
            })
            .collect()
    }

    #[test]
    fn the_inefficiency_of_an_ar1_series_is_its_closed_form() {
        for a in [0.0, 0.5, 0.9] {
            let exact = (1.0 + a) / (1.0 - a);
            let g = statistical_inefficiency(&ar1(a, 200_000, 1));
            assert!((g / exact - 1.0).abs() < 0.1, "a = {a}: {g} vs {exact}");
        }
    }

    #[test]
    fn errors_cover_the_true_mean_as_often_as_they_claim() {
        // 400 independent correlated series of mean 0: the true mean lies
        // within one error of the estimate about 68 % of the time (a naive
        // error, g = 1, would cover it only about 30 % of the time at
        // a = 0.9).
        let trials = 400;
        let covered = (0..trials)
            .filter(|&k| {
                let e = estimate_from(&ar1(0.9, 4000, 100 + k), 0);
                e.mean.abs() < e.error
            })
            .count() as f64
            / trials as f64;
        assert!((covered - 0.683).abs() < 0.07, "covered {covered}");
    }

    #[test]
    fn a_relaxing_start_is_cut_off_and_a_trend_is_flagged() {
        // Stationary noise after an exponential relaxation from +10.
        let noise = ar1(0.5, 5000, 7);
        let x: Vec<f64> = noise
            .iter()
            .enumerate()
            .map(|(t, v)| v + 10.0 * (-(t as f64) / 200.0).exp())
            .collect();
        let e = detect_equilibration(&x, 200);
        assert!(e.equilibrated);
        assert!(e.start > 400 && e.start < 2000, "start {}", e.start);
        assert!(e.mean.abs() < 4.0 * e.error, "{e:?}");
        // Still relaxing at the end (by far more than the noise): not
        // equilibrated.
        let drifting: Vec<f64> = (0..300)
            .map(|t| noise[t] + 30.0 * (-(t as f64) / 200.0).exp())
            .collect();
        assert!(!detect_equilibration(&drifting, 200).equilibrated);
        // A steady ramp never equilibrates.
        let ramp: Vec<f64> = (0..1000).map(|t| t as f64 + noise[t]).collect();
        assert!(!detect_equilibration(&ramp, 200).equilibrated);
    }
}
