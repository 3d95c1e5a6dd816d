//! What can stop either gateway (`serve`, `device`) from starting.

use crate::participant::RosError;
use ipc_types::services::{self, ServiceError};

/// Why a gateway could not start (or stopped during set-up).
#[derive(Debug, thiserror::Error)]
pub enum GatewayError {
    /// The iceoryx2 namespace cannot name services (not a source: the message says it all).
    #[error("iceoryx2 namespace: {0}")]
    Namespace(services::NamespaceError),
    /// ROS 2 names, Zenoh session or declarations.
    #[error(transparent)]
    Ros(#[from] RosError),
    /// An iceoryx2 port.
    #[error(transparent)]
    Ipc(#[from] ServiceError),
    /// A bad setting.
    #[error("{0}")]
    Config(String),
    /// A thread could not start or died starting.
    #[error("the gateway's {thread} thread: {reason}")]
    Thread {
        /// Which.
        thread: &'static str,
        /// Why.
        reason: String,
    },
}

impl From<services::NamespaceError> for GatewayError {
    fn from(e: services::NamespaceError) -> Self {
        GatewayError::Namespace(e)
    }
}
