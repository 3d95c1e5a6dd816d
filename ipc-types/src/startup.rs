//! Whether this process already holds what needs an orderly stop: iceoryx2 nodes (their
//! files outlive a killed process until someone removes them), child processes. Before
//! that, a signal may end the process at once, even in the middle of long start-up work
//! that does not poll a stop flag (reading a big mesh, building collision trees); after
//! it, the signal only asks, and the process stops in order.
//!
//! [`crate::services::create_node`] marks the process; a binary marks it itself before it
//! starts a child process. A signal handler asks [`holds_resources`].

use std::sync::atomic::{AtomicBool, Ordering};

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
