//! Whether this process already holds what needs an orderly stop: iceoryx2 nodes (their
//! files outlive a killed process until someone removes them), child processes. Before
//! that, a signal may end the process at once, even in the middle of long start-up work
//! that does not poll a stop flag (reading a big mesh, building collision trees); after
//! it, the signal only asks, and the process stops in order.
//!
//! [`crate::services::create_node`] marks the process; a binary marks it itself before it
//! starts a child process. A signal handler asks [`holds_resources`].
//!
//! Also what every program of the system does first: [`init_logging`] and
//! [`stop_on_signal`], and where it stands with the kernel's OOM killer
//! ([`raise_oom_score_adj`], [`lower_oom_score_adj`]).

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

static HOLDS: AtomicBool = AtomicBool::new(false);

/// From now on this process holds resources that need an orderly stop.
pub fn hold_resources() {
    HOLDS.store(true, Ordering::SeqCst);
}

/// Whether [`hold_resources`] was called in this process.
pub fn holds_resources() -> bool {
    HOLDS.load(Ordering::SeqCst)
}

/// What a SIGINT / SIGTERM handler does: sets `stop` when the process holds resources,
/// else says "`program`: stopped during start-up" on stderr and ends the process at once
/// with exit code 130 (the shell's code for an interrupted command).
pub fn on_signal(stop: &AtomicBool, program: &str) {
    if holds_resources() {
        stop.store(true, Ordering::Release);
    } else {
        eprintln!("{program}: stopped during start-up");
        std::process::exit(130);
    }
}

/// The flag SIGINT / SIGTERM set, the handler installed at the first call in a process
/// (later calls return the same flag). Until the process holds resources a signal ends it
/// at once with exit code 130, saying so as `program` ([`on_signal`]).
pub fn stop_on_signal(program: &'static str) -> Result<Arc<AtomicBool>, ctrlc::Error> {
    static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    if let Some(s) = STOP.get() {
        return Ok(s.clone());
    }
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    ctrlc::set_handler(move || on_signal(&s, program))?;
    Ok(STOP.get_or_init(|| stop).clone())
}

/// Logs to stderr with `default_filter` (e.g. `info,zenoh=warn`) unless `RUST_LOG` says
/// otherwise, in colour only on a terminal. A second call does nothing.
pub fn init_logging(default_filter: &str) {
    init_logging_with(default_filter, tracing_subscriber::layer::Identity::new());
}

/// [`init_logging`], with `layer` beside the log's writer: it sees the events its own filter
/// enables, whatever `RUST_LOG` lets the log print (the gateways count Zenoh's refusals so).
pub fn init_logging_with<L>(default_filter: &str, layer: L)
where
    L: tracing_subscriber::Layer<tracing_subscriber::Registry> + Send + Sync + 'static,
{
    use tracing_subscriber::Layer;
    use tracing_subscriber::layer::SubscriberExt;
    use tracing_subscriber::util::SubscriberInitExt;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_filter));
    let log = tracing_subscriber::fmt::layer()
        .with_ansi(std::io::stderr().is_terminal())
        .with_writer(std::io::stderr)
        .with_filter(filter);
    let _ = tracing_subscriber::registry()
        .with(layer)
        .with(log)
        .try_init();
}

/// This process's `oom_score_adj`: from -1000 (never killed for memory) through 0 (the
/// default) to 1000 (killed first).
const OOM_SCORE_ADJ: &str = "/proc/self/oom_score_adj";

/// What became of a request to change this process's `oom_score_adj`: the value now in
/// effect (read back) and why. Printed (`Display`) and written into the programs' JSON
/// summaries (not a wire type).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct OomScoreAdj {
    /// The value in effect now, read back after the request (-1000 to 1000); `None` when
    /// unavailable.
    pub value: Option<i32>,
    /// The value before the request.
    pub before: Option<i32>,
    /// The value asked for.
    pub requested: i32,
    /// Whether it was applied, and if not why not.
    pub outcome: OomOutcome,
    /// Why it was kept, refused or unavailable; `None` when applied.
    pub reason: Option<String>,
}

