//! What a device can do and the limits it reports to the loop.

use serde::{Deserialize, Serialize};

use crate::{DeviceError, DeviceLimits, Wrench};

/// Which inputs and outputs a device has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Capabilities {
    /// The device can render a force (false for an input-only device such as a SpaceMouse).
    pub force_output: bool,
    /// The device can render a torque about the end-effector point.
    pub torque_output: bool,
    /// The device senses the end-effector orientation (3 rotational DOF of input).
    pub orientation_input: bool,
    /// Number of buttons; they occupy bits `0..buttons` of [`crate::DeviceState::buttons`]
    /// (at most 32).
    pub buttons: u32,
}

/// A device's name, limits and capabilities.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeviceSpec {
    /// Human-readable device name (model, or "simulated-arm").
    pub name: String,
    /// What the device renders stably at 1 kHz; the loop keeps its output inside them
    /// (contact, coupling and guidance share this budget). Flattened, so a recording's
    /// spec keeps its fields at the top level.
    #[serde(flatten)]
    pub limits: DeviceLimits,
    /// Inputs and outputs the device has.
    pub capabilities: Capabilities,
}

impl DeviceSpec {
    /// Checks that every limit is finite and non-negative, the workspace radius positive
    /// and the button count at most 32; the error names the field.
    pub fn validate(&self) -> Result<(), DeviceError> {
        self.limits
            .validate()
            .map_err(|e| DeviceError::InvalidConfig(e.field()))?;
        if self.capabilities.buttons > 32 {
            return Err(DeviceError::InvalidConfig("capabilities.buttons"));
        }
        Ok(())
    }

    /// `wrench` reduced to what this device can output: force and torque norms clamped to
    /// `max_force_n` / `max_torque_nm` (direction kept), an output the device lacks zeroed,
    /// a non-finite wrench replaced by [`Wrench::ZERO`]. Allocation-free.
    pub fn saturate(&self, wrench: &Wrench) -> Wrench {
        let max_force = if self.capabilities.force_output {
            self.limits.max_force_n
        } else {
            0.0
        };
        let max_torque = if self.capabilities.torque_output {
            self.limits.max_torque_nm
        } else {
            0.0
        };
        wrench.saturated(max_force, max_torque)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::sim::SimulatedArmConfig;

    /// The simulated arm's spec without torque output.
    fn spec() -> DeviceSpec {
        let mut spec = SimulatedArmConfig::default().spec();
        spec.capabilities.torque_output = false;
        spec
    }

    #[test]
    fn validate_accepts_sane_and_rejects_bad_fields() {
        assert_eq!(spec().validate(), Ok(()));
        let mut s = spec();
        s.limits.max_force_n = f64::NAN;
        assert_eq!(s.validate(), Err(DeviceError::InvalidConfig("max_force_n")));
        let mut s = spec();
        s.limits.workspace_radius_m = 0.0;
        assert_eq!(
            s.validate(),
            Err(DeviceError::InvalidConfig("workspace_radius_m"))
        );
        let mut s = spec();
        s.capabilities.buttons = 33;
        assert!(s.validate().is_err());
    }

    #[test]
    fn a_spec_is_recorded_with_its_limits_at_the_top_level_bit_for_bit() {
        // Recordings (and their JSON schema) hold the limits as top-level fields.
        let mut original = spec();
        original.limits.max_damping_n_s_per_m = 0.1 + 0.2;
        let json = serde_json::to_value(&original).unwrap();
        assert_eq!(json["max_force_n"], 8.0);
        assert_eq!(json["workspace_radius_m"], 0.12);
        assert!(json.get("limits").is_none());
        let text = serde_json::to_string(&original).unwrap();
        let back: DeviceSpec = serde_json::from_str(&text).unwrap();
        assert_eq!(back, original);
    }

    #[test]
    fn saturate_respects_limits_and_capabilities() {
        let w = Wrench::new(Vector3::new(0.0, 100.0, 0.0), Vector3::new(1.0, 0.0, 0.0));
        let out = spec().saturate(&w);
        assert!((out.force - Vector3::new(0.0, 8.0, 0.0)).norm() < 1e-12);
        // No torque output on this device.
        assert_eq!(out.torque, Vector3::zeros());
    }
}
