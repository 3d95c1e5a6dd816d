//! The reacting operator on a SpaceMouse: a simulated 6-D mouse whose puck deflections come
//! from the operator's intent, moving a rate-controlled avatar (the same
//! [`RateControl`] as the real device, so guidance and contact act on it the same way).

use nalgebra::Vector3;

use super::operator::{DECISION_PERIOD_S, Operator, Perception};
use crate::spacemouse::{RateControl, SpaceMouseConfig, apply_pseudo_force};
use crate::{DeviceError, DeviceSpec, DeviceState, HapticDevice, Wrench};

/// A SpaceMouse held by a simulated [`Operator`]. The operator sees the avatar's pose and
/// feels nothing (the device renders no force): it notices a block only by seeing no
/// progress. Each decision's intended velocity becomes the deflection `v / v_max` (clamped
/// to full scale); the wrench the loop writes moves the avatar through the rate control's
/// admittance, as with the real device.
///
/// Deterministic for a given operator, config and `now_ns` sequence; `read` and `write` do
/// not allocate.
#[derive(Debug)]
pub struct SimulatedSpaceMouse {
    config: SpaceMouseConfig,
    spec: DeviceSpec,
    operator: Operator,
    rate: RateControl,
    open: bool,
    last_now_ns: Option<u64>,
    /// The operator's clock, s.
    t_s: f64,
    next_decision_s: f64,
    deflection: (Vector3<f64>, Vector3<f64>),
}

impl SimulatedSpaceMouse {
    /// A simulated SpaceMouse with `config`, held by `operator`; the avatar starts at the
    /// operator's route start.
    pub fn new(config: SpaceMouseConfig, operator: Operator) -> Result<Self, DeviceError> {
        config.validate()?;
        let mut rate = RateControl::new(config.rate);
        rate.reset_to(operator.start_pose());
        Ok(SimulatedSpaceMouse {
            spec: config.spec_for("simulated SpaceMouse (operator model)", 2),
            config,
            operator,
            rate,
            open: false,
            last_now_ns: None,
            t_s: 0.0,
            next_decision_s: 0.0,
            deflection: (Vector3::zeros(), Vector3::zeros()),
        })
    }

    /// The operator.
    pub fn operator(&self) -> &Operator {
        &self.operator
    }

    /// The avatar.
    pub fn rate_control(&self) -> &RateControl {
        &self.rate
    }

    /// Translation and rotation deflections of the last decision, each in [−1, 1].
    pub fn deflection(&self) -> (Vector3<f64>, Vector3<f64>) {
        self.deflection
    }
}

impl HapticDevice for SimulatedSpaceMouse {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.open = true;
        self.last_now_ns = None;
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        if !self.open {
            return Err(DeviceError::NotOpen);
        }
        let dt_s = self
            .last_now_ns
            .map_or(0.0, |t| now_ns.saturating_sub(t) as f64 * 1e-9)
            .min(self.config.max_step_s);
        self.last_now_ns = Some(self.last_now_ns.map_or(now_ns, |p| p.max(now_ns)));
        self.t_s += dt_s;
        if self.t_s >= self.next_decision_s {
            let intent = self.operator.decide(&Perception {
                t_s: self.t_s,
                pose: *self.rate.pose(),
                felt: None,
            });
            let r = &self.config.rate;
            self.deflection = (
                intent.linear_velocity / r.max_speed_m_per_s,
                intent.angular_velocity / r.max_angular_speed_rad_per_s,
            );
            self.next_decision_s = (self.next_decision_s + DECISION_PERIOD_S).max(self.t_s);
        }
        let (t, r) = self.deflection;
        self.rate.step_deflections(&t, &r, dt_s);
        Ok(DeviceState {
            pose: *self.rate.pose(),
            linear_velocity: self.rate.linear_velocity(),
            angular_velocity: self.rate.angular_velocity(),
            buttons: 0,
            timestamp_ns: now_ns,
        })
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        if !self.open {
            return Err(DeviceError::NotOpen);
        }
        // As the real SpaceMouse: the wrench is the pseudo-force on the avatar.
        apply_pseudo_force(&mut self.rate, &self.config, wrench)
    }

    fn close(&mut self) {
        self.rate.halt();
        self.open = false;
    }
}