/// How a request to change `oom_score_adj` ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OomOutcome {
    /// Written, and read back as asked.
    Applied,
    /// Not written: the value in effect already went as far as asked or further (set by a
    /// service manager, `OOMScoreAdjust=`, or inherited from the parent).
    Kept,
    /// The kernel refused the write (lowering below the value a privileged ancestor left
    /// needs `CAP_SYS_RESOURCE`: EACCES); the value is unchanged.
    Refused,
    /// There is no `/proc/self/oom_score_adj` (not Linux, or no /proc).
    Unavailable,
}

impl std::fmt::Display for OomScoreAdj {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Some(value) = self.value else {
            return write!(
                f,
                "unavailable ({})",
                self.reason.as_deref().unwrap_or("no /proc")
            );
        };
        write!(f, "{value}")?;
        let why = self.reason.as_deref().unwrap_or("");
        match (self.outcome, self.before) {
            (OomOutcome::Applied, Some(b)) if b < value => write!(f, " (raised from {b})"),
            (OomOutcome::Applied, Some(b)) if b > value => write!(f, " (lowered from {b})"),
            (OomOutcome::Applied, _) => write!(f, " (set)"),
            (OomOutcome::Kept, _) => write!(f, " (kept: {why})"),
            (OomOutcome::Refused, _) => write!(f, " (kept; {} refused: {why})", self.requested),
            (OomOutcome::Unavailable, _) => write!(f, " (unavailable: {why})"),
        }
    }
}

/// This process's `oom_score_adj`, or `None` without /proc (or on another system).
pub fn oom_score_adj() -> Option<i32> {
    read_oom_score_adj(std::path::Path::new(OOM_SCORE_ADJ)).ok()
}

/// Raises this process's `oom_score_adj` to `value` (-1000 to 1000), so that the kernel's
/// OOM killer takes it before processes with lower values. Raising needs no rights; a value
/// already at or above `value` is kept (an administrator's or a service manager's higher
/// value wins). Children inherit it. Never fails: the outcome says what is in effect.
pub fn raise_oom_score_adj(value: i32) -> OomScoreAdj {
    adjust(std::path::Path::new(OOM_SCORE_ADJ), value, Direction::Raise)
}

/// Lowers this process's `oom_score_adj` to `value` (-1000 to 1000), so that the kernel's
/// OOM killer takes it after processes with higher values. Going below the lowest value a
/// privileged ancestor left (usually 0) needs `CAP_SYS_RESOURCE`: without it the kernel
/// refuses, the value is kept and the outcome says so. A value already at or below `value`
/// is kept. Children inherit it. Never fails.
pub fn lower_oom_score_adj(value: i32) -> OomScoreAdj {
    adjust(std::path::Path::new(OOM_SCORE_ADJ), value, Direction::Lower)
}

/// Sets this process's `oom_score_adj` to `value`, up or down (see
/// [`raise_oom_score_adj`] and [`lower_oom_score_adj`] for the rights each needs).
pub fn set_oom_score_adj(value: i32) -> OomScoreAdj {
    adjust(
        std::path::Path::new(OOM_SCORE_ADJ),
        value,
        Direction::Either,
    )
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Direction {
    Raise,
    Lower,
    Either,
}

fn read_oom_score_adj(path: &std::path::Path) -> std::io::Result<i32> {
    let text = std::fs::read_to_string(path)?;
    text.trim().parse().map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{}: not a number: {text:?}", path.display()),
        )
    })
}

