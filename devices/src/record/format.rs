//! The MCAP layout of a device recording: topics, JSON schemas and message bodies.
//!
//! | topic | schema | one message per |
//! |---|---|---|
//! | `/device/spec` | `hrrtc.DeviceSpec` | `open` (the device's limits) |
//! | `/device/state` | `hrrtc.DeviceRead` | `read`: the state, or the error it returned |
//! | `/device/wrench` | `hrrtc.DeviceWrench` | `write`: the wrench the loop commanded |
//!
//! Message encoding `json`. `log_time` = the tick time given to `read` (`CLOCK_MONOTONIC`
//! ns); a wrench carries the tick of the read before it. Units SI, device base frame,
//! quaternions `[x, y, z, w]`.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::{DeviceError, DeviceState, Wrench};

/// Topic of the device specification.
pub const TOPIC_SPEC: &str = "/device/spec";
/// Topic of every `read` result.
pub const TOPIC_STATE: &str = "/device/state";
/// Topic of every commanded wrench.
pub const TOPIC_WRENCH: &str = "/device/wrench";

pub(crate) const SCHEMA_SPEC: &str = r#"{"title":"hrrtc.DeviceSpec","type":"object","description":"Limits in SI units (N, N·m, N/m, N·m/rad, N·s/m, m)","properties":{"name":{"type":"string"},"max_force_n":{"type":"number"},"max_torque_nm":{"type":"number"},"max_stiffness_n_per_m":{"type":"number"},"max_rot_stiffness_nm_per_rad":{"type":"number"},"max_damping_n_s_per_m":{"type":"number"},"max_rot_damping_nm_s_per_rad":{"type":"number"},"workspace_radius_m":{"type":"number"},"capabilities":{"type":"object"}}}"#;
pub(crate) const SCHEMA_READ: &str = r#"{"title":"hrrtc.DeviceRead","type":"object","description":"One read at tick_ns: either state or error. Device base frame, m, m/s, rad/s, quaternion [x,y,z,w]","properties":{"tick_ns":{"type":"integer"},"state":{"type":"object","properties":{"position_m":{"type":"array","items":{"type":"number"}},"orientation_xyzw":{"type":"array","items":{"type":"number"}},"linear_velocity_m_s":{"type":"array","items":{"type":"number"}},"angular_velocity_rad_s":{"type":"array","items":{"type":"number"}},"buttons":{"type":"integer"},"timestamp_ns":{"type":"integer"}}},"error":{"type":"string","enum":["disconnected","read-failed","write-failed","invalid-data","not-open","open-failed","invalid-config"]}}}"#;
pub(crate) const SCHEMA_WRENCH: &str = r#"{"title":"hrrtc.DeviceWrench","type":"object","description":"Commanded wrench, device base frame: N, N·m about the end-effector point","properties":{"tick_ns":{"type":"integer"},"force_n":{"type":"array","items":{"type":"number"}},"torque_nm":{"type":"array","items":{"type":"number"}}}}"#;

/// A device state as stored.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StateJson {
    /// m.
    pub position_m: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`.
    pub orientation_xyzw: [f64; 4],
    /// m/s.
    pub linear_velocity_m_s: [f64; 3],
    /// rad/s.
    pub angular_velocity_rad_s: [f64; 3],
    /// Button mask.
    pub buttons: u32,
    /// Device sample time, ns.
    pub timestamp_ns: u64,
}

/// One `read` result.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ReadJson {
    /// Tick time given to `read`, ns.
    pub tick_ns: u64,
    /// The state, when the read succeeded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<StateJson>,
    /// The error name, when it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<&'static str>,
}

/// Owned variant for decoding (serde cannot borrow into `&'static str`).
#[derive(Debug, Clone, Deserialize)]
pub(crate) struct ReadJsonOwned {
    pub tick_ns: u64,
    #[serde(default)]
    pub state: Option<StateJson>,
    #[serde(default)]
    pub error: Option<String>,
}

/// One commanded wrench.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WrenchJson {
    /// Tick of the preceding read, ns.
    pub tick_ns: u64,
    /// N.
    pub force_n: [f64; 3],
    /// N·m.
    pub torque_nm: [f64; 3],
}

impl From<&DeviceState> for StateJson {
    fn from(s: &DeviceState) -> Self {
        let q = s.pose.rotation.coords;
        StateJson {
            position_m: s.pose.translation.vector.into(),
            orientation_xyzw: [q.x, q.y, q.z, q.w],
            linear_velocity_m_s: s.linear_velocity.into(),
            angular_velocity_rad_s: s.angular_velocity.into(),
            buttons: s.buttons,
            timestamp_ns: s.timestamp_ns,
        }
    }
}

impl StateJson {
    /// Back to a state. The quaternion is taken as stored (a recorded non-unit quaternion
    /// must replay as the same bad data, so the loop's checks see what they saw).
    pub fn to_state(&self) -> DeviceState {
        let [x, y, z, w] = self.orientation_xyzw;
        DeviceState {
            pose: Isometry3::from_parts(
                Translation3::from(Vector3::from(self.position_m)),
                UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z)),
            ),
            linear_velocity: Vector3::from(self.linear_velocity_m_s),
            angular_velocity: Vector3::from(self.angular_velocity_rad_s),
            buttons: self.buttons,
            timestamp_ns: self.timestamp_ns,
        }
    }
}

impl From<(u64, &Wrench)> for WrenchJson {
    fn from((tick_ns, w): (u64, &Wrench)) -> Self {
        WrenchJson {
            tick_ns,
            force_n: w.force.into(),
            torque_nm: w.torque.into(),
        }
    }
}

impl WrenchJson {
    /// Back to a wrench.
    pub fn to_wrench(&self) -> Wrench {
        Wrench::new(Vector3::from(self.force_n), Vector3::from(self.torque_nm))
    }
}

/// Stable name of an error in a recording.
pub fn error_name(e: DeviceError) -> &'static str {
    match e {
        DeviceError::Disconnected => "disconnected",
        DeviceError::ReadFailed => "read-failed",
        DeviceError::WriteFailed => "write-failed",
        DeviceError::InvalidData => "invalid-data",
        DeviceError::NotOpen => "not-open",
        DeviceError::OpenFailed(_) => "open-failed",
        DeviceError::InvalidConfig(_) => "invalid-config",
    }
}

/// The error a recorded name stands for; `None` for a name this build does not know.
pub fn error_from_name(name: &str) -> Option<DeviceError> {
    Some(match name {
        "disconnected" => DeviceError::Disconnected,
        "read-failed" => DeviceError::ReadFailed,
        "write-failed" => DeviceError::WriteFailed,
        "invalid-data" => DeviceError::InvalidData,
        "not-open" => DeviceError::NotOpen,
        "open-failed" => DeviceError::OpenFailed("recorded open failure"),
        "invalid-config" => DeviceError::InvalidConfig("recorded configuration error"),
        _ => return None,
    })
}
