//! Progress of a run on standard error: bars on a terminal (indicatif),
//! plain lines otherwise (at most one every few seconds per stage).

use std::time::{Duration, Instant};

use hardbody::run::Progress;
use indicatif::{ProgressBar, ProgressStyle};

/// Seconds between plain progress lines.
const LINE_EVERY: Duration = Duration::from_secs(5);

/// A bar per stage.
#[derive(Default)]
pub struct Bars {
    bar: Option<ProgressBar>,
}

impl Progress for Bars {
    fn stage(&mut self, index: usize, count: usize, description: &str, ticks: u64) {
        let bar = if ticks > 0 {
            let bar = ProgressBar::new(ticks);
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix} [{elapsed_precise}] {bar:30} {percent:>3}% {msg}",
                )
                .expect("a fixed template"),
            );
            bar
        } else {
            let bar = ProgressBar::new_spinner();
            bar.set_style(
                ProgressStyle::with_template("{prefix} [{elapsed_precise}] {spinner} {pos} {msg}")
                    .expect("a fixed template"),
            );
            bar.enable_steady_tick(Duration::from_millis(200));
            bar
        };
        bar.set_prefix(format!("stage {}/{count}: {description}", index + 1));
        self.bar = Some(bar);
    }

    fn tick(&mut self, tick: u64, message: &str) {
        if let Some(bar) = &self.bar {
            bar.set_position(tick);
            bar.set_message(message.to_string());
        }
    }

    fn stage_done(&mut self, message: &str) {
        if let Some(bar) = self.bar.take() {
            bar.finish_with_message(message.to_string());
        }
    }
}

/// Plain lines, for logs and pipes.
#[derive(Default)]
pub struct Lines {
    stage: String,
    last: Option<Instant>,
}

impl Progress for Lines {
    fn stage(&mut self, index: usize, count: usize, description: &str, _ticks: u64) {
        self.stage = format!("stage {}/{count}", index + 1);
        self.last = Some(Instant::now());
        eprintln!("{}: {description}", self.stage);
    }

    fn tick(&mut self, tick: u64, message: &str) {
        if self.last.is_none_or(|t| t.elapsed() >= LINE_EVERY) {
            self.last = Some(Instant::now());
            eprintln!("{}: at {tick}: {message}", self.stage);
        }
    }

    fn stage_done(&mut self, message: &str) {
        eprintln!("{}: done, {message}", self.stage);
    }
}