/// The request at `path` (the real file, or a stand-in in the tests).
fn adjust(path: &std::path::Path, value: i32, direction: Direction) -> OomScoreAdj {
    let mut out = OomScoreAdj {
        value: None,
        before: None,
        requested: value,
        outcome: OomOutcome::Unavailable,
        reason: None,
    };
    if !cfg!(target_os = "linux") {
        out.reason = Some("not Linux".to_owned());
        return out;
    }
    let before = match read_oom_score_adj(path) {
        Ok(v) => v,
        Err(e) => {
            out.reason = Some(format!("{}: {e}", path.display()));
            return out;
        }
    };
    (out.before, out.value) = (Some(before), Some(before));
    let far_enough = match direction {
        Direction::Raise => before >= value,
        Direction::Lower => before <= value,
        Direction::Either => before == value,
    };
    if far_enough {
        out.outcome = OomOutcome::Kept;
        out.reason = Some(match before == value {
            true => "already so".to_owned(),
            false if direction == Direction::Raise => format!("already above {value}"),
            false => format!("already below {value}"),
        });
        return out;
    }
    let written = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .and_then(|mut f| std::io::Write::write_all(&mut f, format!("{value}\n").as_bytes()));
    let now = read_oom_score_adj(path);
    out.value = now.as_ref().ok().copied();
    match (written, now) {
        (Ok(()), Ok(v)) if v == value => out.outcome = OomOutcome::Applied,
        (Ok(()), Ok(v)) => {
            out.outcome = OomOutcome::Refused;
            out.reason = Some(format!("wrote {value}, reads back {v}"));
        }
        (Err(e), _) if e.kind() == std::io::ErrorKind::PermissionDenied => {
            out.outcome = OomOutcome::Refused;
            out.reason = Some(format!("{e}: lowering it needs CAP_SYS_RESOURCE"));
        }
        (Err(e), _) => {
            out.outcome = OomOutcome::Refused;
            out.reason = Some(e.to_string());
        }
        (Ok(()), Err(e)) => {
            out.outcome = OomOutcome::Unavailable;
            out.reason = Some(format!("cannot read it back: {e}"));
        }
    }
    out
}

/// A program's report (`report`'s own fields) with an `oom_score_adj` field beside them,
/// for JSON summaries of reports that are not the program's own type.
#[derive(Debug, serde::Serialize)]
pub struct WithOomScoreAdj<'a, R: serde::Serialize> {
    /// The report.
    #[serde(flatten)]
    pub report: &'a R,
    /// What the program did with its `oom_score_adj`.
    pub oom_score_adj: &'a OomScoreAdj,
}

