//! Conversions between nalgebra values and the wire types of `ipc-types`
//! (quaternions on the wire are `[x, y, z, w]`, nalgebra's storage order). The one place
//! both processes convert.

use crate::{Pose, Twist, Wrench};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

/// Wire pose of `iso`.
#[inline]
pub fn pose(iso: &Isometry3<f64>) -> Pose {
    let q = iso.rotation.coords;
    Pose {
        position_m: iso.translation.vector.into(),
        orientation_xyzw: [q.x, q.y, q.z, q.w],
    }
}

/// The isometry of a wire pose, or `None` if it is not finite or not a unit quaternion
/// (within 1e-6); a valid quaternion is renormalised.
#[inline]
pub fn isometry(p: &Pose) -> Option<Isometry3<f64>> {
    if !p.is_valid() {
        return None;
    }
    let [x, y, z, w] = p.orientation_xyzw;
    let rot = UnitQuaternion::new_normalize(Quaternion::new(w, x, y, z));
    let [px, py, pz] = p.position_m;
    Some(Isometry3::from_parts(Translation3::new(px, py, pz), rot))
}

/// Wire twist from linear (m/s) and angular (rad/s) velocity.
#[inline]
pub fn twist(linear: &Vector3<f64>, angular: &Vector3<f64>) -> Twist {
    Twist {
        linear_m_s: (*linear).into(),
        angular_rad_s: (*angular).into(),
    }
}

/// Wire wrench from force (N) and torque (N·m).
#[inline]
pub fn wrench(force: &Vector3<f64>, torque: &Vector3<f64>) -> Wrench {
    Wrench {
        force_n: (*force).into(),
        torque_nm: (*torque).into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_round_trip_and_order() {
        let iso = Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.3),
            UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
        );
        let p = pose(&iso);
        assert!(
            (p.orientation_xyzw[3] - iso.rotation.w).abs() < 1e-15,
            "w last"
        );
        let back = isometry(&p).unwrap();
        assert!((back.translation.vector - iso.translation.vector).norm() < 1e-15);
        assert!(back.rotation.angle_to(&iso.rotation) < 1e-12);
        let mut bad = p;
        bad.orientation_xyzw = [0.0; 4];
        assert!(isometry(&bad).is_none());
    }
}
