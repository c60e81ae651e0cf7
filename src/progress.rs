//! Progress on stderr for runs that take a while: per file and per stage, shown once a run has
//! lasted [`SHOW_AFTER`] (a quick run prints nothing), never when stderr is not a terminal
//! (indicatif's stderr target hides itself there), never on stdout.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::time::{Duration, Instant};

/// A run shorter than this shows no progress.
pub const SHOW_AFTER: Duration = Duration::from_secs(2);

pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A run of `steps` steps (files and stages), named `what`. A watcher thread reveals the bar
    /// once the run has lasted SHOW_AFTER; it then ticks by itself, so a long stage is seen to be
    /// alive.
    pub fn new(what: &str, steps: usize) -> Progress {
        let bar = ProgressBar::with_draw_target(Some(steps as u64), ProgressDrawTarget::hidden());
        bar.set_style(ProgressStyle::with_template("{prefix} [{elapsed_precise}] {bar:30} {pos}/{len} {msg}").expect("progress template").progress_chars("=> "));
        bar.set_prefix(what.to_string());
        let watched = bar.clone();
        std::thread::spawn(move || {
            let start = Instant::now();
            while start.elapsed() < SHOW_AFTER {
                if watched.is_finished() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            if !watched.is_finished() {
                watched.set_draw_target(ProgressDrawTarget::stderr());
                watched.enable_steady_tick(Duration::from_millis(200));
            }
        });
        Progress { bar }
    }

    /// Starts the next step (the previous one is done).
    pub fn step(&self, msg: impl Into<String>) {
        self.bar.set_message(msg.into());
        self.bar.inc(1);
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
