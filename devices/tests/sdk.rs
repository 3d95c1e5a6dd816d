//! The DHD and HD backends against fake vendor libraries (`devices/fake-sdk/*`), built here
//! with cargo and loaded by path: the real dlopen, symbol lookup and C calls run.

use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::Duration;

use devices::sdk::SdkError;
use devices::sdk::dhd::{Dhd, DhdConfig};
use devices::sdk::hd::{Hd, HdConfig};
use devices::{DeviceError, HapticDevice, Wrench};
use libloading::Library;
use nalgebra::Vector3;

/// Builds `package` (a cdylib) with the same profile as this test and returns its path.
fn build_fake(package: &str, lib: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/sdk-<hash> → target/<profile>
    let profile_dir = exe.parent().and_then(|d| d.parent()).expect("target dir");
    let release = profile_dir.file_name().is_some_and(|n| n == "release");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.args(["build", "--quiet", "-p", package]);
    if release {
        cmd.arg("--release");
    }
    let status = cmd.status().expect("run cargo build for the fake SDK");
    assert!(status.success(), "cargo build -p {package} failed");
    let path = profile_dir.join(format!("lib{lib}.so"));
    assert!(path.exists(), "{} not built", path.display());
    path
}

fn fake_dhd() -> &'static PathBuf {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| build_fake("fake-dhd", "fake_dhd"))
}

fn fake_hd() -> &'static PathBuf {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| build_fake("fake-hd", "fake_hd"))
}

