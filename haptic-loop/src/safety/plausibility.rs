//! The device plausibility monitor: each tick's device read becomes the reading the tick
//! may use and a fault code. Besides the faults the device reports itself (read error,
//! disconnection) it catches non-finite values, a stale timestamp, a jump farther than the
//! arm can move, and a streak of deadline misses; and keeps the last good reading, which
//! stands in (at rest) while reads fail.

use super::SafetyConfig;
use devices::{DeviceError, DeviceState};
use ipc_types::FaultCode;
use nalgebra::Isometry3;

/// Checks each device read against the previous reading and the loop's own timing; holds
/// what it needs of the previous ticks. Allocation-free.
#[derive(Debug, Clone)]
pub(crate) struct Plausibility {
    /// The arm's top speed, m/s.
    max_speed_m_per_s: f64,
    /// Consecutive ticks with a new deadline miss that latch `OVERRUN_STREAK` (0: never).
    max_miss_streak: u32,
    /// Nominal tick period, s: the shortest interval the jump limit allows for.
    period_s: f64,
    /// Device timestamp of the last reading, ns (0 before the first).
    last_timestamp_ns: u64,
    /// Pose of the last reading (device frame, m): the jump check's reference, and what
    /// stands in while reads fail.
    last_pose: Option<Isometry3<f64>>,
    /// Consecutive ticks whose previous tick missed its deadline.
    miss_streak: u32,
    /// Deadline misses since start, as of the last tick.
    last_misses: u64,
}

impl Plausibility {
    /// A monitor with the limits of `safety`, for ticks of `period_s` seconds.
    pub(crate) fn new(safety: &SafetyConfig, period_s: f64) -> Self {
        Self {
            max_speed_m_per_s: safety.max_device_speed_m_per_s,
            max_miss_streak: safety.max_miss_streak,
            period_s,
            last_timestamp_ns: 0,
            last_pose: None,
            miss_streak: 0,
            last_misses: 0,
        }
    }

    /// The reading of `read` if it is usable (`None` if the read failed or is not finite)
    /// and this tick's fault: the read's own, else a stale timestamp or a jump, else
    /// `OVERRUN_STREAK` when `deadline_misses` (since start) has grown in too many
    /// consecutive ticks.
    #[inline]
    pub(crate) fn check(
        &mut self,
        read: Result<DeviceState, DeviceError>,
        deadline_misses: u64,
    ) -> (Option<DeviceState>, FaultCode) {
        let mut fault = FaultCode::NONE;
        let reading = match read {
            Ok(s) if s.is_finite() => Some(s),
            Ok(_) => {
                fault = FaultCode::DEVICE_NON_FINITE;
                None
            }
            Err(DeviceError::Disconnected) => {
                fault = FaultCode::DEVICE_DISCONNECTED;
                None
            }
            Err(_) => {
                fault = FaultCode::DEVICE_READ;
                None
            }
        };
        if let Some(s) = &reading {
            if s.timestamp_ns <= self.last_timestamp_ns {
                fault = FaultCode::DEVICE_STALE;
            } else if let Some(last) = self.last_pose {
                // Farther than the arm can move between the two readings (plus 2 mm of
                // sensor noise): a glitch, not a motion.
                let dt_s = (s.timestamp_ns - self.last_timestamp_ns) as f64 * 1e-9;
                let limit = self.max_speed_m_per_s * dt_s.max(self.period_s) + 0.002;
                if (s.pose.translation.vector - last.translation.vector).norm() > limit {
                    fault = FaultCode::DEVICE_JUMP;
                }
            }
            self.last_timestamp_ns = s.timestamp_ns;
            self.last_pose = Some(s.pose);
        }
        // Deadline misses in consecutive ticks: the loop cannot keep its rhythm.
        if deadline_misses > self.last_misses {
            self.miss_streak += 1;
        } else {
            self.miss_streak = 0;
        }
        self.last_misses = deadline_misses;
        if fault == FaultCode::NONE
            && self.max_miss_streak > 0
            && self.miss_streak >= self.max_miss_streak
        {
            fault = FaultCode::OVERRUN_STREAK;
        }
        (reading, fault)
    }

    /// The last reading's pose at rest (the identity before any): the device as the tick
    /// takes it while reads fail (the force is zero then).
    #[inline]
    pub(crate) fn last_good(&self) -> DeviceState {
        DeviceState::at_rest(self.last_pose.unwrap_or_else(Isometry3::identity), 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    const MS: u64 = 1_000_000;

    fn at(x: f64, t_ns: u64) -> Result<DeviceState, DeviceError> {
        Ok(DeviceState::at_rest(
            Isometry3::translation(x, 0.0, 0.0),
            t_ns,
        ))
    }

    fn monitor() -> Plausibility {
        Plausibility::new(&SafetyConfig::default(), 0.001)
    }

    #[test]
    fn the_last_good_reading_stands_in_at_rest() {
        let mut m = monitor();
        assert_eq!(m.last_good().pose, Isometry3::identity());
        let mut moving = DeviceState::at_rest(Isometry3::translation(0.01, 0.02, 0.0), MS);
        moving.linear_velocity.x = 0.1;
        m.check(Ok(moving), 0);
        m.check(Err(DeviceError::ReadFailed), 0);
        let held = m.last_good();
        assert_eq!(held.pose, moving.pose);
        assert_eq!(held.linear_velocity, Vector3::zeros(), "at rest");
    }

    #[test]
    fn read_failures_give_their_fault_and_no_reading() {
        let mut m = monitor();
        let mut nan = DeviceState::at_rest(Isometry3::identity(), MS);
        nan.linear_velocity.x = f64::NAN;
        assert_eq!(m.check(Ok(nan), 0), (None, FaultCode::DEVICE_NON_FINITE));
        assert_eq!(
            m.check(Err(DeviceError::Disconnected), 0),
            (None, FaultCode::DEVICE_DISCONNECTED)
        );
        assert_eq!(
            m.check(Err(DeviceError::ReadFailed), 0),
            (None, FaultCode::DEVICE_READ)
        );
    }

    #[test]
    fn stale_timestamps_and_jumps_are_faults_but_the_reading_is_kept() {
        let mut m = monitor();
        assert_eq!(m.check(at(0.0, MS), 0).1, FaultCode::NONE);
        let (reading, fault) = m.check(at(0.0, MS), 0);
        assert_eq!(fault, FaultCode::DEVICE_STALE);
        assert!(reading.is_some());
        // 3 m/s for 1 ms plus 2 mm: 5 mm is the limit.
        assert_eq!(m.check(at(0.0049, 2 * MS), 0).1, FaultCode::NONE);
        assert_eq!(m.check(at(0.0101, 3 * MS), 0).1, FaultCode::DEVICE_JUMP);
    }

    #[test]
    fn only_consecutive_misses_make_a_streak() {
        let mut m = monitor();
        let limit = SafetyConfig::default().max_miss_streak;
        let mut misses = 0;
        for i in 1..=u64::from(limit) {
            misses += 1;
            let fault = m.check(at(0.0, i * MS), misses).1;
            let want = if i == u64::from(limit) {
                FaultCode::OVERRUN_STREAK
            } else {
                FaultCode::NONE
            };
            assert_eq!(fault, want, "tick {i}");
        }
        // A tick without a new miss ends the streak.
        let t = u64::from(limit) + 1;
        assert_eq!(m.check(at(0.0, t * MS), misses).1, FaultCode::NONE);
        assert_eq!(
            m.check(at(0.0, (t + 1) * MS), misses + 1).1,
            FaultCode::NONE
        );
    }
}
