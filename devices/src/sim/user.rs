//! A scripted operator: a hand that holds the end effector through a spring-damper whose
//! setpoint follows waypoints.

use nalgebra::{Isometry3, Vector3};
use serde::{Deserialize, Serialize};

use super::grip::{Grip, Setpoint};
use super::path::{Waypoint, WaypointPath};
use super::tremor::Tremor;
use crate::{DeviceError, Wrench};

/// Parameters of [`ScriptedUser`]. Every field has a default, so a partial TOML/JSON table
/// deserializes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScriptedUserConfig {
    /// Translational stiffness of the hand grip in N/m. Default 300.
    pub hand_stiffness_n_per_m: f64,
    /// Translational damping of the hand grip in N·s/m. Default 5.
    pub hand_damping_n_s_per_m: f64,
    /// Rotational stiffness of the hand grip in N·m/rad. Default 0.5.
    pub hand_rot_stiffness_nm_per_rad: f64,
    /// Rotational damping of the hand grip in N·m·s/rad. Default 0.02.
    pub hand_rot_damping_nm_s_per_rad: f64,
    /// Largest force norm the hand applies, in N. Default 10.
    pub max_force_n: f64,
    /// Largest torque norm the hand applies, in N·m. Default 0.5.
    pub max_torque_nm: f64,
    /// Speed of the setpoint along a segment in m/s (> 0). Default 0.05.
    pub linear_speed_m_per_s: f64,
    /// Angular speed of the setpoint along a segment in rad/s (> 0). Default 0.5.
    pub angular_speed_rad_per_s: f64,
    /// RMS tremor of the setpoint position per axis, in m; 0 disables it. Default 0
    /// (physiological tremor is about 1e-4–1e-3 m).
    pub tremor_amplitude_m: f64,
    /// Low-pass corner of the tremor noise in Hz (0 < f < 500). Default 10.
    pub tremor_cutoff_hz: f64,
    /// Seed of the tremor noise (ChaCha8). Default 0.
    pub tremor_seed: u64,
}

impl Default for ScriptedUserConfig {
    fn default() -> Self {
        ScriptedUserConfig {
            hand_stiffness_n_per_m: 300.0,
            hand_damping_n_s_per_m: 5.0,
            hand_rot_stiffness_nm_per_rad: 0.5,
            hand_rot_damping_nm_s_per_rad: 0.02,
            max_force_n: 10.0,
            max_torque_nm: 0.5,
            linear_speed_m_per_s: 0.05,
            angular_speed_rad_per_s: 0.5,
            tremor_amplitude_m: 0.0,
            tremor_cutoff_hz: 10.0,
            tremor_seed: 0,
        }
    }
}

impl ScriptedUserConfig {
    /// The hand's grip.
    pub(crate) fn grip(&self) -> Grip {
        Grip {
            stiffness_n_per_m: self.hand_stiffness_n_per_m,
            damping_n_s_per_m: self.hand_damping_n_s_per_m,
            rot_stiffness_nm_per_rad: self.hand_rot_stiffness_nm_per_rad,
            rot_damping_nm_s_per_rad: self.hand_rot_damping_nm_s_per_rad,
            max_force_n: self.max_force_n,
            max_torque_nm: self.max_torque_nm,
        }
    }

    /// Checks gains and limits are finite and non-negative, speeds positive and the
    /// tremor corner inside (0, 500) Hz.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let non_negative = [
            (self.hand_stiffness_n_per_m, "hand_stiffness_n_per_m"),
            (self.hand_damping_n_s_per_m, "hand_damping_n_s_per_m"),
            (
                self.hand_rot_stiffness_nm_per_rad,
                "hand_rot_stiffness_nm_per_rad",
            ),
            (
                self.hand_rot_damping_nm_s_per_rad,
                "hand_rot_damping_nm_s_per_rad",
            ),
            (self.max_force_n, "max_force_n"),
            (self.max_torque_nm, "max_torque_nm"),
            (self.tremor_amplitude_m, "tremor_amplitude_m"),
        ];
        for (value, name) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        if !(self.tremor_cutoff_hz > 0.0 && self.tremor_cutoff_hz < 500.0) {
            return Err(DeviceError::InvalidConfig("tremor_cutoff_hz"));
        }
        // Speeds are checked when the path is scheduled.
        Ok(())
    }
}

