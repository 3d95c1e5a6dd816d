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
//! [`stop_on_signal`].

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

#[cfg(test)]
mod tests {
    #[test]
    fn creating_a_node_marks_the_process() {
        // Before any node in this test process … (other tests may have made one: only the
        // transition is checked where it can be).
        let (_node, _) = crate::services::create_node("startup_mark_test").unwrap();
        assert!(super::holds_resources());
    }
}
