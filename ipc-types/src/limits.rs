//! The limits a haptic device renders stably, in one type.
//!
//! Every device states them: the loop's devices in their `DeviceSpec`, the simulated arm
//! from its config, an external driver (C, Python, the ROS 2 gateway) in each
//! [`crate::DriverState`] it writes. [`DeviceLimits`] is not a wire type: the driver's
//! state carries the limits as flat fields (its layout is what C and Python read), and
//! [`crate::DriverState::limits`] / [`crate::DriverState::with_limits`] convert.

use serde::{Deserialize, Serialize};

/// What a device can render stably at a 1 kHz update rate. The loop keeps its output
/// inside them: contact, coupling and guidance share this budget.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DeviceLimits {
    /// Maximum force norm in N (desktop arms: about 3–12 N; 0 = no force output).
    pub max_force_n: f64,
    /// Maximum torque norm in N·m (desktop 6-DOF arms: about 0.1–1 N·m; 0 = no torque
    /// output).
    pub max_torque_nm: f64,
    /// Maximum stable translational stiffness at 1 kHz in N/m (real arms: 400–8000).
    pub max_stiffness_n_per_m: f64,
    /// Maximum stable rotational stiffness at 1 kHz in N·m/rad (real arms: 0.3–1).
    pub max_rot_stiffness_nm_per_rad: f64,
    /// Maximum stable translational damping in N·s/m.
    pub max_damping_n_s_per_m: f64,
    /// Maximum stable rotational damping in N·m·s/rad.
    pub max_rot_damping_nm_s_per_rad: f64,
    /// Radius in m of the sphere, centred on the device's base-frame origin, that the end
    /// effector can reach.
    pub workspace_radius_m: f64,
}

/// A limit that [`DeviceLimits::validate`] refused, named by its field.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// The limit is NaN or infinite.
    #[error("{field} is {value}: must be a finite number")]
    NotFinite {
        /// The field's name, as in [`DeviceLimits`].
        field: &'static str,
        /// The value given.
        value: f64,
    },
    /// The limit is negative, or the workspace radius not positive.
    #[error("{field} is {value}: must be {rule}")]
    OutOfRange {
        /// The field's name, as in [`DeviceLimits`].
        field: &'static str,
        /// The value given.
        value: f64,
        /// What the field must be (`≥ 0`, `> 0`).
        rule: &'static str,
    },
}

impl LimitError {
    /// The name of the refused field.
    pub fn field(&self) -> &'static str {
        match self {
            LimitError::NotFinite { field, .. } | LimitError::OutOfRange { field, .. } => field,
        }
    }
}

impl DeviceLimits {
    /// Every limit 0 and the workspace radius `workspace_radius_m` (m): a device that
    /// renders nothing (input only, or not yet announced).
    pub const fn none(workspace_radius_m: f64) -> Self {
        DeviceLimits {
            max_force_n: 0.0,
            max_torque_nm: 0.0,
            max_stiffness_n_per_m: 0.0,
            max_rot_stiffness_nm_per_rad: 0.0,
            max_damping_n_s_per_m: 0.0,
            max_rot_damping_nm_s_per_rad: 0.0,
            workspace_radius_m,
        }
    }

    /// Each limit with its field's name, the workspace radius last.
    fn named(&self) -> [(&'static str, f64); 7] {
        [
            ("max_force_n", self.max_force_n),
            ("max_torque_nm", self.max_torque_nm),
            ("max_stiffness_n_per_m", self.max_stiffness_n_per_m),
            (
                "max_rot_stiffness_nm_per_rad",
                self.max_rot_stiffness_nm_per_rad,
            ),
            ("max_damping_n_s_per_m", self.max_damping_n_s_per_m),
            (
                "max_rot_damping_nm_s_per_rad",
                self.max_rot_damping_nm_s_per_rad,
            ),
            ("workspace_radius_m", self.workspace_radius_m),
        ]
    }

    /// Checks that every limit is finite (all of them first, so a non-finite value is
    /// reported as such wherever it is), then that each is non-negative and the workspace
    /// radius positive. Allocation-free: a driver's every sample is checked with it.
    pub fn validate(&self) -> Result<(), LimitError> {
        let named = self.named();
        if let Some(&(field, value)) = named.iter().find(|(_, v)| !v.is_finite()) {
            return Err(LimitError::NotFinite { field, value });
        }
        let [bounds @ .., (field, radius)] = named;
        if let Some((field, value)) = bounds.into_iter().find(|(_, v)| *v < 0.0) {
            let rule = "≥ 0";
            return Err(LimitError::OutOfRange { field, value, rule });
        }
        if radius <= 0.0 {
            let (value, rule) = (radius, "> 0");
            return Err(LimitError::OutOfRange { field, value, rule });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> DeviceLimits {
        DeviceLimits {
            max_force_n: 8.0,
            max_torque_nm: 0.5,
            max_stiffness_n_per_m: 2000.0,
            max_rot_stiffness_nm_per_rad: 0.8,
            max_damping_n_s_per_m: 5.0,
            max_rot_damping_nm_s_per_rad: 0.01,
            workspace_radius_m: 0.12,
        }
    }

    #[test]
    fn validate_names_the_refused_field() {
        assert_eq!(limits().validate(), Ok(()));
        assert_eq!(DeviceLimits::none(0.1).validate(), Ok(()));
        let l = DeviceLimits {
            max_rot_damping_nm_s_per_rad: -0.01,
            ..limits()
        };
        let e = l.validate().unwrap_err();
        assert_eq!(e.field(), "max_rot_damping_nm_s_per_rad");
        assert_eq!(
            e.to_string(),
            "max_rot_damping_nm_s_per_rad is -0.01: must be ≥ 0"
        );
        let e = DeviceLimits::none(0.0).validate().unwrap_err();
        assert_eq!(e.to_string(), "workspace_radius_m is 0: must be > 0");
    }

    #[test]
    fn a_non_finite_limit_is_reported_before_a_negative_one() {
        let l = DeviceLimits {
            max_force_n: -1.0,
            workspace_radius_m: f64::INFINITY,
            ..limits()
        };
        assert_eq!(
            l.validate(),
            Err(LimitError::NotFinite {
                field: "workspace_radius_m",
                value: f64::INFINITY
            })
        );
    }
}
