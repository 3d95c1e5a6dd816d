//! Recording a device session to MCAP and replaying it.
//!
//! [`Recorder`] wraps any [`crate::HapticDevice`]: every `read` result and every written
//! wrench goes into a lock-free ring (`rtrb`, preallocated) that a writer thread drains to
//! an MCAP file, so the RT thread never touches the file. A full ring drops events and
//! counts them; it never blocks. [`ReplayDevice`] plays a recording back: the n-th `read`
//! returns the n-th recorded read (state or error) whatever the clock says, so a replay is
//! deterministic. See [`format`] for the file layout.

pub mod format;
mod recorder;
mod replay;

pub use recorder::{RecordStats, Recorder};
pub use replay::ReplayDevice;

use thiserror::Error;

/// Why a recording could not be written or read. Rich (allocates): set-up and shutdown only.
#[derive(Debug, Error)]
pub enum RecordError {
    /// The file could not be created, opened or read.
    #[error("{path}: {error}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        error: std::io::Error,
    },
    /// The MCAP writer or reader failed.
    #[error("{path}: MCAP: {what}")]
    Mcap {
        /// File.
        path: String,
        /// Cause.
        what: String,
    },
    /// A message does not decode or breaks the layout (the text says which).
    #[error("{path}: {what}")]
    Format {
        /// File.
        path: String,
        /// What is wrong.
        what: String,
    },
}

#[cfg(test)]
mod tests;
