//! Every type that crosses a process boundary between the haptic loop and the planner.
//!
//! # Conventions (they hold for every type in this crate)
//!
//! - Units are SI: metres, newtons, newton-metres, seconds, radians. Field names carry
//!   the unit (`_m`, `_n`, `_nm`, `_ns`, ...) where it is not obvious.
//! - Timestamps are `CLOCK_MONOTONIC` nanoseconds of the host. Both processes run on the
//!   same host (iceoryx2 is host-local), so their timestamps are directly comparable.
//! - **Quaternions are stored as `[x, y, z, w]`** (vector part first, scalar last), the
//!   order nalgebra uses internally. This is the only place the order is stated.
//! - The *scene frame* is right-handed with Z up; scene geometry is in metres.
//!   The *device frame* is the base frame of the haptic device as its driver reports it,
//!   also converted to metres.
//! - Modes and faults are `u32` codes with named constants ([`FaultCode`],
//!   [`ContactCode`], [`GuidanceMode`]): another process can write any bit pattern into
//!   shared memory, and every bit pattern of a `u32` is a valid value, whereas an invalid
//!   Rust `enum` or `bool` would be undefined behaviour. Receivers treat unknown codes as
//!   faults.
//! - Every type is `#[repr(C)]`, fixed size, built from fixed-width numbers and arrays,
//!   and carries a versioned iceoryx2 type name. Sizes are asserted at compile time so a
//!   layout change cannot go unnoticed.

#![warn(missing_docs)]

mod codes;
pub mod convert;
mod driver;
mod guidance;
pub mod latency;
pub mod layout;
mod limits;
pub mod pacing;
mod path;
mod roadmap;
pub mod services;
pub mod startup;
mod state;

pub use codes::{ContactCode, FaultCode, GuidanceFreshness, GuidanceMode};
pub use driver::{
    DRIVER_NAME_LEN, DriverCommand, DriverError, DriverState, DriverStatus, OutputCode,
};
pub use guidance::{Guidance, GuidanceError};
pub use limits::{DeviceLimits, LimitError};
pub use path::{PATH_CAPACITY, Path};
pub use roadmap::{
    NO_PARENT, ROADMAP_NODES, ROADMAP_TREES, Roadmap, RoadmapNode, RoadmapTree, TreeKind,
};
pub use state::HapticState;

use iceoryx2::prelude::ZeroCopySend;

/// A rigid pose: position and orientation.
///
/// The frame is stated by the field that holds it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[type_name("hrrtc::Pose.v1")]
pub struct Pose {
    /// Position in metres.
    pub position_m: [f64; 3],
    /// Orientation as a unit quaternion, `[x, y, z, w]`.
    pub orientation_xyzw: [f64; 4],
}

impl Pose {
    /// The identity pose: origin, no rotation.
    pub const IDENTITY: Self = Self {
        position_m: [0.0; 3],
        orientation_xyzw: [0.0, 0.0, 0.0, 1.0],
    };

    /// True when every component is finite and the quaternion has unit norm within 1e-6.
    pub fn is_valid(&self) -> bool {
        let finite = self.position_m.iter().all(|v| v.is_finite())
            && self.orientation_xyzw.iter().all(|v| v.is_finite());
        let norm2: f64 = self.orientation_xyzw.iter().map(|v| v * v).sum();
        finite && (norm2 - 1.0).abs() < 1e-6
    }
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// A force and a torque.
///
/// The frame and the reference point of the torque are stated by the field that holds it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("hrrtc::Wrench.v1")]
pub struct Wrench {
    /// Force in newtons.
    pub force_n: [f64; 3],
    /// Torque in newton-metres.
    pub torque_nm: [f64; 3],
}

impl Wrench {
    /// No force, no torque.
    pub const ZERO: Self = Self {
        force_n: [0.0; 3],
        torque_nm: [0.0; 3],
    };