/// A simulated operator's hand.
///
/// The hand is a 6-DOF spring-damper between a setpoint and the end effector:
/// `f = K·(p_s + tremor − p) + C·(v_s − v)` and `τ = K_r·log(q_s ⊗ q⁻¹) + C_r·(ω_s − ω)`,
/// clamped in norm to `max_force_n` / `max_torque_nm`. The setpoint starts at the first
/// waypoint at `t = 0` and moves along the waypoints (see [`Waypoint`]) at the configured
/// speeds, holding the last one. The wrench returned is what the hand applies *on* the end
/// effector (the operator force `f_u`), base frame.
///
/// Waypoints are stored at construction; [`hand_wrench`](ScriptedUser::hand_wrench),
/// [`setpoint`](ScriptedUser::setpoint) and [`finished`](ScriptedUser::finished) never
/// allocate. Deterministic for a given config (including `tremor_seed`) and query times.
#[derive(Debug, Clone)]
pub struct ScriptedUser {
    config: ScriptedUserConfig,
    path: WaypointPath,
    tremor: Tremor,
    last_wrench: Wrench,
}

impl ScriptedUser {
    /// A user following `waypoints` (device base frame) with `config`. Allocates; fails on
    /// an invalid config or an empty/non-finite waypoint list.
    pub fn new(
        config: ScriptedUserConfig,
        waypoints: impl IntoIterator<Item = Waypoint>,
    ) -> Result<Self, DeviceError> {
        config.validate()?;
        let path = WaypointPath::new(
            waypoints.into_iter().collect(),
            config.linear_speed_m_per_s,
            config.angular_speed_rad_per_s,
        )?;
        Ok(ScriptedUser {
            config,
            path,
            tremor: Tremor::new(
                config.tremor_amplitude_m,
                config.tremor_cutoff_hz,
                config.tremor_seed,
            ),
            last_wrench: Wrench::ZERO,
        })
    }

    /// A user that holds `pose` (device base frame) forever.
    pub fn holding(config: ScriptedUserConfig, pose: Isometry3<f64>) -> Result<Self, DeviceError> {
        ScriptedUser::new(config, [Waypoint::new(pose)])
    }

    /// The configuration.
    pub fn config(&self) -> &ScriptedUserConfig {
        &self.config
    }

    /// The waypoints, in order.
    pub fn waypoints(&self) -> &[Waypoint] {
        self.path.waypoints()
    }

    /// Nominal setpoint pose (no tremor) at `t_s` seconds after the start, base frame.
    pub fn setpoint(&self, t_s: f64) -> Isometry3<f64> {
        self.path.at(t_s).pose
    }

    /// Nominal setpoint twist at `t_s`: (linear m/s, angular rad/s), base frame.
    pub fn setpoint_twist(&self, t_s: f64) -> (Vector3<f64>, Vector3<f64>) {
        let sp = self.path.at(t_s);
        (sp.linear_velocity, sp.angular_velocity)
    }

    /// Time in s at which the setpoint has reached the last waypoint and its dwell ended.
    pub fn duration_s(&self) -> f64 {
        self.path.duration_s()
    }

    /// True once the setpoint has reached the last waypoint and finished its dwell.
    pub fn finished(&self, t_s: f64) -> bool {
        t_s >= self.path.duration_s()
    }

    /// The wrench last returned by [`hand_wrench`](ScriptedUser::hand_wrench).
    pub fn last_wrench(&self) -> Wrench {
        self.last_wrench
    }

    /// The wrench the hand applies on the end effector at `t_s` (s since start), given the
    /// end-effector pose (m, base frame) and twist (m/s, rad/s, base frame). Advances the
    /// tremor to `t_s` (call with non-decreasing times). Allocation-free.
    pub fn hand_wrench(
        &mut self,
        t_s: f64,
        ee_pose: &Isometry3<f64>,
        ee_linear_velocity: &Vector3<f64>,
        ee_angular_velocity: &Vector3<f64>,
    ) -> Wrench {
        let c = &self.config;
        let sp = self.path.at(t_s);
        let mut pose = sp.pose;
        pose.translation.vector += self.tremor.offset_at(t_s);
        let setpoint = Setpoint {
            pose,
            linear_velocity: sp.linear_velocity,
            angular_velocity: sp.angular_velocity,
        };
        self.last_wrench = c.grip().wrench(
            &setpoint,
            ee_pose,
            ee_linear_velocity,
            ee_angular_velocity,
            Vector3::zeros(),
        );
        self.last_wrench
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, UnitQuaternion};