/// Whether this process holds `CAP_SYS_RESOURCE` (bit 24 of `CapEff` in
/// /proc/self/status), which lowering `oom_score_adj` needs; `None` without /proc.
pub fn has_cap_sys_resource() -> Option<bool> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let hex = status
        .lines()
        .find_map(|l| l.strip_prefix("CapEff:"))?
        .trim();
    Some(u64::from_str_radix(hex, 16).ok()? & (1 << 24) != 0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn creating_a_node_marks_the_process() {
        // Before any node in this test process … (other tests may have made one: only the
        // transition is checked where it can be).
        let (_node, _) = crate::services::create_node("startup_mark_test").unwrap();
        assert!(super::holds_resources());
    }
    /// Set in the child process that [`raising_needs_no_rights_lowering_is_refused_without_them`]
    /// runs: raising `oom_score_adj` cannot be undone without `CAP_SYS_RESOURCE`, so the
    /// test process itself keeps its value.
    const OOM_CHILD: &str = "HRRTC_OOM_SCORE_ADJ_TEST_CHILD";

    fn has_cap_sys_resource() -> bool {
        super::has_cap_sys_resource().expect("CapEff in /proc/self/status")
    }

    #[test]
    fn raising_needs_no_rights_lowering_is_refused_without_them() {
        use super::{OomOutcome, lower_oom_score_adj, oom_score_adj, raise_oom_score_adj};
        if std::env::var_os(OOM_CHILD).is_none() {
            // This test again, alone, in a child process.
            let path = concat!(
                module_path!(),
                "::raising_needs_no_rights_lowering_is_refused_without_them"
            );
            let name = path.split_once("::").unwrap().1;
            let out = std::process::Command::new(std::env::current_exe().unwrap())
                .args([name, "--exact", "--nocapture", "--test-threads=1"])
                .env(OOM_CHILD, "1")
                .output()
                .unwrap();
            let stdout = String::from_utf8_lossy(&out.stdout);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(out.status.success(), "child: {stdout}\n{stderr}");
            // It ran (a filter that matches nothing passes too).
            assert!(stdout.contains("1 passed"), "child: {stdout}\n{stderr}");
            return;
        }
        let Some(before) = oom_score_adj() else {
            let r = raise_oom_score_adj(500);
            assert_eq!(r.outcome, OomOutcome::Unavailable, "{r:?}");
            assert_eq!(r.value, None);
            return;
        };
        // Raising needs no rights.
        let r = raise_oom_score_adj(500);
        assert_eq!(
            r.value,
            oom_score_adj(),
            "the report is the value read back"
        );
        assert_eq!(r.before, Some(before));
        if before < 500 {
            assert_eq!(r.outcome, OomOutcome::Applied, "{r:?}");
            assert_eq!(r.value, Some(500));
        } else {
            assert_eq!(r.outcome, OomOutcome::Kept, "{r:?}");
        }
        let raised = r.value.unwrap();
        // A higher value in effect is kept.
        let k = raise_oom_score_adj(300);
        assert_eq!(k.outcome, OomOutcome::Kept, "{k:?}");
        assert_eq!(k.value, Some(raised));
        assert_eq!(oom_score_adj(), Some(raised));
        // Lowering: applied with CAP_SYS_RESOURCE; without it refused (the kernel's floor
        // for an unprivileged process is 0 unless a privileged ancestor lowered it), the
        // value kept, and said why.
        let l = lower_oom_score_adj(-900);
        assert_eq!(
            l.value,
            oom_score_adj(),
            "the report is the value read back"
        );
        if has_cap_sys_resource() {
            assert_eq!(l.outcome, OomOutcome::Applied, "{l:?}");
            assert_eq!(l.value, Some(-900));
        } else {
            assert_eq!(
                l.outcome,
                OomOutcome::Refused,
                "{l:?} (without CAP_SYS_RESOURCE only a privileged ancestor that set -900 or \
                 less lets this through)"
            );
            assert_eq!(l.value, Some(raised));
            let why = l.reason.as_deref().unwrap();
            assert!(why.contains("CAP_SYS_RESOURCE"), "{why}");
            assert!(l.to_string().contains("-900 refused"), "{l}");
        }
    }

    #[test]
    fn a_stand_in_file_is_raised_lowered_and_kept_as_asked() {
        use super::{Direction, OomOutcome, adjust};
        let dir = std::env::temp_dir().join(format!("hrrtc-oom-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("oom_score_adj");
        std::fs::write(&file, "0\n").unwrap();
        let r = adjust(&file, 300, Direction::Raise);
        assert_eq!(
            (r.outcome, r.before, r.value),
            (OomOutcome::Applied, Some(0), Some(300))
        );
        assert_eq!(r.to_string(), "300 (raised from 0)");
        assert_eq!(std::fs::read_to_string(&file).unwrap().trim(), "300");
        let k = adjust(&file, 200, Direction::Raise);
        assert_eq!((k.outcome, k.value), (OomOutcome::Kept, Some(300)));
        assert_eq!(k.to_string(), "300 (kept: already above 200)");
        let l = adjust(&file, -900, Direction::Lower);
        assert_eq!((l.outcome, l.value), (OomOutcome::Applied, Some(-900)));
        assert_eq!(l.to_string(), "-900 (lowered from 300)");
        let k = adjust(&file, -500, Direction::Lower);
        assert_eq!((k.outcome, k.value), (OomOutcome::Kept, Some(-900)));
        let s = adjust(&file, 100, Direction::Either);
        assert_eq!((s.outcome, s.value), (OomOutcome::Applied, Some(100)));
        // What is not a number is not guessed at.
        std::fs::write(&file, "many\n").unwrap();
        let u = adjust(&file, 500, Direction::Raise);
        assert_eq!((u.outcome, u.value), (OomOutcome::Unavailable, None));
        assert!(u.to_string().contains("not a number"), "{u}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn without_the_file_it_is_unavailable_and_serialises_so() {
        use super::{Direction, OomOutcome, adjust};
        let r = adjust(
            std::path::Path::new("/nonexistent/proc/self/oom_score_adj"),
            -900,
            Direction::Lower,
        );
        assert_eq!(
            (r.outcome, r.value, r.before),
            (OomOutcome::Unavailable, None, None)
        );
        assert!(r.to_string().starts_with("unavailable ("), "{r}");
        let json = serde_json::to_value(&r).unwrap();
        assert_eq!(json["outcome"], "unavailable");
        assert_eq!(json["requested"], -900);
        assert!(json["value"].is_null());
        // Beside a report's own fields.
        #[derive(serde::Serialize)]
        struct Report {
            ticks: u64,
        }
        let with = super::WithOomScoreAdj {
            report: &Report { ticks: 7 },
            oom_score_adj: &r,
        };
        let json = serde_json::to_value(&with).unwrap();
        assert_eq!(json["ticks"], 7);
        assert_eq!(json["oom_score_adj"]["outcome"], "unavailable");
    }
}
