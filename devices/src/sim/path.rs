//! A timed path through waypoint poses: the scripted user's hand setpoint.
//!
//! Built once (allocates); queried per sub-step without allocating.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::DeviceError;

/// A pose for the scripted user's hand to pass through, and how long to hold it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    /// Hand setpoint pose in the device base frame (translation in m).
    pub pose: Isometry3<f64>,
    /// Time in s to hold this pose on arrival before moving on (≥ 0).
    pub dwell_s: f64,
}

impl Waypoint {
    /// A waypoint at `pose` (m, device base frame) with no dwell.
    pub fn new(pose: Isometry3<f64>) -> Self {
        Waypoint { pose, dwell_s: 0.0 }
    }

    /// A waypoint at position `(x, y, z)` in m (device base frame), identity orientation,
    /// no dwell.
    pub fn at(x: f64, y: f64, z: f64) -> Self {
        Waypoint::new(Isometry3::translation(x, y, z))
    }

    /// This waypoint with a dwell of `dwell_s` seconds.
    pub fn with_dwell(self, dwell_s: f64) -> Self {
        Waypoint { dwell_s, ..self }
    }
}

impl From<Isometry3<f64>> for Waypoint {
    fn from(pose: Isometry3<f64>) -> Self {
        Waypoint::new(pose)
    }
}

/// The setpoint at one instant: pose and its nominal twist (base frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Setpoint {
    pub pose: Isometry3<f64>,
    /// m/s, base frame.
    pub linear_velocity: Vector3<f64>,
    /// rad/s, base frame.
    pub angular_velocity: Vector3<f64>,
}

/// Waypoints with their schedule. Between waypoints `i` and `i+1` the position moves
/// linearly and the orientation by slerp (`q(s) = exp(s·Δθ) ⊗ q_i`, `Δθ` the shortest
/// rotation vector from `q_i` to `q_{i+1}`, base frame), both with the same parameter
/// `s ∈ [0, 1]` growing linearly over the segment. The segment takes
/// `max(‖Δp‖/v, ‖Δθ‖/ω)`, so neither speed limit is exceeded and both finish together.
#[derive(Debug, Clone)]
pub(crate) struct WaypointPath {
    waypoints: Vec<Waypoint>,
    /// Arrival time at waypoint `i`, s.
    arrive_s: Vec<f64>,
    /// Departure time from waypoint `i` (arrival + dwell), s.
    depart_s: Vec<f64>,
    /// Rotation vector from waypoint `i` to `i+1`, rad, base frame (last entry zero).
    delta_rotation: Vec<Vector3<f64>>,
}

impl WaypointPath {
    /// Schedules `waypoints` at `linear_speed_m_per_s` and `angular_speed_rad_per_s`.
    pub fn new(
        waypoints: Vec<Waypoint>,
        linear_speed_m_per_s: f64,
        angular_speed_rad_per_s: f64,
    ) -> Result<Self, DeviceError> {
        if !(linear_speed_m_per_s.is_finite() && linear_speed_m_per_s > 0.0) {
            return Err(DeviceError::InvalidConfig("linear_speed_m_per_s"));
        }
        if !(angular_speed_rad_per_s.is_finite() && angular_speed_rad_per_s > 0.0) {
            return Err(DeviceError::InvalidConfig("angular_speed_rad_per_s"));
        }
        if waypoints.is_empty() {
            return Err(DeviceError::InvalidConfig("waypoints (empty)"));
        }
        for w in &waypoints {
            let finite = w.pose.translation.vector.iter().all(|c| c.is_finite())
                && w.pose.rotation.coords.iter().all(|c| c.is_finite());
            if !finite {
                return Err(DeviceError::InvalidConfig("waypoints (non-finite pose)"));
            }
            if !(w.dwell_s.is_finite() && w.dwell_s >= 0.0) {
                return Err(DeviceError::InvalidConfig("waypoints (dwell_s)"));
            }
        }
        let n = waypoints.len();
        let (mut arrive_s, mut depart_s) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let mut delta_rotation = Vec::with_capacity(n);
        let mut t = 0.0;
        for (i, w) in waypoints.iter().enumerate() {
            arrive_s.push(t);
            t += w.dwell_s;
            depart_s.push(t);
            let delta = match waypoints.get(i + 1) {
                Some(next) => {
                    let dp = (next.pose.translation.vector - w.pose.translation.vector).norm();
                    let dr = (next.pose.rotation * w.pose.rotation.inverse()).scaled_axis();
                    t += (dp / linear_speed_m_per_s).max(dr.norm() / angular_speed_rad_per_s);
                    dr
                }
                None => Vector3::zeros(),
            };
            delta_rotation.push(delta);
        }
        Ok(WaypointPath {
            waypoints,
            arrive_s,
            depart_s,
            delta_rotation,
        })
    }

    /// The waypoints, in order.
    pub fn waypoints(&self) -> &[Waypoint] {
        &self.waypoints
    }

    /// Time in s at which the last waypoint's dwell ends.
    pub fn duration_s(&self) -> f64 {
        self.depart_s.last().copied().unwrap_or(0.0)
    }

