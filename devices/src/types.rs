//! Values exchanged with a device every tick: the wrench written and the state read.
//!
//! Frames: the *device base frame* is fixed to the device's base (for the simulated arm, its
//! origin is the centre of the workspace sphere). The *end-effector point* is the point the
//! device reports the pose of and applies torque about (stylus tip, handle centre).

use std::ops::{Add, AddAssign, Neg, Sub};

use nalgebra::{Isometry3, Vector3};

/// A force and a torque applied at the end-effector point, both in the device base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wrench {
    /// Force in N, device base frame, applied at the end-effector point.
    pub force: Vector3<f64>,
    /// Torque in N·m about the end-effector point, device base frame.
    pub torque: Vector3<f64>,
}

impl Wrench {
    /// No force and no torque.
    pub const ZERO: Wrench = Wrench {
        force: Vector3::new(0.0, 0.0, 0.0),
        torque: Vector3::new(0.0, 0.0, 0.0),
    };

    /// A wrench from a force (N) and a torque (N·m), both in the device base frame.
    pub const fn new(force: Vector3<f64>, torque: Vector3<f64>) -> Self {
        Wrench { force, torque }
    }

    /// A pure force (N, device base frame) with no torque.
    pub const fn from_force(force: Vector3<f64>) -> Self {
        Wrench {
            force,
            torque: Vector3::new(0.0, 0.0, 0.0),
        }
    }

    /// True when all six components are finite (no NaN, no ±∞).
    pub fn is_finite(&self) -> bool {
        self.force
            .iter()
            .chain(self.torque.iter())
            .all(|c| c.is_finite())
    }

    /// This wrench with the force norm clamped to `max_force_n` (N) and the torque norm
    /// clamped to `max_torque_nm` (N·m), each keeping its direction. A non-finite wrench
    /// gives [`Wrench::ZERO`]; a negative limit acts as zero.
    pub fn saturated(&self, max_force_n: f64, max_torque_nm: f64) -> Wrench {
        if !self.is_finite() {
            return Wrench::ZERO;
        }
        Wrench {
            force: clamp_norm(self.force, max_force_n),
            torque: clamp_norm(self.torque, max_torque_nm),
        }
    }
}

impl Default for Wrench {
    fn default() -> Self {
        Wrench::ZERO
    }
}

impl Add for Wrench {
    type Output = Wrench;
    fn add(self, rhs: Wrench) -> Wrench {
        Wrench::new(self.force + rhs.force, self.torque + rhs.torque)
    }
}

impl AddAssign for Wrench {
    fn add_assign(&mut self, rhs: Wrench) {
        self.force += rhs.force;
        self.torque += rhs.torque;
    }
}

impl Sub for Wrench {
    type Output = Wrench;
    fn sub(self, rhs: Wrench) -> Wrench {
        Wrench::new(self.force - rhs.force, self.torque - rhs.torque)
    }
}

impl Neg for Wrench {
    type Output = Wrench;
    fn neg(self) -> Wrench {
        Wrench::new(-self.force, -self.torque)
    }
}

/// `v` scaled down so that its norm is at most `max` (a negative or NaN `max` acts as 0).
/// Inline: the loop's guidance and safety stages call it from another crate every tick.
#[inline]
pub fn clamp_norm(v: Vector3<f64>, max: f64) -> Vector3<f64> {
    let max = if max > 0.0 { max } else { 0.0 };
    let norm = v.norm();
    if norm > max { v * (max / norm) } else { v }
}

/// One sample of the device, as `read` returns it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceState {
    /// Pose of the end effector in the device base frame (translation in m).
    pub pose: Isometry3<f64>,
    /// Linear velocity of the end-effector point in m/s, device base frame.
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity of the end effector in rad/s, device base frame.
    pub angular_velocity: Vector3<f64>,
    /// Button mask: bit `i` set means button `i` is pressed.
    pub buttons: u32,
    /// When the device sampled this state, `CLOCK_MONOTONIC` ns (the device's own sample
    /// time; for the simulator it equals the `now_ns` given to `read`).
    pub timestamp_ns: u64,
}

impl DeviceState {
    /// A state at rest at `pose` (m, device base frame), no buttons, sampled at
    /// `timestamp_ns` (`CLOCK_MONOTONIC` ns).
    pub fn at_rest(pose: Isometry3<f64>, timestamp_ns: u64) -> Self {
        DeviceState {
            pose,
            linear_velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            buttons: 0,
            timestamp_ns,
        }
    }

    /// True when button `index` (0-based) is pressed; false for `index >= 32`.
    pub fn button(&self, index: u32) -> bool {
        index < 32 && self.buttons & (1 << index) != 0
    }

    /// True when pose and velocities are all finite and the rotation is a unit quaternion
    /// (norm within 1e-6 of 1).
    pub fn is_finite(&self) -> bool {
        let q = self.pose.rotation.coords;
        self.pose.translation.vector.iter().all(|c| c.is_finite())
            && q.iter().all(|c| c.is_finite())
            && (q.norm() - 1.0).abs() < 1e-6
            && self.linear_velocity.iter().all(|c| c.is_finite())
            && self.angular_velocity.iter().all(|c| c.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_is_zero_and_finite() {
        assert_eq!(Wrench::ZERO.force, Vector3::zeros());
        assert_eq!(Wrench::ZERO.torque, Vector3::zeros());
        assert!(Wrench::ZERO.is_finite());
        assert_eq!(Wrench::default(), Wrench::ZERO);
    }

    #[test]
    fn non_finite_is_detected() {
        let mut w = Wrench::from_force(Vector3::new(1.0, 2.0, 3.0));
        assert!(w.is_finite());
        w.torque.y = f64::NAN;
        assert!(!w.is_finite());
        w.torque.y = 0.0;
        w.force.z = f64::INFINITY;
        assert!(!w.is_finite());
        assert_eq!(w.saturated(10.0, 1.0), Wrench::ZERO);
    }

    #[test]
    fn saturation_keeps_direction() {
        let w = Wrench::new(Vector3::new(30.0, 40.0, 0.0), Vector3::new(0.0, 0.0, -2.0));
        let s = w.saturated(5.0, 0.5);
        assert!((s.force - Vector3::new(3.0, 4.0, 0.0)).norm() < 1e-12);
        assert!((s.torque - Vector3::new(0.0, 0.0, -0.5)).norm() < 1e-12);
        // Already inside the limits: unchanged.
        let small = Wrench::new(Vector3::new(0.1, 0.0, 0.0), Vector3::new(0.0, 0.01, 0.0));
        assert_eq!(small.saturated(5.0, 0.5), small);
        // Negative limit acts as zero.
        assert_eq!(w.saturated(-1.0, -1.0), Wrench::ZERO);
    }

    #[test]
    fn arithmetic() {
        let a = Wrench::new(Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 1.0, 0.0));
        let b = Wrench::new(Vector3::new(0.0, 2.0, 0.0), Vector3::new(0.0, 0.0, 3.0));
        let mut c = a + b;
        assert_eq!(c.force, Vector3::new(1.0, 2.0, 0.0));
        assert_eq!(c - b, a);
        c += -a;
        assert_eq!(c, b);
    }

    #[test]
    fn buttons_and_state_validity() {
        let mut s = DeviceState::at_rest(Isometry3::identity(), 42);
        assert!(s.is_finite());
        s.buttons = 0b101;
        assert!(s.button(0) && !s.button(1) && s.button(2) && !s.button(40));
        s.linear_velocity.x = f64::NAN;
        assert!(!s.is_finite());
    }
}
