//! Timing histograms (HDR, nanosecond values from 1 ns to 100 s, 3 significant digits),
//! summarised in µs for JSON reports: the planner's state latency and the haptic loop's
//! timing. Here so that both processes share one implementation without depending on
//! each other.

use hdrhistogram::Histogram;
use serde::{Deserialize, Serialize};

/// Percentiles of one quantity, µs.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 99th percentile.
    pub p99: f64,
    /// 99.9th percentile.
    pub p999: f64,
    /// Largest value seen.
    pub max: f64,
    /// Number of values.
    pub count: u64,
}

/// Histogram of nanosecond values from 1 ns to 100 s with 3 significant digits.
#[derive(Debug, Clone)]
pub struct NsHistogram(Histogram<u64>);

impl Default for NsHistogram {
    fn default() -> Self {
        Self::new()
    }
}

impl NsHistogram {
    /// An empty histogram.
    pub fn new() -> Self {
        // Bounds are constants: this cannot fail.
        Self(Histogram::new_with_bounds(1, 100_000_000_000, 3).expect("valid histogram bounds"))
    }

    /// Records `ns`, clamped into the histogram's range.
    pub fn record(&mut self, ns: u64) {
        self.0.saturating_record(ns.max(1));
    }

    /// Forgets all values.
    pub fn reset(&mut self) {
        self.0.reset();
    }

    /// Adds all values of `other`.
    pub fn add(&mut self, other: &Self) {
        // Same bounds by construction: cannot fail.
        let _ = self.0.add(&other.0);
    }

    /// The recorded distribution as (value µs, count) pairs in increasing value, one per
    /// histogram bucket that holds values: for plots.
    pub fn distribution_us(&self) -> Vec<(f64, u64)> {
        self.0
            .iter_recorded()
            .map(|v| (v.value_iterated_to() as f64 / 1000.0, v.count_at_value()))
            .collect()
    }

    /// Percentiles in µs.
    pub fn percentiles_us(&self) -> Percentiles {
        let h = &self.0;
        if h.is_empty() {
            return Percentiles::default();
        }
        let us = |ns: u64| ns as f64 / 1000.0;
        Percentiles {
            p50: us(h.value_at_quantile(0.5)),
            p90: us(h.value_at_quantile(0.9)),
            p99: us(h.value_at_quantile(0.99)),
            p999: us(h.value_at_quantile(0.999)),
            max: us(h.max()),
            count: h.len(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_what_was_recorded_in_microseconds() {
        let mut h = NsHistogram::new();
        assert_eq!(h.percentiles_us(), Percentiles::default());
        for i in 1..=100u64 {
            h.record(i * 1000);
        }
        h.record(0);
        let s = h.percentiles_us();
        assert_eq!(s.count, 101);
        assert!((s.p50 - 50.0).abs() < 0.1, "{s:?}");
        assert!((s.max - 100.0).abs() < 0.1, "{s:?}");
    }
}
