//! The one rhythm every stage keeps: advance to the next point where
//! something may be due, write the `/stats` due there, write a frame where
//! one is due (or the run is stopped, or the stage ends) and the stage can
//! give one, and end at the stage's end or at a stop once its frame is
//! written. Each stage kind says only how it advances and what it writes.

use std::sync::atomic::{AtomicBool, Ordering};

use crate::log::{LogWriter, StateRecord, Stats};
use crate::scene::plan::{StageBuild, stage_entry};

use super::{Phase, Progress, Runner, StageError, StageResult};

/// What is due where a stage has advanced to.
#[derive(Debug, Clone, Copy)]
pub(super) struct Mark {
    /// Log time there (ns).
    pub(super) time: u64,
    /// A `/stats` message is due.
    pub(super) stats: bool,
    /// A frame is due.
    pub(super) frame: bool,
    /// The stage has ended.
    pub(super) end: bool,
}

/// One stage kind, driven by [`Runner::drive`].
pub(super) trait StageRun {
    /// Runs on to the next point where something may be due.
    fn advance(&mut self, runner: &mut Runner) -> Result<Mark, StageError>;
    /// The `/stats` message due at the mark reached.
    fn stats(&mut self, runner: &Runner) -> Stats;
    /// The progress shown with it: the tick and the latest figures.
    fn progress(&self) -> (u64, String);
    /// Whether a frame can be written where the stage stands (a frame is a
    /// state to resume from: no overlaps, predictions restarted).
    fn frame_ready(&mut self) -> Result<bool, StageError>;
    /// The frame where the stage stands; `complete` at its end.
    fn frame(&mut self, runner: &Runner, complete: bool) -> StateRecord;
    /// After a failure of [`StageRun::advance`]: what the log should keep
    /// of it (a last valid frame, or the state to replay the failure from).
    fn failed(&mut self, runner: &mut Runner, log: &mut LogWriter);
    /// The state handed on and the stage's line; `stopped` when the run was
    /// stopped before the stage's end.
    fn finish(self, runner: &mut Runner, stopped: bool) -> (Phase, String);
    /// What the stage's driver was built with, as data: the log records it
    /// (metadata `hardbody.stage`) beside the plan `check` printed, in the
    /// form of the plan's stage entries ([`crate::scene::plan::Plan::to_json`]).
    fn built_with(&self) -> StagePlan;
}

/// What one stage's driver was built with, as the run records it.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct StagePlan {
    /// The stage's index in the scene.
    pub(super) index: usize,
    /// The JSON entry: `stage`, `kind`, and `mc_neighbours` (Monte Carlo
    /// and compression) or `neighbours` (dynamics).
    pub(super) entry: serde_json::Value,
}

impl StagePlan {
    /// Stage `index` (of kind `kind`) as its driver was built.
    pub(super) fn new(index: usize, kind: &str, built: StageBuild) -> Self {
        StagePlan {
            index,
            entry: stage_entry(index, kind, built),
        }
    }
}

impl Runner {
    /// Runs `stage` to its end, or to a stop (`stop` set, or the pause
    /// point reached), at the scene's cadence.
    pub(super) fn drive(
        &mut self,
        mut stage: impl StageRun,
        log: &mut LogWriter,
        progress: &mut dyn Progress,
        stop: &AtomicBool,
    ) -> StageResult {
        let built = stage.built_with();
        log.stage_plan(built.index, &built.entry)?;
        let stopped = loop {
            let mark = match stage.advance(self) {
                Ok(mark) => mark,
                Err(e) => {
                    stage.failed(self, log);
                    return Err(e);
                }
            };
            if mark.stats {
                log.stats(mark.time, &stage.stats(self))?;
                let (tick, message) = stage.progress();
                progress.tick(tick, &message);
            }
            let paused = self.pause_at.is_some_and(|t| mark.time >= t);
            let stop = !mark.end && (paused || stop.load(Ordering::Relaxed));
            let mut framed = false;
            if (mark.frame || mark.end || stop) && stage.frame_ready()? {
                let record = stage.frame(self, mark.end);
                log.frame(mark.time, &record)?;
                if stop {
                    self.stopped_at = Some((mark.time, record));
                }
                framed = true;
            }
            if mark.end {
                break false;
            }
            if stop && framed {
                break true;
            }
        };
        let (phase, line) = stage.finish(self, stopped);
        Ok((phase, line, stopped))
    }
}
