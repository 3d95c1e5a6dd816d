//! The non-real-time side of a SpaceMouse: folds HID reports into [`RawAxes`] and hands the
//! newest snapshot to the RT thread through a triple buffer (lock-free, wait-free, newest
//! value wins), so the RT thread never waits on HID I/O.

use triple_buffer::{Input, Output, triple_buffer};

use super::report::{self, RawAxes, ReportError};

/// What the RT side sees: the held axes, how many reports have arrived (it dates a change
/// by the tick at which this count moved), and whether the device is attached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Snapshot {
    /// Newest value of every axis and button.
    pub axes: RawAxes,
    /// Motion and button reports folded in since start.
    pub reports: u64,
    /// The device is attached and being read.
    pub connected: bool,
}

/// Writer side of the handoff. Owned by the HID reader thread (or by a test feeding bytes).
pub struct Feed {
    input: Input<Snapshot>,
    current: Snapshot,
    /// Reports rejected as malformed since start.
    malformed: u64,
}

impl std::fmt::Debug for Feed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Feed")
            .field("current", &self.current)
            .field("malformed", &self.malformed)
            .finish()
    }
}

/// A connected feed and the reader end the RT side holds. The initial snapshot says
/// "not connected" until [`Feed::attach`].
pub(crate) fn channel() -> (Feed, Output<Snapshot>) {
    let (input, output) = triple_buffer(&Snapshot::default());
    (
        Feed {
            input,
            current: Snapshot::default(),
            malformed: 0,
        },
        output,
    )
}

impl Feed {
    /// Folds one raw input report (`bytes[0]` = report id) in and publishes. Reports of
    /// other ids (battery, vendor) are skipped; a malformed motion report is counted and
    /// returned as an error, and the held values stay as they were.
    pub fn push(&mut self, bytes: &[u8]) -> Result<(), ReportError> {
        match report::parse(bytes) {
            Ok(r) => {
                self.current.axes.apply(r);
                self.current.reports += 1;
                self.input.write(self.current);
                Ok(())
            }
            Err(ReportError::Unhandled(_)) => Ok(()),
            Err(e) => {
                self.malformed += 1;
                Err(e)
            }
        }
    }

    /// The device is (again) attached: axes restart from rest, since the puck's state
    /// while unplugged is unknown.
    pub fn attach(&mut self) {
        self.current.axes = RawAxes::default();
        self.current.connected = true;
        self.input.write(self.current);
    }

    /// The device went away: the RT side reports a fault and stops the avatar.
    pub fn detach(&mut self) {
        self.current.axes = RawAxes::default();
        self.current.connected = false;
        self.input.write(self.current);
    }

    /// Malformed reports seen so far.
    pub fn malformed(&self) -> u64 {
        self.malformed
    }
}
