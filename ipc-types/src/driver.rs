//! The external driver: a device driver in another process (C, C++, Python or Rust, anything
//! iceoryx2 serves) publishes [`DriverState`] and subscribes to [`DriverCommand`], so the
//! haptic loop can drive an arm it does not support natively. Services:
//! [`crate::services::DRIVER_STATE`] and [`crate::services::DRIVER_COMMAND`].
//!
//! Frames: everything is in the **device base frame** as the driver defines it (right-handed,
//! Z up recommended; the loop's mapping turns it into the scene). Torques are about the
//! end-effector point. Units SI. Quaternions `[x, y, z, w]` (see the crate docs).

use crate::{DeviceLimits, Header, LimitError, Pose, Twist, Wrench};
use iceoryx2::prelude::ZeroCopySend;

/// Bytes of [`DriverState::name`].
pub const DRIVER_NAME_LEN: usize = 32;

/// What the driver says about its device.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::DriverStatus.v1")]
pub struct DriverStatus(pub u32);

impl DriverStatus {
    /// Nothing was ever written (the all-zero default).
    pub const UNKNOWN: Self = Self(0);
    /// The device is read and accepts force commands.
    pub const OK: Self = Self(1);
    /// The device is not ready yet (homing, calibrating); the loop renders no force.
    pub const NOT_READY: Self = Self(2);
    /// The driver lost the device or the device reports an error.
    pub const FAULT: Self = Self(3);

    /// A short lower-case name; `"unknown"` for codes this build does not know.
    pub fn name(self) -> &'static str {
        match self {
            Self::OK => "ok",
            Self::NOT_READY => "not-ready",
            Self::FAULT => "fault",
            _ => "unknown",
        }
    }
}

/// Whether the driver should apply the commanded wrench.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, ZeroCopySend)]
#[type_name("hrrtc::OutputCode.v1")]
pub struct OutputCode(pub u32);

impl OutputCode {
    /// Output zero force (also what a driver must do for any unknown code).
    pub const OFF: Self = Self(0);
    /// Apply `wrench`.
    pub const ON: Self = Self(1);
}

/// One sample of the device, written by the driver at its own rate (typically 1 kHz).
///
/// Semantics: latest value. `header.timestamp_ns` is when the driver sampled the device
/// (`CLOCK_MONOTONIC`): the loop treats a state older than its stale limit as a fault.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("hrrtc::DriverState.v1")]
pub struct DriverState {
    /// Sequence from 1 per driver process; timestamp = device sample time.
    pub header: Header,
    /// End-effector pose, device base frame, m.
    pub pose: Pose,
    /// End-effector velocity, device base frame, m/s and rad/s.
    pub twist: Twist,
    /// Buttons, bit i = button i pressed.
    pub buttons: u32,
    /// [`DriverStatus`].
    pub status: DriverStatus,
    /// Device model, UTF-8, NUL-padded.
    pub name: [u8; DRIVER_NAME_LEN],
    /// Maximum force norm, N.
    pub max_force_n: f64,
    /// Maximum torque norm, N·m (0 = no torque output).
    pub max_torque_nm: f64,
    /// Maximum stable translational stiffness at 1 kHz, N/m.
    pub max_stiffness_n_per_m: f64,
    /// Maximum stable rotational stiffness, N·m/rad.
    pub max_rot_stiffness_nm_per_rad: f64,
    /// Maximum stable translational damping, N·s/m.
    pub max_damping_n_s_per_m: f64,
    /// Radius of the reachable sphere around the base-frame origin, m.
    pub workspace_radius_m: f64,
    /// Number of buttons (≤ 32).
    pub button_count: u32,
    /// 1 if the device senses orientation, else 0.
    pub orientation_input: u32,
}

/// The wrench the loop wants, written by the loop after every tick.
///
/// Semantics: latest value. A driver must output zero force when the newest command is
/// older than its own watchdog (a dead loop sends nothing), when `output` is not
/// [`OutputCode::ON`], or when [`DriverCommand::validate`] fails.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("hrrtc::DriverCommand.v1")]
pub struct DriverCommand {
    /// Sequence from 1 per loop process; timestamp = the tick that computed it.
    pub header: Header,
    /// Force (N) and torque (N·m, about the end-effector point), device base frame,
    /// already within the limits the driver reported.
    pub wrench: Wrench,
    /// [`OutputCode`].
    pub output: OutputCode,
    /// Reserved, zero.
    pub reserved: u32,
}

