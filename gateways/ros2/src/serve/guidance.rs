//! Guidance from a ROS 2 node: a `geometry_msgs/msg/WrenchStamped` on the gateway's
//! `guidance` topic is the guidance force F_s the node wants rendered (N, and N·m about the
//! object's reference point), in the `scene` frame (`header.frame_id` must name it). It becomes
//! an `ipc_types::Guidance` with F_a = the wrench and gains of 1 N/m and 1 N·m/rad (so
//! F_s = k·F_a is the wrench), which the loop renders as any planner's guidance: bounded to
//! 40 % of the device's force, rate limited, faded after its time-to-live.
//!
//! Every sample is checked before it is handed on, and a rejected one is counted by kind,
//! logged (at most once a second per kind, so a flood cannot flood the log) and never
//! reaches the loop:
//!
//! | kind | what |
//! |---|---|
//! | `wrong_type` | a sample on the topic with another type name or hash in its key |
//! | `attachment` | no attachment, or not rmw_zenoh's 33 bytes |
//! | `cdr` | not a whole little-endian CDR WrenchStamped (short, long, bad header or string) |
//! | `frame` | `header.frame_id` is not the `scene` frame |
//! | `future` | stamped more than 100 ms ahead of this host's clock |
//! | `stale` | stamped longer ago than the time-to-live (it would only fade) |
//! | `invalid` | fails the loop's own check, `Guidance::validate` (NaN or infinite values, beyond ±10⁶) |
//!
//! A zero stamp (a node that does not stamp, `ros2 topic pub` without `stamp: now`) counts as
//! the arrival time.

use ipc_types::{Guidance, GuidanceError, GuidanceMode, Header};

use crate::cdr::CdrError;
use crate::clock::Clocks;
use crate::msgs::{Message, Time, WrenchStamped};
use crate::rejections::Rejected;
use crate::rmw::{Attachment, AttachmentError};

/// Largest lead of a stamp over our clock, ns (the bridge's limit, `hrrtc-bridge`).
pub const MAX_FUTURE_NS: i64 = 100_000_000;

/// Why a guidance sample was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Rejection {
    /// Another type on the topic.
    #[error("wrong type: key {got}, expected {expected}")]
    WrongType {
        /// The sample's key.
        got: String,
        /// Ours.
        expected: String,
    },
    /// A bad attachment.
    #[error(transparent)]
    Attachment(#[from] AttachmentError),
    /// Not a WrenchStamped.
    #[error("not a WrenchStamped: {0}")]
    Cdr(#[from] CdrError),
    /// Another frame.
    #[error("header.frame_id {got:?}: guidance must be in {expected:?}")]
    Frame {
        /// The sample's frame.
        got: String,
        /// The scene frame.
        expected: String,
    },
    /// Stamped ahead of our clock.
    #[error("header.stamp {ahead_ms:.1} ms in the future (more than 100 ms)")]
    Future {
        /// How far ahead, ms.
        ahead_ms: f64,
    },
    /// Stamped before its time-to-live.
    #[error("header.stamp {age_ms:.1} ms old, beyond the {ttl_ms:.0} ms time-to-live")]
    Stale {
        /// Its age, ms.
        age_ms: f64,
        /// The time-to-live, ms.
        ttl_ms: f64,
    },
    /// Fails the loop's checks.
    #[error("fails the loop's guidance check: {0:?}")]
    Invalid(GuidanceError),
}

impl Rejected for Rejection {
    const WHAT: &'static str = "guidance sample";
    const KINDS: &'static [&'static str] = &[
        "wrong_type",
        "attachment",
        "cdr",
        "frame",
        "future",
        "stale",
        "invalid",
    ];

    fn kind(&self) -> &'static str {
        match self {
            Rejection::WrongType { .. } => "wrong_type",
            Rejection::Attachment(_) => "attachment",
            Rejection::Cdr(_) => "cdr",
            Rejection::Frame { .. } => "frame",
            Rejection::Future { .. } => "future",
            Rejection::Stale { .. } => "stale",
            Rejection::Invalid(_) => "invalid",
        }
    }
}

