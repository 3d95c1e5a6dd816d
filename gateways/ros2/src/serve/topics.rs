//! The gateway's topics and frames, and what one tick's [`HapticState`] becomes on them.
//!
//! Frames (REP-103: right-handed, metres), named under the gateway's ROS namespace without its
//! leading `/` (namespace `/hrrtc`: `hrrtc/scene`, ...):
//!
//! | frame | what | parent (TF) |
//! |---|---|---|
//! | `scene` | the scene's frame (Z up) | `--parent-frame` if given, by an identity on `/tf_static` |
//! | `object` | the rendered object (the contact proxy), at its reference point | `scene`, `/tf` every published tick |
//! | `hand` | the object where the hand holds it (the device pose mapped into the scene: q_user) | `scene`, `/tf` |
//! | `start`, `goal` | the scene's query | `scene`, `/tf_static` |
//! | `device_base` | the arm's base frame as its driver reports it (not joined to `scene`: the loop's mapping scales, which no transform can) | none |
//! | `device` | the arm's end effector | `device_base`, `/tf` |
//!
//! Topics, every published tick (all `header.stamp` the tick's start in ROS time):
//! `object_pose`, `hand_pose` (PoseStamped, `scene`), `device_pose` (PoseStamped,
//! `device_base`), `commanded_wrench` (WrenchStamped, `device`: the wrench written to the arm,
//! about the end effector), `guidance_wrench` and `contact_wrench` (WrenchStamped, `object`:
//! F_s rendered this tick and the contact wrench on the proxy, about the object's reference
//! point), `contact` (Float64MultiArray, [`CONTACT_LABEL`]), `/tf`.

use ipc_types::HapticState;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::msgs::{
    Float64MultiArray, Header, Pose, PoseStamped, TfMessage, Time, TransformStamped, Wrench,
    WrenchStamped,
};

/// The layout label of the `contact` topic: ten values, the contact code (0 contact rendering
/// off, 1 free, 2 proximity, 3 touching), the held contact normal n_c (unit, out of the
/// obstacle, `scene` axes), the contact point (m, `scene`), the deepest penetration (m), and
/// the tick's stamp as in the other topics' headers (seconds, nanoseconds).
pub const CONTACT_LABEL: &str =
    "code,normal_x,normal_y,normal_z,point_x,point_y,point_z,penetration_m,stamp_sec,stamp_nanosec";
/// Values in a `contact` sample.
pub const CONTACT_LEN: u32 = 10;

/// The gateway's frame names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frames {
    /// The scene.
    pub scene: String,
    /// The rendered object (proxy).
    pub object: String,
    /// The object as held (q_user).
    pub hand: String,
    /// The arm's base.
    pub device_base: String,
    /// The arm's end effector.
    pub device: String,
    /// The query's start.
    pub start: String,
    /// The query's goal.
    pub goal: String,
}

impl Frames {
    /// Frames under `ros_namespace` (absolute): `/hrrtc` gives `hrrtc/scene`, ...; `/` gives
    /// `scene`, ...
    pub fn new(ros_namespace: &str) -> Self {
        let p = ros_namespace.trim_matches('/');
        let f = |leaf: &str| {
            if p.is_empty() {
                leaf.to_owned()
            } else {
                format!("{p}/{leaf}")
            }
        };
        Frames {
            scene: f("scene"),
            object: f("object"),
            hand: f("hand"),
            device_base: f("device_base"),
            device: f("device"),
            start: f("start"),
            goal: f("goal"),
        }
    }
}

/// One tick on the gateway's topics.
#[derive(Debug, Clone, PartialEq)]
pub struct StateMessages {
    /// `object_pose`.
    pub object_pose: PoseStamped,
    /// `hand_pose`.
    pub hand_pose: PoseStamped,
    /// `device_pose`.
    pub device_pose: PoseStamped,
    /// `commanded_wrench`.
    pub commanded_wrench: WrenchStamped,
    /// `guidance_wrench`.
    pub guidance_wrench: WrenchStamped,
    /// `contact_wrench`.
    pub contact_wrench: WrenchStamped,
    /// `contact`.
    pub contact: Float64MultiArray,
    /// `/tf`.
    pub tf: TfMessage,
}

fn rotation(q: &[f64; 4]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2]))
}

/// `w` (vectors in a parent frame's axes) in the axes of a frame oriented `q` in it.
fn into_frame(q: &[f64; 4], w: &ipc_types::Wrench) -> Wrench {
    let r = rotation(q);
    let f = r.inverse_transform_vector(&Vector3::from(w.force_n));
    let t = r.inverse_transform_vector(&Vector3::from(w.torque_nm));
    Wrench {
        force: f.into(),
        torque: t.into(),
    }
}

fn transform(header: &Header, child: &str, p: &ipc_types::Pose) -> TransformStamped {
    TransformStamped {
        header: header.clone(),
        child_frame_id: child.to_owned(),
        translation: p.position_m,
        rotation: p.orientation_xyzw,
    }
}

