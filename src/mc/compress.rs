//! Compression to a target packing fraction (after HOOMD's QuickCompress):
//! between sweeps of particle moves the box is shrunk isotropically by the
//! largest step that leaves no overlap, never past the target. The step
//! adapts (grows on success, halves on failure); when it has fallen below
//! `min_step` for `patience` sweeps in a row the packing is jammed and
//! compression stops with the packing fraction reached. No overlap is ever
//! created: every shrink is checked before it is kept.

use rand::Rng;
use serde::{Deserialize, Serialize};

use super::System;
use super::moves::{Counts, Ensemble, MoveSizes, sweep};
use super::tuning::Tuner;

/// Knobs of a compression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompressOptions {
    /// Target packing fraction.
    pub target: f64,
    /// Give up after this many sweeps.
    pub max_sweeps: u64,
    /// First relative shrink of the box edge tried.
    pub initial_step: f64,
    /// A step below this counts as no progress.
    pub min_step: f64,
    /// Sweeps without progress before declaring the packing jammed.
    pub patience: u64,
}

impl CompressOptions {
    /// Defaults for a target packing fraction.
    pub fn to(target: f64) -> Self {
        Self {
            target,
            max_sweeps: 1_000_000,
            initial_step: 0.01,
            min_step: 1e-6,
            patience: 2000,
        }
    }
}

/// Why compression could not start or did not finish.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompressError {
    /// The target is not a packing fraction in (0, 1).
    #[error("compression target {0} is not a packing fraction in (0, 1)")]
    BadTarget(f64),
    /// The target lies below the start: nothing to compress.
    #[error("compression target {target} is below the starting packing fraction {start}")]
    TargetBelowStart {
        /// Requested.
        target: f64,
        /// Where the system is.
        start: f64,
    },
    /// Move sizes that cannot move anything.
    #[error("translation move size must be > 0, got {0}")]
    ZeroMoveSize(f64),
    /// Jammed: no shrink possible for `patience` sweeps.
    #[error("jammed at packing fraction {reached:.4} after {sweeps} sweeps (target {target})")]
    Jammed {
        /// Packing fraction reached.
        reached: f64,
        /// Requested.
        target: f64,
        /// Sweeps done.
        sweeps: u64,
    },
    /// The target needs a box edge shorter than twice the interaction
    /// range (the minimum image would not be unique): too few particles
    /// for that packing fraction.
    #[error(
        "at packing fraction {target} the box edge would be {edge:.4}, below twice the interaction range {range:.4}: use more particles (reached {reached:.4})"
    )]
    BoxLimit {
        /// Packing fraction reached.
        reached: f64,
        /// Requested.
        target: f64,
        /// The shortest edge the target needs.
        edge: f64,
        /// Twice the largest bounding radius.
        range: f64,
    },
    /// Ran out of sweeps.
    #[error("reached packing fraction {reached:.4} of {target} in the allowed {sweeps} sweeps")]
    OutOfSweeps {
        /// Packing fraction reached.
        reached: f64,
        /// Requested.
        target: f64,
        /// Sweeps done.
        sweeps: u64,
    },
}

/// How a completed compression went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompressReport {
    /// Sweeps used.
    pub sweeps: u64,
    /// Final packing fraction (the target).
    pub packing_fraction: f64,
    /// Move counters over the whole compression.
    pub counts: Counts,
    /// Move sizes at the end (tuned as it went).
    pub sizes: MoveSizes,
}

/// Compresses `system` to `opts.target`; on success the packing fraction is
/// the target (to rounding) and the state is overlap-free.
pub fn compress<R: Rng>(
    system: &mut System,
    sizes: MoveSizes,
    opts: &CompressOptions,
    rng: &mut R,
) -> Result<CompressReport, CompressError> {
    let mut c = Compressor::new(system, sizes, opts)?;
    loop {
        if let Some(report) = c.sweep(system, rng)? {
            return Ok(report);
        }
    }
}

