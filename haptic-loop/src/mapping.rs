//! Device workspace → scene: position scale, a rigid offset, and a clutch (indexing) button.
//!
//! Forces go the other way unscaled, only rotated: a scene-side stiffness k (N per scene
//! metre) is felt at the device as `position_scale · k` N per device metre. The contact
//! and guidance stages budget their gains with that factor (see `Tick::new`).

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// How the device maps into the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappingConfig {
    /// Scene metres per device metre (> 0). Typical 1–5: desktop arms reach ±0.1 m, scenes
    /// span ±0.3 m or more.
    pub position_scale: f64,
    /// Pose in the scene frame that the device origin (at identity orientation) maps to.
    pub origin: Isometry3<f64>,
    /// Device button whose press engages the clutch: while held, device motion does not
    /// move the object, so the operator can re-centre the hand (indexing). `None` disables.
    pub clutch_button: Option<u32>,
}

impl Default for MappingConfig {
    fn default() -> Self {
        Self {
            position_scale: 1.0,
            origin: Isometry3::identity(),
            clutch_button: None,
        }
    }
}

/// The mapping with its clutch state.
#[derive(Debug, Clone)]
pub struct Mapping {
    scale: f64,
    /// Current scene pose of the device origin; the clutch moves it.
    anchor: Isometry3<f64>,
    clutch_button: Option<u32>,
    held: Option<Isometry3<f64>>,
    last: Option<Isometry3<f64>>,
}

impl Mapping {
    /// A mapping with the clutch released.
    pub fn new(config: &MappingConfig) -> Self {
        Self {
            scale: config.position_scale,
            anchor: config.origin,
            clutch_button: config.clutch_button,
            held: None,
            last: None,
        }
    }

    /// Scene metres per device metre.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Rotation from device frame to scene frame.
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        self.anchor.rotation
    }

    /// The scene pose for device pose `device` (device frame) with `buttons` pressed.
    /// While the clutch is held the returned pose stays where it was; on release the
    /// anchor is moved so the pose continues from there without a jump.
    pub fn to_scene(&mut self, device: &Isometry3<f64>, buttons: u32) -> Isometry3<f64> {
        let clutched = self
            .clutch_button
            .is_some_and(|b| b < 32 && buttons & (1 << b) != 0);
        let direct = self.direct(device);
        let out = match (clutched, self.held) {
            (true, None) => {
                // Hold where the object was before the press, not where this tick's
                // (already moving) hand would put it.
                let held = self.last.unwrap_or(direct);
                self.held = Some(held);
                held
            }
            (true, Some(held)) => held,
            (false, Some(held)) => {
                // Re-anchor so that `direct(device) == held` now.
                let rot = held.rotation * device.rotation.inverse();
                let pos = held.translation.vector - rot * (device.translation.vector * self.scale);
                self.anchor = Isometry3::from_parts(Translation3::from(pos), rot);
                self.held = None;
                held
            }
            (false, None) => direct,
        };
        self.last = Some(out);
        out
    }

    /// The device pose that maps to scene pose `scene` with the current anchor: used to
    /// script a simulated user in scene terms.
    pub fn to_device(&self, scene: &Isometry3<f64>) -> Isometry3<f64> {
        let rot = self.anchor.rotation.inverse() * scene.rotation;
        let pos = self.anchor.rotation.inverse()
            * (scene.translation.vector - self.anchor.translation.vector)
            / self.scale;
        Isometry3::from_parts(Translation3::from(pos), rot)
    }

    /// A scene-frame vector (force, torque) expressed in the device frame.
    pub fn vector_to_device(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.anchor.rotation.inverse() * v
    }

    fn direct(&self, device: &Isometry3<f64>) -> Isometry3<f64> {
        let pos = self.anchor.translation.vector
            + self.anchor.rotation * (device.translation.vector * self.scale);
        Isometry3::from_parts(
            Translation3::from(pos),
            self.anchor.rotation * device.rotation,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn iso(x: f64, y: f64, z: f64, yaw: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(x, y, z),
            UnitQuaternion::from_euler_angles(0.0, 0.0, yaw),
        )
    }

    fn cfg() -> MappingConfig {
        MappingConfig {
            position_scale: 3.0,
            origin: iso(-0.2, 0.0, 0.1, std::f64::consts::FRAC_PI_2),
            clutch_button: Some(0),
        }
    }

    #[test]
    fn scales_rotates_and_round_trips() {
        let mut m = Mapping::new(&cfg());
        let dev = iso(0.01, 0.0, 0.0, 0.3);
        let scene = m.to_scene(&dev, 0);
        // +x on the device is +y in the scene (origin yawed 90°), times 3.
        assert!((scene.translation.vector - Vector3::new(-0.2, 0.03, 0.1)).norm() < 1e-12);
        let back = m.to_device(&scene);
        assert!((back.translation.vector - dev.translation.vector).norm() < 1e-12);
        assert!(back.rotation.angle_to(&dev.rotation) < 1e-12);
        let f = m.vector_to_device(&Vector3::new(0.0, 1.0, 0.0));
        assert!((f - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn clutch_holds_then_continues_without_jump() {
        let mut m = Mapping::new(&cfg());
        let before = m.to_scene(&iso(0.02, 0.0, 0.0, 0.0), 0);
        // Clutch in, hand moves back 5 cm and turns: the object stays.
        let held = m.to_scene(&iso(-0.03, 0.01, 0.0, 0.4), 1);
        assert_eq!(held, before);
        // Clutch out: no jump ...
        let after = m.to_scene(&iso(-0.03, 0.01, 0.0, 0.4), 0);
        assert!((after.translation.vector - before.translation.vector).norm() < 1e-12);
        assert!(after.rotation.angle_to(&before.rotation) < 1e-12);
        // ... and motion continues relative to the new hand position.
        let moved = m.to_scene(&iso(-0.02, 0.01, 0.0, 0.4), 0);
        let d = moved.translation.vector - after.translation.vector;
        assert!((d.norm() - 0.03).abs() < 1e-12, "1 cm × scale 3");
    }
}
