//! Valid samples of each target's input, made by the gateways' own encoders
//! (`frame::encode`, `msgs::Message::encode`, `Attachment::encode`), with a few of the
//! near misses each check tells apart: the corpora start from the real formats.

use crate::device::{Topic, put_sample};
use crate::guidance::{NOW, SCENE_FRAME};
use crate::ros2::put_attachment;
use hrrtc_bridge::frame::{self, FrameHeader, Kind};
use hrrtc_ros2::msgs::{self, Joy, Message, PoseStamped, Time, TwistStamped, WrenchStamped};
use hrrtc_ros2::rmw::Attachment;
use ipc_types::{
    Guidance, GuidanceMode, HapticState, Header, Path, Pose, Roadmap, RoadmapNode, RoadmapTree,
    TreeKind,
};

/// Largest seed written to a corpus: libFuzzer's default input length limit.
pub const MAX_SEED_LEN: usize = 4096;

/// One seed input.
#[derive(Debug, Clone)]
pub struct Seed {
    /// A file name for it.
    pub name: String,
    /// The input.
    pub bytes: Vec<u8>,
}

fn seed(name: &str, bytes: Vec<u8>) -> Seed {
    Seed {
        name: format!("seed-{name}"),
        bytes,
    }
}

/// The seeds of `target` (a name of [`crate::TARGETS`]).
pub fn of(target: &str) -> Vec<Seed> {
    match target {
        "bridge_frame" => bridge_frame(),
        "ros2_guidance" => ros2_guidance(),
        "ros2_device" => ros2_device(),
        _ => panic!("no seeds for target {target:?}"),
    }
}

const SENDER: u64 = 0x0123_4567_89ab_cdef;
/// The sending host's clock when it sent: an hour after its boot.
const SENT_NS: u64 = 3_600_000_000_000;

fn pose(x: f64, angle_rad: f64) -> Pose {
    let (s, c) = (angle_rad / 2.0).sin_cos();
    Pose {
        position_m: [x, -0.1, 0.25],
        orientation_xyzw: [0.0, 0.0, s, c],
    }
}

/// The first `payload_len` payload bytes of a frame of `value` (the rest is as in an empty
/// value, which the target completes short frames with).
fn prefix(mut frame: Vec<u8>, payload_len: usize) -> Vec<u8> {
    frame.truncate(frame::HEADER_LEN + payload_len);
    frame
}

fn bridge_frame() -> Vec<Seed> {
    let mut state = HapticState {
        header: Header::new(5, SENT_NS - 2_000_000, 41),
        user_pose: pose(0.1, 0.3),
        proxy_pose: pose(0.09, 0.3),
        penetration_m: 0.0005,
        published_ns: SENT_NS - 1_000_000,
        guidance_sequence: 3,
        ..HapticState::default()
    };
    state.commanded_wrench.force_n = [0.5, 0.0, -1.0];
    let unstamped = HapticState {
        header: Header::new(6, 0, 41),
        published_ns: 0,
        ..state
    };
    let guidance = Guidance {
        planner_id: 7,
        state_sequence: 5,
        solved: 1,
        mode: GuidanceMode::PATH,
        ..Guidance::roadmap(
            Header::new(3, SENT_NS - 500_000, 42),
            [0.1, 0.0, -0.2, 0.0, 0.01, 0.0],
            20.0,
            0.5,
            100_000_000,
        )
    };
    let future = Guidance {
        header: Header::new(4, SENT_NS + 500_000_000, 42),
        ..guidance
    };
    let mut path = Path::EMPTY;
    path.header = Header::new(1, SENT_NS - 10_000_000, 43);
    path.len = 3;
    path.length = 0.42;
    for (i, w) in path.waypoints.iter_mut().take(3).enumerate() {
        *w = pose(0.1 * i as f64, 0.2 * i as f64);
    }
    let path_len = 24 + 8 + 8 + 56 * 3;
    let mut roadmap = Roadmap::EMPTY;
    roadmap.header = Header::new(9, SENT_NS - 3_000_000, 43);
    roadmap.iterations = 120;
    roadmap.total_nodes = 5;
    (roadmap.trees_len, roadmap.trees_total, roadmap.nodes_len) = (2, 2, 5);
    roadmap.new_nodes = 5;
    roadmap.trees[0] = RoadmapTree {
        id: 0,
        kind: TreeKind::START,
        len: 3,
        reserved: 0,
    };
    roadmap.trees[1] = RoadmapTree {
        id: 1,
        kind: TreeKind::GOAL,
        len: 2,
        reserved: 0,
    };
    for (i, n) in roadmap.nodes.iter_mut().take(5).enumerate() {
        *n = RoadmapNode {
            pose: pose(0.05 * i as f64, 0.1),
            distance_to_goal: 1.0 - 0.1 * i as f64,
            tree_id: u32::from(i >= 3),
            index: i as u32 % 3,
            parent: if i % 3 == 0 {
                ipc_types::NO_PARENT
            } else {
                i as u32 - 1
            },
            ..RoadmapNode::EMPTY
        };
    }
    let roadmap_len = 24 + 8 + 8 + 6 * 4 + 16 * ipc_types::ROADMAP_TREES + 88 * 5;
    let ping = FrameHeader {
        kind: Kind::PING,
        sender: SENDER,
        sent_ns: SENT_NS,
    };
    let pong = FrameHeader {
        kind: Kind::PONG,
        ..ping
    };
    let peer = 0xfeed_0000_0000_0002u64.to_le_bytes();
    vec![
        seed("state", frame::encode(SENDER, SENT_NS, &state)),
        seed(
            "state-unstamped",
            frame::encode(SENDER, SENT_NS, &unstamped),
        ),
        seed(
            "state-prefix",
            prefix(frame::encode(SENDER, SENT_NS, &state), 200),
        ),
        seed("guidance", frame::encode(SENDER, SENT_NS, &guidance)),
        seed("guidance-future", frame::encode(SENDER, SENT_NS, &future)),
        seed(
            "guidance-as-path",
            frame::encode_raw(
                FrameHeader {
                    kind: Kind::PATH,
                    ..ping
                },
                guidance_bytes(&guidance).as_slice(),
            ),
        ),
        seed("path", frame::encode(SENDER, SENT_NS, &path)),
        seed(
            "path-prefix",
            prefix(frame::encode(SENDER, SENT_NS, &path), path_len),
        ),
        seed("roadmap", frame::encode(SENDER, SENT_NS, &roadmap)),
        seed(
            "roadmap-prefix",
            prefix(frame::encode(SENDER, SENT_NS, &roadmap), roadmap_len),
        ),
        seed("ping", frame::encode_raw(ping, &[])),
        seed("pong", frame::encode_raw(pong, &peer)),
        seed("pong-short", frame::encode_raw(pong, &peer[..7])),
        seed(
            "unknown-kind",
            frame::encode_raw(
                FrameHeader {
                    kind: Kind(7),
                    ..ping
                },
                &[1, 2, 3],
            ),
        ),
        seed("too-short", b"HRB1\x05\0\0\0".to_vec()),
    ]
}

