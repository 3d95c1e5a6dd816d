//! Any stream of samples on `hrrtc-ros2 device`'s topics: the arm's poses
//! (`PoseStamped`), velocities (`TwistStamped`) and buttons (`Joy`), each with its
//! attachment, through what the subscribers' callbacks do with them.
//!
//! The callbacks and the state they share are private to the gateway; they are built from
//! public pieces (`Attachment::decode`, `Message::decode`, `PoseTracker::update`,
//! `DriverState`), which [`Arm`] puts together as `Shared::state_for_pose` and the velocity
//! and button callbacks do, so that every `DriverState` the gateway would hand to the loop
//! is checked as the loop checks it (`DriverState::validate`).
//!
//! Input: samples one after another, one each millisecond, each as a topic byte (its value
//! mod 3: 0 pose, 1 velocity, 2 buttons), one byte of attachment length (255: none), the
//! attachment, the payload's length (`u16`, little-endian) and the payload.

use crate::ros2::{self, Sample};
use hrrtc_ros2::device::{DeviceConfig, FAULT_HOLD_NS, MAX_REACH_M, PoseRejection, PoseTracker};
use hrrtc_ros2::msgs::{Joy, Message, PoseStamped, Time, TwistStamped};
use hrrtc_ros2::rmw::Attachment;
use ipc_types::{DriverState, DriverStatus, Header, Pose, Twist};

/// Most samples read from one input.
const MAX_SAMPLES: usize = 64;
/// The arrival time of the first sample, ns (10 s after boot); one more ms each.
const FIRST_ARRIVAL_NS: u64 = 10_000_000_000;

/// A topic of the device gateway.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Topic {
    /// The arm's pose.
    Pose = 0,
    /// Its velocity.
    Twist = 1,
    /// Its buttons.
    Joy = 2,
}

/// Any samples on the device gateway's topics: decoding never panics, decoded attachments
/// and messages re-encode to themselves, and every `DriverState` handed to the loop passes
/// the loop's check (finite, a unit quaternion, within the arm's reach) with the status the
/// samples call for.
pub fn ros2_device(data: &[u8]) {
    let config = DeviceConfig::new("fuzz", "/arm/pose", "/arm/wrench");
    let mut arm = Arm::new(&config);
    let mut now_ns = FIRST_ARRIVAL_NS;
    let mut rest = data;
    for _ in 0..MAX_SAMPLES {
        let Some((topic, sample, next)) = take_sample(rest) else {
            break;
        };
        rest = next;
        now_ns += 1_000_000;
        match topic {
            Topic::Pose => arm.pose(sample, now_ns),
            Topic::Twist => arm.twist(sample),
            Topic::Joy => arm.joy(sample),
        }
    }
}

/// One sample off `data`, and what follows it.
fn take_sample(data: &[u8]) -> Option<(Topic, Sample<'_>, &[u8])> {
    let (&topic, rest) = data.split_first()?;
    let topic = match topic % 3 {
        0 => Topic::Pose,
        1 => Topic::Twist,
        _ => Topic::Joy,
    };
    let (attachment, rest) = ros2::take_attachment(rest)?;
    let (len, rest) = match rest {
        [a, b, rest @ ..] => (usize::from(u16::from_le_bytes([*a, *b])), rest),
        _ => (rest.len(), &[][..]),
    };
    let (payload, rest) = rest.split_at(len.min(rest.len()));
    let sample = Sample {
        attachment,
        payload,
    };
    Some((topic, sample, rest))
}

/// A sample on `topic` as [`ros2_device`] reads it.
pub fn put_sample(out: &mut Vec<u8>, topic: Topic, attachment: Option<&[u8]>, payload: &[u8]) {
    out.push(topic as u8);
    ros2::put_attachment(out, attachment);
    let len = u16::try_from(payload.len()).expect("a payload of less than 64 KiB");
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(payload);
}

/// The device gateway's state shared by its callbacks (`device::Shared`).
struct Arm<'a> {
    config: &'a DeviceConfig,
    tracker: PoseTracker,
    twist: Option<Twist>,
    buttons: u32,
    sequence: u64,
    last_good: Pose,
    fault_until_ns: u64,
}

