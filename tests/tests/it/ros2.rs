//! A ROS 2 arm driver as the loop's device: `haptic-loop run --device ros2:...` starts
//! `hrrtc-ros2 device` beside itself, and this test plays the driver on rmw_zenoh's wire (a
//! `hrrtc_ros2` participant connected to the gateway over loopback TCP): its poses reach the
//! loop, the loop's wrench commands come back, and a bad pose or a silent driver makes the
//! loop latch zero force. (The wire itself is checked against rosbags and zenoh-ext by the
//! Python tests in `gateways/ros2/python`.)

use hrrtc_ros2::msgs::{Header, Message, Pose, PoseStamped, WrenchStamped};
use hrrtc_ros2::participant::{Participant, SessionConfig};
use hrrtc_ros2::rmw::{self, Attachment, Distro, Qos, TypeInfo};
use ipc_types::{FaultCode, HapticState, services};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tests::{free_port, norm, one_loop_at_a_time, unique_namespace, wait_for};
use zenoh::Wait;

/// What the driver thread sends each millisecond.
const GOOD: u8 = 0;
const ONE_NAN: u8 = 1;
const SILENT: u8 = 2;

#[test]
fn a_ros2_driver_is_the_loops_device_and_a_bad_or_silent_one_fails_safe() {
    let _serial = one_loop_at_a_time();
    let ns = unique_namespace("ros2dev");
    let port = free_port();
    let (pose_topic, wrench_topic) = (format!("/{ns}/pose"), format!("/{ns}/wrench"));
    let spec = format!(
        "ros2:pose={pose_topic},wrench={wrench_topic},max_force=4,workspace=0.1,stale_ms=50,\
         listen=tcp/127.0.0.1:{port},insecure=true"
    );
    let (node, _) = services::create_node("it_ros2_watch").unwrap();
    let state = services::state_reader(&node, &ns).unwrap();
    let _lp = tests::start_loop(
        &ns,
        &[
            "--priority",
            "0",
            "--no-contact",
            "--duration-s",
            "60",
            "--device",
            &spec,
        ],
    );
    let driver = Participant::open(
        &SessionConfig {
            distro: Distro::Jazzy,
            ..SessionConfig::insecure(Vec::new(), vec![format!("tcp/127.0.0.1:{port}")])
        },
        "/",
        "it_arm_driver",
    )
    .unwrap();
    let poses = driver
        .publisher::<PoseStamped>(&pose_topic, Qos::volatile(1), true)
        .unwrap();
    let wrenches: Arc<Mutex<Vec<(WrenchStamped, Attachment)>>> = Arc::default();
    let wrench_key = rmw::topic_key(
        0,
        &wrench_topic,
        &TypeInfo::of(WrenchStamped::TYPE, Distro::Jazzy),
    );
    let _sub = {
        let wrenches = wrenches.clone();
        driver
            .session()
            .declare_subscriber(wrench_key)
            .callback(move |s| {
                let a = Attachment::decode(s.attachment().map(|a| a.to_bytes()).as_deref());
                if let (Ok(w), Ok(a)) = (WrenchStamped::decode(&s.payload().to_bytes()), a) {
                    wrenches.lock().unwrap().push((w, a));
                }
            })
            .wait()
            .unwrap()
    };
    // The driver: an arm at rest 1 cm along x, sampled at 1 kHz.
    let mode = Arc::new(AtomicU8::new(GOOD));
    let done = Arc::new(AtomicBool::new(false));
    let thread = {
        let (mode, done) = (mode.clone(), done.clone());
        std::thread::spawn(move || {
            let mut next = ipc_types::monotonic_ns();
            while !done.load(Ordering::Acquire) {
                next += 1_000_000;
                ipc_types::sleep_until_ns(next);
                let x = match mode.load(Ordering::Acquire) {
                    SILENT => continue,
                    ONE_NAN => {
                        mode.store(GOOD, Ordering::Release);
                        f64::NAN
                    }
                    _ => 0.01,
                };
                let msg = PoseStamped {
                    header: Header {
                        frame_id: "arm_base".into(),
                        ..Header::default()
                    },
                    pose: Pose {
                        position: [x, 0.0, 0.0],
                        orientation: [0.0, 0.0, 0.0, 1.0],
                    },
                };
                poses.publish(&msg, hrrtc_ros2::clock::realtime_ns());
            }
        })
    };
    let newer = |what: &str, cond: &dyn Fn(&HapticState) -> bool| -> HapticState {
        wait_for(what, Duration::from_secs(30), || {
            let s = *state.get();
            (s.header.sequence > 0 && cond(&s)).then_some(s)
        })
    };
    newer("the driver's pose in the loop, forces on", &|s| {
        (s.device_pose.position_m[0] - 0.01).abs() < 1e-12 && s.fault == FaultCode::NONE
    });
    wait_for("wrench commands", Duration::from_secs(10), || {
        (!wrenches.lock().unwrap().is_empty()).then_some(())
    });
    {
        let w = wrenches.lock().unwrap();
        let (last, att) = w.last().unwrap();
        assert_eq!(last.header.frame_id, "arm_base");
        assert!(norm(last.wrench.force) <= 4.0 + 1e-9, "{last:?}");
        assert!(last.wrench.force.iter().all(|v| v.is_finite()));
        let seqs: Vec<i64> = w.iter().map(|(_, a)| a.sequence).collect();
        assert!(seqs.windows(2).all(|p| p[0] < p[1]), "attachment sequence");
        assert!(att.source_timestamp_ns > 0);
    }
    // One NaN pose among good ones: a read fault (not a stale one), zero force.
    mode.store(ONE_NAN, Ordering::Release);
    let s = newer("a fault after the NaN pose", &|s| {
        s.fault != FaultCode::NONE
    });
    assert_eq!(s.fault, FaultCode::DEVICE_READ, "{}", s.fault.name());
    assert_eq!(s.commanded_wrench.force_n, [0.0; 3]);
    newer("forces back after the fault", &|s| {
        s.fault == FaultCode::NONE
    });
    // The driver falls silent: stale, a fault, zero force.
    mode.store(SILENT, Ordering::Release);
    let s = newer("a stale driver", &|s| s.fault != FaultCode::NONE);
    assert_eq!(
        s.fault,
        FaultCode::DEVICE_DISCONNECTED,
        "{}",
        s.fault.name()
    );
    assert_eq!(s.commanded_wrench.force_n, [0.0; 3]);
    done.store(true, Ordering::Release);
    thread.join().unwrap();
}