/// Why a driver message was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriverError {
    /// `header.sequence` is 0: nothing was ever written.
    NeverWritten,
    /// A pose, velocity, wrench or limit is NaN or infinite, or the quaternion is not unit.
    NonFinite,
    /// A limit is negative, the workspace radius not positive, or more than 32 buttons.
    BadLimits,
    /// The name is not UTF-8.
    BadName,
    /// A status or output code unknown to this build.
    UnknownCode,
}

impl DriverState {
    /// Checks what a reader must check before using a sample another process wrote.
    /// Allocation-free.
    pub fn validate(&self) -> Result<(), DriverError> {
        if self.header.sequence == 0 {
            return Err(DriverError::NeverWritten);
        }
        let twist_ok = self
            .twist
            .linear_m_s
            .iter()
            .chain(&self.twist.angular_rad_s)
            .all(|v| v.is_finite());
        if !self.pose.is_valid() || !twist_ok {
            return Err(DriverError::NonFinite);
        }
        match self.limits().validate() {
            Err(LimitError::NotFinite { .. }) => return Err(DriverError::NonFinite),
            Err(LimitError::OutOfRange { .. }) => return Err(DriverError::BadLimits),
            Ok(()) => {}
        }
        if self.button_count > 32 {
            return Err(DriverError::BadLimits);
        }
        self.name_str().ok_or(DriverError::BadName)?;
        match self.status {
            DriverStatus::OK | DriverStatus::NOT_READY | DriverStatus::FAULT => Ok(()),
            _ => Err(DriverError::UnknownCode),
        }
    }

    /// The limits this state announces. The wire carries no rotational damping limit, so
    /// it is 0: the loop adds no rotational damping for an external driver's device.
    pub fn limits(&self) -> DeviceLimits {
        DeviceLimits {
            max_force_n: self.max_force_n,
            max_torque_nm: self.max_torque_nm,
            max_stiffness_n_per_m: self.max_stiffness_n_per_m,
            max_rot_stiffness_nm_per_rad: self.max_rot_stiffness_nm_per_rad,
            max_damping_n_s_per_m: self.max_damping_n_s_per_m,
            max_rot_damping_nm_s_per_rad: 0.0,
            workspace_radius_m: self.workspace_radius_m,
        }
    }

    /// This state announcing `limits` (all but the rotational damping limit, which the
    /// wire does not carry).
    pub fn with_limits(self, limits: &DeviceLimits) -> Self {
        DriverState {
            max_force_n: limits.max_force_n,
            max_torque_nm: limits.max_torque_nm,
            max_stiffness_n_per_m: limits.max_stiffness_n_per_m,
            max_rot_stiffness_nm_per_rad: limits.max_rot_stiffness_nm_per_rad,
            max_damping_n_s_per_m: limits.max_damping_n_s_per_m,
            workspace_radius_m: limits.workspace_radius_m,
            ..self
        }
    }

    /// The name without its NUL padding, if UTF-8.
    pub fn name_str(&self) -> Option<&str> {
        let end = self
            .name
            .iter()
            .position(|b| *b == 0)
            .unwrap_or(DRIVER_NAME_LEN);
        core::str::from_utf8(&self.name[..end]).ok()
    }

    /// Sets the name, truncated to [`DRIVER_NAME_LEN`] bytes at a character boundary.
    pub fn set_name(&mut self, name: &str) {
        let mut end = name.len().min(DRIVER_NAME_LEN);
        while !name.is_char_boundary(end) {
            end -= 1;
        }
        self.name = [0; DRIVER_NAME_LEN];
        self.name[..end].copy_from_slice(&name.as_bytes()[..end]);
    }
}

impl DriverCommand {
    /// Checks a command before a driver applies it. Allocation-free.
    pub fn validate(&self) -> Result<(), DriverError> {
        if self.header.sequence == 0 {
            return Err(DriverError::NeverWritten);
        }
        if !self.wrench.is_finite() {
            return Err(DriverError::NonFinite);
        }
        match self.output {
            OutputCode::OFF | OutputCode::ON => Ok(()),
            _ => Err(DriverError::UnknownCode),
        }
    }
}

