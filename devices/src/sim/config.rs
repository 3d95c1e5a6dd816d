//! Parameters of the simulated arm and the [`DeviceSpec`] derived from them.

use serde::{Deserialize, Serialize};

use crate::{Capabilities, DeviceError, DeviceLimits, DeviceSpec};

/// Physical and sensor parameters of [`super::SimulatedArm`]. The defaults model a desktop
/// 6-DOF arm with a light handle. Every field has a default, so a partial TOML/JSON table
/// deserializes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulatedArmConfig {
    /// Name reported in the spec.
    pub name: String,
    /// Effective moving mass at the end effector in kg (desktop arms: 0.05–0.5). Default 0.2.
    pub mass_kg: f64,
    /// Diagonal rotational inertia about the end-effector point, body frame, in kg·m²
    /// (x, y, z). Default 1e-4 each.
    pub inertia_kg_m2: [f64; 3],
    /// Viscous damping of the mechanism on linear velocity in N·s/m. Default 0.3
    /// (time constant m/c ≈ 0.67 s).
    pub linear_damping_n_s_per_m: f64,
    /// Viscous damping of the mechanism on angular velocity in N·m·s/rad. Default 1e-3.
    pub angular_damping_nm_s_per_rad: f64,
    /// Force saturation of the commanded wrench in N. Default 8.
    pub max_force_n: f64,
    /// Torque saturation of the commanded wrench in N·m. Default 0.5.
    pub max_torque_nm: f64,
    /// Reported maximum stable translational stiffness at 1 kHz in N/m. Default 2000.
    pub max_stiffness_n_per_m: f64,
    /// Reported maximum stable rotational stiffness at 1 kHz in N·m/rad. Default 0.8.
    pub max_rot_stiffness_nm_per_rad: f64,
    /// Reported maximum stable translational damping in N·s/m. Default 5.
    pub max_damping_n_s_per_m: f64,
    /// Reported maximum stable rotational damping in N·m·s/rad. Default 0.01.
    pub max_rot_damping_nm_s_per_rad: f64,
    /// Radius in m of the workspace sphere about the base origin. Default 0.12.
    pub workspace_radius_m: f64,
    /// Stiffness of the workspace wall (applied to the dynamics only) in N/m. Default 3e4.
    pub wall_stiffness_n_per_m: f64,
    /// Damping of the workspace wall on outward radial velocity in N·s/m. Default 100
    /// (damping ratio ≈ 0.65 with the default mass).
    pub wall_damping_n_s_per_m: f64,
    /// Position sensor resolution in m (reported translations are multiples of it);
    /// 0 disables quantization. Default 1e-5.
    pub position_resolution_m: f64,
    /// Orientation sensor resolution in rad (each rotation-vector component of the
    /// reported orientation is a multiple of it); 0 disables quantization. Default 1e-3.
    pub angle_resolution_rad: f64,
    /// Number of buttons the arm reports. Default 2.
    pub buttons: u32,
    /// Longest span in ns that one `read` integrates; a longer gap (a stall) is clamped to
    /// it, so simulated time then lags the clock. Default 10 ms.
    pub max_step_ns: u64,
    /// Longest integration sub-step in ns; a larger step is split evenly. Default 1 ms.
    pub max_substep_ns: u64,
}

impl Default for SimulatedArmConfig {
    fn default() -> Self {
        SimulatedArmConfig {
            name: "simulated-arm".to_owned(),
            mass_kg: 0.2,
            inertia_kg_m2: [1e-4; 3],
            linear_damping_n_s_per_m: 0.3,
            angular_damping_nm_s_per_rad: 1e-3,
            max_force_n: 8.0,
            max_torque_nm: 0.5,
            max_stiffness_n_per_m: 2000.0,
            max_rot_stiffness_nm_per_rad: 0.8,
            max_damping_n_s_per_m: 5.0,
            max_rot_damping_nm_s_per_rad: 0.01,
            workspace_radius_m: 0.12,
            wall_stiffness_n_per_m: 3e4,
            wall_damping_n_s_per_m: 100.0,
            position_resolution_m: 1e-5,
            angle_resolution_rad: 1e-3,
            buttons: 2,
            max_step_ns: 10_000_000,
            max_substep_ns: 1_000_000,
        }
    }
}

