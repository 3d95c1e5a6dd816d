//! ROS time and the loop's clock. ROS 2 stamps (`header.stamp`, the attachment's source
//! timestamp) are the system clock, nanoseconds since the UNIX epoch; the loop's are
//! `CLOCK_MONOTONIC`. Conversions go through the two clocks read together now: a stamp
//! moves by the offset between them, so a step of the system clock (NTP) moves stamps
//! converted after it, never those already sent.

use crate::msgs::Time;

/// `CLOCK_REALTIME` now, ns since the UNIX epoch.
pub fn realtime_ns() -> i64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_REALTIME always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_REALTIME, &mut ts) };
    ts.tv_sec * 1_000_000_000 + ts.tv_nsec
}

/// The two clocks read together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Clocks {
    /// `CLOCK_MONOTONIC`, ns.
    pub monotonic_ns: u64,
    /// `CLOCK_REALTIME`, ns since the epoch.
    pub realtime_ns: i64,
}

impl Clocks {
    /// Both clocks now.
    pub fn now() -> Self {
        Clocks {
            monotonic_ns: ipc_types::monotonic_ns(),
            realtime_ns: realtime_ns(),
        }
    }

    /// The system time of a `CLOCK_MONOTONIC` stamp, ns since the epoch.
    pub fn to_realtime_ns(&self, monotonic_ns: u64) -> i64 {
        self.realtime_ns + (monotonic_ns as i64).wrapping_sub(self.monotonic_ns as i64)
    }

    /// The ROS time of a `CLOCK_MONOTONIC` stamp.
    pub fn to_ros(&self, monotonic_ns: u64) -> Time {
        Time::from_ns(self.to_realtime_ns(monotonic_ns))
    }

    /// The `CLOCK_MONOTONIC` stamp of a ROS time (negative: before the clock's zero).
    pub fn to_monotonic_ns(&self, t: Time) -> i64 {
        self.monotonic_ns as i64 + (t.as_ns() - self.realtime_ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_convert_both_ways() {
        let c = Clocks {
            monotonic_ns: 5_000_000_000,
            realtime_ns: 1_733_312_345_000_000_000,
        };
        let t = c.to_ros(5_250_000_001);
        assert_eq!(
            t,
            Time {
                sec: 1_733_312_345,
                nanosec: 250_000_001
            }
        );
        assert_eq!(c.to_monotonic_ns(t), 5_250_000_001);
        let now = Clocks::now();
        // The system clock is after 2020 and the two reads are consistent to a second.
        assert!(now.realtime_ns > 1_577_836_800_000_000_000);
        assert!(
            (now.to_realtime_ns(ipc_types::monotonic_ns()) - realtime_ns()).abs() < 1_000_000_000
        );
    }
}
