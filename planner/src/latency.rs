//! Latency histograms of the process shell (HDR, nanosecond values, 3 significant digits),
//! summarised in µs for the JSON report.

use hdrhistogram::Histogram;
use serde::Serialize;

/// Percentiles of a latency, µs (all zero when nothing was recorded).
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq)]
pub struct LatencyUs {
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// 99.9th percentile.
    pub p999: f64,
    /// Largest value.
    pub max: f64,
    /// Values recorded.
    pub count: u64,
}

/// Latencies from 1 ns to 100 s.
#[derive(Debug, Clone)]
pub struct LatencyHistogram(Histogram<u64>);

impl Default for LatencyHistogram {
    fn default() -> Self {
        // Constant bounds: cannot fail.
        Self(Histogram::new_with_bounds(1, 100_000_000_000, 3).expect("valid histogram bounds"))
    }
}

impl LatencyHistogram {
    /// Records `ns`, clamped into the range (a value is never lost).
    pub fn record(&mut self, ns: u64) {
        self.0.saturating_record(ns.max(1));
    }

    /// The percentiles in µs.
    pub fn summary(&self) -> LatencyUs {
        let h = &self.0;
        if h.is_empty() {
            return LatencyUs::default();
        }
        let us = |q: f64| h.value_at_quantile(q) as f64 / 1000.0;
        LatencyUs {
            p50: us(0.5),
            p90: us(0.9),
            p99: us(0.99),
            p999: us(0.999),
            max: h.max() as f64 / 1000.0,
            count: h.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_what_was_recorded_in_microseconds() {
        let mut h = LatencyHistogram::default();
        assert_eq!(h.summary(), LatencyUs::default());
        for i in 1..=100u64 {
            h.record(i * 1000);
        }
        h.record(0);
        let s = h.summary();
        assert_eq!(s.count, 101);
        assert!((s.p50 - 50.0).abs() < 0.1, "{s:?}");
        assert!((s.max - 100.0).abs() < 0.1, "{s:?}");
    }
}
