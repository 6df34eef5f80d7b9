//! Move-size tuning toward a target acceptance, from windowed counts, each
//! change clamped to ±20 % (as lumol does). Used during equilibration only:
//! production keeps the sizes fixed so that sampling obeys detailed balance.

use rand::Rng;

use super::System;
use super::moves::{Count, Counts, Ensemble, MoveSizes, sweep};

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
