//! Any sample on `hrrtc-ros2 serve`'s guidance topic: its attachment, the `WrenchStamped`
//! in its payload and the whole per-sample check of the subscriber's callback,
//! `GuidanceInput::accept`, at a few clock readings.
//!
//! Input: one byte of attachment length (255: no attachment), the attachment, then the
//! payload (the rest).

use crate::ros2::{self, Sample};
use hrrtc_ros2::clock::Clocks;
use hrrtc_ros2::msgs::WrenchStamped;
use hrrtc_ros2::rejections::Rejected;
use hrrtc_ros2::serve::guidance::{GuidanceInput, Rejection};
use ipc_types::GuidanceMode;

/// The guidance topic's key (type and hash as `serve` subscribes to them).
pub const KEY: &str = "0/hrrtc/guidance/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_fuzz";
/// The scene frame guidance must be in.
pub const SCENE_FRAME: &str = "hrrtc/scene";
/// The guidance time-to-live, ns (serve's default, 100 ms).
pub const TTL_NS: u64 = 100_000_000;
/// This host's clocks when the seeds' samples arrive: 10 s after boot, November 2023.
pub const NOW: Clocks = Clocks {
    monotonic_ns: 10_000_000_000,
    realtime_ns: 1_700_000_000_000_000_000,
};
/// A host up for 400 days at the last second of ROS's 32-bit `sec` (January 2038).
const LATE: Clocks = Clocks {
    monotonic_ns: 400 * 86_400_000_000_000,
    realtime_ns: i32::MAX as i64 * 1_000_000_000,
};
/// The newest tick seen, handed on with each sample.
const STATE_SEQUENCE: u64 = 42;

/// Any attachment and payload on the guidance topic: decoding never panics, a decoded
/// attachment or `WrenchStamped` re-encodes to itself, and what `accept` hands to the loop
/// is the wrench, finite and within the loop's own check, stamped in the past within its
/// time-to-live; what it refuses is refused for a reason that matches the sample.
pub fn ros2_guidance(data: &[u8]) {
    let Some((attachment, payload)) = ros2::take_attachment(data) else {
        return;
    };
    let sample = Sample {
        attachment,
        payload,
    };
    let attached = ros2::attachment(sample.attachment);
    let wrench = ros2::message::<WrenchStamped>(sample.payload);
    // A clock that reads the sample's own stamp 5 ms after it, so that any stamp gets past
    // the time checks.
    let own = wrench.as_ref().map(|w| Clocks {
        realtime_ns: w.header.stamp.as_ns() + 5_000_000,
        ..NOW
    });
    for now in [Some(NOW), Some(LATE), own].into_iter().flatten() {
        accept(sample, attached, wrench.as_ref(), now);
    }
}

/// One sample through `GuidanceInput::accept` at `now`.
fn accept(sample: Sample<'_>, attached: bool, wrench: Option<&WrenchStamped>, now: Clocks) {
    let mut input = GuidanceInput::new(KEY.into(), SCENE_FRAME.into(), TTL_NS, 77);
    let other = KEY.replace("WrenchStamped_", "PoseStamped_");
    assert!(matches!(
        input.accept(&other, sample.payload, sample.attachment, now, 1),
        Err(Rejection::WrongType { .. })
    ));
    let result = input.accept(KEY, sample.payload, sample.attachment, now, STATE_SEQUENCE);
    let g = match result {
        Ok(g) => g,
        Err(e) => {
            assert!(Rejection::KINDS.contains(&e.kind()));
            assert!(!e.to_string().is_empty());
            match e {
                Rejection::Attachment(_) => assert!(!attached),
                Rejection::Cdr(_) => assert!(attached && wrench.is_none()),
                Rejection::WrongType { .. } => panic!("our own key refused: {e}"),
                _ => assert!(attached && wrench.is_some(), "{e}"),
            }
            return;
        }
    };
    assert!(attached, "accepted without an attachment");
    let w = wrench.expect("accepted without a WrenchStamped");
    assert_eq!(w.header.frame_id, SCENE_FRAME);
    assert_eq!(g.validate(), Ok(()), "handed to the loop");
    let [fx, fy, fz] = w.wrench.force;
    let [tx, ty, tz] = w.wrench.torque;
    let expected = [fx, fy, fz, tx, ty, tz];
    assert!(g.attractive.iter().all(|v| v.is_finite()));
    assert_eq!(g.attractive.map(f64::to_bits), expected.map(f64::to_bits));
    assert_eq!((g.gain_n_per_m, g.gain_nm_per_rad), (1.0, 1.0));
    assert_eq!(g.mode, GuidanceMode::PATH);
    assert_eq!((g.header.sequence, g.state_sequence), (1, STATE_SEQUENCE));
    assert_eq!(g.time_to_live_ns, TTL_NS);
    // Stamped after zero, not after now, and fresh.
    let stamp = g.header.timestamp_ns;
    assert!(stamp >= 1 && stamp <= now.monotonic_ns, "stamp {stamp}");
    assert!(now.monotonic_ns - stamp <= TTL_NS, "stamp {stamp}");
    // Only accepted samples take a sequence number.
    let again = input.accept(KEY, sample.payload, sample.attachment, now, 0);
    assert_eq!(again.map(|g| g.header.sequence), Ok(2));
}
