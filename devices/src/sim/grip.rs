//! The hand's grip on the end effector: the spring-damper law both simulated hands (the
//! scripted user and the reacting operator) hold the arm by.

use nalgebra::{Isometry3, Vector3};

use crate::Wrench;
use crate::types::clamp_norm;

/// A grip's constants (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Grip {
    /// Translational stiffness, N/m.
    pub stiffness_n_per_m: f64,
    /// Translational damping, N·s/m.
    pub damping_n_s_per_m: f64,
    /// Rotational stiffness, N·m/rad.
    pub rot_stiffness_nm_per_rad: f64,
    /// Rotational damping, N·m·s/rad.
    pub rot_damping_nm_s_per_rad: f64,
    /// Largest force norm, N.
    pub max_force_n: f64,
    /// Largest torque norm, N·m.
    pub max_torque_nm: f64,
}

/// Where the hand wants the end effector: pose (m, base frame) and twist (m/s, rad/s).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Setpoint {
    pub pose: Isometry3<f64>,
    pub linear_velocity: Vector3<f64>,
    pub angular_velocity: Vector3<f64>,
}

impl Grip {
    /// The wrench the hand applies on the end effector at `ee_pose` moving with
    /// `ee_linear_velocity` / `ee_angular_velocity` (base frame): spring-damper toward
    /// `setpoint`, plus `extra_force_n` (a deliberate push), each part bounded by the grip's
    /// limits; zero if anything is not finite. Allocation-free.
    pub fn wrench(
        &self,
        setpoint: &Setpoint,
        ee_pose: &Isometry3<f64>,
        ee_linear_velocity: &Vector3<f64>,
        ee_angular_velocity: &Vector3<f64>,
        extra_force_n: Vector3<f64>,
    ) -> Wrench {
        let force = (setpoint.pose.translation.vector - ee_pose.translation.vector)
            * self.stiffness_n_per_m
            + (setpoint.linear_velocity - ee_linear_velocity) * self.damping_n_s_per_m
            + extra_force_n;
        let rotation_error = (setpoint.pose.rotation * ee_pose.rotation.inverse()).scaled_axis();
        let torque = rotation_error * self.rot_stiffness_nm_per_rad
            + (setpoint.angular_velocity - ee_angular_velocity) * self.rot_damping_nm_s_per_rad;
        let w = Wrench::new(
            clamp_norm(force, self.max_force_n),
            clamp_norm(torque, self.max_torque_nm),
        );
        if w.is_finite() { w } else { Wrench::ZERO }
    }
}
