//! Move-size tuning toward a target acceptance, from windowed counts, each
//! change clamped to ±20 % (as lumol does). Used during equilibration only:
//! production keeps the sizes fixed so that sampling obeys detailed balance.

use rand::Rng;

use super::moves::{Count, Counts, Ensemble, MoveSizes, sweep};
use crate::state::System;

/// Tunes move sizes toward `target` acceptance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuner {
    /// Target acceptance rate (default 0.3).
    pub target: f64,
    /// Largest translation (half the smallest box edge makes sense).
    pub max_translate: f64,
}

impl Tuner {
    /// Scales each size by acceptance/target, clamped to [0.8, 1.2], for
    /// the kinds of move tried in the window.
    pub fn update(&self, sizes: &mut MoveSizes, window: &Counts) {
        let factor = |c: &Count| {
            if c.tried == 0 {
                1.0
            } else {
                (c.rate() / self.target).clamp(0.8, 1.2)
            }
        };
        sizes.translate = (sizes.translate * factor(&window.translate)).min(self.max_translate);
        sizes.rotate = (sizes.rotate * factor(&window.rotate)).min(std::f64::consts::PI);
        sizes.volume = (sizes.volume * factor(&window.volume)).min(1.0);
        sizes.shear = (sizes.shear * factor(&window.shear)).min(0.5);
    }

    /// Runs `sweeps` serial sweeps of `ensemble`, tuning `sizes` from the
    /// counts of every `window` sweeps: the equilibration before sizes are
    /// frozen for production.
    pub fn equilibrate<R: Rng>(
        &self,
        system: &mut System,
        sizes: &mut MoveSizes,
        ensemble: &Ensemble,
        sweeps: u64,
        window: u64,
        rng: &mut R,
    ) {
        let mut counts = Counts::default();
        for s in 1..=sweeps {
            counts += sweep(system, sizes, ensemble, rng);
            if s % window == 0 {
                self.update(sizes, &counts);
                counts = Counts::default();
            }
        }
    }
}

/// How long a Monte Carlo stage tunes its move sizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TuningSpan {
    /// Through this many sweeps, then frozen (a scene's `tune_sweeps`, or
    /// a fifth of an NVT stage, whose density does not change).
    Fixed(u64),
    /// Through `at_least` sweeps and on until the density has stopped
    /// drifting ([`DriftWatch`]), but no further than `at_most`: an NPT
    /// stage, whose density may still be far from its equilibrium when a
    /// fixed span ends (move sizes tuned at a dilute start then stay too
    /// large for the dense state, and both acceptances collapse).
    UntilSettled {
        /// Least sweeps of tuning.
        at_least: u64,
        /// Most sweeps of tuning.
        at_most: u64,
    },
}

impl TuningSpan {
    /// Whether sizes are still tuned at sweep `s`, given whether the
    /// density has settled.
    pub fn tunes_at(&self, s: u64, settled: bool) -> bool {
        match *self {
            TuningSpan::Fixed(t) => s <= t,
            TuningSpan::UntilSettled { at_least, at_most } => {
                s <= at_least || (!settled && s <= at_most)
            }
        }
    }
}

/// Watches the packing fraction at the end of each tuning window and says
/// when it has stopped drifting: over the last [`DriftWatch::SPAN`]
/// samples, the means of the older and the newer half differ by less than
/// the samples' standard deviation. A relaxing density drifts by more than
/// it fluctuates; a stationary one, however correlated, mostly does not.
/// Once settled it stays settled.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DriftWatch {
    /// The latest samples, oldest first (at most `SPAN`).
    pub samples: Vec<f64>,
    /// Whether the density has settled.
    pub settled: bool,
}

impl DriftWatch {
    /// Samples compared (20 windows of 50 sweeps: 1000 sweeps).
    pub const SPAN: usize = 20;

    /// Takes the packing fraction at the end of a window; whether the
    /// density has settled.
    pub fn observe(&mut self, packing_fraction: f64) -> bool {
        if self.settled {
            return true;
        }
        self.samples.push(packing_fraction);
        if self.samples.len() > Self::SPAN {
            self.samples.remove(0);
        }
        if self.samples.len() == Self::SPAN {
            let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
            let (older, newer) = self.samples.split_at(Self::SPAN / 2);
            let all = mean(&self.samples);
            let spread = (self.samples.iter().map(|v| (v - all).powi(2)).sum::<f64>()
                / (Self::SPAN - 1) as f64)
                .sqrt();
            self.settled = (mean(newer) - mean(older)).abs() <= spread;
        }
        self.settled
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drifting_density_is_not_settled_a_fluctuating_one_is() {
        let mut watch = DriftWatch::default();
        // A steady rise with small noise: never settled.
        for k in 0..100 {
            let noise = if k % 2 == 0 { 1e-4 } else { -1e-4 };
            assert!(!watch.observe(0.1 + 0.002 * k as f64 + noise), "sample {k}");
        }
        // Then flat with the same noise: settled within one span.
        let mut settled_at = None;
        for k in 0..40 {
            let noise = if k % 2 == 0 { 1e-4 } else { -1e-4 };
            if watch.observe(0.4 + noise) && settled_at.is_none() {
                settled_at = Some(k);
            }
        }
        let k = settled_at.expect("a flat density settles");
        assert!(k < DriftWatch::SPAN + 5, "settled after {k} samples");
        assert!(watch.observe(0.9), "settled stays settled");
    }

    #[test]
    fn tuning_until_settled_stops_between_its_bounds() {
        let span = TuningSpan::UntilSettled {
            at_least: 100,
            at_most: 1000,
        };
        assert!(span.tunes_at(100, true));
        assert!(!span.tunes_at(150, true));
        assert!(span.tunes_at(150, false));
        assert!(!span.tunes_at(1050, false));
        assert!(!TuningSpan::Fixed(100).tunes_at(150, false));
    }
}
