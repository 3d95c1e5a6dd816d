//! The operator's hand on a haptic arm: a grip spring-damper whose setpoint moves with the
//! operator's intent.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use super::{DECISION_PERIOD_S, Intent, Operator, Perception};
use crate::sim::grip::Setpoint;
use crate::types::clamp_norm;
use crate::{DeviceError, Wrench};

/// A hand holding the end effector: `f = K·(p_s − p) + C·(v_s − v) + f_press` and
/// `τ = K_r·log(q_s ⊗ q⁻¹) + C_r·(ω_s − ω)`, clamped to `max_force_n` / `max_torque_nm`
/// (on a pressing step the spring gives along the press, which the press force replaces),
/// where the setpoint `(p_s, q_s)` moves with the operator's intended velocity `(v_s, ω_s)`.
/// The setpoint stays within the stretch at which the grip reaches its force and torque
/// limits of the end effector: a blocked hand pushes with bounded effort, it does not walk
/// on through the wall. The wrench returned is what the hand applies on the end effector
/// (the operator force f_u), base frame.
///
/// The mind decides every [`DECISION_PERIOD_S`] of the hand's clock, with the end
/// effector's pose and the device's wrench as perceived then; the grip is evaluated at every
/// call. Allocation-free after construction; deterministic.
#[derive(Debug, Clone)]
pub struct OperatorHand {
    operator: Operator,
    setpoint: Isometry3<f64>,
    intent: Intent,
    next_decision_s: f64,
    last_t_s: Option<f64>,
    last_wrench: Wrench,
}

impl OperatorHand {
    /// A hand driven by `operator`, its setpoint at the route's start.
    pub fn new(operator: Operator) -> Self {
        OperatorHand {
            setpoint: operator.start_pose(),
            intent: operator.intent(),
            operator,
            next_decision_s: 0.0,
            last_t_s: None,
            last_wrench: Wrench::ZERO,
        }
    }

    /// A hand for `route` with `config`; see [`Operator::new`].
    pub fn with_route(
        config: super::OperatorConfig,
        route: Vec<super::RouteStep>,
    ) -> Result<Self, DeviceError> {
        Ok(OperatorHand::new(Operator::new(config, route)?))
    }

    /// The mind.
    pub fn operator(&self) -> &Operator {
        &self.operator
    }

    /// The grip's setpoint (m, base frame), without the press.
    pub fn setpoint(&self) -> Isometry3<f64> {
        self.setpoint
    }

    /// The wrench last returned.
    pub fn last_wrench(&self) -> Wrench {
        self.last_wrench
    }

    /// The wrench the hand applies on the end effector at `t_s` (s since start, non-
    /// decreasing) given the end effector's pose (m, base frame), twist (m/s, rad/s) and the
    /// wrench the device applies on it (`felt`, N and N·m, base frame).
    pub fn hand_wrench(
        &mut self,
        t_s: f64,
        ee_pose: &Isometry3<f64>,
        ee_linear_velocity: &Vector3<f64>,
        ee_angular_velocity: &Vector3<f64>,
        felt: &Wrench,
    ) -> Wrench {
        let c = *self.operator.config();
        if t_s >= self.next_decision_s {
            self.intent = self.operator.decide(&Perception {
                t_s,
                pose: *ee_pose,
                felt: Some(*felt),
            });
            self.next_decision_s = (self.next_decision_s + DECISION_PERIOD_S).max(t_s);
        }
        let h = self.last_t_s.map_or(0.0, |t| (t_s - t).clamp(0.0, 0.01));
        self.last_t_s = Some(t_s);
        // Move the setpoint, then keep it within the grip's reach of the handle.
        let p = self.setpoint.translation.vector + self.intent.linear_velocity * h;
        let q = UnitQuaternion::from_scaled_axis(self.intent.angular_velocity * h)
            * self.setpoint.rotation;
        let reach = c.max_force_n / c.hand_stiffness_n_per_m;
        let mut off = clamp_norm(p - ee_pose.translation.vector, reach);
        // Pressing, the hand gives along the press what the surface takes: the grip holds
        // no height there, the press force does the pushing.
        if let Some(n) = self.intent.press_n.try_normalize(1e-9) {
            off -= n * off.dot(&n);
        }
        let p = ee_pose.translation.vector + off;
        let turn_reach = c.max_torque_nm / c.hand_rot_stiffness_nm_per_rad;
        let off = (q * ee_pose.rotation.inverse()).scaled_axis();
        let q = UnitQuaternion::from_scaled_axis(clamp_norm(off, turn_reach)) * ee_pose.rotation;
        self.setpoint = Isometry3::from_parts(p.into(), q);

        let setpoint = Setpoint {
            pose: self.setpoint,
            linear_velocity: self.intent.linear_velocity,
            angular_velocity: self.intent.angular_velocity,
        };
        self.last_wrench = c.grip().wrench(
            &setpoint,
            ee_pose,
            ee_linear_velocity,
            ee_angular_velocity,
            self.intent.press_n,
        );
        self.last_wrench
    }
}
