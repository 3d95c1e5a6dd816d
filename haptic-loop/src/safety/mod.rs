//! Everything that limits what the device is told, in the order of the tick:
//!
//! 1. **Plausibility** ([`Plausibility`]): each device read is checked (read errors,
//!    non-finite values, a stale timestamp, a jump farther than the arm can move, a streak
//!    of deadline misses); while reads fail, the last good reading stands in, at rest, and
//!    the fault zeroes the force.
//! 2. **The wanted wrench** ([`wanted_wrench`]): contact and guidance rotated into the
//!    device frame, plus what is always on: a soft wall at the workspace sphere and a
//!    little viscous damping of the end effector.
//! 3. **The output stage** ([`Safety`]): NaN guard, saturation, force-rate limit, fault
//!    latch and the ramp forces come back through; a fault clears only while the device is
//!    still ([`SafetyConfig::is_still`]).
//!
//! Guidance is bounded before it reaches this (`guidance`: a share of the same device
//! limits, faded, rate limited). Allocation-free; runs in the RT tick.

mod output;
mod plausibility;

pub use output::Safety;
pub(crate) use plausibility::Plausibility;

use crate::mapping::Mapping;
use devices::{DeviceSpec, DeviceState, Wrench};
use nalgebra::Vector3;

/// Safety limits. Each bound is the smaller of this and the device's own specification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyConfig {
    /// Cap on |force|, N; `f64::INFINITY` = the device's maximum.
    pub max_force_n: f64,
    /// Cap on |torque|, N·m; `f64::INFINITY` = the device's maximum.
    pub max_torque_nm: f64,
    /// Largest change of force per second, N/s (e.g. 2000 N/s = 2 N per 1 ms tick). Going to
    /// zero on a fault is not rate limited.
    pub max_force_rate_n_per_s: f64,
    /// Largest change of torque per second, N·m/s.
    pub max_torque_rate_nm_per_s: f64,
    /// Time over which forces ramp from zero to full after start or after a fault clears, s.
    pub ramp_s: f64,
    /// A fault clears after its cause has been absent, and the device still, this long, s.
    pub fault_clear_s: f64,
    /// The device counts as still below this end-effector speed, m/s (device frame).
    pub still_speed_m_per_s: f64,
    /// ... and below this angular speed, rad/s.
    pub still_rate_rad_per_s: f64,
    /// Fastest plausible end-effector speed, m/s: a larger position change between two
    /// readings is a `DEVICE_JUMP` fault.
    pub max_device_speed_m_per_s: f64,
    /// This many consecutive ticks that each missed a deadline latch `OVERRUN_STREAK`.
    pub max_miss_streak: u32,
    /// Always-on viscous damping on the end-effector velocity, as a fraction of the device's
    /// stable damping (0 disables).
    pub damping_fraction: f64,
    /// Stiffness of the soft wall at the workspace boundary (the device's workspace
    /// sphere), as a fraction of the device's stable stiffness (0 disables).
    pub boundary_stiffness_fraction: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            max_force_n: f64::INFINITY,
            max_torque_nm: f64::INFINITY,
            max_force_rate_n_per_s: 2000.0,
            max_torque_rate_nm_per_s: 100.0,
            ramp_s: 0.5,
            fault_clear_s: 0.1,
            still_speed_m_per_s: 0.02,
            still_rate_rad_per_s: 0.5,
            max_device_speed_m_per_s: 3.0,
            max_miss_streak: 5,
            damping_fraction: 0.1,
            boundary_stiffness_fraction: 0.5,
        }
    }
}

impl SafetyConfig {
    /// Whether `device` is at rest: below both still speeds (device frame).
    #[inline]
    pub fn is_still(&self, device: &DeviceState) -> bool {
        device.linear_velocity.norm() < self.still_speed_m_per_s
            && device.angular_velocity.norm() < self.still_rate_rad_per_s
    }
}

/// The wrench wanted at the device before the output stage: `force` and `torque` (scene
/// frame) rotated into the device frame by `mapping`, plus what is always on, in the device
/// frame: a soft wall at the workspace sphere of `spec` and a little viscous damping of
/// the end effector (`config`'s fractions of the device's stable stiffness and damping).
#[inline]
pub(crate) fn wanted_wrench(
    config: &SafetyConfig,
    spec: &DeviceSpec,
    mapping: &Mapping,
    device: &DeviceState,
    force: &Vector3<f64>,
    torque: &Vector3<f64>,
) -> Wrench {
    let limits = &spec.limits;
    let p = device.pose.translation.vector;
    let outside = p.norm() - limits.workspace_radius_m;
    let boundary = if outside > 0.0 {
        -p.normalize()
            * (outside * config.boundary_stiffness_fraction * limits.max_stiffness_n_per_m)
    } else {
        Vector3::zeros()
    };
    let damping =
        -device.linear_velocity * (config.damping_fraction * limits.max_damping_n_s_per_m);
    let rot_damping =
        -device.angular_velocity * (config.damping_fraction * limits.max_rot_damping_nm_s_per_rad);
    Wrench {
        force: mapping.vector_to_device(force) + boundary + damping,
        torque: mapping.vector_to_device(torque) + rot_damping,
    }
}
