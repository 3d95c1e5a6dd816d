//! Rigid-body pose `Se3`: the configuration of the moving object and the placement of
//! primitives.
//!
//! This module is plain data plus exact group operations: metrics, sampling and collision
//! are the planner's.
//!
//! Conventions: positions in metres; rotations are unit quaternions (nalgebra order
//! `w, i, j, k` internally; files use roll–pitch–yaw, see [`Se3::from_rpy`]). A pose maps
//! points from its local (child) frame into its parent frame:
//! `p_parent = rot · p_local + pos`.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

/// A rigid-body pose in SE(3): translation `pos` (m) and orientation `rot`, both
/// expressed in the parent frame (the scene frame for configurations: right-handed,
/// Z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se3 {
    /// Position of the local origin in the parent frame (m).
    pub pos: Vector3<f64>,
    /// Orientation of the local frame relative to the parent frame.
    pub rot: UnitQuaternion<f64>,
}

impl Default for Se3 {
    fn default() -> Self {
        Self::identity()
    }
}

impl Se3 {
    /// The identity pose (origin, no rotation).
    pub fn identity() -> Self {
        Self {
            pos: Vector3::zeros(),
            rot: UnitQuaternion::identity(),
        }
    }

    /// A pose from its position (m) and orientation.
    pub fn new(pos: Vector3<f64>, rot: UnitQuaternion<f64>) -> Self {
        Self { pos, rot }
    }

    /// A pure translation to `(x, y, z)` (m).
    pub fn from_xyz(x: f64, y: f64, z: f64) -> Self {
        Self::new(Vector3::new(x, y, z), UnitQuaternion::identity())
    }

    /// A pose from position (m) and fixed-axis roll, pitch, yaw (rad): the rotation is
    /// `Rz(yaw) · Ry(pitch) · Rx(roll)` about the parent frame's axes.
    pub fn from_rpy(pos: Vector3<f64>, roll: f64, pitch: f64, yaw: f64) -> Self {
        Self::new(pos, UnitQuaternion::from_euler_angles(roll, pitch, yaw))
    }

    /// Composition `self · other`: `other` is expressed in `self`'s local frame.
    pub fn compose(&self, other: &Se3) -> Se3 {
        Se3 {
            pos: self.pos + self.rot * other.pos,
            rot: self.rot * other.rot,
        }
    }

    /// The inverse pose (parent expressed in the local frame).
    pub fn inverse(&self) -> Se3 {
        let rot = self.rot.inverse();
        Se3 {
            pos: -(rot * self.pos),
            rot,
        }
    }

    /// Maps a point given in the local frame into the parent frame (m).
    pub fn transform_point(&self, p_local: &Vector3<f64>) -> Vector3<f64> {
        self.rot * p_local + self.pos
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.pos.iter().all(|v| v.is_finite()) && self.rot.coords.iter().all(|v| v.is_finite())
    }

    /// The pose of an nalgebra isometry.
    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        Self::new(iso.translation.vector, iso.rotation)
    }

    /// The equivalent nalgebra isometry.
    pub fn to_isometry(&self) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::from(self.pos), self.rot)
    }
}

/// The rotation vector (axis · angle, rad) of `q`, with angle in [0, π] (shortest
/// rotation). Accurate for small angles, unlike `acos`-based formulas.
pub fn rotation_vector(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (mut w, mut v) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        v = -v;
    }
    let s = v.norm();
    if s < 1e-300 {
        return 2.0 * v;
    }
    let angle = 2.0 * s.atan2(w);
    v * (angle / s)
}

/// The rotation angle of `q` (rad), in [0, π].
pub fn rotation_angle(q: &UnitQuaternion<f64>) -> f64 {
    2.0 * q.imag().norm().atan2(q.w.abs())
}

/// The angle of the rotation `a⁻¹·b` (rad), in [0, π]; exactly 0 when `a == b`.
/// Uses `4·atan2(|a − b'|, |a + b'|)` on the quaternions (`b' = ±b` on `a`'s hemisphere),
/// accurate for small and large angles.
pub fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    let (a, b) = (a.as_ref().coords, b.as_ref().coords);
    let b = if a.dot(&b) < 0.0 { -b } else { b };
    4.0 * (a - b).norm().atan2((a + b).norm())
}

/// The unit quaternion whose rotation vector is `v` (axis · angle, rad).
pub fn exp_rotation(v: &Vector3<f64>) -> UnitQuaternion<f64> {
    let half = 0.5 * v.norm();
    if half < 1e-12 {
        // Second-order accurate near zero; renormalised.
        return UnitQuaternion::from_quaternion(Quaternion::new(
            1.0,
            0.5 * v.x,
            0.5 * v.y,
            0.5 * v.z,
        ));
    }
    let k = half.sin() / (2.0 * half);
    UnitQuaternion::new_unchecked(Quaternion::new(half.cos(), k * v.x, k * v.y, k * v.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn compose_with_inverse_is_identity() {
        let a = Se3::from_rpy(Vector3::new(0.1, -0.2, 0.3), 0.4, -0.5, 1.2);
        let i = a.compose(&a.inverse());
        assert!(i.pos.norm() < 1e-12);
        assert!(rotation_angle(&i.rot) < 1e-12);
    }

    #[test]
    fn transform_point_matches_isometry() {
        let a = Se3::from_rpy(Vector3::new(0.1, -0.2, 0.3), 0.4, -0.5, 1.2);
        let p = Vector3::new(0.01, 0.02, -0.03);
        let q = a.to_isometry().transform_point(&p.into());
        assert!((a.transform_point(&p) - q.coords).norm() < 1e-12);
    }

    #[test]
    fn rotation_vector_roundtrips_and_is_shortest() {
        for v in [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1e-9, 0.0, 0.0),
            Vector3::new(0.3, -0.2, 0.1),
            Vector3::new(0.0, 0.0, PI - 1e-6),
        ] {
            let q = exp_rotation(&v);
            assert!((rotation_vector(&q) - v).norm() < 1e-9, "{v:?}");
            assert!((rotation_angle(&q) - v.norm()).abs() < 1e-9);
            let a = UnitQuaternion::from_euler_angles(0.3, -1.0, 2.0);
            assert!((angle_between(&a, &(a * q)) - v.norm()).abs() < 1e-9);
            assert_eq!(angle_between(&a, &a), 0.0);
        }
        // A rotation of 1.5π about z is the shortest rotation of 0.5π about -z.
        let q = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 1.5 * PI);
        assert!((rotation_vector(&q) - Vector3::new(0.0, 0.0, -0.5 * PI)).norm() < 1e-9);
    }
}
