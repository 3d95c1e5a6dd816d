//! Rate control of an avatar from SpaceMouse deflections, with the planner's guidance
//! pseudo-force mixed into its motion (I-RRT Algorithm 2, non-haptic branch:
//! `F_d ← COMPUTE_DEVICE_PSEUDO_FORCE(Q_device, F_s)`). Pure: time is passed in.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::report::RawAxes;
use crate::{DeviceError, Wrench};

/// Maps the HID frame (x right, y toward the operator, z down) to the scene frame
/// (right-handed, Z up; X to the operator's right, Y away from the operator): scene axis `i`
/// is `signs[i] · raw[source[i]]`. The same map applies to rotations; it must be a proper
/// rotation (determinant +1) so both frames stay right-handed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisMap {
    /// Raw axis feeding scene x, y, z.
    pub source: [usize; 3],
    /// Sign applied to each, ±1.
    pub signs: [f64; 3],
}

impl Default for AxisMap {
    /// x → x, y → −y, z → −z: a 180° turn about x (spacenavd's convention for the HID
    /// frame; verify on your device, mounting can differ).
    fn default() -> Self {
        AxisMap {
            source: [0, 1, 2],
            signs: [1.0, -1.0, -1.0],
        }
    }
}

impl AxisMap {
    /// Checks that `source` is a permutation of 0, 1, 2, every sign is ±1, and the map
    /// keeps handedness.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let mut seen = [false; 3];
        for &s in &self.source {
            if s > 2 || seen[s] {
                return Err(DeviceError::InvalidConfig(
                    "axis_map.source (not a permutation of 0, 1, 2)",
                ));
            }
            seen[s] = true;
        }
        if self.signs.iter().any(|s| *s != 1.0 && *s != -1.0) {
            return Err(DeviceError::InvalidConfig(
                "axis_map.signs (each must be 1 or -1)",
            ));
        }
        if self.matrix().determinant() < 0.0 {
            return Err(DeviceError::InvalidConfig(
                "axis_map (a mirror: the scene frame must stay right-handed)",
            ));
        }
        Ok(())
    }

    fn matrix(&self) -> nalgebra::Matrix3<f64> {
        let mut m = nalgebra::Matrix3::zeros();
        for i in 0..3 {
            m[(i, self.source[i])] = self.signs[i];
        }
        m
    }

    /// `raw` (HID frame) expressed in the scene frame.
    pub fn apply(&self, raw: Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            self.signs[0] * raw[self.source[0]],
            self.signs[1] * raw[self.source[1]],
            self.signs[2] * raw[self.source[2]],
        )
    }
}

/// How deflections and guidance move the avatar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateConfig {
    /// Raw count of a full deflection (3Dconnexion devices: about 350).
    pub full_scale_counts: f64,
    /// Fraction of full scale ignored around rest, 0–0.9 (sensor noise and a puck that does
    /// not centre exactly).
    pub deadband: f64,
    /// Avatar speed at full deflection, m/s (device base frame).
    pub max_speed_m_per_s: f64,
    /// Avatar angular speed at full deflection, rad/s.
    pub max_angular_speed_rad_per_s: f64,
    /// Velocity added per newton of guidance pseudo-force, (m/s)/N: the admittance through
    /// which F_s moves the avatar.
    pub guidance_m_per_s_per_n: f64,
    /// Angular velocity added per N·m of guidance torque, (rad/s)/(N·m).
    pub guidance_rad_per_s_per_nm: f64,
    /// The avatar stays inside this sphere around the base-frame origin, m.
    pub workspace_radius_m: f64,
    /// Held deflection is dropped to zero when no report came for this long, s: a lost
    /// "released" report must not leave the avatar drifting.
    pub hold_timeout_s: f64,
    /// HID → scene axes.
    pub axis_map: AxisMap,
}

impl Default for RateConfig {
    fn default() -> Self {
        RateConfig {
            full_scale_counts: 350.0,
            deadband: 0.05,
            max_speed_m_per_s: 0.05,
            max_angular_speed_rad_per_s: 0.8,
            guidance_m_per_s_per_n: 0.01,
            guidance_rad_per_s_per_nm: 1.0,
            workspace_radius_m: 0.12,
            hold_timeout_s: 0.5,
            axis_map: AxisMap::default(),
        }
    }
}

