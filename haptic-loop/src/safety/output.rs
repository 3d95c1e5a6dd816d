//! The last stage before the device: NaN guard, saturation, force-rate limit, fault latch
//! and the ramp forces come back through. Allocation-free; runs in the RT tick.
//!
//! State machine: forces start latched off (`STARTUP`). Any fault cause latches zero force
//! in the tick it is seen. A latched fault clears only after its cause has been absent
//! *and* the device has been still ([`SafetyConfig::is_still`]) for `fault_clear_s`; forces then ramp in
//! over `ramp_s`, rate limited. So nothing jumps at start, and a hand that is moving when a
//! fault ends is not suddenly pushed.

use super::SafetyConfig;
use devices::{Wrench, clamp_norm};
use ipc_types::FaultCode;

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
    /// `device_max_torque_nm`, N·m). Starts latched in `STARTUP`: forces come on once the
    /// device has been still for `fault_clear_s`, through the ramp.
    pub fn new(config: SafetyConfig, device_max_force_n: f64, device_max_torque_nm: f64) -> Self {
        Self {
            config,
            max_force_n: config.max_force_n.min(device_max_force_n).max(0.0),
            max_torque_nm: config.max_torque_nm.min(device_max_torque_nm).max(0.0),
            latched: FaultCode::STARTUP,
            clear_for_s: 0.0,
            ramp: 0.0,
            last: Wrench::ZERO,
            faults_total: 0,
        }
    }

    /// The limits and thresholds in use.
    pub fn config(&self) -> &SafetyConfig {
        &self.config
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
    /// detected this tick (`NONE` if none); `still` says whether the device is at rest.
    /// Returns the wrench to write and the fault to report. A fault gives zero force in this
    /// very tick.
    pub fn apply(
        &mut self,
        wanted: &Wrench,
        cause: FaultCode,
        still: bool,
        dt_s: f64,
    ) -> (Wrench, FaultCode) {
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
            self.clear_for_s = if still { self.clear_for_s + dt_s } else { 0.0 };
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

    /// Runs 2 s with the device still: past start-up, the ramp and the rate limit.
    fn full(s: &mut Safety, w: &Wrench) -> Wrench {
        let mut out = Wrench::ZERO;
        for _ in 0..2000 {
            out = s.apply(w, FaultCode::NONE, true, DT).0;
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
    fn starts_off_until_still_then_ramps_in_and_limits_rate() {
        let mut s = Safety::new(SafetyConfig::default(), 8.0, 0.5);
        // Moving: held off however long.
        for _ in 0..500 {
            let (out, fault) = s.apply(&push(4.0), FaultCode::NONE, false, DT);
            assert_eq!(fault, FaultCode::STARTUP);
            assert_eq!(out.force.norm(), 0.0);
        }
        // Still for 0.1 s: still off, then on.
        for _ in 0..99 {
            assert_eq!(
                s.apply(&push(4.0), FaultCode::NONE, true, DT).1,
                FaultCode::STARTUP
            );
        }
        assert_eq!(s.faults_total(), 0, "start-up is not a fault");
        let first = s.apply(&push(4.0), FaultCode::NONE, true, DT).0;
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
        let (out, fault) = s.apply(&nan, FaultCode::NONE, true, DT);
        assert_eq!(fault, FaultCode::NON_FINITE_WRENCH);
        assert_eq!(out.force.norm(), 0.0);
        // Held off while the clear time runs, then ramps: never a step back to 4 N.
        let mut prev = 0.0;
        let mut max_step: f64 = 0.0;
        for i in 0..1000 {
            let (out, fault) = s.apply(&push(4.0), FaultCode::NONE, true, DT);
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
    fn a_fault_clears_only_while_the_device_is_still() {
        let mut s = Safety::new(SafetyConfig::default(), 8.0, 0.5);
        full(&mut s, &push(4.0));
        s.apply(&push(4.0), FaultCode::DEVICE_STALE, true, DT);
        // Cause gone but the hand moves: stays latched.
        for _ in 0..1000 {
            let (out, fault) = s.apply(&push(4.0), FaultCode::NONE, false, DT);
            assert_eq!(fault, FaultCode::DEVICE_STALE);
            assert_eq!(out.force.norm(), 0.0);
        }
        // Still: clears after 0.1 s and ramps.
        for _ in 0..100 {
            s.apply(&push(4.0), FaultCode::NONE, true, DT);
        }
        assert_eq!(s.fault(), FaultCode::NONE);
    }

    #[test]
    fn external_fault_zeroes_output() {
        let mut s = Safety::new(SafetyConfig::default(), 8.0, 0.5);
        full(&mut s, &push(4.0));
        let (out, fault) = s.apply(&push(4.0), FaultCode::DEVICE_READ, true, DT);
        assert_eq!(fault, FaultCode::DEVICE_READ);
        assert_eq!(out.force.norm() + out.torque.norm(), 0.0);
    }
}
