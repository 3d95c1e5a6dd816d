//! Turns the newest planner [`Guidance`] sample into the guidance wrench F_s = k·F_a
//! (I-RRT eq. 3), faded by age and bounded. Allocation-free; runs in the RT tick.

use devices::clamp_norm;
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
    /// When the guidance comes from another planner than the last sample (another of
    /// several planners is chosen, or a planner restarted), F_s moves from what was
    /// rendered to the new planner's over this time, linearly, s: a switch is never a step.
    pub switch_s: f64,
    /// Bound on how fast |F_s force| may change, N/s (per component of the change's
    /// norm). Each planner sample may differ from the last by a step (a new solution, a
    /// carrot that moves on); the hand feels it as a ramp instead. 20 N/s takes a 2 N
    /// lead 0.1 s to build up, 0.02 N per 1 ms tick.
    pub max_force_rate_n_per_s: f64,
    /// Bound on how fast |F_s torque| may change, N·m/s.
    pub max_torque_rate_nm_per_s: f64,
}

impl Default for GuidanceConfig {
    fn default() -> Self {
        Self {
            fade_s: 0.2,
            max_force_fraction: 0.4,
            max_torque_fraction: 0.4,
            max_future_s: 0.1,
            switch_s: 0.2,
            max_force_rate_n_per_s: 20.0,
            max_torque_rate_nm_per_s: 1.0,
        }
    }
}

impl GuidanceConfig {
    /// Guidance off: F_s is bounded to zero (k = 0 at the arm), everything else default.
    pub fn none() -> Self {
        Self {
            max_force_fraction: 0.0,
            max_torque_fraction: 0.0,
            ..Self::default()
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
    /// F_s rendered by the last call (force N, torque N·m).
    last_output: (Vector3<f64>, Vector3<f64>),
    /// When the last call rendered, ns (`None` before the first).
    last_render_ns: Option<u64>,
    /// A switch of planner in progress: what was rendered when it began, and when, ns.
    blend_from: Option<(Vector3<f64>, Vector3<f64>, u64)>,
}

/// Who wrote a sample: its planner id and process. Two samples of one source differ in
/// sequence; a new source starts a blend.
fn source(g: &Guidance) -> (u32, u32) {
    (g.planner_id, g.header.writer_pid)
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
            last_output: (Vector3::zeros(), Vector3::zeros()),
            last_render_ns: None,
            blend_from: None,
        }
    }

    /// Samples rejected as invalid so far (each distinct sequence counted once).
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// F_s at `now_ns` from the newest sample `g`.
    pub fn render(&mut self, g: &Guidance, now_ns: u64) -> RenderedGuidance {
        let r = self.render_unblended(g, now_ns);
        let r = match self.blend_from {
            Some((force, torque, start_ns)) => {
                let switch_ns = self.config.switch_s * 1e9;
                let w = now_ns.saturating_sub(start_ns) as f64 / switch_ns;
                if w >= 1.0 || !w.is_finite() {
                    self.blend_from = None;
                    r
                } else {
                    // Both ends are bounded, so every point between them is.
                    RenderedGuidance {
                        force_n: force * (1.0 - w) + r.force_n * w,
                        torque_nm: torque * (1.0 - w) + r.torque_nm * w,
                        ..r
                    }
                }
            }
            None => r,
        };
        // Rate-limited towards the target: a step between samples becomes a ramp. The
        // first call starts from zero, as the loop does.
        let dt_s = self
            .last_render_ns
            .map_or(0.0, |last| now_ns.saturating_sub(last) as f64 * 1e-9);
        let (last_force, last_torque) = self.last_output;
        let r = RenderedGuidance {
            force_n: last_force
                + clamp_norm(
                    r.force_n - last_force,
                    self.config.max_force_rate_n_per_s * dt_s,
                ),
            torque_nm: last_torque
                + clamp_norm(
                    r.torque_nm - last_torque,
                    self.config.max_torque_rate_nm_per_s * dt_s,
                ),
            ..r
        };
        self.last_output = (r.force_n, r.torque_nm);
        self.last_render_ns = Some(now_ns);
        r
    }