/// Turns WrenchStamped samples into the loop's guidance.
#[derive(Debug, Clone)]
pub struct GuidanceInput {
    /// The topic's key (with our type and hash).
    pub key: String,
    /// The `scene` frame.
    pub scene_frame: String,
    /// Time-to-live given to each sample, ns.
    pub ttl_ns: u64,
    /// This process's id (`header.writer_pid`).
    pub pid: u32,
    /// This gateway's planner id (random, non-zero).
    pub planner_id: u32,
    sequence: u64,
}

impl GuidanceInput {
    /// Samples on `key` into guidance for a loop, in `scene_frame`, fresh for `ttl_ns`.
    pub fn new(key: String, scene_frame: String, ttl_ns: u64, planner_id: u32) -> Self {
        GuidanceInput {
            key,
            scene_frame,
            ttl_ns,
            pid: std::process::id(),
            planner_id: planner_id.max(1),
            sequence: 0,
        }
    }

    /// The guidance of one sample that arrived on `key` at `now`, or why not; `state_sequence`
    /// is the newest tick seen (for the loop's round-trip figures).
    pub fn accept(
        &mut self,
        key: &str,
        payload: &[u8],
        attachment: Option<&[u8]>,
        now: Clocks,
        state_sequence: u64,
    ) -> Result<Guidance, Rejection> {
        if key != self.key {
            return Err(Rejection::WrongType {
                got: key.to_owned(),
                expected: self.key.clone(),
            });
        }
        Attachment::decode(attachment)?;
        let w = WrenchStamped::decode(payload)?;
        if w.header.frame_id != self.scene_frame {
            return Err(Rejection::Frame {
                got: w.header.frame_id,
                expected: self.scene_frame.clone(),
            });
        }
        let stamp_ns = if w.header.stamp == Time::default() {
            now.monotonic_ns as i64
        } else {
            now.to_monotonic_ns(w.header.stamp)
        };
        let age = now.monotonic_ns as i64 - stamp_ns;
        if age < -MAX_FUTURE_NS {
            return Err(Rejection::Future {
                ahead_ms: -age as f64 / 1e6,
            });
        }
        if age > self.ttl_ns as i64 {
            return Err(Rejection::Stale {
                age_ms: age as f64 / 1e6,
                ttl_ms: self.ttl_ns as f64 / 1e6,
            });
        }
        let [fx, fy, fz] = w.wrench.force;
        let [tx, ty, tz] = w.wrench.torque;
        let g = Guidance {
            header: Header {
                sequence: self.sequence + 1,
                // Not after now: the loop's fade counts from it.
                timestamp_ns: stamp_ns.clamp(1, now.monotonic_ns as i64) as u64,
                writer_pid: self.pid,
                reserved: 0,
            },
            attractive: [fx, fy, fz, tx, ty, tz],
            gain_n_per_m: 1.0,
            gain_nm_per_rad: 1.0,
            time_to_live_ns: self.ttl_ns,
            state_sequence,
            mode: GuidanceMode::PATH,
            solved: 1,
            planner_id: self.planner_id,
            ..Guidance::default()
        };
        g.validate().map_err(Rejection::Invalid)?;
        self.sequence += 1;
        Ok(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::{Header as RosHeader, Wrench};

    const KEY: &str = "0/hrrtc/guidance/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_8dc3";

    fn now() -> Clocks {
        Clocks {
            monotonic_ns: 10_000_000_000,
            realtime_ns: 1_700_000_000_000_000_000,
        }
    }

    fn sample(force: [f64; 3], frame: &str, stamp: Time) -> Vec<u8> {
        WrenchStamped {
            header: RosHeader {
                stamp,
                frame_id: frame.into(),
            },
            wrench: Wrench {
                force,
                torque: [0.0, 0.0, 0.01],
            },
        }
        .encode()
    }

    fn attachment() -> [u8; 33] {
        Attachment {
            sequence: 1,
            source_timestamp_ns: 0,
            gid: [3; 16],
        }
        .encode()
    }

    fn input() -> GuidanceInput {
        GuidanceInput::new(KEY.into(), "hrrtc/scene".into(), 100_000_000, 77)
    }

    #[test]
    fn a_wrench_becomes_guidance_whose_force_is_the_wrench() {
        let mut g = input();
        let stamp = Time::from_ns(now().realtime_ns - 5_000_000);
        let out = g
            .accept(
                KEY,
                &sample([0.3, 0.0, -0.1], "hrrtc/scene", stamp),
                Some(&attachment()),
                now(),
                42,
            )
            .unwrap();
        let f: Vec<f64> = (0..3)
            .map(|i| out.gain_n_per_m * out.attractive[i])
            .collect();
        assert_eq!(f, vec![0.3, 0.0, -0.1]);
        assert_eq!(out.gain_nm_per_rad * out.attractive[5], 0.01);
        assert_eq!(out.header.timestamp_ns, now().monotonic_ns - 5_000_000);
        assert_eq!((out.header.sequence, out.state_sequence), (1, 42));
        assert_eq!(out.planner_id, 77);
        assert_eq!(out.validate(), Ok(()));
        // A zero stamp is the arrival time.
        let out = g
            .accept(
                KEY,
                &sample([0.3, 0.0, 0.0], "hrrtc/scene", Time::default()),
                Some(&attachment()),
                now(),
                43,
            )
            .unwrap();
        assert_eq!(out.header.timestamp_ns, now().monotonic_ns);
        assert_eq!(out.header.sequence, 2);
    }

    #[test]
    fn malformed_samples_are_rejected_by_kind() {
        let mut g = input();
        let ok = sample([0.3, 0.0, 0.0], "hrrtc/scene", Time::default());
        let att = attachment();
        let kind = |g: &mut GuidanceInput, key: &str, p: &[u8], a: Option<&[u8]>| {
            g.accept(key, p, a, now(), 1).unwrap_err().kind()
        };
        let other = "0/hrrtc/guidance/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_10f3";
        assert_eq!(kind(&mut g, other, &ok, Some(&att)), "wrong_type");
        assert_eq!(kind(&mut g, KEY, &ok, None), "attachment");
        assert_eq!(kind(&mut g, KEY, &ok, Some(&att[..20])), "attachment");
        assert_eq!(kind(&mut g, KEY, &ok[..ok.len() - 9], Some(&att)), "cdr");
        assert_eq!(kind(&mut g, KEY, &[0, 1, 0, 0], Some(&att)), "cdr");
        let mut be = ok.clone();
        be[1] = 0;
        assert_eq!(kind(&mut g, KEY, &be, Some(&att)), "cdr");
        let mut long = ok.clone();
        long.extend_from_slice(&[0; 8]);
        assert_eq!(kind(&mut g, KEY, &long, Some(&att)), "cdr");
        let frame = sample([0.3, 0.0, 0.0], "map", Time::default());
        assert_eq!(kind(&mut g, KEY, &frame, Some(&att)), "frame");
        let ahead = sample(
            [0.3, 0.0, 0.0],
            "hrrtc/scene",
            Time::from_ns(now().realtime_ns + 500_000_000),
        );
        assert_eq!(kind(&mut g, KEY, &ahead, Some(&att)), "future");
        let old = sample(
            [0.3, 0.0, 0.0],
            "hrrtc/scene",
            Time::from_ns(now().realtime_ns - 2_000_000_000),
        );
        assert_eq!(kind(&mut g, KEY, &old, Some(&att)), "stale");
        for bad in [f64::NAN, f64::INFINITY, 1e300, -2e6] {
            let p = sample([bad, 0.0, 0.0], "hrrtc/scene", Time::default());
            assert_eq!(kind(&mut g, KEY, &p, Some(&att)), "invalid", "{bad}");
        }
        // Nothing rejected took a sequence number.
        let out = g.accept(KEY, &ok, Some(&att), now(), 1).unwrap();
        assert_eq!(out.header.sequence, 1);
        let e = g.accept(KEY, &frame, Some(&att), now(), 1).unwrap_err();
        assert!(e.to_string().contains("\"map\""), "{e}");
    }
}
