//! The last stage before the device: NaN guard, saturation, force-rate limit, fault latch
//! and the ramp forces come back through. Allocation-free; runs in the RT tick.

use crate::guidance::clamp_norm;
use devices::Wrench;
use ipc_types::FaultCode;

/// Safety limits. Each bound is the smaller of this and the device's own specification.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyConfig {
    /// Cap on |force|, N; `f64::INFINITY` = the device's maximum.
    pub max_force_n: f64,
    /// Cap on |torque|, N·m; `f64::INFINITY` = the device's maximum.
    pub max_torque_nm: f64,
    /// Largest change of force per second, N/s (e.g. 2000 N/s = 2 N per 1 ms tick). Going to
    /// zero on a fault is not rate limited.
    pub max_force_rate_n_per_s: f64,
    /// Largest change of torque per second, N·m/s.
    pub max_torque_rate_nm_per_s: f64,
    /// Time over which forces ramp from zero to full after start or after a fault clears, s.
    pub ramp_s: f64,
    /// A fault clears after its cause has been absent this long, s.
    pub fault_clear_s: f64,
}

impl Default for SafetyConfig {
    fn default() -> Self {
        Self {
            max_force_n: f64::INFINITY,
            max_torque_nm: f64::INFINITY,
            max_force_rate_n_per_s: 2000.0,
            max_torque_rate_nm_per_s: 100.0,
            ramp_s: 0.5,
            fault_clear_s: 0.1,
        }
    }
}

/// Fault latch and output shaping.
#[derive(Debug, Clone)]
pub struct Safety {
    config: SafetyConfig,
    max_force_n: f64,
    max_torque_nm: f64,
    latched: FaultCode,
    clear_for_s: f64,
    ramp: f64,
    last: Wrench,
    faults_total: u64,
}

impl Safety {
    /// Limits are the smaller of `config` and the device's (`device_max_force_n`, N;
    /// `device_max_torque_nm`, N·m). Starts ramping in from zero.
    pub fn new(config: SafetyConfig, device_max_force_n: f64, device_max_torque_nm: f64) -> Self {
        Self {
            config,
            max_force_n: config.max_force_n.min(device_max_force_n).max(0.0),
            max_torque_nm: config.max_torque_nm.min(device_max_torque_nm).max(0.0),
            latched: FaultCode::NONE,
            clear_for_s: 0.0,
            ramp: 0.0,
            last: Wrench::ZERO,
            faults_total: 0,
        }
    }

    /// The fault currently latched, `NONE` if forces are on.
    pub fn fault(&self) -> FaultCode {
        self.latched
    }

    /// How many times a fault was latched since start.
    pub fn faults_total(&self) -> u64 {
        self.faults_total
    }

    /// Ramp factor in [0, 1]: 1 = full force.
    pub fn ramp(&self) -> f64 {
        self.ramp
    }