/// Everything a compression carries from sweep to sweep besides the
/// system and the random stream: with them, enough to resume it exactly.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompressorState {
    /// Sweeps done.
    pub sweeps: u64,
    /// Move sizes now.
    pub sizes: MoveSizes,
    /// Relative shrink tried next.
    pub step: f64,
    /// Sweeps in a row without progress.
    pub stalled: u64,
    /// Counts since the last move-size update.
    pub window: Counts,
    /// Counts over the whole compression.
    pub counts: Counts,
    /// Largest translation the tuner allows (half the starting box's
    /// shortest edge, kept so that a resumed compression tunes as the
    /// original did).
    pub max_translate: f64,
}

/// A compression one sweep at a time (see [`compress`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Compressor {
    opts: CompressOptions,
    tuner: Tuner,
    state: CompressorState,
}

impl Compressor {
    /// Checks the options against the system.
    pub fn new(
        system: &System,
        sizes: MoveSizes,
        opts: &CompressOptions,
    ) -> Result<Self, CompressError> {
        if !(opts.target > 0.0 && opts.target < 1.0) {
            return Err(CompressError::BadTarget(opts.target));
        }
        let start = system.packing_fraction();
        if opts.target < start {
            return Err(CompressError::TargetBelowStart {
                target: opts.target,
                start,
            });
        }
        if sizes.translate.is_nan() || sizes.translate <= 0.0 {
            return Err(CompressError::ZeroMoveSize(sizes.translate));
        }
        // Said at once, not found out as a "jam" thousands of sweeps later.
        let edge = system.periodic_box().lengths().min() * (start / opts.target).cbrt();
        let range = system.interaction_range();
        if edge < 2.0 * range {
            return Err(CompressError::BoxLimit {
                reached: start,
                target: opts.target,
                edge,
                range,
            });
        }
        Ok(Self::resume(
            opts,
            CompressorState {
                sweeps: 0,
                sizes,
                step: opts.initial_step,
                stalled: 0,
                window: Counts::default(),
                counts: Counts::default(),
                max_translate: system.periodic_box().lengths().min() / 2.0,
            },
        ))
    }

    /// Continues a compression from a saved state.
    pub fn resume(opts: &CompressOptions, state: CompressorState) -> Self {
        Self {
            opts: *opts,
            tuner: Tuner {
                target: 0.3,
                max_translate: state.max_translate,
            },
            state,
        }
    }

    /// The state to save (with the system and the random stream).
    pub fn state(&self) -> &CompressorState {
        &self.state
    }

    /// One sweep of moves, then the largest box shrink that leaves no
    /// overlap; `Some` report when the target is reached.
    pub fn sweep<R: Rng>(
        &mut self,
        system: &mut System,
        rng: &mut R,
    ) -> Result<Option<CompressReport>, CompressError> {
        let st = &mut self.state;
        let opts = &self.opts;
        if st.sweeps >= opts.max_sweeps {
            return Err(CompressError::OutOfSweeps {
                reached: system.packing_fraction(),
                target: opts.target,
                sweeps: opts.max_sweeps,
            });
        }
        st.sweeps += 1;
        let s = st.sweeps;
        let c = sweep(system, &st.sizes, &Ensemble::Nvt, rng);
        st.counts += c;
        st.window += c;
        if s.is_multiple_of(20) {
            self.tuner.update(&mut st.sizes, &st.window);
            st.window = Counts::default();
        }
        // The edge factor that lands exactly on the target, and the factor
        // of the current step; take whichever shrinks less.
        let phi = system.packing_fraction();
        let to_target = (phi / opts.target).cbrt();
        let factor = to_target.max(1.0 - st.step);
        let lengths = system.periodic_box().lengths() * factor;
        if system.try_rescale(lengths) {
            st.step = (st.step * 1.5).min(0.1);
            st.stalled = 0;
            if factor == to_target {
                return Ok(Some(CompressReport {
                    sweeps: s,
                    packing_fraction: system.packing_fraction(),
                    counts: st.counts,
                    sizes: st.sizes,
                }));
            }
        } else {
            st.step *= 0.5;
            if st.step < opts.min_step {
                st.step = opts.min_step;
                st.stalled += 1;
                if st.stalled >= opts.patience {
                    return Err(CompressError::Jammed {
                        reached: phi,
                        target: opts.target,
                        sweeps: s,
                    });
                }
            }
        }
        Ok(None)
    }
}
