//! [`HapticState`]: what the haptic loop publishes every tick.

use crate::{ContactCode, FaultCode, GuidanceFreshness, Header, Pose, Twist, Wrench};
use iceoryx2::prelude::ZeroCopySend;

/// The operator's side of the world, written by the haptic loop once per tick.
///
/// Semantics: latest value (see [`crate::services::HAPTIC_STATE`]). A reader that polls it
/// sees every tick only if it polls faster than the loop; `header.sequence` tells it how many
/// it skipped.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, ZeroCopySend)]
#[type_name("hrrtc::HapticState.v2")]
pub struct HapticState {
    /// Sequence = tick number since the loop started (from 1); timestamp = start of the tick.
    pub header: Header,

    /// End-effector pose as the device reports it, device frame.
    pub device_pose: Pose,
    /// End-effector velocity, device frame.
    pub device_twist: Twist,
    /// Device pose mapped into the scene (scale, offset, clutch): the operator's
    /// configuration `q_user` (I-RRT) / `q_device` (H-RRT-C), scene frame. It is the pose
    /// of the moving object's reference point.
    pub user_pose: Pose,
    /// Pose of the proxy (avatar) object, scene frame. Equal to `user_pose` while contact
    /// rendering is off; held out of the obstacles by the virtual coupling when it is on.
    pub proxy_pose: Pose,

    /// Wrench written to the device this tick after all limits, device frame; torque about
    /// the end-effector point.
    pub commanded_wrench: Wrench,
    /// Contact wrench on the proxy from the scene, scene frame; torque about the object's
    /// reference point.
    pub contact_wrench: Wrench,
    /// Guidance wrench F_s = k·F_a actually rendered this tick (after fade and bound), scene
    /// frame; torque about the object's reference point.
    pub guidance_wrench: Wrench,

    /// [`ContactCode`] of this tick.
    pub contact: ContactCode,
    /// [`FaultCode`]; `FaultCode::NONE` when forces are rendered.
    pub fault: FaultCode,
    /// Device buttons, bit i = button i pressed.
    pub buttons: u32,
    /// [`GuidanceFreshness`] of the guidance rendered this tick.
    pub guidance_freshness: GuidanceFreshness,

    /// Unit contact normal n_c of the first contact, held while contact lasts (H-RRT-C),
    /// pointing out of the obstacle, scene frame. Zero when not in contact.
    pub contact_normal: [f64; 3],
    /// Contact point on the obstacle surface, scene frame, m. Zero when not in contact.
    pub contact_point_m: [f64; 3],
    /// Operator force f_u: the force the operator applies to the object through the
    /// coupling, scene frame, N.
    pub operator_force_n: [f64; 3],
    /// Δp: proxy displacement since the previous tick, scene frame, m.
    pub displacement_m: [f64; 3],
    /// Deepest penetration of a pointshell point into the scene this tick, m (0 when not
    /// penetrating or contact rendering is off).
    pub penetration_m: f64,

    /// `header.sequence` of the [`crate::Guidance`] rendered this tick, 0 if none.
    pub guidance_sequence: u64,
    /// Wake-up latency of the previous tick (actual wake − deadline), ns.
    pub prev_wake_latency_ns: u64,
    /// Compute time of the previous tick (wake → publish), ns.
    pub prev_compute_ns: u64,
    /// Period between the previous two wake-ups, ns.
    pub prev_period_ns: u64,
    /// Deadline misses since start.
    pub deadline_misses: u64,
    /// `CLOCK_MONOTONIC` time the loop handed this state to the transport (just before the
    /// blackboard write), ns; 0 where it was not published. `header.timestamp_ns` − this is
    /// the tick's compute before publishing; a reader's clock − this is the transport's
    /// latency.
    pub published_ns: u64,
}

const _: () = {
    assert!(core::mem::size_of::<HapticState>() == 552);
    assert!(core::mem::align_of::<HapticState>() == 8);
};