    /// The setpoint at `t_s` (s since the path started; before 0 acts as 0, after the
    /// end holds the last waypoint). Allocation-free, O(log n).
    pub fn at(&self, t_s: f64) -> Setpoint {
        let t = t_s.max(0.0);
        // Latest waypoint reached: arrive_s[0] = 0 ≤ t, so the count is ≥ 1.
        let i = self.arrive_s.partition_point(|&a| a <= t).saturating_sub(1);
        let (Some(from), Some(&depart)) = (self.waypoints.get(i), self.depart_s.get(i)) else {
            return Setpoint::still(Isometry3::identity());
        };
        let (Some(to), Some(&arrive_next)) = (self.waypoints.get(i + 1), self.arrive_s.get(i + 1))
        else {
            return Setpoint::still(from.pose);
        };
        let duration = arrive_next - depart;
        if t < depart || duration <= 0.0 {
            return Setpoint::still(from.pose);
        }
        let s = ((t - depart) / duration).clamp(0.0, 1.0);
        let delta_p = to.pose.translation.vector - from.pose.translation.vector;
        let delta_r = self
            .delta_rotation
            .get(i)
            .copied()
            .unwrap_or_else(Vector3::zeros);
        let position = from.pose.translation.vector + delta_p * s;
        let rotation = UnitQuaternion::from_scaled_axis(delta_r * s) * from.pose.rotation;
        Setpoint {
            pose: Isometry3::from_parts(Translation3::from(position), rotation),
            linear_velocity: delta_p / duration,
            angular_velocity: delta_r / duration,
        }
    }
}

impl Setpoint {
    fn still(pose: Isometry3<f64>) -> Self {
        Setpoint {
            pose,
            linear_velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rot_z(angle: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_scaled_axis(Vector3::z() * angle)
    }

    #[test]
    fn schedule_uses_the_slower_of_the_two_speeds_and_dwell() {
        let a = Waypoint::at(0.0, 0.0, 0.0).with_dwell(0.5);
        let b = Waypoint::new(Isometry3::from_parts(
            Translation3::new(0.1, 0.0, 0.0),
            rot_z(1.0),
        ));
        // 0.1 m at 0.05 m/s = 2 s; 1 rad at 1 rad/s = 1 s: translation decides.
        let path = WaypointPath::new(vec![a, b.with_dwell(0.25)], 0.05, 1.0).expect("valid");
        assert!((path.duration_s() - 2.75).abs() < 1e-12);
        // Rotation decides when it is slow.
        let path = WaypointPath::new(vec![a, b], 0.05, 0.25).expect("valid");
        assert!((path.duration_s() - 4.5).abs() < 1e-12);
    }

    #[test]
    fn interpolates_linearly_and_by_slerp() {
        let a = Waypoint::at(0.0, 0.0, 0.0).with_dwell(1.0);
        let b = Waypoint::new(Isometry3::from_parts(
            Translation3::new(0.1, -0.1, 0.0),
            rot_z(0.8),
        ));
        let path = WaypointPath::new(vec![a, b], 0.1, 1.0).expect("valid");
        let d = 0.1 * 2f64.sqrt() / 0.1; // segment duration, s
        // Dwelling at the first waypoint.
        let sp = path.at(0.5);
        assert_eq!(sp.pose, a.pose);
        assert_eq!(sp.linear_velocity, Vector3::zeros());
        // Halfway along the segment.
        let sp = path.at(1.0 + d / 2.0);
        assert!((sp.pose.translation.vector - Vector3::new(0.05, -0.05, 0.0)).norm() < 1e-12);
        assert!(sp.pose.rotation.angle_to(&rot_z(0.4)) < 1e-12);
        let expected = a.pose.rotation.slerp(&b.pose.rotation, 0.5);
        assert!(sp.pose.rotation.angle_to(&expected) < 1e-12);
        assert!((sp.linear_velocity - Vector3::new(0.1, -0.1, 0.0) / d).norm() < 1e-12);
        assert!((sp.angular_velocity - Vector3::z() * 0.8 / d).norm() < 1e-12);
        // Holds the last waypoint forever.
        let sp = path.at(100.0);
        assert_eq!(sp.pose, b.pose);
        assert_eq!(sp.angular_velocity, Vector3::zeros());
        // Negative time acts as zero.
        assert_eq!(path.at(-3.0).pose, a.pose);
    }

    #[test]
    fn half_turn_and_repeated_waypoints_do_not_panic() {
        let a = Waypoint::at(0.0, 0.0, 0.0);
        let b = Waypoint::new(Isometry3::from_parts(
            Translation3::identity(),
            rot_z(std::f64::consts::PI),
        ));
        let path = WaypointPath::new(vec![a, a, b], 0.1, 1.0).expect("valid");
        assert!((path.duration_s() - std::f64::consts::PI).abs() < 1e-9);
        let mid = path.at(std::f64::consts::FRAC_PI_2);
        assert!((mid.pose.rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert!(path.at(10.0).pose.rotation.angle_to(&b.pose.rotation) < 1e-12);
    }

    #[test]
    fn rejects_empty_and_bad_waypoints() {
        assert!(WaypointPath::new(vec![], 0.1, 1.0).is_err());
        let ok = Waypoint::at(0.0, 0.0, 0.0);
        assert!(WaypointPath::new(vec![ok], 0.0, 1.0).is_err());
        assert!(WaypointPath::new(vec![ok], 0.1, f64::NAN).is_err());
        let bad = Waypoint::at(f64::NAN, 0.0, 0.0);
        assert!(WaypointPath::new(vec![bad], 0.1, 1.0).is_err());
        let bad = Waypoint::at(0.0, 0.0, 0.0).with_dwell(-1.0);
        assert!(WaypointPath::new(vec![bad], 0.1, 1.0).is_err());
    }
}
