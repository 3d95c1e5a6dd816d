//! `u32` codes for modes and faults. Unknown values are representable on purpose: a reader
//! must treat any value it does not know as a fault, never as undefined behaviour.

use iceoryx2::prelude::ZeroCopySend;

/// Why the haptic loop is not rendering force, or `NONE`.
///
/// A non-zero code latches zero force until the fault is cleared and forces ramp back in.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::FaultCode.v1")]
pub struct FaultCode(pub u32);

impl FaultCode {
    /// No fault: forces are rendered.
    pub const NONE: Self = Self(0);
    /// The device read failed.
    pub const DEVICE_READ: Self = Self(1);
    /// The device write failed.
    pub const DEVICE_WRITE: Self = Self(2);
    /// The device returned NaN or infinite values.
    pub const DEVICE_NON_FINITE: Self = Self(3);
    /// The device position jumped further in one tick than the arm can physically move.
    pub const DEVICE_JUMP: Self = Self(4);
    /// The device timestamp did not advance.
    pub const DEVICE_STALE: Self = Self(5);
    /// The device is disconnected.
    pub const DEVICE_DISCONNECTED: Self = Self(6);
    /// Too many deadlines were missed in a row.
    pub const OVERRUN_STREAK: Self = Self(7);
    /// A computed wrench was not finite (NaN guard tripped).
    pub const NON_FINITE_WRENCH: Self = Self(8);
    /// Forces are held off at start-up until the device is still.
    pub const STARTUP: Self = Self(9);

    /// A short lower-case name for logs and summaries; `"unknown"` for codes this build does
    /// not know.
    pub fn name(self) -> &'static str {
        match self {
            Self::NONE => "none",
            Self::DEVICE_READ => "device-read",
            Self::DEVICE_WRITE => "device-write",
            Self::DEVICE_NON_FINITE => "device-non-finite",
            Self::DEVICE_JUMP => "device-jump",
            Self::DEVICE_STALE => "device-stale",
            Self::DEVICE_DISCONNECTED => "device-disconnected",
            Self::OVERRUN_STREAK => "overrun-streak",
            Self::NON_FINITE_WRENCH => "non-finite-wrench",
            Self::STARTUP => "startup",
            _ => "unknown",
        }
    }
}

/// Contact state of the proxy object with the scene.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::ContactCode.v1")]
pub struct ContactCode(pub u32);

impl ContactCode {
    /// Contact rendering is not active (no voxmap loaded); contact fields are zero.
    pub const DISABLED: Self = Self(0);
    /// No contact.
    pub const FREE: Self = Self(1);
    /// Inside the proximity layer, braking, not touching.
    pub const PROXIMITY: Self = Self(2);
    /// Touching: at least one pointshell point penetrates the scene.
    pub const CONTACT: Self = Self(3);
}

/// What the planner's guidance currently means.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::GuidanceMode.v1")]
pub struct GuidanceMode(pub u32);

impl GuidanceMode {
    /// No guidance: the loop renders no F_s.
    pub const NONE: Self = Self(0);
    /// F_a pulls towards the weighted barycenter of nearby roadmap nodes (I-RRT §3).
    pub const ROADMAP: Self = Self(1);
    /// A solution exists: F_a leads along the solution path.
    pub const PATH: Self = Self(2);
    /// The planner proved there is no way from the start to the goal (a ball inside the
    /// object cannot pass; `planner_core::no_way`): F_a is zero, and a session may end.
    pub const NO_WAY: Self = Self(3);

    /// A short lower-case name; `"unknown"` for codes this build does not know.
    pub fn name(self) -> &'static str {
        match self {
            Self::NONE => "none",
            Self::ROADMAP => "roadmap",
            Self::PATH => "path",
            Self::NO_WAY => "no-way",
            _ => "unknown",
        }
    }
}

/// How fresh the guidance rendered in a tick was.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::GuidanceFreshness.v1")]
pub struct GuidanceFreshness(pub u32);

impl GuidanceFreshness {
    /// No valid guidance sample was ever received.
    pub const NONE: Self = Self(0);
    /// The newest sample is within its time-to-live: F_s at full strength.
    pub const FRESH: Self = Self(1);
    /// Past its time-to-live: F_s fades linearly to zero.
    pub const FADING: Self = Self(2);
    /// Past time-to-live plus fade: F_s is zero.
    pub const LOST: Self = Self(3);

    /// A short lower-case name; `"unknown"` for codes this build does not know.
    pub fn name(self) -> &'static str {
        match self {
            Self::NONE => "none",
            Self::FRESH => "fresh",
            Self::FADING => "fading",
            Self::LOST => "lost",
            _ => "unknown",
        }
    }
}

const _: () = {
    assert!(core::mem::size_of::<GuidanceFreshness>() == 4);
    assert!(core::mem::size_of::<FaultCode>() == 4);
    assert!(core::mem::size_of::<ContactCode>() == 4);
    assert!(core::mem::size_of::<GuidanceMode>() == 4);
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_codes_are_named_unknown() {
        assert_eq!(FaultCode(12345).name(), "unknown");
        assert_eq!(GuidanceMode(7).name(), "unknown");
        assert_eq!(FaultCode::OVERRUN_STREAK.name(), "overrun-streak");
    }
}
