//! What a device can do and the limits it reports to the loop.

use serde::{Deserialize, Serialize};

use crate::{DeviceError, Wrench};

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

/// A device's name, limits and capabilities. Every limit is what the device can render
/// stably at a 1 kHz update rate; the loop must keep its output inside them (contact,
/// coupling and guidance share this budget).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeviceSpec {
    /// Human-readable device name (model, or "simulated-arm").
    pub name: String,
    /// Maximum force norm in N (desktop arms: about 3–12 N).
    pub max_force_n: f64,
    /// Maximum torque norm in N·m (desktop 6-DOF arms: about 0.1–1 N·m).
    pub max_torque_nm: f64,
    /// Maximum stable translational stiffness at 1 kHz in N/m (real arms: 400–8000).
    pub max_stiffness_n_per_m: f64,
    /// Maximum stable rotational stiffness at 1 kHz in N·m/rad (real arms: 0.3–1).
    pub max_rot_stiffness_nm_per_rad: f64,
    /// Maximum stable translational damping in N·s/m.
    pub max_damping_n_s_per_m: f64,
    /// Maximum stable rotational damping in N·m·s/rad.
    pub max_rot_damping_nm_s_per_rad: f64,
    /// Radius in m of the sphere, centred on the base-frame origin, that the end effector
    /// can reach.
    pub workspace_radius_m: f64,
    /// Inputs and outputs the device has.
    pub capabilities: Capabilities,
}

impl DeviceSpec {
    /// Checks that every limit is finite and non-negative, the workspace radius positive
    /// and the button count at most 32.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let limits = [
            (self.max_force_n, "max_force_n"),
            (self.max_torque_nm, "max_torque_nm"),
            (self.max_stiffness_n_per_m, "max_stiffness_n_per_m"),
            (
                self.max_rot_stiffness_nm_per_rad,
                "max_rot_stiffness_nm_per_rad",
            ),
            (self.max_damping_n_s_per_m, "max_damping_n_s_per_m"),
            (
                self.max_rot_damping_nm_s_per_rad,
                "max_rot_damping_nm_s_per_rad",
            ),
        ];
        for (value, name) in limits {
            if !(value.is_finite() && value >= 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        if !(self.workspace_radius_m.is_finite() && self.workspace_radius_m > 0.0) {
            return Err(DeviceError::InvalidConfig("workspace_radius_m"));
        }
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
            self.max_force_n
        } else {
            0.0
        };
        let max_torque = if self.capabilities.torque_output {
            self.max_torque_nm
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

    fn spec() -> DeviceSpec {
        DeviceSpec {
            name: "test".into(),
            max_force_n: 8.0,
            max_torque_nm: 0.5,
            max_stiffness_n_per_m: 2000.0,
            max_rot_stiffness_nm_per_rad: 0.8,
            max_damping_n_s_per_m: 5.0,
            max_rot_damping_nm_s_per_rad: 0.01,
            workspace_radius_m: 0.12,
            capabilities: Capabilities {
                force_output: true,
                torque_output: false,
                orientation_input: true,
                buttons: 2,
            },
        }
    }

    #[test]
    fn validate_accepts_sane_and_rejects_bad_fields() {
        assert_eq!(spec().validate(), Ok(()));
        let mut s = spec();
        s.max_force_n = f64::NAN;
        assert_eq!(s.validate(), Err(DeviceError::InvalidConfig("max_force_n")));
        let mut s = spec();
        s.workspace_radius_m = 0.0;
        assert_eq!(
            s.validate(),
            Err(DeviceError::InvalidConfig("workspace_radius_m"))
        );
        let mut s = spec();
        s.capabilities.buttons = 33;
        assert!(s.validate().is_err());
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