impl<'a> Arm<'a> {
    fn new(config: &'a DeviceConfig) -> Self {
        Arm {
            config,
            tracker: PoseTracker::new(config.velocity_filter_s),
            twist: None,
            buttons: 0,
            sequence: 0,
            last_good: Pose::IDENTITY,
            fault_until_ns: 0,
        }
    }

    /// A pose sample: the arm's state, or the last good pose at rest as `FAULT`
    /// (`Shared::state_for_pose`).
    fn pose(&mut self, sample: Sample<'_>, now_ns: u64) {
        let attached = ros2::attachment(sample.attachment);
        let message = ros2::message::<PoseStamped>(sample.payload);
        let result = Attachment::decode(sample.attachment)
            .map_err(PoseRejection::from)
            .and_then(|_| PoseStamped::decode(sample.payload).map_err(PoseRejection::from))
            .and_then(|p| {
                let t = if p.header.stamp == Time::default() {
                    now_ns as i64
                } else {
                    p.header.stamp.as_ns()
                };
                self.tracker.update(&p.pose, t)
            });
        self.sequence += 1;
        let state = match result {
            Ok((pose, twist)) => {
                let p = message.expect("a pose accepted without a PoseStamped");
                assert!(attached, "a pose accepted without an attachment");
                assert_eq!(
                    pose.position_m.map(f64::to_bits),
                    p.pose.position.map(f64::to_bits)
                );
                assert!(pose.position_m.iter().all(|v| v.is_finite()));
                let distance_m = pose.position_m.iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!(distance_m <= MAX_REACH_M * (1.0 + 1e-12), "{distance_m} m");
                // The orientation is the sample's, renormalised.
                let q = p.pose.orientation;
                let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() <= 1e-3 + 1e-12, "norm {norm}");
                for (out, given) in pose.orientation_xyzw.iter().zip(q) {
                    assert!((out - given / norm).abs() < 1e-9, "{out} from {given}");
                }
                self.last_good = pose;
                let status = if now_ns < self.fault_until_ns {
                    DriverStatus::FAULT
                } else {
                    DriverStatus::OK
                };
                self.state(now_ns, pose, self.twist.unwrap_or(twist), status)
            }
            Err(e) => {
                assert!(!e.to_string().is_empty());
                match e {
                    PoseRejection::Attachment(_) => assert!(!attached),
                    PoseRejection::Cdr(_) => assert!(attached && message.is_none()),
                    PoseRejection::WrongType(_) => panic!("a wrong type from its payload"),
                    _ => assert!(attached && message.is_some(), "{e}"),
                }
                self.fault_until_ns = now_ns + FAULT_HOLD_NS;
                self.state(
                    now_ns,
                    self.last_good,
                    Twist::default(),
                    DriverStatus::FAULT,
                )
            }
        };
        assert_eq!(state.validate(), Ok(()), "a state for the loop: {state:?}");
    }

    /// A velocity sample: the arm's own velocity while good, none after a bad one.
    fn twist(&mut self, sample: Sample<'_>) {
        let attached = ros2::attachment(sample.attachment);
        let message = ros2::message::<TwistStamped>(sample.payload).filter(|_| attached);
        self.twist = match message {
            Some(tw) if tw.linear.iter().chain(&tw.angular).all(|v| v.is_finite()) => Some(Twist {
                linear_m_s: tw.linear,
                angular_rad_s: tw.angular,
            }),
            _ => None,
        };
    }

    /// A buttons sample: bit i for `buttons[i] != 0`, of the first 32.
    fn joy(&mut self, sample: Sample<'_>) {
        let attached = ros2::attachment(sample.attachment);
        if let Some(j) = ros2::message::<Joy>(sample.payload).filter(|_| attached) {
            self.buttons = j.button_mask();
            let pressed = j.buttons.iter().take(32).filter(|b| **b != 0).count();
            assert_eq!(self.buttons.count_ones() as usize, pressed);
        }
    }

    /// The state handed to the loop (`device::driver_state`).
    fn state(&self, now_ns: u64, pose: Pose, twist: Twist, status: DriverStatus) -> DriverState {
        let mut s = DriverState {
            header: Header::new(self.sequence, now_ns, std::process::id()),
            pose,
            twist,
            buttons: self.buttons,
            status,
            button_count: self.config.buttons,
            orientation_input: u32::from(self.config.orientation_input),
            ..DriverState::default()
        }
        .with_limits(&self.config.limits);
        s.set_name(&self.config.name);
        s
    }
}