impl RateConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), DeviceError> {
        let positive = [
            (self.full_scale_counts, "full_scale_counts"),
            (self.max_speed_m_per_s, "max_speed_m_per_s"),
            (
                self.max_angular_speed_rad_per_s,
                "max_angular_speed_rad_per_s",
            ),
            (self.workspace_radius_m, "workspace_radius_m"),
            (self.hold_timeout_s, "hold_timeout_s"),
        ];
        for (v, name) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        for (v, name) in [
            (self.guidance_m_per_s_per_n, "guidance_m_per_s_per_n"),
            (self.guidance_rad_per_s_per_nm, "guidance_rad_per_s_per_nm"),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        if !(self.deadband.is_finite() && (0.0..=0.9).contains(&self.deadband)) {
            return Err(DeviceError::InvalidConfig("deadband (0–0.9)"));
        }
        self.axis_map.validate()
    }

    /// One raw count as a deflection in [−1, 1] with the deadband removed (continuous at
    /// its edge, so motion starts from zero speed).
    pub fn deflection(&self, raw: f64) -> f64 {
        let d = (raw / self.full_scale_counts).clamp(-1.0, 1.0);
        let a = d.abs();
        if a <= self.deadband {
            0.0
        } else {
            d.signum() * (a - self.deadband) / (1.0 - self.deadband)
        }
    }

    fn deflections(&self, raw: [i16; 3]) -> Vector3<f64> {
        let v = Vector3::new(
            self.deflection(f64::from(raw[0])),
            self.deflection(f64::from(raw[1])),
            self.deflection(f64::from(raw[2])),
        );
        self.axis_map.apply(v)
    }
}

/// The avatar moved by rate control: pose in the device base frame (axes = scene axes, origin
/// where the avatar started), velocities, and the guidance wrench last written.
#[derive(Debug, Clone, Copy)]
pub struct RateControl {
    config: RateConfig,
    pose: Isometry3<f64>,
    linear_velocity: Vector3<f64>,
    angular_velocity: Vector3<f64>,
    guidance: Wrench,
}

impl RateControl {
    /// An avatar at rest at the origin. `config` must be valid.
    pub fn new(config: RateConfig) -> Self {
        RateControl {
            config,
            pose: Isometry3::identity(),
            linear_velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            guidance: Wrench::ZERO,
        }
    }

    /// Sets the guidance pseudo-force F_s (N, N·m, base frame) that will move the avatar
    /// from the next step on.
    pub fn set_guidance(&mut self, wrench: Wrench) {
        self.guidance = if wrench.is_finite() {
            wrench
        } else {
            Wrench::ZERO
        };
    }

    /// Puts the avatar at rest at `pose` (device base frame), e.g. where a task starts.
    pub fn reset_to(&mut self, pose: Isometry3<f64>) {
        self.halt();
        self.pose = pose;
    }

    /// Stops the avatar where it is (unplug, fault).
    pub fn halt(&mut self) {
        self.linear_velocity = Vector3::zeros();
        self.angular_velocity = Vector3::zeros();
        self.guidance = Wrench::ZERO;
    }

    /// Advances by `dt_s` seconds with `axes` held for `report_age_s` seconds (a report
    /// older than `hold_timeout_s` counts as released); see [`RateControl::step_deflections`].
    pub fn step(&mut self, axes: &RawAxes, report_age_s: f64, dt_s: f64) {
        let c = &self.config;
        let (t, r) = if report_age_s > c.hold_timeout_s {
            (Vector3::zeros(), Vector3::zeros())
        } else {
            (
                c.deflections(axes.translation),
                c.deflections(axes.rotation),
            )
        };
        self.step_deflections(&t, &r, dt_s);
    }

    /// Advances by `dt_s` seconds with deflections `t` and `r` (scene axes, each in
    /// [−1, 1]; larger values are clamped): v = v_max·deflection + admittance·F_s, then
    /// explicit Euler on the pose, kept inside the workspace sphere (the outward velocity is
    /// removed at its wall).
    pub fn step_deflections(&mut self, t: &Vector3<f64>, r: &Vector3<f64>, dt_s: f64) {
        let c = &self.config;
        let unit = |v: &Vector3<f64>| {
            v.map(|x| {
                if x.is_finite() {
                    x.clamp(-1.0, 1.0)
                } else {
                    0.0
                }
            })
        };
        let (t, r) = (unit(t), unit(r));
        let mut v = t * c.max_speed_m_per_s + self.guidance.force * c.guidance_m_per_s_per_n;
        let w =
            r * c.max_angular_speed_rad_per_s + self.guidance.torque * c.guidance_rad_per_s_per_nm;
        let dt = if dt_s.is_finite() { dt_s.max(0.0) } else { 0.0 };
        let mut p = self.pose.translation.vector + v * dt;
        let dist = p.norm();
        if dist > c.workspace_radius_m {
            let n = p / dist;
            p = n * c.workspace_radius_m;
            let outward = v.dot(&n);
            if outward > 0.0 {
                v -= n * outward;
            }
        }
        self.pose.translation = Translation3::from(p);
        // Angular velocity is in the base frame: the increment multiplies from the left.
        self.pose.rotation = UnitQuaternion::from_scaled_axis(w * dt) * self.pose.rotation;
        self.linear_velocity = v;
        self.angular_velocity = w;
    }

