//! The view's error: which service, file or server failed, and why.

use ipc_types::services::ServiceError;
use std::path::PathBuf;

/// Why the view could not start, run, or merge recordings. The message names the service,
/// the file or the address; the cause is the [`std::error::Error::source`].
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// An iceoryx2 node or service could not be opened; the message names the service.
    #[error(transparent)]
    Ipc(#[from] ServiceError),
    /// A subscriber failed to receive (not a missed sample: those overflow safely).
    #[error("cannot receive from the {service} service")]
    Receive {
        /// `roadmap`, `path` or `guidance`.
        service: &'static str,
        /// What iceoryx2 said.
        source: iceoryx2::port::ReceiveError,
    },
    /// The WebSocket server could not be started.
    #[error("cannot start the WebSocket server on {host}:{port} (in use? try --port)")]
    Server {
        /// Address it was to bind.
        host: String,
        /// Port it was to bind.
        port: u16,
        /// What the Foxglove SDK said.
        source: foxglove::FoxgloveError,
    },
    /// A file could not be created or read.
    #[error("cannot {action} {}", path.display())]
    File {
        /// What was done: `create`, `create the recording`, `read`.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The recording could not be started or finished.
    #[error("cannot {action} the recording {}", path.display())]
    Recording {
        /// `write` or `finish`.
        action: &'static str,
        /// The MCAP file.
        path: PathBuf,
        /// What the Foxglove SDK said.
        source: foxglove::FoxgloveError,
    },
    /// An MCAP file to merge could not be read: not MCAP, or corrupt.
    #[error("{}: {what}", path.display())]
    McapRead {
        /// `not an MCAP file` or `corrupt MCAP`.
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// What the mcap crate said.
        source: mcap::McapError,
    },
    /// The merged MCAP file could not be written or finished.
    #[error("cannot {action} {}", path.display())]
    McapWrite {
        /// `write` or `finish`.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// What the mcap crate said.
        source: mcap::McapError,
    },
}