/// Each fake simulates one global device: tests of the same fake take turns.
fn serial(lock: &'static Mutex<()>) -> MutexGuard<'static, ()> {
    lock.lock().unwrap_or_else(|p| p.into_inner())
}
static DHD_LOCK: Mutex<()> = Mutex::new(());
static HD_LOCK: Mutex<()> = Mutex::new(());

/// The fake's test controls, loaded from the same file (dlopen returns the same handle, so
/// they act on the instance the backend uses).
struct Controls {
    lib: Library,
}

impl Controls {
    fn open(path: &PathBuf) -> Controls {
        // SAFETY: our own fake library; no initialisers beyond Rust statics.
        let lib = unsafe { Library::new(path) }.expect("load fake");
        Controls { lib }
    }
    /// # Safety
    /// `T` must match the fake's symbol.
    unsafe fn f<T: Copy>(&self, name: &str) -> T {
        // SAFETY: forwarded to the caller.
        unsafe { *self.lib.get::<T>(name.as_bytes()).expect(name) }
    }
}

const MS: u64 = 1_000_000;

#[test]
fn dhd_loads_opens_reads_and_writes_in_our_frame() {
    let _g = serial(&DHD_LOCK);
    let path = fake_dhd().clone();
    let c = Controls::open(&path);
    // SAFETY: signatures as defined in devices/fake-sdk/fake-dhd.
    unsafe {
        c.f::<extern "C" fn(i32, i32)>("fakeDhdSetConnected")(1, 60); // Falcon
        let rot_z_90 = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        c.f::<unsafe extern "C" fn(
            *const [f64; 3],
            *const [[f64; 3]; 3],
            *const [f64; 3],
            *const [f64; 3],
            u32,
        )>("fakeDhdSetState")(
            &[0.01, 0.02, 0.03],
            &rot_z_90,
            &[0.1, 0.0, 0.0],
            &[0.0, 0.0, 0.5],
            0b101,
        );
    }
    let mut dev = Dhd::load(DhdConfig {
        library: path.clone(),
        watchdog_s: 0.02,
    })
    .expect("fake libdhd loads");
    assert_eq!(dev.device_count(), 1);
    assert_eq!(dev.read(0), Err(DeviceError::NotOpen));
    dev.open().expect("open");
    // Spec of system type 60 (Falcon), name from dhdGetSystemName.
    assert_eq!(dev.spec().name, "fake omega.3");
    assert_eq!(dev.spec().limits.max_force_n, 8.0);
    let s = dev.read(5 * MS).expect("read");
    // DHD (x toward operator, y right, z up) → ours (X right, Y away, Z up).
    let p = s.pose.translation.vector;
    assert!((p - Vector3::new(0.02, -0.01, 0.03)).norm() < 1e-12, "{p}");
    assert!((s.linear_velocity - Vector3::new(0.0, -0.1, 0.0)).norm() < 1e-12);
    assert!((s.angular_velocity - Vector3::new(0.0, 0.0, 0.5)).norm() < 1e-12);
    // A rotation about vertical stays a rotation about vertical, same angle.
    let (axis, angle) = s.pose.rotation.axis_angle().expect("rotated");
    assert!((angle - std::f64::consts::FRAC_PI_2).abs() < 1e-9 && axis.z > 0.999);
    assert_eq!(s.buttons, 0b101);
    assert_eq!(s.timestamp_ns, 5 * MS);

    // Write 2 N to our +X (right) and 20 N up: DHD gets y = 2·k, z = 20·k with the norm
    // saturated to the Falcon's 8 N.
    dev.write(&Wrench::from_force(Vector3::new(2.0, 0.0, 20.0)))
        .expect("write");
    let mut out = [0.0f64; 8];
    // SAFETY: signature from the fake.
    let writes = unsafe {
        c.f::<unsafe extern "C" fn(*mut [f64; 8]) -> u64>("fakeDhdLastCommand")(&mut out)
    };
    assert!(writes >= 2, "zero command at open, then ours");
    let f = Vector3::new(out[0], out[1], out[2]);
    assert!((f.norm() - 8.0).abs() < 1e-9, "{f}");
    assert!(f.x.abs() < 1e-12 && f.y > 0.0 && f.z > 0.0);
    assert_eq!(out[6], 1.0, "force enabled");
    assert_eq!(out[7], 160.0, "watchdog 20 ms in 125 µs units");
    assert_eq!(
        dev.write(&Wrench::from_force(Vector3::new(f64::NAN, 0.0, 0.0))),
        Err(DeviceError::InvalidData)
    );

    // Unplug: the next read is a fault.
    // SAFETY: signature from the fake.
    unsafe { c.f::<extern "C" fn(i32, i32)>("fakeDhdSetConnected")(0, 60) };
    assert_eq!(dev.read(6 * MS), Err(DeviceError::ReadFailed));
    assert_eq!(dev.write(&Wrench::ZERO), Err(DeviceError::WriteFailed));
    dev.close();
    // Absent device: a clear open error.
    match dev.open() {
        Err(DeviceError::OpenFailed(msg)) => assert!(msg.contains("no Force Dimension device")),
        other => panic!("expected OpenFailed, got {other:?}"),
    }
    // SAFETY: signature from the fake.
    unsafe { c.f::<extern "C" fn(i32, i32)>("fakeDhdSetConnected")(1, 33) };
    dev.open().expect("replugged device opens again");
    dev.close();
    // SAFETY: signature from the fake.
    let n = unsafe { c.f::<extern "C" fn() -> i32>("fakeDhdIsOpen")() };
    assert_eq!(n, 0);
}

#[test]
fn dhd_missing_library_or_symbols_is_a_clear_error() {
    let e = Dhd::load(DhdConfig {
        library: "/nonexistent/libdhd.so".into(),
        watchdog_s: 0.02,
    })
    .expect_err("missing file");
    assert!(matches!(e, SdkError::Load { .. }));
    assert!(e.to_string().contains("LD_LIBRARY_PATH"));
    // The HD fake is a real library without DHD symbols.
    let e = Dhd::load(DhdConfig {
        library: fake_hd().clone(),
        watchdog_s: 0.02,
    })
    .expect_err("wrong library");
    assert!(
        matches!(
            e,
            SdkError::Symbol {
                symbol: "dhdGetDeviceCount",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn hd_servo_bridge_converts_mm_and_frames_and_never_blocks() {
    let _g = serial(&HD_LOCK);
    let path = fake_hd().clone();
    let c = Controls::open(&path);
    type SetState = unsafe extern "C" fn(*const [f64; 16], *const [f64; 3], *const [f64; 3], i32);
    type LastForce = unsafe extern "C" fn(*mut [f64; 3]) -> u64;
    // Stylus at (10, 20, 30) mm in HD (x right, y up, z toward operator), identity rotation.
    let mut t = [0.0; 16];
    t[0] = 1.0;
    t[5] = 1.0;
    t[10] = 1.0;
    t[15] = 1.0;
    t[12] = 10.0;
    t[13] = 20.0;
    t[14] = 30.0;
    // SAFETY: signatures from devices/fake-sdk/fake-hd.
    unsafe {
        c.f::<extern "C" fn(i32)>("fakeHdSetConnected")(1);
        c.f::<extern "C" fn(i32)>("fakeHdPauseServo")(0);
        c.f::<SetState>("fakeHdSetState")(&t, &[0.0, 0.0, 100.0], &[0.0; 3], 0b10);
    }
    let mut dev = Hd::load(HdConfig {
        library: path.clone(),
        ..HdConfig::default()
    })
    .expect("fake libHD loads");
    dev.open().expect("open");
    assert_eq!(dev.spec().name, "Fake Touch");
    assert_eq!(dev.spec().limits.max_stiffness_n_per_m, 500.0);
    assert!((dev.spec().limits.workspace_radius_m - 0.06).abs() < 1e-12);
    assert!(!dev.spec().capabilities.torque_output);

    let s = dev.read(MS).expect("read after the first servo tick");
    // mm → m and HD → ours: X = x, Y = −z, Z = y.
    let p = s.pose.translation.vector;
    assert!(
        (p - Vector3::new(0.010, -0.030, 0.020)).norm() < 1e-12,
        "{p}"
    );
    assert!((s.linear_velocity - Vector3::new(0.0, -0.1, 0.0)).norm() < 1e-12);
    assert_eq!(s.buttons, 0b10);

    // 1 N away from the operator (our +Y) is −z in HD; the servo thread applies it.
    dev.write(&Wrench::from_force(Vector3::new(0.0, 1.0, 0.0)))
        .unwrap();
    let mut f = [0.0; 3];
    let deadline = std::time::Instant::now() + Duration::from_secs(2);
    loop {
        // SAFETY: signature from the fake.
        unsafe { c.f::<LastForce>("fakeHdLastForce")(&mut f) };
        if (f[2] + 1.0).abs() < 1e-12 || std::time::Instant::now() > deadline {
            break;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    assert!(
        (f[2] + 1.0).abs() < 1e-12 && f[0] == 0.0 && f[1] == 0.0,
        "{f:?}"
    );

    // Our loop goes quiet: after command_timeout_ticks the servo side zeroes the force.
    let deadline = std::time::Instant::now() + Duration::from_secs(2);
    loop {
        // SAFETY: signature from the fake.
        unsafe { c.f::<LastForce>("fakeHdLastForce")(&mut f) };
        if f == [0.0; 3] || std::time::Instant::now() > deadline {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    assert_eq!(f, [0.0; 3], "servo side drops a stale command");

    // The servo thread stalls: read reports a fault once no tick came for servo_stale_s.
    // SAFETY: signature from the fake.
    unsafe { c.f::<extern "C" fn(i32)>("fakeHdPauseServo")(1) };
    std::thread::sleep(Duration::from_millis(20));
    let t0 = 10_000 * MS;
    assert!(
        dev.read(t0).is_ok(),
        "newest sample still recent by our clock"
    );
    assert_eq!(dev.read(t0 + 60 * MS), Err(DeviceError::ReadFailed));
    // SAFETY: signature from the fake.
    unsafe { c.f::<extern "C" fn(i32)>("fakeHdPauseServo")(0) };
    std::thread::sleep(Duration::from_millis(20));
    assert!(dev.read(t0 + 61 * MS).is_ok(), "servo resumed");

    dev.close();
    // SAFETY: signature from the fake.
    let n = unsafe { c.f::<extern "C" fn() -> i32>("fakeHdScheduled")() };
    assert_eq!(n, 0);
    assert_eq!(dev.read(t0 + 62 * MS), Err(DeviceError::NotOpen));

    // Absent device: hdInitDevice fails with a clear message.
    // SAFETY: signature from the fake.
    unsafe { c.f::<extern "C" fn(i32)>("fakeHdSetConnected")(0) };
    match dev.open() {
        Err(DeviceError::OpenFailed(msg)) => assert!(msg.contains("hdInitDevice failed")),
        other => panic!("expected OpenFailed, got {other:?}"),
    }
    // SAFETY: signature from the fake.
    unsafe { c.f::<extern "C" fn(i32)>("fakeHdSetConnected")(1) };
}
