//! Compression to a target packing fraction (after HOOMD's QuickCompress):
//! between sweeps of particle moves the box is shrunk isotropically by the
//! largest step that leaves no overlap, never past the target. The step
//! adapts (grows on success, halves on failure); when it has fallen below
//! `min_step` for `patience` sweeps in a row the packing is jammed and
//! compression stops with the packing fraction reached. No overlap is ever
//! created: every shrink is checked before it is kept.

use std::ops::ControlFlow;

use rand::Rng;

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
    /// Stopped from outside (an interrupted run).
    #[error("stopped at packing fraction {reached:.4} after {sweeps} sweeps")]
    Stopped {
        /// Packing fraction reached.
        reached: f64,
        /// Sweeps done.
        sweeps: u64,
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
    compress_observed(system, sizes, opts, rng, |_, _, _, _| {
        ControlFlow::Continue(())
    })
}

/// [`compress`], calling `observe(system, sweep, counts of that sweep,
/// move sizes)` after every sweep (and its box shrink); a `Break` stops
/// the compression with [`CompressError::Stopped`].
pub fn compress_observed<R: Rng>(
    system: &mut System,
    mut sizes: MoveSizes,
    opts: &CompressOptions,
    rng: &mut R,
    mut observe: impl FnMut(&System, u64, &Counts, &MoveSizes) -> ControlFlow<()>,
) -> Result<CompressReport, CompressError> {
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
    let tuner = Tuner {
        target: 0.3,
        max_translate: system.periodic_box().lengths().min() / 2.0,
    };
    let mut step = opts.initial_step;
    let mut stalled = 0;
    let mut counts = Counts::default();
    let mut window = Counts::default();
    for s in 1..=opts.max_sweeps {
        let c = sweep(system, &sizes, &Ensemble::Nvt, rng);
        counts += c;
        window += c;
        if s % 20 == 0 {
            tuner.update(&mut sizes, &window);
            window = Counts::default();
        }
        // The edge factor that lands exactly on the target, and the factor
        // of the current step; take whichever shrinks less.
        let phi = system.packing_fraction();
        let to_target = (phi / opts.target).cbrt();
        let factor = to_target.max(1.0 - step);
        let lengths = system.periodic_box().lengths() * factor;
        let shrunk = system.try_rescale(lengths);
        if observe(system, s, &c, &sizes).is_break() {
            return Err(CompressError::Stopped {
                reached: system.packing_fraction(),
                sweeps: s,
            });
        }
        if shrunk {
            step = (step * 1.5).min(0.1);
            stalled = 0;
            if factor == to_target {
                return Ok(CompressReport {
                    sweeps: s,
                    packing_fraction: system.packing_fraction(),
                    counts,
                    sizes,
                });
            }
        } else {
            step *= 0.5;
            if step < opts.min_step {
                step = opts.min_step;
                stalled += 1;
                if stalled >= opts.patience {
                    return Err(CompressError::Jammed {
                        reached: phi,
                        target: opts.target,
                        sweeps: s,
                    });
                }
            }
        }
    }
    Err(CompressError::OutOfSweeps {
        reached: system.packing_fraction(),
        target: opts.target,
        sweeps: opts.max_sweeps,
    })
}