    use super::*;

    #[test]
    fn spring_damper_law_and_clamp() {
        let mut user = ScriptedUser::holding(ScriptedUserConfig::default(), Isometry3::identity())
            .expect("valid");
        let ee = Isometry3::from_parts(
            Translation3::new(0.01, 0.0, 0.0),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.2)),
        );
        let w = user.hand_wrench(0.0, &ee, &Vector3::new(0.0, 0.1, 0.0), &Vector3::zeros());
        // 300 N/m · (−0.01 m) in x, 5 N·s/m · (−0.1 m/s) in y.
        assert!((w.force - Vector3::new(-3.0, -0.5, 0.0)).norm() < 1e-12);
        // 0.5 N·m/rad · (−0.2 rad) about z.
        assert!((w.torque - Vector3::new(0.0, 0.0, -0.1)).norm() < 1e-12);
        assert_eq!(user.last_wrench(), w);
        // Far away: the force is clamped to 10 N.
        let far = Isometry3::translation(1.0, 0.0, 0.0);
        let w = user.hand_wrench(0.0, &far, &Vector3::zeros(), &Vector3::zeros());
        assert!((w.force.norm() - 10.0).abs() < 1e-12);
        assert!(w.force.x < 0.0);
    }

    #[test]
    fn finished_after_path_and_dwell() {
        let user = ScriptedUser::new(
            ScriptedUserConfig::default(),
            [
                Waypoint::at(0.0, 0.0, 0.0),
                Waypoint::at(0.05, 0.0, 0.0).with_dwell(0.5),
            ],
        )
        .expect("valid");
        assert!((user.duration_s() - 1.5).abs() < 1e-12);
        assert!(!user.finished(1.4));
        assert!(user.finished(1.5));
        assert_eq!(user.setpoint(0.5).translation.vector.x, 0.025);
        let (v, w) = user.setpoint_twist(0.5);
        assert!((v - Vector3::new(0.05, 0.0, 0.0)).norm() < 1e-12);
        assert_eq!(w, Vector3::zeros());
    }

    #[test]
    fn tremor_is_seeded() {
        let run = |seed: u64| {
            let config = ScriptedUserConfig {
                tremor_amplitude_m: 5e-4,
                tremor_seed: seed,
                ..Default::default()
            };
            let mut user = ScriptedUser::holding(config, Isometry3::identity()).expect("valid");
            let ee = Isometry3::identity();
            (0..500)
                .map(|i| {
                    user.hand_wrench(i as f64 * 1e-3, &ee, &Vector3::zeros(), &Vector3::zeros())
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(1), run(1));
        assert_ne!(run(1), run(2));
        // Without tremor, holding still at the setpoint gives no force.
        let mut still = ScriptedUser::holding(ScriptedUserConfig::default(), Isometry3::identity())
            .expect("valid");
        let w = still.hand_wrench(
            0.3,
            &Isometry3::identity(),
            &Vector3::zeros(),
            &Vector3::zeros(),
        );
        assert_eq!(w, Wrench::ZERO);
    }

    #[test]
    fn rejects_bad_config() {
        let pose = Isometry3::identity();
        let bad = [
            ScriptedUserConfig {
                hand_stiffness_n_per_m: -1.0,
                ..Default::default()
            },
            ScriptedUserConfig {
                linear_speed_m_per_s: 0.0,
                ..Default::default()
            },
            ScriptedUserConfig {
                tremor_cutoff_hz: 600.0,
                ..Default::default()
            },
        ];
        for c in bad {
            assert!(ScriptedUser::holding(c, pose).is_err(), "accepted {c:?}");
        }
        assert!(ScriptedUser::new(ScriptedUserConfig::default(), []).is_err());
    }
}