    /// True when all six components are finite.
    pub fn is_finite(&self) -> bool {
        self.force_n
            .iter()
            .chain(&self.torque_nm)
            .all(|v| v.is_finite())
    }
}

/// A linear and an angular velocity.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("hrrtc::Twist.v1")]
pub struct Twist {
    /// Linear velocity in m/s.
    pub linear_m_s: [f64; 3],
    /// Angular velocity in rad/s.
    pub angular_rad_s: [f64; 3],
}

/// Header of every message: who wrote it and when.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ZeroCopySend)]
#[type_name("hrrtc::Header.v1")]
pub struct Header {
    /// Increments by one per message from one writer. Starts at 1; 0 means "never written".
    pub sequence: u64,
    /// `CLOCK_MONOTONIC` time the message was written, ns.
    pub timestamp_ns: u64,
    /// Process id of the writer, so a reader can tell a restarted writer apart.
    pub writer_pid: u32,
    /// Reserved, zero. Keeps the header 8-byte aligned.
    pub reserved: u32,
}

impl Header {
    /// Message `sequence` of writer `writer_pid`, written at `timestamp_ns` (`CLOCK_MONOTONIC`).
    pub const fn new(sequence: u64, timestamp_ns: u64, writer_pid: u32) -> Self {
        Header {
            sequence,
            timestamp_ns,
            writer_pid,
            reserved: 0,
        }
    }
}

/// `CLOCK_MONOTONIC` now, ns: the clock of every timestamp on the wire.
#[inline]
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleeps until `CLOCK_MONOTONIC` reaches `deadline_ns` (absolute: no drift accumulates,
/// and a signal does not cut the sleep short). Returns at once if the deadline has passed.
pub fn sleep_until_ns(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: `ts` is a valid timespec; a null remainder is allowed with TIMER_ABSTIME.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        // EINTR: a signal interrupted the sleep; the absolute deadline is unchanged.
        if rc != libc::EINTR {
            break;
        }
    }
}

/// Why the calling thread could not get a SCHED_FIFO priority; it keeps its scheduler.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PriorityError {
    /// Not a SCHED_FIFO priority (1–99).
    #[error("invalid SCHED_FIFO priority {priority}: {reason}")]
    Invalid {
        /// The priority asked for.
        priority: u8,
        /// Why it is invalid.
        reason: String,
    },
    /// The kernel refused it: no `CAP_SYS_NICE` and no `rtprio` limit that allows it.
    #[error("SCHED_FIFO priority {priority} not permitted ({reason})")]
    NotPermitted {
        /// The priority asked for.
        priority: u8,
        /// What the kernel said.
        reason: String,
    },
}

/// Puts the calling thread under SCHED_FIFO at `priority` (1–99). Fails without
/// `CAP_SYS_NICE` or an `rtprio` limit; the thread then keeps its scheduler.
pub fn set_thread_fifo_priority(priority: u8) -> Result<(), PriorityError> {
    use thread_priority::{
        RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue, ThreadSchedulePolicy,
        set_thread_priority_and_policy, thread_native_id,
    };
    let value = ThreadPriorityValue::try_from(priority).map_err(|e| PriorityError::Invalid {
        priority,
        reason: e.to_string(),
    })?;
    set_thread_priority_and_policy(
        thread_native_id(),
        ThreadPriority::Crossplatform(value),
        ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
    )
    .map_err(|e| PriorityError::NotPermitted {
        priority,
        reason: format!("{e:?}"),
    })
}

/// Sets the calling thread's timer slack (how late the kernel may end its sleeps to batch
/// wake-ups), ns. A normal thread has 50 µs; a reader pacing itself to a loop's ticks wants
/// about 1 µs. Returns whether the kernel accepted it.
pub fn set_thread_timer_slack_ns(slack_ns: u64) -> bool {
    // SAFETY: PR_SET_TIMERSLACK takes one integer argument and changes only this thread.
    unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, slack_ns as libc::c_ulong) == 0 }
}

const _: () = {
    assert!(core::mem::size_of::<Pose>() == 56);
    assert!(core::mem::size_of::<Wrench>() == 48);
    assert!(core::mem::size_of::<Twist>() == 48);
    assert!(core::mem::size_of::<Header>() == 24);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_pose_is_valid_and_nan_is_not() {
        assert!(Pose::IDENTITY.is_valid());
        let mut p = Pose::IDENTITY;
        p.position_m[1] = f64::NAN;
        assert!(!p.is_valid());
        let mut q = Pose::IDENTITY;
        q.orientation_xyzw = [0.0, 0.0, 0.0, 2.0];
        assert!(!q.is_valid());
    }

    #[test]
    fn wrench_finiteness() {
        assert!(Wrench::ZERO.is_finite());
        let mut w = Wrench::ZERO;
        w.torque_nm[2] = f64::INFINITY;
        assert!(!w.is_finite());
    }
}