fn guidance_bytes(g: &Guidance) -> Vec<u8> {
    frame::encode(0, 0, g)[frame::HEADER_LEN..].to_vec()
}

fn attachment(sequence: i64) -> [u8; 33] {
    Attachment {
        sequence,
        source_timestamp_ns: NOW.realtime_ns - 1_000_000,
        gid: core::array::from_fn(|i| i as u8 * 7),
    }
    .encode()
}

fn wrench(force: [f64; 3], frame: &str, stamp: Time) -> Vec<u8> {
    WrenchStamped {
        header: msgs::Header {
            stamp,
            frame_id: frame.into(),
        },
        wrench: msgs::Wrench {
            force,
            torque: [0.0, 0.01, -0.02],
        },
    }
    .encode()
}

fn ros2_guidance() -> Vec<Seed> {
    let recent = Time::from_ns(NOW.realtime_ns - 5_000_000);
    let sample = |attachment: Option<&[u8]>, payload: &[u8]| {
        let mut out = Vec::new();
        put_attachment(&mut out, attachment);
        out.extend_from_slice(payload);
        out
    };
    let att = attachment(1);
    let ok = wrench([0.3, 0.0, -0.1], SCENE_FRAME, recent);
    let mut padded = ok.clone();
    padded.extend_from_slice(&[0, 0, 0]);
    let mut big_endian = ok.clone();
    big_endian[1] = 0;
    let mut bad_gid_len = att;
    bad_gid_len[16] = 15;
    let at = |ns: i64| Time::from_ns(NOW.realtime_ns + ns);
    vec![
        seed("wrench", sample(Some(&att), &ok)),
        seed(
            "wrench-unstamped",
            sample(
                Some(&att),
                &wrench([0.3, 0.0, 0.0], SCENE_FRAME, Time::default()),
            ),
        ),
        seed("wrench-padded", sample(Some(&att), &padded)),
        seed(
            "wrench-other-frame",
            sample(Some(&att), &wrench([0.3, 0.0, 0.0], "map", recent)),
        ),
        seed(
            "wrench-future",
            sample(
                Some(&att),
                &wrench([0.3, 0.0, 0.0], SCENE_FRAME, at(500_000_000)),
            ),
        ),
        seed(
            "wrench-stale",
            sample(
                Some(&att),
                &wrench([0.3, 0.0, 0.0], SCENE_FRAME, at(-2_000_000_000)),
            ),
        ),
        seed(
            "wrench-nan",
            sample(
                Some(&att),
                &wrench([f64::NAN, 0.0, 0.0], SCENE_FRAME, recent),
            ),
        ),
        seed(
            "wrench-huge",
            sample(Some(&att), &wrench([2e6, 0.0, 0.0], SCENE_FRAME, recent)),
        ),
        seed("no-attachment", sample(None, &ok)),
        seed("short-attachment", sample(Some(&att[..20]), &ok)),
        seed("bad-gid-length", sample(Some(&bad_gid_len), &ok)),
        seed("big-endian", sample(Some(&att), &big_endian)),
        seed("truncated", sample(Some(&att), &ok[..ok.len() - 9])),
    ]
}

