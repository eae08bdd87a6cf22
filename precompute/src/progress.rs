//! Progress of the stages of a bake on stderr, and stage timings for the report: bars
//! (indicatif) on a terminal; plain lines where stderr is a file or a pipe (a log, CI, a batch
//! job), a line when a stage starts and ends and one every [`LINE_INTERVAL`] seconds in
//! between with the elapsed time and an estimate of what is left, so a slow bake can be told
//! from a hung one.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Seconds between two progress lines of a stage (plain-line mode).
pub const LINE_INTERVAL: f64 = 5.0;

/// How progress shows on stderr.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Nothing shown.
    Hidden,
    /// indicatif bars (a terminal).
    Bars,
    /// Plain lines (a log file or a pipe).
    Lines,
}

/// Shows progress on stderr as its [`Mode`] says; always records timings, and the process's
/// peak resident memory at the end of each stage where Linux reports it ([`Progress::peaks`]).
pub struct Progress {
    mode: Mode,
    stages: std::sync::Mutex<Vec<(String, f64)>>,
    peaks: std::sync::Mutex<Vec<(String, u64)>>,
    /// Per stage that ended: the process's resident and peak resident bytes when it began.
    starts: std::sync::Mutex<Vec<(String, Memory)>>,
    /// Per stage that planned its buffers: the bytes it said it needs.
    estimates: std::sync::Mutex<Vec<(String, u64)>>,
}

/// The process's memory at one moment (Linux; `None` elsewhere).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Memory {
    /// Resident bytes (`VmRSS`).
    pub resident: Option<u64>,
    /// Peak resident bytes so far (`VmHWM`).
    pub peak: Option<u64>,
}

impl Memory {
    /// Now.
    pub fn now() -> Self {
        Self {
            resident: status_bytes("VmRSS:"),
            peak: peak_resident(),
        }
    }
}

impl Progress {
    /// Progress bars on stderr when `enabled`; timings are recorded either way.
    pub fn new(enabled: bool) -> Self {
        Self::with_mode(if enabled { Mode::Bars } else { Mode::Hidden })
    }

    /// Progress shown as `mode` says; timings are recorded either way.
    pub fn with_mode(mode: Mode) -> Self {
        Self {
            mode,
            stages: std::sync::Mutex::new(Vec::new()),
            peaks: std::sync::Mutex::new(Vec::new()),
            starts: std::sync::Mutex::new(Vec::new()),
            estimates: std::sync::Mutex::new(Vec::new()),
        }
    }

    /// No bars, timings only.
    pub fn hidden() -> Self {
        Self::new(false)
    }

    /// Starts a stage with `total` work items (0: a spinner).
    pub fn stage(&self, name: &str, total: u64) -> Stage<'_> {
        let memory = Memory::now();
        if self.mode == Mode::Lines {
            eprintln!("lrr: {name}: started");
        }
        let bar = if self.mode == Mode::Bars {
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
        // A stage without counted work says every LINE_INTERVAL that it still runs.
        let ticker = (self.mode == Mode::Lines && total == 0).then(|| {
            let (stop, wait) = std::sync::mpsc::channel::<()>();
            let (name, start) = (name.to_string(), Instant::now());
            let interval = std::time::Duration::from_secs_f64(LINE_INTERVAL);
            let thread = std::thread::spawn(move || {
                while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                    wait.recv_timeout(interval)
                {
                    let t = start.elapsed().as_secs_f64();
                    eprintln!("lrr: {name}: still running, {t:.0} s elapsed");
                }
            });
            (stop, thread)
        });
        Stage {
            progress: self,
            name: name.to_string(),
            memory,
            start: Instant::now(),
            bar,
            ticker,
            total,
            done: AtomicU64::new(0),
            printed_ms: AtomicU64::new(0),
        }
    }

    /// (stage name, seconds) in the order stages finished.
    pub fn timings(&self) -> Vec<(String, f64)> {
        self.stages
            .lock()
            .expect("no panics while holding the lock")
            .clone()
    }

    /// (stage name, bytes) in the order stages finished: the process's peak resident memory
    /// so far (`VmHWM`) when the stage ended, so the stage that raised it is the first whose
    /// figure is the final one. The mark is never set back (tools such as GNU time read it
    /// too). Empty where Linux does not report it. Per process: bakes running side by side in
    /// one process (tests) share it.
    pub fn peaks(&self) -> Vec<(String, u64)> {
        self.peaks
            .lock()
            .expect("no panics while holding the lock")
            .clone()
    }

