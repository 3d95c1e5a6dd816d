//! Turns the newest planner [`Guidance`] sample into the guidance wrench F_s = k·F_a
//! (I-RRT eq. 3), faded by age and bounded. Allocation-free; runs in the RT tick.

use ipc_types::{Guidance, GuidanceFreshness};
use nalgebra::Vector3;

/// How guidance is faded and bounded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidanceConfig {
    /// After a sample's time-to-live, F_s fades linearly to zero over this time, s.
    /// Typical 0.1–0.5 s: long enough not to be felt as a step, short enough that a dead
    /// planner's last wish does not linger.
    pub fade_s: f64,
    /// Bound on |F_s force| as a fraction of the device's maximum force (0–1).
    pub max_force_fraction: f64,
    /// Bound on |F_s torque| as a fraction of the device's maximum torque (0–1).
    pub max_torque_fraction: f64,
    /// Samples stamped further than this in the future are rejected as corrupt, s.
    pub max_future_s: f64,
}

impl Default for GuidanceConfig {
    fn default() -> Self {
        Self {
            fade_s: 0.2,
            max_force_fraction: 0.4,
            max_torque_fraction: 0.4,
            max_future_s: 0.1,
        }
    }
}

/// F_s for one tick, scene frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderedGuidance {
    /// Force, N.
    pub force_n: Vector3<f64>,
    /// Torque about the object's reference point, N·m.
    pub torque_nm: Vector3<f64>,
    /// Freshness of the sample used.
    pub freshness: GuidanceFreshness,
    /// Sequence of the sample used, 0 if none.
    pub sequence: u64,
    /// Age of the sample at render time, ns (0 if none).
    pub age_ns: u64,
}

impl RenderedGuidance {
    const NONE: Self = Self {
        force_n: Vector3::new(0.0, 0.0, 0.0),
        torque_nm: Vector3::new(0.0, 0.0, 0.0),
        freshness: GuidanceFreshness::NONE,
        sequence: 0,
        age_ns: 0,
    };
}

/// Stateful renderer: remembers the last valid sample so a rejected one does not cut
/// guidance abruptly, and counts rejections.
#[derive(Debug, Clone)]
pub struct GuidanceFilter {
    config: GuidanceConfig,
    max_force_n: f64,
    max_torque_nm: f64,
    last_valid: Option<Guidance>,
    rejected: u64,
    last_rejected_sequence: u64,
}

impl GuidanceFilter {
    /// A filter bounded by the device's limits (`device_max_force_n`, N;
    /// `device_max_torque_nm`, N·m) scaled by the config's fractions.
    pub fn new(config: GuidanceConfig, device_max_force_n: f64, device_max_torque_nm: f64) -> Self {
        Self {
            config,
            max_force_n: device_max_force_n * config.max_force_fraction,
            max_torque_nm: device_max_torque_nm * config.max_torque_fraction,
            last_valid: None,
            rejected: 0,
            last_rejected_sequence: 0,
        }
    }

    /// Samples rejected as invalid so far (each distinct sequence counted once).
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// F_s at `now_ns` from the newest sample `g`.
    pub fn render(&mut self, g: &Guidance, now_ns: u64) -> RenderedGuidance {
        let future_ns = (self.config.max_future_s * 1e9) as u64;
        let is_new = self
            .last_valid
            .is_none_or(|last| last.header.sequence != g.header.sequence);
        if g.header.sequence != 0 && is_new {
            if g.validate().is_ok() && g.header.timestamp_ns <= now_ns.saturating_add(future_ns) {
                self.last_valid = Some(*g);
            } else if g.header.sequence != self.last_rejected_sequence {
                self.rejected += 1;
                self.last_rejected_sequence = g.header.sequence;
            }
        }
        let Some(g) = self.last_valid else {
            return RenderedGuidance::NONE;
        };
        let age_ns = now_ns.saturating_sub(g.header.timestamp_ns);
        let ttl_ns = g.time_to_live_ns;
        let fade_ns = (self.config.fade_s * 1e9) as u64;
        let (factor, freshness) = if age_ns <= ttl_ns {
            (1.0, GuidanceFreshness::FRESH)
        } else if age_ns < ttl_ns.saturating_add(fade_ns) {
            let into_fade = (age_ns - ttl_ns) as f64 / fade_ns as f64;
            (1.0 - into_fade, GuidanceFreshness::FADING)
        } else {
            (0.0, GuidanceFreshness::LOST)
        };
        let a = &g.attractive;
        let force = Vector3::new(a[0], a[1], a[2]) * (g.gain_n_per_m * factor);
        let torque = Vector3::new(a[3], a[4], a[5]) * (g.gain_nm_per_rad * factor);
        // Validation bounds every factor, so this holds; kept as the last line of defence
        // of the RT path (a NaN here would latch a loop fault).
        if !(force.iter().chain(torque.iter()).all(|x| x.is_finite())) {
            return RenderedGuidance::NONE;
        }
        RenderedGuidance {
            force_n: clamp_norm(force, self.max_force_n),
            torque_nm: clamp_norm(torque, self.max_torque_nm),
            freshness,
            sequence: g.header.sequence,
            age_ns,
        }
    }
}

