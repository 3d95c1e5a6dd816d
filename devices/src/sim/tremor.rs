//! Band-limited hand tremor: seeded Gaussian white noise through a two-pole low-pass.
//!
//! The noise is sampled on its own fixed 1 kHz grid of simulated time, so a run depends
//! only on the seed and the times it is queried at, not on how the caller sub-steps.

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Period of the tremor's noise samples in s.
const SAMPLE_PERIOD_S: f64 = 1e-3;

/// A 3-axis tremor offset generator (translation only).
///
/// Per axis: `x ← a·x + √(1−a²)·w` (unit-variance AR(1), `w ~ N(0, 1)`), then
/// `y ← a·y + (1−a)·x`, with `a = exp(−2π·f_c·T)`. The stationary variance of `y` is
/// `(1+a²)/(1+a)²`, divided out so that the offset's RMS per axis is `amplitude_m`. Both
/// stages start at zero, so the tremor fades in over about `1/(π·f_c)` s.
#[derive(Debug, Clone)]
pub(crate) struct Tremor {
    rng: ChaCha8Rng,
    amplitude_m: f64,
    pole: f64,
    input_gain: f64,
    output_gain: f64,
    stage1: Vector3<f64>,
    stage2: Vector3<f64>,
    /// Samples drawn so far; sample `k` is taken at `k·SAMPLE_PERIOD_S`.
    samples: u64,
}

impl Tremor {
    /// A generator of RMS `amplitude_m` (m per axis; 0 disables it and draws nothing),
    /// low-pass corner `cutoff_hz` (Hz, 0 < f_c < 500) and RNG `seed`.
    pub fn new(amplitude_m: f64, cutoff_hz: f64, seed: u64) -> Self {
        let pole = (-2.0 * std::f64::consts::PI * cutoff_hz * SAMPLE_PERIOD_S).exp();
        Tremor {
            rng: ChaCha8Rng::seed_from_u64(seed),
            amplitude_m,
            pole,
            input_gain: (1.0 - pole * pole).sqrt(),
            output_gain: (1.0 + pole) / (1.0 + pole * pole).sqrt(),
            stage1: Vector3::zeros(),
            stage2: Vector3::zeros(),
            samples: 0,
        }
    }

    /// The tremor offset in m (base frame) at simulated time `t_s`: the filter is advanced
    /// through every sample time `≤ t_s`. Time never goes back: an earlier `t_s` returns
    /// the current offset. Allocation-free; the work is proportional to the time advanced.
    pub fn offset_at(&mut self, t_s: f64) -> Vector3<f64> {
        if self.amplitude_m <= 0.0 {
            return Vector3::zeros();
        }
        while (self.samples as f64) * SAMPLE_PERIOD_S <= t_s {
            let white = Vector3::new(
                StandardNormal.sample(&mut self.rng),
                StandardNormal.sample(&mut self.rng),
                StandardNormal.sample(&mut self.rng),
            );
            self.stage1 = self.stage1 * self.pole + white * self.input_gain;
            self.stage2 = self.stage2 * self.pole + self.stage1 * (1.0 - self.pole);
            self.samples += 1;
        }
        self.current()
    }

    /// The offset at the last sample drawn, in m (base frame).
    pub fn current(&self) -> Vector3<f64> {
        if self.amplitude_m <= 0.0 {
            return Vector3::zeros();
        }
        self.stage2 * (self.output_gain * self.amplitude_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(seed: u64, n: usize) -> Vec<Vector3<f64>> {
        let mut t = Tremor::new(1e-3, 10.0, seed);
        (0..n).map(|i| t.offset_at(i as f64 * 1e-3)).collect()
    }

    #[test]
    fn same_seed_same_trace_different_seed_differs() {
        assert_eq!(trace(7, 2000), trace(7, 2000));
        let (a, b) = (trace(7, 2000), trace(8, 2000));
        assert!(a.iter().zip(&b).any(|(x, y)| (x - y).norm() > 1e-5));
    }

    #[test]
    fn rms_matches_amplitude() {
        let xs = trace(3, 40_000);
        let tail = &xs[1000..];
        let mean_sq = tail.iter().map(|v| v.norm_squared() / 3.0).sum::<f64>() / tail.len() as f64;
        let rms = mean_sq.sqrt();
        assert!((rms - 1e-3).abs() < 0.15e-3, "rms {rms}");
    }

    #[test]
    fn independent_of_query_pattern() {
        // Querying every 0.25 ms or every 5 ms lands on the same samples.
        let mut fine = Tremor::new(1e-3, 10.0, 11);
        let mut coarse = Tremor::new(1e-3, 10.0, 11);
        for i in 0..=4000 {
            fine.offset_at(i as f64 * 0.25e-3);
        }
        for i in 0..=200 {
            coarse.offset_at(i as f64 * 5e-3);
        }
        // End both between sample times, away from any rounding at a boundary.
        assert_eq!(fine.offset_at(1.0005), coarse.offset_at(1.0005));
    }

    #[test]
    fn zero_amplitude_is_silent_and_is_band_limited_otherwise() {
        let mut off = Tremor::new(0.0, 10.0, 1);
        assert_eq!(off.offset_at(1.0), Vector3::zeros());
        // Band-limited: a sample-to-sample step is much smaller than the 1 mm RMS (white
        // noise of that RMS would step by about 1.4 mm).
        let xs = trace(5, 5000);
        let step_ms = xs
            .windows(2)
            .map(|w| (w[1] - w[0]).norm_squared() / 3.0)
            .sum::<f64>()
            / (xs.len() - 1) as f64;
        let step_rms = step_ms.sqrt();
        assert!(step_rms < 0.15e-3, "step rms {step_rms}");
    }
}
