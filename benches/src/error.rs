//! Why a benchmark fixture could not be set up or run. The harness binaries report it
//! through `anyhow`; the fixtures themselves name what failed.

use std::path::PathBuf;
use std::time::Duration;

/// Why a fixture of the benchmarks failed.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The haptic loop's set-up failed (IPC ports, relay thread, device).
    #[error(transparent)]
    Loop(#[from] haptic_loop::Error),
    /// The contact stage could not be built.
    #[error(transparent)]
    Contact(#[from] haptic_loop::contact::ContactError),
    /// A project service could not be opened.
    #[error(transparent)]
    Ipc(#[from] ipc_types::services::ServiceError),
    /// The planner rejected its scene or parameters.
    #[error(transparent)]
    Planner(#[from] planner_core::PlannerError),
    /// Standard output could not be written (the reader child's report).
    #[error("cannot write the report: {0}")]
    Report(#[from] std::io::Error),
    /// The simulated arm or its operator rejected their configuration.
    #[error("simulated arm: {0}")]
    Device(#[from] devices::DeviceError),
    /// No box face of the scene admits its object's largest face (`face_contact`).
    #[error("scene '{0}': no box obstacle face admits the object's largest face")]
    NoFace(String),
    /// A bare iceoryx2 call of the baseline measurements failed.
    #[error("{what}: {reason}")]
    Iceoryx {
        /// What was being created or done, e.g. `bare publisher`.
        what: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// The `planner` executable is not beside the running harness.
    #[error(
        "the planner binary is not next to this one ({}): run `cargo build --release -p planner`",
        .0.display()
    )]
    NoPlanner(PathBuf),
    /// A process or thread could not be started.
    #[error("cannot start {what}: {error}")]
    Start {
        /// The program or thread.
        what: String,
        /// The OS error.
        error: std::io::Error,
    },
    /// Not a messaging pattern of the baseline (`pubsub` or `blackboard`).
    #[error("pattern must be pubsub or blackboard, got '{0}'")]
    Pattern(String),
    /// Not a built-in scene.
    #[error("no built-in scene {0}")]
    UnknownScene(String),
    /// The baseline writer's stop sample did not come.
    #[error("no stop sample within {0:?} (writer gone?)")]
    NoStop(Duration),
}

impl BenchError {
    /// A bare iceoryx2 error while doing `what`.
    pub fn iceoryx<E: core::fmt::Debug>(what: &str) -> impl FnOnce(E) -> BenchError {
        let what = what.to_owned();
        move |e| BenchError::Iceoryx {
            what,
            reason: format!("{e:?}"),
        }
    }
}