const _: () = {
    assert!(core::mem::size_of::<DriverStatus>() == 4);
    assert!(core::mem::size_of::<OutputCode>() == 4);
    assert!(core::mem::size_of::<DriverState>() == 24 + 56 + 48 + 8 + 32 + 48 + 8);
    assert!(core::mem::align_of::<DriverState>() == 8);
    assert!(core::mem::size_of::<DriverCommand>() == 24 + 48 + 8);
};

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> DriverState {
        let mut s = DriverState {
            header: Header {
                sequence: 1,
                ..Header::default()
            },
            status: DriverStatus::OK,
            max_force_n: 8.0,
            max_stiffness_n_per_m: 2000.0,
            workspace_radius_m: 0.1,
            button_count: 2,
            ..DriverState::default()
        };
        s.set_name("test arm");
        s
    }

    #[test]
    fn state_validation() {
        assert_eq!(state().validate(), Ok(()));
        assert_eq!(state().name_str(), Some("test arm"));
        assert_eq!(
            DriverState::default().validate(),
            Err(DriverError::NeverWritten)
        );
        let mut s = state();
        s.pose.orientation_xyzw = [0.0; 4];
        assert_eq!(s.validate(), Err(DriverError::NonFinite));
        let mut s = state();
        s.max_force_n = -1.0;
        assert_eq!(s.validate(), Err(DriverError::BadLimits));
        let mut s = state();
        s.workspace_radius_m = f64::NAN;
        assert_eq!(s.validate(), Err(DriverError::NonFinite));
        let mut s = state();
        s.name[0] = 0xff;
        assert_eq!(s.validate(), Err(DriverError::BadName));
        let mut s = state();
        s.status = DriverStatus(77);
        assert_eq!(s.validate(), Err(DriverError::UnknownCode));
        let mut s = state();
        s.set_name("ééééééééééééééééé"); // 34 bytes: cut at a boundary
        assert_eq!(s.name_str().map(str::len), Some(32));
    }

    #[test]
    fn limits_round_trip_through_the_flat_fields_but_rotational_damping() {
        let limits = DeviceLimits {
            max_force_n: 3.0,
            max_torque_nm: 0.2,
            max_stiffness_n_per_m: 900.0,
            max_rot_stiffness_nm_per_rad: 0.4,
            max_damping_n_s_per_m: 4.0,
            max_rot_damping_nm_s_per_rad: 0.01,
            workspace_radius_m: 0.07,
        };
        let s = state().with_limits(&limits);
        assert_eq!(s.max_stiffness_n_per_m, 900.0);
        assert_eq!((s.button_count, s.name_str()), (2, Some("test arm")));
        assert_eq!(
            s.limits(),
            DeviceLimits {
                max_rot_damping_nm_s_per_rad: 0.0,
                ..limits
            }
        );
        assert_eq!(s.validate(), Ok(()));
    }

    #[test]
    fn command_validation() {
        let mut c = DriverCommand {
            header: Header {
                sequence: 3,
                ..Header::default()
            },
            output: OutputCode::ON,
            ..DriverCommand::default()
        };
        assert_eq!(c.validate(), Ok(()));
        c.wrench.force_n[0] = f64::NAN;
        assert_eq!(c.validate(), Err(DriverError::NonFinite));
        c.wrench.force_n[0] = 0.0;
        c.output = OutputCode(2);
        assert_eq!(c.validate(), Err(DriverError::UnknownCode));
    }
}

#[cfg(test)]
mod fuzz {
    use super::*;

    /// Any bytes another process could leave in shared memory give a verdict, never a panic.
    #[test]
    fn arbitrary_bytes_validate_without_panicking() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut accepted = 0;
        for round in 0..20_000 {
            let mut s = DriverState::default();
            let mut c = DriverCommand::default();
            // SAFETY: both types are plain integers and floats (every bit pattern valid);
            // we write exactly their size.
            unsafe {
                let sp = (&mut s as *mut DriverState).cast::<u8>();
                for i in 0..core::mem::size_of::<DriverState>() {
                    *sp.add(i) = next() as u8;
                }
                let cp = (&mut c as *mut DriverCommand).cast::<u8>();
                for i in 0..core::mem::size_of::<DriverCommand>() {
                    *cp.add(i) = next() as u8;
                }
            }
            if round % 2 == 0 {
                // Half the time start from a valid message and corrupt one field.
                s.header.sequence = 1;
                s.status = DriverStatus::OK;
                s.pose = crate::Pose::IDENTITY;
            }
            if s.validate().is_ok() {
                accepted += 1;
                assert!(s.pose.is_valid() && s.name_str().is_some());
            }
            let _ = c.validate();
        }
        // Random limits are almost never all finite and non-negative: nearly all rejected.
        assert!(accepted < 100, "{accepted} random states accepted");
    }
}
