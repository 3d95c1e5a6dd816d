//! The shell's error: what could not be set up before the planner process runs. Once it
//! runs, nothing fails: a sample that cannot be sent is logged and skipped, never waited
//! for.

use ipc_types::services::ServiceError;
use planner_core::PlannerError;

/// Why the planner process could not start.
#[derive(Debug, thiserror::Error)]
pub enum ShellError {
    /// An iceoryx2 node or service could not be opened; the message names the service.
    #[error(transparent)]
    Ipc(#[from] ServiceError),
    /// The planner could not be built for the scene (a parameter out of range, the start
    /// or the goal in collision).
    #[error(transparent)]
    Planner(#[from] PlannerError),
    /// The memory bound leaves the trees no room.
    #[error(transparent)]
    Memory(#[from] planner_core::memory::BoundTooSmall),
    /// A thread could not be started.
    #[error("cannot start the {thread} thread")]
    Thread {
        /// Which thread.
        thread: &'static str,
        /// The OS error.
        source: std::io::Error,
    },
}