    /// (stage name, memory when it began) in the order stages finished.
    pub fn starts(&self) -> Vec<(String, Memory)> {
        self.starts
            .lock()
            .expect("no panics while holding the lock")
            .clone()
    }

    /// Records that stage `name` planned `bytes` of buffers (what `--max-memory` was checked
    /// against), so that a report can set the stage's peak beside it.
    pub fn estimate(&self, name: &str, bytes: u128) {
        self.estimates
            .lock()
            .expect("no panics while holding the lock")
            .push((name.to_string(), bytes.min(u128::from(u64::MAX)) as u64));
    }

    /// (stage name, bytes) of [`estimate`](Self::estimate), in the order given.
    pub fn estimates(&self) -> Vec<(String, u64)> {
        self.estimates
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
    /// The process's memory when the stage began.
    memory: Memory,
    start: Instant,
    bar: Option<ProgressBar>,
    /// Plain-line mode, no total: the thread that prints "still running" (stopped by
    /// dropping the sender).
    ticker: Option<(std::sync::mpsc::Sender<()>, std::thread::JoinHandle<()>)>,
    /// Work items in all (0: unknown).
    total: u64,
    /// Work items done (plain-line mode).
    done: AtomicU64,
    /// Milliseconds after the start of the last line printed.
    printed_ms: AtomicU64,
}

impl Stage<'_> {
    /// Advances the stage's bar by `n` work items.
    pub fn inc(&self, n: u64) {
        if let Some(bar) = &self.bar {
            bar.inc(n);
        }
        if self.progress.mode != Mode::Lines {
            return;
        }
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        let now = self.start.elapsed().as_millis() as u64;
        let last = self.printed_ms.load(Ordering::Relaxed);
        if now.saturating_sub(last) < (LINE_INTERVAL * 1000.0) as u64 {
            return;
        }
        // One thread prints each line.
        if self
            .printed_ms
            .compare_exchange(last, now, Ordering::Relaxed, Ordering::Relaxed)
            .is_ok()
        {
            eprintln!(
                "lrr: {}",
                progress_line(&self.name, done, self.total, now as f64 / 1e3)
            );
        }
    }

    /// Ends the stage and records its time.
    pub fn finish(self) -> f64 {
        let seconds = self.start.elapsed().as_secs_f64();
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
        if let Some((stop, thread)) = self.ticker {
            drop(stop);
            let _ = thread.join();
        }
        if self.progress.mode == Mode::Lines {
            eprintln!("lrr: {}: done in {seconds:.1} s", self.name);
        }
        self.progress.record(&self.name, seconds);
        self.progress
            .starts
            .lock()
            .expect("no panics while holding the lock")
            .push((self.name.clone(), self.memory));
        if let Some(bytes) = peak_resident() {
            self.progress
                .peaks
                .lock()
                .expect("no panics while holding the lock")
                .push((self.name.clone(), bytes));
        }
        seconds
    }
}

/// The process's peak resident memory in bytes since it started (`VmHWM` of
/// /proc/self/status), where Linux reports it.
pub fn peak_resident() -> Option<u64> {
    status_bytes("VmHWM:")
}

/// A `kB` line of /proc/self/status, in bytes.
fn status_bytes(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// A progress line: `stage: done/total (p%), t s elapsed, about r s left` (the rest at the
/// rate so far); without a total, the items done and the time.
pub fn progress_line(name: &str, done: u64, total: u64, elapsed: f64) -> String {
    if total == 0 {
        return format!("{name}: {done} done, {elapsed:.0} s elapsed");
    }
    let fraction = (done as f64 / total as f64).min(1.0);
    let left = if fraction > 0.0 {
        format!("about {:.0} s left", elapsed * (1.0 - fraction) / fraction)
    } else {
        "time left unknown".to_string()
    };
    format!(
        "{name}: {done}/{total} ({:.0}%), {elapsed:.0} s elapsed, {left}",
        100.0 * fraction
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_say_what_is_done_and_what_is_left() {
        assert_eq!(
            progress_line("form factors", 250, 1000, 10.0),
            "form factors: 250/1000 (25%), 10 s elapsed, about 30 s left"
        );
        assert_eq!(
            progress_line("probes", 0, 10, 6.0),
            "probes: 0/10 (0%), 6 s elapsed, time left unknown"
        );
        assert_eq!(
            progress_line("mesh", 3, 0, 7.2),
            "mesh: 3 done, 7 s elapsed"
        );
    }
}
