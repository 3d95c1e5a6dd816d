//! Timing statistics of the RT thread, kept off the RT thread.
//!
//! The RT thread pushes one [`TickSample`] per tick into a preallocated lock-free SPSC ring
//! (`rtrb`); the stats thread drains it into HDR histograms (`hdrhistogram`), keeps a
//! one-second window for progress lines, and hands the totals to the final report.

use crate::work::TickWork;
use serde::Serialize;

/// Timing of one tick, as pushed by the RT thread.
#[derive(Debug, Clone, Copy, Default)]
pub struct TickSample {
    /// Tick number from 1.
    pub tick: u64,
    /// Actual wake-up minus deadline, ns.
    pub wake_latency_ns: u64,
    /// Wake-up to end of the tick's work, ns.
    pub compute_ns: u64,
    /// CPU time the RT thread used from its wake-up to the end of the tick's work, ns: not
    /// the time other threads had the CPU.
    pub compute_cpu_ns: u64,
    /// Wake-up minus previous wake-up, ns (0 for the first tick).
    pub period_ns: u64,
    /// Age of the guidance sample rendered, ns (0 if none).
    pub guidance_age_ns: u64,
    /// Publish → render latency, ns: the guidance age when this tick is the first to render
    /// a new sample (0 otherwise).
    pub guidance_latency_ns: u64,
    /// Deadlines missed at the end of this tick (0 almost always).
    pub missed: u64,
    /// What the tick did.
    pub work: TickWork,
}

/// The tick that used the most CPU time, and what it did: whether a slow tick was the
/// loop's work (large counts) or the machine's (ordinary counts).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct SlowestTick {
    /// Tick number from 1.
    pub tick: u64,
    /// Its CPU time, µs.
    pub compute_cpu_us: f64,
    /// Its wall-clock compute time, µs.
    pub compute_us: f64,
    /// Its work counts.
    pub work: TickWork,
}

pub use ipc_types::latency::{NsHistogram, Percentiles};

/// The histograms of one run or one window.
#[derive(Debug, Clone, Default)]
pub struct TimingHistograms {
    /// Wake-up latency.
    pub wake: NsHistogram,
    /// Compute time.
    pub compute: NsHistogram,
    /// Compute time by the thread's CPU clock.
    pub compute_cpu: NsHistogram,
    /// Period.
    pub period: NsHistogram,
    /// Guidance age at render time.
    pub guidance_age: NsHistogram,
    /// Guidance publish → first tick rendering it.
    pub guidance_latency: NsHistogram,
    /// Ticks recorded.
    pub ticks: u64,
    /// Deadlines missed.
    pub deadline_misses: u64,
    /// The tick with the most CPU time.
    pub slowest: SlowestTick,
}

impl TimingHistograms {
    /// Records one tick.
    pub fn record(&mut self, s: &TickSample) {
        self.wake.record(s.wake_latency_ns);
        self.compute.record(s.compute_ns);
        self.compute_cpu.record(s.compute_cpu_ns);
        let cpu_us = s.compute_cpu_ns as f64 / 1000.0;
        if self.ticks == 0 || cpu_us > self.slowest.compute_cpu_us {
            self.slowest = SlowestTick {
                tick: s.tick,
                compute_cpu_us: cpu_us,
                compute_us: s.compute_ns as f64 / 1000.0,
                work: s.work,
            };
        }
        if s.period_ns > 0 {
            self.period.record(s.period_ns);
        }
        if s.guidance_age_ns > 0 {
            self.guidance_age.record(s.guidance_age_ns);
        }
        if s.guidance_latency_ns > 0 {
            self.guidance_latency.record(s.guidance_latency_ns);
        }
        self.ticks += 1;
        self.deadline_misses += s.missed;
    }

    /// Forgets everything.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// One second of the loop, for progress lines.
#[derive(Debug, Clone, Copy, Default)]
pub struct SecondSummary {
    /// Seconds since the loop started.
    pub elapsed_s: f64,
    /// Ticks in this window.
    pub ticks: u64,
    /// Wake-up latency p99 in this window, µs.
    pub wake_p99_us: f64,
    /// Wake-up latency max in this window, µs.
    pub wake_max_us: f64,
    /// Compute time p99 in this window, µs.
    pub compute_p99_us: f64,
    /// Compute time max by the thread's CPU clock in this window, µs.
    pub compute_cpu_max_us: f64,
    /// Deadline misses since start.
    pub deadline_misses_total: u64,
    /// Of them, overruns (the tick's own CPU time passed the period) since start.
    pub overruns_total: u64,
    /// Samples the stats thread could not take in time (ring full) since start.
    pub dropped_samples_total: u64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_are_in_microseconds_and_ordered() {
        let mut h = NsHistogram::new();
        for i in 1..=1000u64 {
            h.record(i * 1000);
        }
        let p = h.percentiles_us();
        assert!((p.p50 - 500.0).abs() < 1.0);
        assert!((p.p99 - 990.0).abs() < 1.0);
        assert!((p.max - 1000.0).abs() < 1.0);
        assert!(p.p50 <= p.p90 && p.p90 <= p.p99 && p.p99 <= p.p999 && p.p999 <= p.max);
        assert_eq!(p.count, 1000);
    }

    #[test]
    fn guidance_latency_counts_only_new_samples() {
        let mut h = TimingHistograms::default();
        for i in 0..10u64 {
            h.record(&TickSample {
                guidance_age_ns: 1000 + i,
                guidance_latency_ns: if i % 5 == 0 { 1000 + i } else { 0 },
                ..TickSample::default()
            });
        }
        assert_eq!(h.guidance_age.percentiles_us().count, 10);
        assert_eq!(h.guidance_latency.percentiles_us().count, 2);
    }

    #[test]
    fn cpu_time_is_kept_beside_the_wall_clock_with_the_slowest_tick() {
        let mut h = TimingHistograms::default();
        let tick = |cpu_us: u64, missed: u64| TickSample {
            compute_ns: 1_500_000,
            compute_cpu_ns: cpu_us * 1000,
            missed,
            ..TickSample::default()
        };
        h.record(&tick(20, 0));
        h.record(&tick(30, 1));
        h.record(&tick(1200, 2));
        assert_eq!(h.deadline_misses, 3);
        assert_eq!(h.slowest.compute_cpu_us, 1200.0);
        let cpu = h.compute_cpu.percentiles_us();
        assert_eq!(cpu.count, 3);
        assert!((cpu.max - 1200.0).abs() < 1.0, "{cpu:?}");
    }

    #[test]
    fn out_of_range_values_are_clamped_not_lost() {
        let mut h = NsHistogram::new();
        h.record(0);
        h.record(u64::MAX);
        assert_eq!(h.percentiles_us().count, 2);
    }
}