/// What tick `s` publishes, its headers stamped `stamp` (the tick's start in ROS time).
pub fn state_messages(s: &HapticState, stamp: Time, f: &Frames) -> StateMessages {
    let header = |frame: &str| Header {
        stamp,
        frame_id: frame.to_owned(),
    };
    let pose = |frame: &str, p: &ipc_types::Pose| PoseStamped {
        header: header(frame),
        pose: Pose::from(*p),
    };
    let wrench = |frame: &str, q: &[f64; 4], w: &ipc_types::Wrench| WrenchStamped {
        header: header(frame),
        wrench: into_frame(q, w),
    };
    let mut contact = Vec::with_capacity(CONTACT_LEN as usize);
    contact.push(f64::from(s.contact.0));
    contact.extend_from_slice(&s.contact_normal);
    contact.extend_from_slice(&s.contact_point_m);
    contact.push(s.penetration_m);
    contact.push(f64::from(stamp.sec));
    contact.push(f64::from(stamp.nanosec));
    let scene = header(&f.scene);
    StateMessages {
        object_pose: pose(&f.scene, &s.proxy_pose),
        hand_pose: pose(&f.scene, &s.user_pose),
        device_pose: pose(&f.device_base, &s.device_pose),
        commanded_wrench: wrench(
            &f.device,
            &s.device_pose.orientation_xyzw,
            &s.commanded_wrench,
        ),
        guidance_wrench: wrench(
            &f.object,
            &s.proxy_pose.orientation_xyzw,
            &s.guidance_wrench,
        ),
        contact_wrench: wrench(&f.object, &s.proxy_pose.orientation_xyzw, &s.contact_wrench),
        contact: Float64MultiArray {
            dims: vec![(CONTACT_LABEL.to_owned(), CONTACT_LEN, CONTACT_LEN)],
            data_offset: 0,
            data: contact,
        },
        tf: TfMessage {
            transforms: vec![
                transform(&scene, &f.object, &s.proxy_pose),
                transform(&scene, &f.hand, &s.user_pose),
                transform(&header(&f.device_base), &f.device, &s.device_pose),
            ],
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipc_types::ContactCode;

    fn state() -> HapticState {
        let quarter_turn_z = [
            0.0,
            0.0,
            std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
        ];
        let mut s = HapticState::default();
        s.header.sequence = 9;
        s.proxy_pose = ipc_types::Pose {
            position_m: [0.1, 0.2, 0.3],
            orientation_xyzw: quarter_turn_z,
        };
        s.user_pose = ipc_types::Pose {
            position_m: [0.1, 0.2, 0.31],
            orientation_xyzw: quarter_turn_z,
        };
        s.device_pose.position_m = [0.01, 0.0, 0.0];
        s.commanded_wrench.force_n = [1.0, 0.0, 0.0];
        s.guidance_wrench.force_n = [0.0, 2.0, 0.0];
        s.contact_wrench.torque_nm = [0.0, 0.0, 0.5];
        s.contact = ContactCode::CONTACT;
        s.contact_normal = [0.0, 0.0, 1.0];
        s.contact_point_m = [0.1, 0.2, 0.25];
        s.penetration_m = 1e-4;
        s
    }

    #[test]
    fn a_tick_becomes_its_topics_in_their_frames() {
        let f = Frames::new("/hrrtc");
        assert_eq!(f.scene, "hrrtc/scene");
        assert_eq!(Frames::new("/").device, "device");
        let stamp = Time {
            sec: 10,
            nanosec: 5,
        };
        let m = state_messages(&state(), stamp, &f);
        assert_eq!(m.object_pose.header.frame_id, "hrrtc/scene");
        assert_eq!(m.object_pose.header.stamp, stamp);
        assert_eq!(m.object_pose.pose.position, [0.1, 0.2, 0.3]);
        assert_eq!(m.hand_pose.pose.position, [0.1, 0.2, 0.31]);
        assert_eq!(m.device_pose.header.frame_id, "hrrtc/device_base");
        // The device is not rotated: its wrench keeps its axes.
        assert_eq!(m.commanded_wrench.header.frame_id, "hrrtc/device");
        assert_eq!(m.commanded_wrench.wrench.force, [1.0, 0.0, 0.0]);
        // The object is turned a quarter about z: the scene's +y is its +x.
        let g = m.guidance_wrench.wrench.force;
        assert!((g[0] - 2.0).abs() < 1e-12 && g[1].abs() < 1e-12, "{g:?}");
        assert_eq!(m.guidance_wrench.header.frame_id, "hrrtc/object");
        assert!((m.contact_wrench.wrench.torque[2] - 0.5).abs() < 1e-12);
        assert_eq!(
            m.contact.data,
            vec![3.0, 0.0, 0.0, 1.0, 0.1, 0.2, 0.25, 1e-4, 10.0, 5.0]
        );
        assert_eq!(m.contact.dims[0].0.split(',').count(), CONTACT_LEN as usize);
        let children: Vec<_> = m.tf.transforms.iter().map(|t| &t.child_frame_id).collect();
        assert_eq!(children, ["hrrtc/object", "hrrtc/hand", "hrrtc/device"]);
        assert_eq!(m.tf.transforms[2].header.frame_id, "hrrtc/device_base");
    }
}