/// `v` scaled down so that its norm is at most `max` (direction kept).
pub fn clamp_norm(v: Vector3<f64>, max: f64) -> Vector3<f64> {
    let n = v.norm();
    if n > max && n > 0.0 { v * (max / n) } else { v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::{GuidanceMode, Header};

    const MS: u64 = 1_000_000;

    fn sample(seq: u64, t_ns: u64) -> Guidance {
        Guidance {
            header: Header {
                sequence: seq,
                timestamp_ns: t_ns,
                writer_pid: 1,
                reserved: 0,
            },
            attractive: [0.05, 0.0, 0.0, 0.0, 0.0, 0.1],
            gain_n_per_m: 20.0,
            gain_nm_per_rad: 0.5,
            time_to_live_ns: 100 * MS,
            mode: GuidanceMode::ROADMAP,
            ..Guidance::default()
        }
    }

    fn filter() -> GuidanceFilter {
        GuidanceFilter::new(GuidanceConfig::default(), 8.0, 0.5)
    }

    #[test]
    fn fresh_sample_renders_k_times_fa() {
        let mut f = filter();
        let r = f.render(&sample(1, 1000 * MS), 1010 * MS);
        assert_eq!(r.freshness, GuidanceFreshness::FRESH);
        assert!((r.force_n.x - 1.0).abs() < 1e-12, "20 N/m * 0.05 m = 1 N");
        assert!(
            (r.torque_nm.z - 0.05).abs() < 1e-12,
            "0.5 N·m/rad * 0.1 rad"
        );
        assert_eq!(r.sequence, 1);
    }

    #[test]
    fn stale_sample_fades_linearly_then_is_lost() {
        let mut f = filter();
        let g = sample(1, 1000 * MS);
        // ttl 100 ms, fade 200 ms: half-way through the fade at 200 ms past ttl start.
        let half = f.render(&g, 1000 * MS + 200 * MS);
        assert_eq!(half.freshness, GuidanceFreshness::FADING);
        assert!((half.force_n.x - 0.5).abs() < 1e-9);
        let lost = f.render(&g, 1000 * MS + 300 * MS);
        assert_eq!(lost.freshness, GuidanceFreshness::LOST);
        assert_eq!(lost.force_n.norm(), 0.0);
        assert_eq!(lost.torque_nm.norm(), 0.0);
        // Monotone non-increasing through the fade.
        let mut prev = f64::INFINITY;
        for t in (0..400).map(|i| 1000 * MS + i * MS) {
            let m = f.render(&g, t).force_n.norm();
            assert!(m <= prev + 1e-12);
            prev = m;
        }
    }

    #[test]
    fn guidance_is_bounded_by_device_fraction() {
        let mut f = filter();
        let mut g = sample(1, 0);
        g.attractive = [10.0, 0.0, 0.0, 0.0, 0.0, 10.0];
        let r = f.render(&g, 0);
        assert!((r.force_n.norm() - 8.0 * 0.4).abs() < 1e-12);
        assert!((r.torque_nm.norm() - 0.5 * 0.4).abs() < 1e-12);
    }

    #[test]
    fn invalid_sample_is_rejected_and_last_valid_kept() {
        let mut f = filter();
        f.render(&sample(1, 0), 0);
        let mut bad = sample(2, MS);
        bad.attractive[0] = f64::NAN;
        let r = f.render(&bad, 2 * MS);
        assert_eq!(r.sequence, 1, "kept the last valid sample");
        assert!(r.force_n.iter().all(|v| v.is_finite()));
        // The same bad sample read again is not counted twice.
        f.render(&bad, 3 * MS);
        assert_eq!(f.rejected(), 1);
        let mut future = sample(3, 10_000 * MS);
        future.header.timestamp_ns = 10_000 * MS;
        f.render(&future, 4 * MS);
        assert_eq!(f.rejected(), 2, "a stamp 10 s in the future is corrupt");
    }

    #[test]
    fn never_written_gives_no_force() {
        let mut f = filter();
        let r = f.render(&Guidance::default(), 5 * MS);
        assert_eq!(r.freshness, GuidanceFreshness::NONE);
        assert_eq!(r.force_n.norm(), 0.0);
        assert_eq!(f.rejected(), 0);
    }
}
