//! Device-level tests from byte sequences, per report format and model family.

use nalgebra::Vector3;

use super::report::known_model;
use super::*;

const MS: u64 = 1_000_000;

fn navigator() -> (SpaceMouse, Feed) {
    let model = known_model(0x046d, 0xc626).expect("SpaceNavigator in table");
    let (mut dev, mut feed) = SpaceMouse::with_feed(SpaceMouseConfig::default(), model).unwrap();
    feed.attach();
    dev.open().unwrap();
    (dev, feed)
}

fn compact() -> (SpaceMouse, Feed) {
    let model = known_model(0x256f, 0xc635).expect("SpaceMouse Compact in table");
    let (mut dev, mut feed) = SpaceMouse::with_feed(SpaceMouseConfig::default(), model).unwrap();
    feed.attach();
    dev.open().unwrap();
    (dev, feed)
}

/// Runs ticks `from..=to` (ms) and returns the last state.
fn run(dev: &mut SpaceMouse, from: u64, to: u64) -> DeviceState {
    let mut last = None;
    for i in from..=to {
        last = Some(dev.read(i * MS).expect("read"));
        dev.write(&Wrench::ZERO).expect("write");
    }
    last.expect("at least one tick")
}

#[test]
fn split_reports_move_the_avatar_in_the_scene_frame() {
    let (mut dev, mut feed) = navigator();
    assert_eq!(dev.spec().name, "SpaceNavigator");
    assert!(!dev.spec().capabilities.force_output);
    // Full push away from the user: HID y = -350 (0xfea2), split id 1.
    feed.push(&[0x01, 0x00, 0x00, 0xa2, 0xfe, 0x00, 0x00])
        .unwrap();
    // Twist counter-clockwise from above: HID rz = -350, split id 2.
    feed.push(&[0x02, 0x00, 0x00, 0x00, 0x00, 0xa2, 0xfe])
        .unwrap();
    run(&mut dev, 0, 0);
    let s = run(&mut dev, 1, 100); // 100 ms at full speed
    assert!((s.linear_velocity - Vector3::new(0.0, 0.05, 0.0)).norm() < 1e-12);
    assert!(
        (s.pose.translation.y - 0.005).abs() < 1e-9,
        "{}",
        s.pose.translation.y
    );
    assert!((s.angular_velocity.z - 0.8).abs() < 1e-12);
    assert_eq!(s.timestamp_ns, 100 * MS);
    // Release: zero report stops it.
    feed.push(&[0x01, 0, 0, 0, 0, 0, 0]).unwrap();
    feed.push(&[0x02, 0, 0, 0, 0, 0, 0]).unwrap();
    let s = run(&mut dev, 101, 110);
    assert_eq!(s.linear_velocity, Vector3::zeros());
    assert!((s.pose.translation.y - 0.005).abs() < 1e-9);
}

