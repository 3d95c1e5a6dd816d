//! Sensor quantization of the simulated arm: what `read` reports, not what the physics
//! integrates.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// `value` rounded to the nearest multiple of `resolution`; unchanged when `resolution` is
/// not positive.
pub(crate) fn quantize(value: f64, resolution: f64) -> f64 {
    if resolution > 0.0 {
        (value / resolution).round() * resolution
    } else {
        value
    }
}

/// Each component of `v` quantized to `resolution`.
fn quantize_vector(v: &Vector3<f64>, resolution: f64) -> Vector3<f64> {
    v.map(|c| quantize(c, resolution))
}

/// The pose an encoder-based sensor would report: each translation component a multiple
/// of `position_resolution_m` (m), and the orientation rebuilt from its rotation vector
/// (axis·angle, base frame, angle in [0, π]) with each component a multiple of
/// `angle_resolution_rad` (rad). Allocation-free.
pub(crate) fn quantize_pose(
    pose: &Isometry3<f64>,
    position_resolution_m: f64,
    angle_resolution_rad: f64,
) -> Isometry3<f64> {
    let translation = quantize_vector(&pose.translation.vector, position_resolution_m);
    let rotation = if angle_resolution_rad > 0.0 {
        let rotation_vector = quantize_vector(&pose.rotation.scaled_axis(), angle_resolution_rad);
        UnitQuaternion::from_scaled_axis(rotation_vector)
    } else {
        pose.rotation
    };
    Isometry3::from_parts(Translation3::from(translation), rotation)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// True when `value` is within a rounding error of a multiple of `resolution`.
    fn is_multiple(value: f64, resolution: f64) -> bool {
        let ratio = value / resolution;
        (ratio - ratio.round()).abs() < 1e-6
    }

    #[test]
    fn scalar_rounds_to_nearest_multiple() {
        assert!((quantize(0.123_456, 1e-3) - 0.123).abs() < 1e-15);
        assert!((quantize(-0.000_6, 1e-3) + 0.001).abs() < 1e-15);
        assert_eq!(quantize(0.123_456, 0.0), 0.123_456);
    }

    #[test]
    fn pose_components_are_multiples_and_error_is_bounded() {
        let pose = Isometry3::from_parts(
            Translation3::new(0.012_345_6, -0.098_765_4, 0.000_004_9),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.123_45, -0.5432, 1.0001)),
        );
        let (pos_res, ang_res) = (1e-5, 1e-3);
        let q = quantize_pose(&pose, pos_res, ang_res);
        for c in q.translation.vector.iter() {
            assert!(is_multiple(*c, pos_res), "{c}");
        }
        for c in q.rotation.scaled_axis().iter() {
            assert!(is_multiple(*c, ang_res), "{c}");
        }
        assert!((q.translation.vector - pose.translation.vector).amax() <= pos_res / 2.0 + 1e-15);
        // Half a step on each of three components at most.
        assert!(q.rotation.angle_to(&pose.rotation) <= 3f64.sqrt() * ang_res / 2.0 + 1e-12);
    }

    #[test]
    fn zero_resolution_is_identity() {
        let pose = Isometry3::from_parts(
            Translation3::new(0.1, 0.2, 0.3),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.1, 0.2, 0.3)),
        );
        assert_eq!(quantize_pose(&pose, 0.0, 0.0), pose);
    }
}