    fn render_unblended(&mut self, g: &Guidance, now_ns: u64) -> RenderedGuidance {
        let future_ns = (self.config.max_future_s * 1e9) as u64;
        let is_new = self.last_valid.is_none_or(|last| {
            last.header.sequence != g.header.sequence || source(&last) != source(g)
        });
        if g.header.sequence != 0 && is_new {
            if g.validate().is_ok() && g.header.timestamp_ns <= now_ns.saturating_add(future_ns) {
                if self
                    .last_valid
                    .is_some_and(|last| source(&last) != source(g))
                {
                    let (force, torque) = self.last_output;
                    self.blend_from = Some((force, torque, now_ns));
                }
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

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::Header;

    const MS: u64 = 1_000_000;

    fn sample(seq: u64, t_ns: u64) -> Guidance {
        Guidance::roadmap(
            Header::new(seq, t_ns, 1),
            [0.05, 0.0, 0.0, 0.0, 0.0, 0.1],
            20.0,
            0.5,
            100 * MS,
        )
    }

    /// A filter whose rate limit does not act within a tick (the tests below are about
    /// the other stages), having rendered nothing at t = 0 so that the next call has a
    /// tick length to limit against.
    fn filter() -> GuidanceFilter {
        let mut f = GuidanceFilter::new(
            GuidanceConfig {
                max_force_rate_n_per_s: 1e9,
                max_torque_rate_nm_per_s: 1e9,
                ..GuidanceConfig::default()
            },
            8.0,
            0.5,
        );
        f.render(&Guidance::default(), 0);
        f
    }

    /// A new solution (F_a → the path's lead) or a carrot that moves on changes the
    /// sample by a step; the rendered F_s follows at the configured rate, 20 N/s and
    /// 1 N·m/s by default: 0.02 N and 0.001 N·m per 1 ms tick.
    #[test]
    fn a_step_between_samples_is_rendered_as_a_ramp() {
        let mut f = GuidanceFilter::new(GuidanceConfig::default(), 8.0, 0.5);
        let mut largest = (0.0f64, 0.0f64);
        let mut prev = (Vector3::zeros(), Vector3::zeros());
        let mut last = None;
        for i in 0..400u64 {
            let t = 1000 * MS + i * MS;
            let mut g = sample(1 + i, t);
            if i >= 200 {
                // The other way, twice as far: a 2 N force step, 0.1 N·m of torque.
                g.attractive = [-0.05, 0.0, 0.0, 0.0, 0.0, -0.1];
            }
            let r = f.render(&g, t);
            largest.0 = largest.0.max((r.force_n - prev.0).norm());
            largest.1 = largest.1.max((r.torque_nm - prev.1).norm());
            prev = (r.force_n, r.torque_nm);
            if i == 100 || i == 399 {
                last = Some((i, r));
            }
            if i == 100 {
                assert!((r.force_n.x - 1.0).abs() < 1e-9, "1 N reached in 50 ms");
                assert!((r.torque_nm.z - 0.05).abs() < 1e-9, "0.05 N·m in 50 ms");
            }
            if i == 249 {
                assert!((r.force_n.x - 0.0).abs() < 1e-9, "half-way after 50 ms");
            }
        }
        assert!(
            (largest.0 - 0.02).abs() < 1e-9,
            "largest force step {} N",
            largest.0
        );
        assert!(
            (largest.1 - 0.001).abs() < 1e-9,
            "largest torque step {} N·m",
            largest.1
        );
        let (_, r) = last.unwrap();
        assert!((r.force_n.x + 1.0).abs() < 1e-9 && (r.torque_nm.z + 0.05).abs() < 1e-9);
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
        let mut f = filter();
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
        let mut g = sample(1, MS);
        g.attractive = [10.0, 0.0, 0.0, 0.0, 0.0, 10.0];
        let r = f.render(&g, MS);
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

    /// Another planner's sample (or a restarted planner's) takes over through a blend over
    /// `switch_s`: the rendered force moves from the old planner's to the new one's in
    /// equal steps of 1 ms, never a jump.
    #[test]
    fn a_switch_of_planner_blends_instead_of_stepping() {
        let mut f = filter();
        let a = sample(40, 1000 * MS);
        assert!((f.render(&a, 1001 * MS).force_n.x - 1.0).abs() < 1e-12);
        let mut b = sample(40, 1001 * MS);
        b.planner_id = 2;
        b.attractive[0] = -0.05;
        let mut prev = 1.0;
        let mut largest_step: f64 = 0.0;
        for i in 0..=250u64 {
            let t = 1002 * MS + i * MS;
            let mut b_now = b;
            b_now.header.sequence = 40 + i / 10;
            b_now.header.timestamp_ns = t;
            let x = f.render(&b_now, t).force_n.x;
            if i == 5 {
                // The first sample of the new planner repeats the old one's sequence: it
                // is taken all the same (another source), so the blend began at i = 0.
                assert!((x - 0.95).abs() < 1e-9, "{x} N after 5 ms of the blend");
            }
            largest_step = largest_step.max((x - prev).abs());
            prev = x;
        }
        // From +1 N to −1 N over 200 ms: 0.01 N per 1 ms tick.
        assert!(
            (largest_step - 0.01).abs() < 1e-9,
            "largest step {largest_step} N"
        );
        assert!(
            (prev + 1.0).abs() < 1e-12,
            "arrived at the new planner's force"
        );
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
