//! Golden bytes: each payload below is what rosbags 0.11.9 (`Typestore.serialize_cdr`,
//! ROS 2 Jazzy store) writes for the same values (`/tmp`-independent: the values are spelled
//! out here and in the generating script's comment in each test). Our encoder must produce
//! the same bytes, and our decoder must read them back.

use super::*;

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn header(frame: &str) -> Header {
    Header {
        stamp: Time {
            sec: 1_733_312_345,
            nanosec: 123_456_789,
        },
        frame_id: frame.into(),
    }
}

fn pose(x: f64) -> Pose {
    Pose {
        position: [x, -0.25, 1.5],
        orientation: [0.0, 0.0, 0.6, 0.8],
    }
}

fn golden<M: Message + PartialEq + std::fmt::Debug>(m: &M, bytes: &str) {
    let expected = hex(bytes);
    assert_eq!(m.encode(), expected, "{}", M::TYPE.name);
    assert_eq!(&M::decode(&expected).unwrap(), m, "{}", M::TYPE.name);
    // One byte short is an error naming a field, never a panic.
    let e = M::decode(&expected[..expected.len() - 1]).unwrap_err();
    assert!(
        matches!(
            e,
            CdrError::Short { .. }
                | CdrError::Unterminated { .. }
                | CdrError::SequenceTooLong { .. }
        ),
        "{}: {e}",
        M::TYPE.name
    );
}

#[test]
fn pose_stamped() {
    golden(
        &PoseStamped {
            header: header("hrrtc/scene"),
            pose: pose(0.125),
        },
        "00010000593f506715cd5b070c00000068727274632f7363656e6500000000000000c03f000000000000d0bf\
         000000000000f83f00000000000000000000000000000000333333333333e33f9a9999999999e93f",
    );
}

#[test]
fn wrench_stamped() {
    golden(
        &WrenchStamped {
            header: header("hrrtc/object"),
            wrench: Wrench {
                force: [1.0, -2.0, 0.5],
                torque: [0.01, 0.0, -0.02],
            },
        },
        "00010000593f506715cd5b070d00000068727274632f6f626a6563740000000000000000000000000000f03f\
         00000000000000c0000000000000e03f7b14ae47e17a843f00000000000000007b14ae47e17a94bf",
    );
}

#[test]
fn twist_stamped() {
    golden(
        &TwistStamped {
            header: header("arm_base"),
            linear: [0.01, 0.02, -0.03],
            angular: [0.1, 0.0, 0.0],
        },
        "00010000593f506715cd5b070900000061726d5f62617365000000007b14ae47e17a843f7b14ae47e17a943f\
         b81e85eb51b89ebf9a9999999999b93f00000000000000000000000000000000",
    );
}

#[test]
fn tf_message() {
    golden(
        &TfMessage {
            transforms: vec![
                TransformStamped {
                    header: header("hrrtc/scene"),
                    child_frame_id: "hrrtc/object".into(),
                    translation: [0.1, 0.2, 0.3],
                    rotation: [0.0, 0.0, 0.0, 1.0],
                },
                TransformStamped {
                    header: header("hrrtc/device_base"),
                    child_frame_id: "hrrtc/dev".into(),
                    translation: [-0.1, 0.0, 0.05],
                    rotation: [0.0, 0.6, 0.0, 0.8],
                },
            ],
        },
        "0001000002000000593f506715cd5b070c00000068727274632f7363656e65000d00000068727274632f6f62\
         6a656374000000009a9999999999b93f9a9999999999c93f333333333333d33f000000000000000000000000\
         000000000000000000000000000000000000f03f593f506715cd5b071200000068727274632f646576696365\
         5f626173650000000a00000068727274632f6465760000009a9999999999b9bf00000000000000009a999999\
         9999a93f0000000000000000333333333333e33f00000000000000009a9999999999e93f",
    );
}

#[test]
fn path() {
    golden(
        &Path {
            header: header("hrrtc/scene"),
            poses: vec![
                PoseStamped {
                    header: header("hrrtc/scene"),
                    pose: pose(0.0),
                },
                PoseStamped {
                    header: header("hrrtc/scene"),
                    pose: pose(1.0),
                },
            ],
        },
        "00010000593f506715cd5b070c00000068727274632f7363656e650002000000593f506715cd5b070c000000\
         68727274632f7363656e6500000000000000000000000000000000000000d0bf000000000000f83f00000000\
         000000000000000000000000333333333333e33f9a9999999999e93f593f506715cd5b070c00000068727274\
         632f7363656e6500000000000000f03f000000000000d0bf000000000000f83f000000000000000000000000\
         00000000333333333333e33f9a9999999999e93f",
    );
}

#[test]
fn marker_array() {
    golden(
        &MarkerArray {
            markers: vec![Marker {
                header: header("hrrtc/scene"),
                ns: "path".into(),
                id: 3,
                kind: marker::LINE_STRIP,
                action: marker::ADD,
                pose: pose(0.0),
                scale: [0.002, 0.0, 0.0],
                color: Color {
                    r: 0.2,
                    g: 0.8,
                    b: 0.2,
                    a: 1.0,
                },
                lifetime: Time::default(),
                frame_locked: true,
                points: vec![[0.0, 0.0, 0.0], [0.5, 0.25, 0.125]],
                colors: vec![],
                text: "hi".into(),
                mesh_resource: String::new(),
            }],
        },
        "0001000001000000593f506715cd5b070c00000068727274632f7363656e6500050000007061746800000000\
         030000000400000000000000000000000000000000000000000000000000d0bf000000000000f83f00000000\
         000000000000000000000000333333333333e33f9a9999999999e93ffca9f1d24d62603f0000000000000000\
         0000000000000000cdcc4c3ecdcc4c3fcdcc4c3e0000803f0000000000000000010000000200000000000000\
         0000000000000000000000000000000000000000000000000000e03f000000000000d03f000000000000c03f\
         0000000001000000000000000000000000000000010000000000000001000000000000000000000000000000\
         0300000068690000010000000000000001000000000000000000000000",
    );
}

#[test]
fn float64_multi_array() {
    golden(
        &Float64MultiArray {
            dims: vec![("contact".into(), 3, 3)],
            data_offset: 0,
            data: vec![3.0, -0.5, 1e-3],
        },
        "000100000100000008000000636f6e74616374000300000003000000000000000300000000000000000008\
         40000000000000e0bffca9f1d24d62503f",
    );
}

#[test]
fn joy() {
    golden(
        &Joy {
            header: header("arm"),
            axes: vec![0.5, -1.0],
            buttons: vec![1, 0, 1],
        },
        "00010000593f506715cd5b070400000061726d00020000000000003f000080bf030000000100000000000000\
         01000000",
    );
}

#[test]
fn stamps_convert_both_ways() {
    let t = Time::from_ns(1_733_312_345_123_456_789);
    assert_eq!(
        t,
        Time {
            sec: 1_733_312_345,
            nanosec: 123_456_789
        }
    );
    assert_eq!(t.as_ns(), 1_733_312_345_123_456_789);
    assert_eq!(
        Time::from_ns(-1),
        Time {
            sec: -1,
            nanosec: 999_999_999
        }
    );
}
