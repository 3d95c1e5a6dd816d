//! Resident memory of the soak's processes, from `/proc/PID/status`: `RssAnon` (heap,
//! stacks: what a leak grows) apart from `RssShmem` (iceoryx2's shared-memory segments: a
//! restarted planner maps new ones into every process that talks to it).

use serde::Serialize;

/// A process's resident memory, kB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Rss {
    /// The process sampled.
    pub pid: u32,
    /// `RssAnon`, kB.
    pub anon_kb: u64,
    /// `RssShmem`, kB.
    pub shmem_kb: u64,
}

impl Rss {
    /// Process `pid`'s, `None` when it is gone (or there is no /proc).
    pub fn of(pid: u32) -> Option<Rss> {
        let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
        Self::parse(pid, &status)
    }

    /// From the text of `/proc/PID/status`.
    pub fn parse(pid: u32, status: &str) -> Option<Rss> {
        let field = |name: &str| {
            status.lines().find_map(|l| {
                let v = l.strip_prefix(name)?.strip_prefix(':')?;
                v.trim().trim_end_matches("kB").trim().parse::<u64>().ok()
            })
        };
        Some(Rss {
            pid,
            anon_kb: field("RssAnon")?,
            shmem_kb: field("RssShmem")?,
        })
    }

    /// `anon / shmem` in MiB.
    pub fn describe(&self) -> String {
        format!("{:.1} / {:.1}", mb(self.anon_kb), mb(self.shmem_kb))
    }
}

/// KiB (what /proc calls kB) as MiB.
pub fn mb(kb: u64) -> f64 {
    kb as f64 / 1024.0
}

/// The four processes' memory at one moment of the soak.
#[derive(Debug, Clone, Serialize)]
pub struct Sample {
    /// Minutes since the soak began.
    pub minute: f64,
    /// The haptic loop.
    pub haptic_loop: Option<Rss>,
    /// The local planner's current incarnation.
    pub local_planner: Option<Rss>,
    /// The loop-side `hrrtc-bridge`.
    pub bridge: Option<Rss>,
    /// The planner across the bridge.
    pub remote_planner: Option<Rss>,
}

impl Sample {
    /// The processes' names, in the order of [`Sample::processes`].
    pub const NAMES: [&'static str; 4] = [
        "haptic loop",
        "local planner",
        "loop-side bridge",
        "remote planner",
    ];

    /// The processes in the order of the tables, with their names.
    pub fn processes(&self) -> [(&'static str, Option<Rss>); 4] {
        let [a, b, c, d] = Self::NAMES;
        [
            (a, self.haptic_loop),
            (b, self.local_planner),
            (c, self.bridge),
            (d, self.remote_planner),
        ]
    }
}

/// Which samples the report shows: minutes 1, 10, 30 and 60 of an hour, and for other
/// lengths the first, the ones nearest a sixth and a half of the last minute, and the last
/// (indices into `samples`, in order, without repeats).
pub fn reported(samples: &[Sample]) -> Vec<usize> {
    let Some(last) = samples.last() else {
        return Vec::new();
    };
    let nearest = |minute: f64| {
        (0..samples.len())
            .min_by(|&a, &b| {
                let (da, db) = (
                    (samples[a].minute - minute).abs(),
                    (samples[b].minute - minute).abs(),
                );
                da.total_cmp(&db).then(a.cmp(&b))
            })
            .unwrap_or(0)
    };
    let mut picked = vec![
        0,
        nearest(last.minute / 6.0),
        nearest(last.minute / 2.0),
        samples.len() - 1,
    ];
    picked.sort_unstable();
    picked.dedup();
    picked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_fields_are_read_apart() {
        let status = "Name:\tplanner\nVmRSS:\t  91000 kB\nRssAnon:\t   61234 kB\n\
                      RssFile:\t   20000 kB\nRssShmem:\t    9766 kB\n";
        assert_eq!(
            Rss::parse(7, status),
            Some(Rss {
                pid: 7,
                anon_kb: 61234,
                shmem_kb: 9766
            })
        );
        assert_eq!(Rss::parse(7, "Name:\tx\n"), None);
    }

    fn at(minutes: &[f64]) -> Vec<Sample> {
        minutes
            .iter()
            .map(|&minute| Sample {
                minute,
                haptic_loop: None,
                local_planner: None,
                bridge: None,
                remote_planner: None,
            })
            .collect()
    }

    #[test]
    fn an_hour_shows_minutes_1_10_30_60_and_shorter_runs_what_they_have() {
        let hour: Vec<f64> = (1..=60).map(f64::from).collect();
        let shown: Vec<f64> = reported(&at(&hour)).iter().map(|&i| hour[i]).collect();
        assert_eq!(shown, [1.0, 10.0, 30.0, 60.0]);
        assert_eq!(reported(&at(&[1.0, 2.0])), [0, 1]);
        assert_eq!(reported(&at(&[1.0, 2.0, 3.0, 4.0, 5.0])), [0, 1, 4]);
        assert_eq!(reported(&at(&[0.5])), [0]);
        assert!(reported(&[]).is_empty());
    }
}