#[test]
fn combined_reports_and_buttons_on_a_newer_model() {
    let (mut dev, mut feed) = compact();
    // Combined 13 bytes: x = +175 (half), deadband-free rotation zero.
    feed.push(&[0x01, 0xaf, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
        .unwrap();
    feed.push(&[0x03, 0x02, 0x00]).unwrap();
    run(&mut dev, 0, 0);
    let s = run(&mut dev, 1, 10);
    let half = (0.5 - 0.05) / 0.95 * 0.05;
    assert!((s.linear_velocity.x - half).abs() < 1e-12);
    assert!(s.button(1) && !s.button(0));
    // A button beyond the model's two is masked out.
    feed.push(&[0x03, 0x04, 0x00]).unwrap();
    assert_eq!(run(&mut dev, 11, 11).buttons, 0);
}

#[test]
fn malformed_bytes_are_rejected_and_the_held_value_kept() {
    let (mut dev, mut feed) = navigator();
    feed.push(&[0x01, 0x5e, 0x01, 0, 0, 0, 0]).unwrap(); // +350 x
    assert!(feed.push(&[0x01, 0x00]).is_err());
    assert!(feed.push(&[0x02; 9]).is_err());
    assert_eq!(feed.malformed(), 2);
    feed.push(&[0x17, 0x64]).unwrap(); // battery: ignored
    run(&mut dev, 0, 0);
    assert!((run(&mut dev, 1, 5).linear_velocity.x - 0.05).abs() < 1e-12);
}

#[test]
fn unplug_faults_and_stops_then_replug_resumes() {
    let (mut dev, mut feed) = navigator();
    feed.push(&[0x01, 0x5e, 0x01, 0, 0, 0, 0]).unwrap();
    run(&mut dev, 0, 0);
    let before = run(&mut dev, 1, 50);
    feed.detach();
    assert_eq!(dev.read(51 * MS), Err(DeviceError::Disconnected));
    assert_eq!(dev.rate_control().linear_velocity(), Vector3::zeros());
    assert_eq!(dev.read(52 * MS), Err(DeviceError::Disconnected));
    feed.attach();
    // Back from rest where it stopped: no jump, no motion until a report says so.
    let s = run(&mut dev, 53, 60);
    assert_eq!(s.linear_velocity, Vector3::zeros());
    assert!((s.pose.translation.x - before.pose.translation.x).abs() < 1e-12);
    feed.push(&[0x01, 0x5e, 0x01, 0, 0, 0, 0]).unwrap();
    assert!((run(&mut dev, 61, 62).linear_velocity.x - 0.05).abs() < 1e-12);
}

#[test]
fn held_deflection_expires_and_guidance_moves_the_avatar() {
    let (mut dev, mut feed) = navigator();
    feed.push(&[0x01, 0x5e, 0x01, 0, 0, 0, 0]).unwrap();
    run(&mut dev, 0, 0);
    assert!(run(&mut dev, 1, 400).linear_velocity.x > 0.0);
    assert!((dev.report_age_s() - 0.4).abs() < 1e-9);
    // No report for more than hold_timeout_s (0.5 s): motion stops.
    assert_eq!(run(&mut dev, 401, 600).linear_velocity.x, 0.0);
    // F_s through write moves the avatar (I-RRT Alg. 2, non-haptic device), bounded by
    // max_pseudo_force_n = 5 N: 50 N acts as 5 N → 0.05 m/s.
    dev.write(&Wrench::from_force(Vector3::new(0.0, 0.0, 50.0)))
        .unwrap();
    let s = dev.read(601 * MS).unwrap();
    assert!((s.linear_velocity.z - 0.05).abs() < 1e-12);
    let bad = Wrench::from_force(Vector3::new(f64::NAN, 0.0, 0.0));
    assert_eq!(dev.write(&bad), Err(DeviceError::InvalidData));
}

#[test]
fn not_open_and_closed_are_errors() {
    let model = known_model(0x256f, 0xc62e).unwrap();
    let (mut dev, _feed) = SpaceMouse::with_feed(SpaceMouseConfig::default(), model).unwrap();
    assert_eq!(dev.read(0), Err(DeviceError::NotOpen));
    dev.open().unwrap();
    // Fed source not yet attached: same as unplugged.
    assert_eq!(dev.read(0), Err(DeviceError::Disconnected));
    dev.close();
    assert_eq!(dev.write(&Wrench::ZERO), Err(DeviceError::NotOpen));
    let mut bad = SpaceMouseConfig::default();
    bad.rate.deadband = -0.1;
    assert!(SpaceMouse::new(bad).is_err());
}

#[test]
fn hid_open_without_a_device_names_what_to_check() {
    // This machine has no USB: enumeration finds nothing (or HID is absent) and `open`
    // says so clearly. On a machine with a SpaceMouse attached the open must succeed.
    let mut dev = SpaceMouse::new(SpaceMouseConfig::default()).unwrap();
    match enumerate() {
        Ok(found) if !found.is_empty() => {
            dev.open()
                .expect("a SpaceMouse is attached and should open");
            dev.close();
        }
        Ok(_) => match dev.open() {
            Err(DeviceError::OpenFailed(msg)) => assert!(msg.contains("no 3Dconnexion")),
            other => panic!("expected OpenFailed, got {other:?}"),
        },
        Err(_) => assert!(matches!(dev.open(), Err(DeviceError::OpenFailed(_)))),
    }
}
