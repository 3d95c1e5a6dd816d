//! The haptic loop library's error: what could not be set up, naming the part and, where the
//! user can fix it, what to check. Each message includes the underlying error's, which is
//! therefore not also returned as `source()` (a report would print it twice). The RT thread itself never returns errors: faults there
//! are `u32` codes ([`ipc_types::FaultCode`]) latched by [`crate::safety`].

use crate::contact::ContactError;
use devices::DeviceError;
use devices::record::RecordError;
use devices::sdk::SdkError;
use ipc_types::services::ServiceError;

/// Why a loop session, a device or one of its threads could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An iceoryx2 node or service could not be opened; the message names the service.
    #[error(transparent)]
    Ipc(#[from] ServiceError),
    /// The namespace's state blackboard already has a live writer.
    #[error("{error}; is another haptic loop running on this namespace ('{namespace}')?")]
    StateTaken {
        /// The IPC namespace.
        namespace: String,
        /// What iceoryx2 said.
        error: ServiceError,
    },
    /// A device did not open or could not be built; `hint` says what to check.
    #[error("cannot open {device}: {error}{}", if hint.is_empty() { String::new() } else { format!("; {hint}") })]
    Device {
        /// The device, e.g. `the SpaceMouse`.
        device: String,
        /// The device's error.
        error: DeviceError,
        /// What to check (permissions, library path, driver); may be empty.
        hint: &'static str,
    },
    /// A vendor SDK could not be loaded.
    #[error("cannot use {device}: {error}")]
    Sdk {
        /// The device.
        device: String,
        /// The loader's error (names the library and what to check).
        error: SdkError,
    },
    /// A recording could not be written or a replay read.
    #[error("{what}: {error}")]
    Record {
        /// What was being done, naming the file.
        what: String,
        /// The recorder's error.
        error: RecordError,
    },
    /// The contact model could not be built for this scene.
    #[error("scene '{scene}': {error}")]
    Contact {
        /// Scene name.
        scene: String,
        /// Why.
        error: Box<ContactError>,
    },
    /// A thread could not be started or died during its set-up.
    #[error("cannot start the {thread} thread: {reason}")]
    Thread {
        /// Which thread.
        thread: &'static str,
        /// Why (the OS error, or that it died).
        reason: String,
    },
    /// A configuration value is out of range.
    #[error("{what} must be {need}, got {value}")]
    Invalid {
        /// The value, e.g. `rate (Hz)`.
        what: &'static str,
        /// The range, e.g. `within 10–10000`.
        need: &'static str,
        /// The value given.
        value: f64,
    },
}
