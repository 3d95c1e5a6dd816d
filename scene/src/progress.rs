//! Progress of long start-up work (loading a big mesh, building a voxmap or collision
//! trees) and a request to stop it, shared between the thread doing the work and one
//! showing it: a line redrawn in place on a terminal, a log line every few seconds when the
//! output goes to a file or a pipe.
//!
//! The counters are atomics and the stage a short string behind a mutex: set-up code only,
//! never the real-time path. The display is written here rather than with a progress-bar
//! crate because the haptic loop's binary, which shows it too, keeps such crates out of its
//! dependency graph (see `tests/tests/it/rt_deps.rs`).

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How far long work has come, and whether it should stop.
#[derive(Debug, Default)]
pub struct Progress {
    /// Set (by a signal handler, say) to stop the work; work polls it often enough to
    /// stop within a fraction of a second.
    pub cancel: Arc<AtomicBool>,
    stage: Mutex<String>,
    done: AtomicU64,
    total: AtomicU64,
}

impl Progress {
    /// Progress that stops when `cancel` is set.
    pub fn new(cancel: Arc<AtomicBool>) -> Self {
        Progress {
            cancel,
            ..Progress::default()
        }
    }

    /// Starts a stage named `name` of `total` units of work (0: not known).
    pub fn stage(&self, name: &str, total: u64) {
        *self.stage.lock().unwrap_or_else(|p| p.into_inner()) = name.to_owned();
        self.total.store(total, Ordering::Relaxed);
        self.done.store(0, Ordering::Relaxed);
    }

    /// Adds to the total of the current stage.
    pub fn add_total(&self, units: u64) {
        self.total.fetch_add(units, Ordering::Relaxed);
    }

    /// Counts `units` of work done.
    pub fn add(&self, units: u64) {
        self.done.fetch_add(units, Ordering::Relaxed);
    }

    /// Whether the work should stop.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// The stage, units done and units in all (done ≤ total when the total is known).
    pub fn read(&self) -> (String, u64, u64) {
        let stage = self.stage.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let total = self.total.load(Ordering::Relaxed);
        let done = self.done.load(Ordering::Relaxed);
        (stage, if total > 0 { done.min(total) } else { done }, total)
    }
}

/// Shows a [`Progress`] on stderr from a thread of its own until dropped.
#[derive(Debug)]
pub struct Display {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Display {
    /// Shows `progress` on stderr: redrawn every 100 ms on a terminal, a log line
    /// (`tracing`, info) after 0.5 s and then every `log_every` otherwise. Nothing is shown
    /// for the first 0.5 s, so quick work stays quiet.
    pub fn start(progress: Arc<Progress>, log_every: Duration) -> Display {
        let stop = Arc::new(AtomicBool::new(false));
        let s = stop.clone();
        let thread = std::thread::Builder::new()
            .name("progress".into())
            .spawn(move || show(&progress, &s, log_every))
            .ok();
        Display { stop, thread }
    }
}

impl Drop for Display {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Runs `work` while a [`Display`] shows a stage named `stage` of unknown length (how long
/// it has been at it): for work that cannot count its steps, such as reading a big file.
pub fn showing<T>(stage: &str, work: impl FnOnce() -> T) -> T {
    let progress = Arc::new(Progress::default());
    progress.stage(stage, 0);
    let display = Display::start(progress, Duration::from_secs(2));
    let out = work();
    drop(display);
    out
}

fn show(progress: &Progress, stop: &AtomicBool, log_every: Duration) {
    let terminal = std::io::stderr().is_terminal();
    let started = Instant::now();
    let mut stage_started = (String::new(), Instant::now());
    // The first log line as soon as the quiet half second is over, then every `log_every`.
    let mut next_log = started + Duration::from_millis(500);
    let mut drawn = false;
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
        let (stage, done, total) = progress.read();
        if stage.is_empty() || started.elapsed() < Duration::from_millis(500) {
            continue;
        }
        if stage != stage_started.0 {
            stage_started = (stage.clone(), Instant::now());
        }
        let line = describe(&stage, done, total, stage_started.1.elapsed());
        if terminal {
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r\x1b[2K{line}");
            let _ = err.flush();
            drawn = true;
        } else if Instant::now() >= next_log {
            tracing::info!("{line}");
            next_log = Instant::now() + log_every;
        }
    }
    if drawn {
        let _ = write!(std::io::stderr().lock(), "\r\x1b[2K");
    }
}

/// One line: the stage, a bar and the share done with the time left when the total is
/// known, else the units done.
fn describe(stage: &str, done: u64, total: u64, elapsed: Duration) -> String {
    let secs = elapsed.as_secs_f64();
    if total == 0 {
        return format!("{stage}: {done} … ({secs:.1} s)");
    }
    // The total is an estimate: work past it is the last few per cent, never "100 %" and
    // "0 s left" while the work goes on.
    let share = (done as f64 / total as f64).min(0.99);
    let width = 30;
    let filled = ((share * width as f64) as usize).min(width);
    let left = if done >= total {
        ", finishing".to_owned()
    } else if share > 0.02 {
        format!(", about {:.0} s left", secs * (1.0 - share) / share)
    } else {
        String::new()
    };
    format!(
        "{stage}: [{}{}] {:>3.0} % ({secs:.1} s{left})",
        "#".repeat(filled),
        " ".repeat(width - filled),
        share * 100.0
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stage_counts_and_a_line_says_how_far() {
        let p = Progress::default();
        p.stage("voxmap", 200);
        p.add(50);
        assert_eq!(p.read(), ("voxmap".to_owned(), 50, 200));
        let line = describe("voxmap", 50, 200, Duration::from_secs(2));
        assert!(line.starts_with("voxmap: [#######"), "{line}");
        assert!(
            line.contains(" 25 %") && line.contains("about 6 s left"),
            "{line}"
        );
        p.add(500);
        assert_eq!(p.read().1, 200, "done never passes the total");
        // Past the estimate: 99 % and "finishing", not 100 % with nothing left.
        let line = describe("voxmap", 200, 200, Duration::from_secs(9));
        assert!(
            line.contains(" 99 %") && line.contains("finishing") && !line.contains("left"),
            "{line}"
        );
        p.stage("pointshell", 0);
        assert_eq!(p.read(), ("pointshell".to_owned(), 0, 0));
        assert_eq!(
            describe("pointshell", 7, 0, Duration::ZERO),
            "pointshell: 7 … (0.0 s)"
        );
    }

    #[test]
    fn cancel_is_shared() {
        let flag = Arc::new(AtomicBool::new(false));
        let p = Progress::new(flag.clone());
        assert!(!p.cancelled());
        flag.store(true, Ordering::Relaxed);
        assert!(p.cancelled());
    }
}
