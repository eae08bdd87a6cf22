//! Progress bars (indicatif) for the stages of a bake, and stage timings for the report.

use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Shows progress on stderr when enabled (and stderr is a terminal); always records timings.
pub struct Progress {
    enabled: bool,
    stages: std::sync::Mutex<Vec<(String, f64)>>,
}

impl Progress {
    /// Progress bars on stderr when `enabled`; timings are recorded either way.
    pub fn new(enabled: bool) -> Self {
        Self {
            enabled,
            stages: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// No bars, timings only.
    pub fn hidden() -> Self {
        Self::new(false)
    }

    /// Starts a stage with `total` work items (0: a spinner).
    pub fn stage(&self, name: &str, total: u64) -> Stage<'_> {
        let bar = if self.enabled {
            let bar =
                ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(5));
            let style = if total > 0 {
                ProgressStyle::with_template(
                    "{prefix:>14} [{bar:30}] {pos}/{len} {per_sec} eta {eta}",
                )
            } else {
                ProgressStyle::with_template("{prefix:>14} {spinner} {elapsed}")
            };
            bar.set_style(style.expect("static template").progress_chars("=> "));
            bar.set_prefix(name.to_string());
            // Bars appear only for stages that last: indicatif draws at most 5 times a second.
            bar.enable_steady_tick(std::time::Duration::from_millis(1000));
            Some(bar)
        } else {
            None
        };
        Stage {
            progress: self,
            name: name.to_string(),
            start: Instant::now(),
            bar,
        }
    }

    /// (stage name, seconds) in the order stages finished.
    pub fn timings(&self) -> Vec<(String, f64)> {
        self.stages
            .lock()
            .expect("no panics while holding the lock")
            .clone()
    }

    /// Records a stage measured elsewhere.
    pub(crate) fn record(&self, name: &str, seconds: f64) {
        self.stages
            .lock()
            .expect("no panics while holding the lock")
            .push((name.to_string(), seconds));
    }
}

/// A running stage of a [`Progress`]: its bar and start time.
pub struct Stage<'a> {
    progress: &'a Progress,
    name: String,
    start: Instant,
    bar: Option<ProgressBar>,
}

impl Stage<'_> {
    /// Advances the stage's bar by `n` work items.
    pub fn inc(&self, n: u64) {
        if let Some(bar) = &self.bar {
            bar.inc(n);
        }
    }

    /// Ends the stage and records its time.
    pub fn finish(self) -> f64 {
        let seconds = self.start.elapsed().as_secs_f64();
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
        self.progress.record(&self.name, seconds);
        seconds
    }
}
