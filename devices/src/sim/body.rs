//! A free rigid body integrated with semi-implicit (symplectic) Euler.
//!
//! Pure: no clock, no I/O; the caller passes the total wrench and the step. The reference
//! point is the end-effector point and is taken as the centre of mass, so a force there
//! produces no torque.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::Wrench;

/// Mass and diagonal body-frame inertia of the body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MassProperties {
    /// Mass in kg (> 0).
    pub mass_kg: f64,
    /// Principal moments of inertia about the reference point in kg·m², body frame (> 0).
    pub inertia_kg_m2: Vector3<f64>,
}

/// Pose and twist of the body, all in the device base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RigidBody {
    /// Pose of the body in the base frame (translation in m).
    pub pose: Isometry3<f64>,
    /// Linear velocity in m/s, base frame.
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity in rad/s, base frame.
    pub angular_velocity: Vector3<f64>,
}

impl RigidBody {
    /// A body at rest at `pose`.
    pub fn at_rest(pose: Isometry3<f64>) -> Self {
        RigidBody {
            pose,
            linear_velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
        }
    }

    /// Advances by `h` seconds under the total `wrench` (N, N·m about the reference point,
    /// base frame), held constant over the step.
    ///
    /// Semi-implicit Euler: velocities first (Newton, and Euler's equations with the
    /// gyroscopic term evaluated in the body frame), then the pose from the *new*
    /// velocities; the orientation is updated with the exponential map
    /// `q ← exp(ω·h) ⊗ q` (ω in the base frame, hence the left product) and renormalized.
    /// Allocation-free and deterministic.
    pub fn step(&mut self, mass: &MassProperties, wrench: &Wrench, h: f64) {
        // Translation.
        self.linear_velocity += wrench.force * (h / mass.mass_kg);
        self.pose.translation.vector += self.linear_velocity * h;

        // Rotation: I_b·ω̇_b = τ_b − ω_b × (I_b·ω_b) in the body frame.
        let rotation = self.pose.rotation;
        let omega_b = rotation.inverse_transform_vector(&self.angular_velocity);
        let torque_b = rotation.inverse_transform_vector(&wrench.torque);
        let momentum_b = mass.inertia_kg_m2.component_mul(&omega_b);
        let alpha_b = (torque_b - omega_b.cross(&momentum_b)).component_div(&mass.inertia_kg_m2);
        self.angular_velocity += rotation.transform_vector(&alpha_b) * h;

        let mut q = UnitQuaternion::from_scaled_axis(self.angular_velocity * h) * rotation;
        q.renormalize();
        self.pose.rotation = q;
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Translation3;

    use super::*;

    fn props() -> MassProperties {
        MassProperties {
            mass_kg: 0.5,
            inertia_kg_m2: Vector3::new(1e-3, 1e-3, 1e-3),
        }
    }

    #[test]
    fn no_wrench_no_motion() {
        let start = Isometry3::from_parts(
            Translation3::new(0.01, -0.02, 0.03),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.1, 0.2, 0.3)),
        );
        let mut body = RigidBody::at_rest(start);
        for _ in 0..1000 {
            body.step(&props(), &Wrench::ZERO, 1e-3);
        }
        assert_eq!(body.pose.translation, start.translation);
        assert!(body.pose.rotation.angle_to(&start.rotation) < 1e-12);
    }

    #[test]
    fn constant_force_follows_semi_implicit_euler() {
        let mut body = RigidBody::at_rest(Isometry3::identity());
        let w = Wrench::from_force(Vector3::new(1.0, 0.0, 0.0));
        let (h, n) = (1e-3, 100);
        for _ in 0..n {
            body.step(&props(), &w, h);
        }
        let a = 1.0 / 0.5;
        assert!((body.linear_velocity.x - a * h * n as f64).abs() < 1e-12);
        // x_n = a·h²·n(n+1)/2 for semi-implicit Euler from rest.
        let expected = a * h * h * (n * (n + 1)) as f64 / 2.0;
        assert!((body.pose.translation.x - expected).abs() < 1e-12);
    }

    #[test]
    fn constant_spin_about_fixed_axis_rotates_by_omega_t() {
        let mut body = RigidBody::at_rest(Isometry3::identity());
        body.angular_velocity = Vector3::new(0.0, 0.0, 2.0);
        for _ in 0..500 {
            body.step(&props(), &Wrench::ZERO, 1e-3);
        }
        let expected = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 1.0));
        assert!(body.pose.rotation.angle_to(&expected) < 1e-9);
        assert!((body.angular_velocity.z - 2.0).abs() < 1e-12);
        assert!((body.pose.rotation.coords.norm() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn torque_gives_angular_acceleration_in_base_frame() {
        // Rotated body, asymmetric inertia: torque about base z must still give
        // α = τ / I about the body axis that is aligned with base z.
        let rot =
            UnitQuaternion::from_scaled_axis(Vector3::new(std::f64::consts::FRAC_PI_2, 0.0, 0.0));
        let mut body = RigidBody::at_rest(Isometry3::from_parts(Translation3::identity(), rot));
        let mass = MassProperties {
            mass_kg: 0.5,
            inertia_kg_m2: Vector3::new(1e-3, 2e-3, 4e-3),
        };
        // A +90° rotation about x maps body y onto base z, so the moment is I_y = 2e-3.
        let w = Wrench::new(Vector3::zeros(), Vector3::new(0.0, 0.0, 0.01));
        body.step(&mass, &w, 1e-3);
        let alpha = body.angular_velocity / 1e-3;
        assert!((alpha - Vector3::new(0.0, 0.0, 5.0)).norm() < 1e-9);
    }
}
