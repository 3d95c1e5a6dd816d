//! Record → replay round trips and bad files.

use std::path::PathBuf;

use nalgebra::Vector3;

use super::*;
use crate::sim::{SimulatedArm, SimulatedArmConfig};
use crate::{DeviceError, HapticDevice, Wrench};

const MS: u64 = 1_000_000;

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("hrrtc_{name}_{}.mcap", std::process::id()))
}

#[test]
fn recording_replays_reads_errors_and_wrenches_exactly() {
    let path = temp("roundtrip");
    let arm = SimulatedArm::new(SimulatedArmConfig::default()).unwrap();
    let mut rec = Recorder::create(arm, &path).expect("create recording");
    rec.open().unwrap();
    let mut reads = Vec::new();
    let mut wrenches = Vec::new();
    for i in 1..=300u64 {
        if i == 100 {
            rec.inner_mut().inject_fault(Some(DeviceError::ReadFailed));
        }
        if i == 103 {
            rec.inner_mut().inject_fault(None);
        }
        reads.push(rec.read(i * MS));
        let w = Wrench::from_force(Vector3::new(0.5 * (i as f64 * 0.01).sin(), 0.1, 0.0));
        let _ = rec.write(&w);
        wrenches.push(w);
    }
    let stats = rec.finish().expect("finish");
    assert_eq!(
        stats,
        RecordStats {
            reads: 300,
            wrenches: 300,
            dropped: 0
        }
    );

    let mut replay = ReplayDevice::from_file(&path).expect("load");
    assert_eq!(replay.len(), 300);
    assert_eq!(replay.spec().name, "simulated-arm");
    assert_eq!(replay.read(0), Err(DeviceError::NotOpen));
    replay.open().unwrap();
    for (i, expected) in reads.iter().enumerate() {
        // The clock given to a replay does not matter: reads come back in order.
        assert_eq!(replay.read(7).as_ref(), expected.as_ref(), "read {i}");
        replay.write(&wrenches[i]).unwrap();
    }
    assert_eq!(
        replay.read(0),
        Err(DeviceError::Disconnected),
        "past the end"
    );
    assert!(replay.finished());
    assert_eq!(replay.max_wrench_deviation(), 0.0);
    assert_eq!(replay.compared_writes(), 300);
    assert_eq!(replay.recorded_wrenches()[5], wrenches[5]);

    // A different command is measured, not hidden.
    replay.open().unwrap();
    replay.read(0).unwrap();
    replay
        .write(&Wrench::from_force(Vector3::new(1.0, 0.1, 0.0)))
        .unwrap();
    let expected = 1.0 - wrenches[0].force.x;
    assert!((replay.max_wrench_deviation() - expected).abs() < 1e-12);
    let _ = std::fs::remove_file(&path);
}

#[test]
fn bad_files_are_errors_not_panics() {
    let p = PathBuf::from("x.mcap");
    assert!(ReplayDevice::from_bytes(b"", &p).is_err());
    assert!(ReplayDevice::from_bytes(b"not an mcap file at all", &p).is_err());
    let missing = ReplayDevice::from_file(&temp("does_not_exist")).unwrap_err();
    assert!(matches!(missing, RecordError::Io { .. }));

    // A valid recording, truncated anywhere, never panics.
    let path = temp("truncate");
    let arm = SimulatedArm::new(SimulatedArmConfig::default()).unwrap();
    let mut rec = Recorder::create(arm, &path).unwrap();
    rec.open().unwrap();
    for i in 1..=20 {
        let _ = rec.read(i * MS);
        let _ = rec.write(&Wrench::ZERO);
    }
    rec.finish().unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert!(ReplayDevice::from_bytes(&bytes, &p).is_ok());
    for cut in (0..bytes.len()).step_by(7) {
        let _ = ReplayDevice::from_bytes(&bytes[..cut], &p);
    }
    // A recording with no spec (the device was never opened) is refused with a reason.
    let arm = SimulatedArm::new(SimulatedArmConfig::default()).unwrap();
    let mut rec = Recorder::create(arm, &path).unwrap();
    rec.finish().unwrap();
    let e = ReplayDevice::from_file(&path).unwrap_err();
    assert!(e.to_string().contains("/device/spec"), "{e}");
    let _ = std::fs::remove_file(&path);
    // An unwritable path fails at create, naming it.
    let arm = SimulatedArm::new(SimulatedArmConfig::default()).unwrap();
    let e = Recorder::create(arm, std::path::Path::new("/nonexistent/dir/x.mcap")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/dir/x.mcap"));
}