fn pose_stamped(x: f64, q: [f64; 4], stamp: Time) -> Vec<u8> {
    PoseStamped {
        header: msgs::Header {
            stamp,
            frame_id: "base_link".into(),
        },
        pose: msgs::Pose {
            position: [x, 0.2, 0.3],
            orientation: q,
        },
    }
    .encode()
}

fn twist_stamped(linear: [f64; 3]) -> Vec<u8> {
    TwistStamped {
        header: msgs::Header {
            stamp: Time::from_ns(NOW.realtime_ns),
            frame_id: "base_link".into(),
        },
        linear,
        angular: [0.0, 0.0, 0.1],
    }
    .encode()
}

fn joy(buttons: Vec<i32>) -> Vec<u8> {
    Joy {
        header: msgs::Header::default(),
        axes: vec![0.0, 0.5, -1.0],
        buttons,
    }
    .encode()
}

/// A sample of a stream on the device gateway's topics: topic, attachment, payload.
type Sent<'a> = (Topic, Option<&'a [u8]>, Vec<u8>);

fn ros2_device() -> Vec<Seed> {
    const ID: [f64; 4] = [0.0, 0.0, 0.0, 1.0];
    let half = std::f64::consts::FRAC_1_SQRT_2;
    let t = |ms: i64| Time::from_ns(NOW.realtime_ns + ms * 1_000_000);
    let att = attachment(1);
    let a = Some(&att[..]);
    let stream = |samples: &[Sent<'_>]| {
        let mut out = Vec::new();
        for (topic, attachment, payload) in samples {
            put_sample(&mut out, *topic, *attachment, payload);
        }
        out
    };
    vec![
        seed(
            "poses",
            stream(&[
                (Topic::Pose, a, pose_stamped(0.0, ID, t(0))),
                (Topic::Pose, a, pose_stamped(0.001, ID, t(1))),
                (
                    Topic::Pose,
                    a,
                    pose_stamped(0.002, [0.0, 0.0, half, half], t(2)),
                ),
            ]),
        ),
        seed(
            "poses-unstamped",
            stream(&[
                (Topic::Pose, a, pose_stamped(0.0, ID, Time::default())),
                (Topic::Pose, a, pose_stamped(0.001, ID, Time::default())),
            ]),
        ),
        seed(
            "pose-twist-joy",
            stream(&[
                (Topic::Twist, a, twist_stamped([0.1, 0.0, 0.0])),
                (Topic::Joy, a, joy(vec![1, 0, 1])),
                (Topic::Pose, a, pose_stamped(0.0, ID, t(0))),
            ]),
        ),
        seed(
            "bad-pose-then-good",
            stream(&[
                (
                    Topic::Pose,
                    a,
                    pose_stamped(0.0, [0.0, 0.0, 0.0, 2.0], t(0)),
                ),
                (Topic::Pose, a, pose_stamped(1e9, ID, t(1))),
                (Topic::Pose, a, pose_stamped(f64::NAN, ID, t(2))),
                (
                    Topic::Pose,
                    a,
                    pose_stamped(0.0, [0.0, 0.0, 0.0, 1.0005], t(3)),
                ),
            ]),
        ),
        seed(
            "bad-twist-and-joy",
            stream(&[
                (Topic::Twist, a, twist_stamped([f64::INFINITY, 0.0, 0.0])),
                (Topic::Joy, None, joy(vec![1; 40])),
                (Topic::Joy, a, joy(vec![1; 40])),
                (Topic::Pose, a, pose_stamped(0.0, ID, t(0))),
            ]),
        ),
        seed(
            "pose-no-attachment",
            stream(&[(Topic::Pose, None, pose_stamped(0.0, ID, t(0)))]),
        ),
        seed(
            "pose-gap",
            stream(&[
                (Topic::Pose, a, pose_stamped(0.0, ID, t(0))),
                (Topic::Pose, a, pose_stamped(0.01, ID, t(500))),
                (Topic::Pose, a, pose_stamped(0.02, ID, t(400))),
            ]),
        ),
    ]
}
