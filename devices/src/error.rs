//! The one error type of a device operation.

use thiserror::Error;

/// Why a device operation failed.
///
/// Small and `Copy` so that the 1 kHz loop can store, compare and latch it without
/// allocating. Every variant that can come out of [`crate::HapticDevice::read`] or
/// [`crate::HapticDevice::write`] is a fault for the real-time loop: it must latch zero
/// force and report it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum DeviceError {
    /// The device went away (unplugged, powered off, its driver reported a lost link).
    #[error("device disconnected")]
    Disconnected,
    /// A read of the device's state failed or timed out; the link may recover.
    #[error("device read failed")]
    ReadFailed,
    /// Sending a wrench to the device failed; the link may recover.
    #[error("device write failed")]
    WriteFailed,
    /// Data crossing the API was unusable: a non-finite wrench given to `write`, or a
    /// malformed/non-finite sample coming from the device. The offending value is ignored.
    #[error("invalid data (non-finite or malformed)")]
    InvalidData,
    /// `read` or `write` was called before a successful `open` (or after `close`).
    #[error("device not open")]
    NotOpen,
    /// `open` failed; the text says why (static, so the error stays `Copy`).
    #[error("device open failed: {0}")]
    OpenFailed(&'static str),
    /// A device or simulator configuration was rejected before use; the text names the
    /// offending field.
    #[error("invalid device configuration: {0}")]
    InvalidConfig(&'static str),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_small_copy_and_displays() {
        let e = DeviceError::OpenFailed("no such device");
        let copy = e;
        assert_eq!(e, copy);
        assert_eq!(e.to_string(), "device open failed: no such device");
        assert!(std::mem::size_of::<DeviceError>() <= 24);
    }
}