    /// Avatar pose, device base frame (m).
    pub fn pose(&self) -> &Isometry3<f64> {
        &self.pose
    }

    /// Avatar linear velocity, m/s, base frame.
    pub fn linear_velocity(&self) -> Vector3<f64> {
        self.linear_velocity
    }

    /// Avatar angular velocity, rad/s, base frame.
    pub fn angular_velocity(&self) -> Vector3<f64> {
        self.angular_velocity
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes(t: [i16; 3], r: [i16; 3]) -> RawAxes {
        RawAxes {
            translation: t,
            rotation: r,
            buttons: 0,
        }
    }

    #[test]
    fn deadband_and_full_scale() {
        let c = RateConfig::default();
        assert_eq!(c.deflection(10.0), 0.0); // 10/350 < 5 %
        assert_eq!(c.deflection(350.0), 1.0);
        assert_eq!(c.deflection(-2000.0), -1.0);
        let edge = c.deflection(0.05 * 350.0 + 1e-9);
        assert!(edge.abs() < 1e-9, "continuous at the deadband edge");
        assert!((c.deflection(-0.525 * 350.0) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn hid_axes_map_to_scene_z_up() {
        let mut rc = RateControl::new(RateConfig::default());
        // Push the cap away from the user (HID −y) and lift it (HID −z): scene +y, +z.
        rc.step(&axes([0, -350, -350], [0; 3]), 0.0, 1.0);
        let p = rc.pose().translation.vector;
        assert!((p - Vector3::new(0.0, 0.05, 0.05)).norm() < 1e-12, "{p}");
        // Twist counter-clockwise seen from above (HID −rz): positive yaw about scene z.
        let mut rc = RateControl::new(RateConfig::default());
        rc.step(&axes([0; 3], [0, 0, -350]), 0.0, 0.5);
        let (_, _, yaw) = rc.pose().rotation.euler_angles();
        assert!((yaw - 0.4).abs() < 1e-12);
    }

    #[test]
    fn guidance_moves_the_avatar_without_deflection() {
        // I-RRT Alg. 2 for a non-haptic device: F_s mixes into the avatar's motion.
        let mut rc = RateControl::new(RateConfig::default());
        rc.set_guidance(Wrench::from_force(Vector3::new(2.0, 0.0, 0.0)));
        for _ in 0..1000 {
            rc.step(&RawAxes::default(), 0.0, 0.001);
        }
        assert!((rc.pose().translation.x - 0.02).abs() < 1e-9);
        assert!((rc.linear_velocity().x - 0.02).abs() < 1e-12);
        rc.set_guidance(Wrench::from_force(Vector3::new(f64::NAN, 0.0, 0.0)));
        rc.step(&RawAxes::default(), 0.0, 0.001);
        assert_eq!(rc.linear_velocity(), Vector3::zeros());
    }

    #[test]
    fn stale_hold_stops_and_workspace_bounds() {
        let mut rc = RateControl::new(RateConfig::default());
        rc.step(&axes([350, 0, 0], [0; 3]), 0.6, 1.0);
        assert_eq!(rc.pose().translation.vector, Vector3::zeros());
        for _ in 0..100 {
            rc.step(&axes([350, 0, 0], [0; 3]), 0.0, 0.1);
        }
        assert!((rc.pose().translation.x - 0.12).abs() < 1e-12);
        assert_eq!(rc.linear_velocity().x, 0.0);
    }

    #[test]
    fn config_validation() {
        assert!(RateConfig::default().validate().is_ok());
        let mut c = RateConfig::default();
        c.axis_map.signs = [1.0, 1.0, -1.0];
        assert!(c.validate().is_err(), "mirror rejected");
        let mut c = RateConfig::default();
        c.axis_map.source = [0, 0, 2];
        assert!(c.validate().is_err());
        let c = RateConfig {
            deadband: 1.0,
            ..RateConfig::default()
        };
        assert!(c.validate().is_err());
        let c = RateConfig {
            full_scale_counts: f64::NAN,
            ..RateConfig::default()
        };
        assert!(c.validate().is_err());
    }
}