impl SimulatedArmConfig {
    /// The spec the simulated arm reports: limits copied from this config, full 6-DOF
    /// input and output.
    pub fn spec(&self) -> DeviceSpec {
        DeviceSpec {
            name: self.name.clone(),
            limits: DeviceLimits {
                max_force_n: self.max_force_n,
                max_torque_nm: self.max_torque_nm,
                max_stiffness_n_per_m: self.max_stiffness_n_per_m,
                max_rot_stiffness_nm_per_rad: self.max_rot_stiffness_nm_per_rad,
                max_damping_n_s_per_m: self.max_damping_n_s_per_m,
                max_rot_damping_nm_s_per_rad: self.max_rot_damping_nm_s_per_rad,
                workspace_radius_m: self.workspace_radius_m,
            },
            capabilities: Capabilities {
                force_output: true,
                torque_output: true,
                orientation_input: true,
                buttons: self.buttons,
            },
        }
    }

    /// Checks every field: masses and inertias positive, damping, stiffness and
    /// resolutions finite and non-negative, time steps positive, and the stiffest and most
    /// damped element (the wall) stable for one sub-step `h` of semi-implicit Euler:
    /// `sqrt(k/m)·h < 1` and `c·h/m < 1`.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let positive = [
            (self.mass_kg, "mass_kg"),
            (self.inertia_kg_m2[0], "inertia_kg_m2[0]"),
            (self.inertia_kg_m2[1], "inertia_kg_m2[1]"),
            (self.inertia_kg_m2[2], "inertia_kg_m2[2]"),
        ];
        for (value, name) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        let non_negative = [
            (self.linear_damping_n_s_per_m, "linear_damping_n_s_per_m"),
            (
                self.angular_damping_nm_s_per_rad,
                "angular_damping_nm_s_per_rad",
            ),
            (self.wall_stiffness_n_per_m, "wall_stiffness_n_per_m"),
            (self.wall_damping_n_s_per_m, "wall_damping_n_s_per_m"),
            (self.position_resolution_m, "position_resolution_m"),
            (self.angle_resolution_rad, "angle_resolution_rad"),
        ];
        for (value, name) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        if self.max_step_ns == 0 {
            return Err(DeviceError::InvalidConfig("max_step_ns"));
        }
        if self.max_substep_ns == 0 {
            return Err(DeviceError::InvalidConfig("max_substep_ns"));
        }
        let h = self.max_substep_ns as f64 * 1e-9;
        if (self.wall_stiffness_n_per_m / self.mass_kg).sqrt() * h >= 1.0 {
            return Err(DeviceError::InvalidConfig("wall_stiffness_n_per_m"));
        }
        let damping = self.wall_damping_n_s_per_m + self.linear_damping_n_s_per_m;
        if damping * h / self.mass_kg >= 1.0 {
            return Err(DeviceError::InvalidConfig("wall_damping_n_s_per_m"));
        }
        let [ix, iy, iz] = self.inertia_kg_m2;
        if self.angular_damping_nm_s_per_rad * h / ix.min(iy).min(iz) >= 1.0 {
            return Err(DeviceError::InvalidConfig("angular_damping_nm_s_per_rad"));
        }
        self.spec().validate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_spec_mirrors_them() {
        let c = SimulatedArmConfig::default();
        assert_eq!(c.validate(), Ok(()));
        let s = c.spec();
        assert_eq!(s.limits.max_force_n, 8.0);
        assert_eq!(s.limits.max_torque_nm, 0.5);
        assert_eq!(s.limits.max_stiffness_n_per_m, 2000.0);
        assert_eq!(s.limits.max_rot_stiffness_nm_per_rad, 0.8);
        assert_eq!(s.limits.max_rot_damping_nm_s_per_rad, 0.01);
        assert_eq!(s.limits.workspace_radius_m, 0.12);
        assert!(s.capabilities.force_output && s.capabilities.torque_output);
        assert_eq!(s.capabilities.buttons, 2);
    }

    #[test]
    fn rejects_bad_fields() {
        let bad = [
            SimulatedArmConfig {
                mass_kg: 0.0,
                ..Default::default()
            },
            SimulatedArmConfig {
                inertia_kg_m2: [1e-4, f64::NAN, 1e-4],
                ..Default::default()
            },
            SimulatedArmConfig {
                position_resolution_m: -1e-5,
                ..Default::default()
            },
            SimulatedArmConfig {
                max_substep_ns: 0,
                ..Default::default()
            },
            // Too stiff or too damped a wall for a 1 ms sub-step of a 0.2 kg mass.
            SimulatedArmConfig {
                wall_stiffness_n_per_m: 1e6,
                ..Default::default()
            },
            SimulatedArmConfig {
                wall_damping_n_s_per_m: 300.0,
                ..Default::default()
            },
            SimulatedArmConfig {
                angular_damping_nm_s_per_rad: 0.5,
                ..Default::default()
            },
            SimulatedArmConfig {
                workspace_radius_m: -0.1,
                ..Default::default()
            },
        ];
        for c in bad {
            assert!(c.validate().is_err(), "accepted {c:?}");
        }
    }
}