    /// Shapes `wanted` (device frame) for one tick of `dt_s` seconds. `cause` is a fault
    /// detected this tick (`NONE` if none). Returns the wrench to write and the fault to
    /// report. A fault gives zero force in this very tick.
    pub fn apply(&mut self, wanted: &Wrench, cause: FaultCode, dt_s: f64) -> (Wrench, FaultCode) {
        let cause = if cause == FaultCode::NONE && !wanted.is_finite() {
            FaultCode::NON_FINITE_WRENCH
        } else {
            cause
        };
        if cause != FaultCode::NONE {
            if self.latched == FaultCode::NONE {
                self.faults_total += 1;
            }
            self.latched = cause;
            self.clear_for_s = 0.0;
            self.ramp = 0.0;
            self.last = Wrench::ZERO;
            return (Wrench::ZERO, cause);
        }
        if self.latched != FaultCode::NONE {
            self.clear_for_s += dt_s;
            if self.clear_for_s < self.config.fault_clear_s {
                return (Wrench::ZERO, self.latched);
            }
            self.latched = FaultCode::NONE;
        }
        self.ramp = if self.config.ramp_s > 0.0 {
            (self.ramp + dt_s / self.config.ramp_s).min(1.0)
        } else {
            1.0
        };
        let force = clamp_norm(wanted.force, self.max_force_n) * self.ramp;
        let torque = clamp_norm(wanted.torque, self.max_torque_nm) * self.ramp;
        let max_df = self.config.max_force_rate_n_per_s * dt_s;
        let max_dt = self.config.max_torque_rate_nm_per_s * dt_s;
        let out = Wrench {
            force: self.last.force + clamp_norm(force - self.last.force, max_df),
            torque: self.last.torque + clamp_norm(torque - self.last.torque, max_dt),
        };
        self.last = out;
        (out, FaultCode::NONE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    const DT: f64 = 0.001;

    fn full(s: &mut Safety, w: &Wrench) -> Wrench {
        let mut out = Wrench::ZERO;
        for _ in 0..2000 {
            out = s.apply(w, FaultCode::NONE, DT).0;
        }
        out
    }

    fn push(x: f64) -> Wrench {
        Wrench {
            force: Vector3::new(x, 0.0, 0.0),
            torque: Vector3::new(0.0, 0.0, x / 10.0),
        }
    }

    #[test]
    fn saturates_to_the_smaller_of_config_and_device() {
        let cfg = SafetyConfig {
            max_force_n: 5.0,
            ..SafetyConfig::default()
        };
        let mut s = Safety::new(cfg, 8.0, 0.5);
        let out = full(&mut s, &push(100.0));
        assert!((out.force.norm() - 5.0).abs() < 1e-9);
        assert!((out.torque.norm() - 0.5).abs() < 1e-9);
    }

    #[test]
    fn ramps_in_at_start_and_limits_rate() {
        let mut s = Safety::new(SafetyConfig::default(), 8.0, 0.5);
        let first = s.apply(&push(4.0), FaultCode::NONE, DT).0;
        assert!(
            first.force.norm() <= 2000.0 * DT + 1e-12,
            "rate limit: 2 N per tick"
        );
        assert!(
            first.force.norm() <= 4.0 * DT / 0.5 + 1e-12,
            "ramp: 1/500 of full"
        );
        let out = full(&mut s, &push(4.0));
        assert!((out.force.x - 4.0).abs() < 1e-9);
    }

    #[test]
    fn nan_latches_zero_in_the_same_tick_and_recovers_through_a_ramp() {
        let mut s = Safety::new(SafetyConfig::default(), 8.0, 0.5);
        full(&mut s, &push(4.0));
        let nan = Wrench {
            force: Vector3::new(f64::NAN, 0.0, 0.0),
            torque: Vector3::zeros(),
        };
        let (out, fault) = s.apply(&nan, FaultCode::NONE, DT);
        assert_eq!(fault, FaultCode::NON_FINITE_WRENCH);
        assert_eq!(out.force.norm(), 0.0);
        // Held off while the clear time runs, then ramps: never a step back to 4 N.
        let mut prev = 0.0;
        let mut max_step: f64 = 0.0;
        for i in 0..1000 {
            let (out, fault) = s.apply(&push(4.0), FaultCode::NONE, DT);
            if i < 99 {
                assert_eq!(fault, FaultCode::NON_FINITE_WRENCH);
                assert_eq!(out.force.norm(), 0.0);
            }
            max_step = max_step.max((out.force.x - prev).abs());
            prev = out.force.x;
        }
        assert_eq!(s.fault(), FaultCode::NONE);
        assert!((prev - 4.0).abs() < 1e-9, "recovered to full force");
        assert!(
            max_step <= 4.0 * DT / 0.5 + 1e-9,
            "recovery is a ramp, not a step"
        );
        assert_eq!(s.faults_total(), 1);
    }

    #[test]
    fn external_fault_zeroes_output() {
        let mut s = Safety::new(SafetyConfig::default(), 8.0, 0.5);
        full(&mut s, &push(4.0));
        let (out, fault) = s.apply(&push(4.0), FaultCode::DEVICE_READ, DT);
        assert_eq!(fault, FaultCode::DEVICE_READ);
        assert_eq!(out.force.norm() + out.torque.norm(), 0.0);
    }
}
