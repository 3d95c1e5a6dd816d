//! A fake `libdhd.so`: exports the DHD C functions `devices::sdk::dhd` uses and simulates
//! one device, so the real load / symbol lookup / call path runs in tests without hardware.
//!
//! The test drives it through extra `fakeDhd*` symbols (set the handle's pose, velocity and
//! buttons, unplug it, read back the last commanded force). Frames and units are DHD's:
//! x toward the operator, y right, z up; m, N.

#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_double, c_int, c_uchar, c_uint};
use std::sync::Mutex;

#[derive(Clone, Copy)]
struct Device {
    open: bool,
    connected: bool,
    force_enabled: bool,
    system_type: c_int,
    position: [f64; 3],
    frame: [[f64; 3]; 3],
    velocity: [f64; 3],
    angular_velocity: [f64; 3],
    buttons: c_uint,
    force: [f64; 6],
    watchdog: c_uchar,
    writes: u64,
}

const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

static DEVICE: Mutex<Device> = Mutex::new(Device {
    open: false,
    connected: true,
    force_enabled: false,
    system_type: 33,
    position: [0.0; 3],
    frame: IDENTITY,
    velocity: [0.0; 3],
    angular_velocity: [0.0; 3],
    buttons: 0,
    force: [0.0; 6],
    watchdog: 0,
    writes: 0,
});

static NAME: &[u8] = b"fake omega.3\0";
static LAST_ERROR: Mutex<&'static [u8]> = Mutex::new(b"no error\0");

fn dev() -> std::sync::MutexGuard<'static, Device> {
    DEVICE.lock().unwrap_or_else(|p| p.into_inner())
}

fn fail(msg: &'static [u8]) -> c_int {
    *LAST_ERROR.lock().unwrap_or_else(|p| p.into_inner()) = msg;
    -1
}

fn usable(id: c_char) -> bool {
    let d = dev();
    id == 0 && d.open && d.connected
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdGetDeviceCount() -> c_int {
    c_int::from(dev().connected)
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdOpen() -> c_int {
    let mut d = dev();
    if !d.connected {
        drop(d);
        return fail(b"no device found\0");
    }
    d.open = true;
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdClose(id: c_char) -> c_int {
    let mut d = dev();
    if id != 0 || !d.open {
        drop(d);
        return fail(b"device not open\0");
    }
    d.open = false;
    d.force_enabled = false;
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdGetSystemType(id: c_char) -> c_int {
    if !usable(id) {
        return fail(b"invalid id\0");
    }
    dev().system_type
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdGetSystemName(_id: c_char) -> *const c_char {
    NAME.as_ptr().cast()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn dhdGetPositionAndOrientationFrame(
    px: *mut c_double,
    py: *mut c_double,
    pz: *mut c_double,
    matrix: *mut [[c_double; 3]; 3],
    id: c_char,
) -> c_int {
    if !usable(id) {
        return fail(b"communication error\0");
    }
    let d = dev();
    // SAFETY: the caller passes valid pointers, as the real SDK requires.
    unsafe {
        *px = d.position[0];
        *py = d.position[1];
        *pz = d.position[2];
        *matrix = d.frame;
    }
    0
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn dhdGetLinearVelocity(
    vx: *mut c_double,
    vy: *mut c_double,
    vz: *mut c_double,
    id: c_char,
) -> c_int {
    if !usable(id) {
        return fail(b"communication error\0");
    }
    let v = dev().velocity;
    // SAFETY: valid pointers per the SDK contract.
    unsafe {
        *vx = v[0];
        *vy = v[1];
        *vz = v[2];
    }
    0
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn dhdGetAngularVelocityRad(
    wx: *mut c_double,
    wy: *mut c_double,
    wz: *mut c_double,
    id: c_char,
) -> c_int {
    if !usable(id) {
        return fail(b"communication error\0");
    }
    let w = dev().angular_velocity;
    // SAFETY: valid pointers per the SDK contract.
    unsafe {
        *wx = w[0];
        *wy = w[1];
        *wz = w[2];
    }
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdGetButtonMask(id: c_char) -> c_uint {
    if !usable(id) {
        return 0;
    }
    dev().buttons
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdSetForceAndTorque(
    fx: c_double,
    fy: c_double,
    fz: c_double,
    tx: c_double,
    ty: c_double,
    tz: c_double,
    id: c_char,
) -> c_int {
    if !usable(id) {
        return fail(b"communication error\0");
    }
    let mut d = dev();
    d.force = [fx, fy, fz, tx, ty, tz];
    d.writes += 1;
    // DHD_MOTOR_SATURATED above 12 N, like an omega.3.
    if (fx * fx + fy * fy + fz * fz).sqrt() > 12.0 {
        2
    } else {
        0
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdEnableForce(val: c_uchar, id: c_char) -> c_int {
    if !usable(id) {
        return fail(b"communication error\0");
    }
    dev().force_enabled = val != 0;
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdSetWatchdog(val: c_uchar, id: c_char) -> c_int {
    if !usable(id) {
        return fail(b"communication error\0");
    }
    dev().watchdog = val;
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn dhdErrorGetLastStr() -> *const c_char {
    // Every message is a NUL-terminated &'static [u8]: the pointer stays valid.
    LAST_ERROR
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .as_ptr()
        .cast()
}

// ---- test controls (not part of the DHD API) ----

/// Sets the handle's position (m), orientation frame (row-major) and velocities, DHD frame.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fakeDhdSetState(
    position: *const [f64; 3],
    frame: *const [[f64; 3]; 3],
    velocity: *const [f64; 3],
    angular_velocity: *const [f64; 3],
    buttons: c_uint,
) {
    let mut d = dev();
    // SAFETY: the test passes valid pointers.
    unsafe {
        d.position = *position;
        d.frame = *frame;
        d.velocity = *velocity;
        d.angular_velocity = *angular_velocity;
    }
    d.buttons = buttons;
}

/// Plugs (1) or unplugs (0) the simulated device; chooses its system type.
#[unsafe(no_mangle)]
pub extern "C" fn fakeDhdSetConnected(connected: c_int, system_type: c_int) {
    let mut d = dev();
    d.connected = connected != 0;
    d.system_type = system_type;
}

/// Copies the last commanded force and torque (N, N·m, DHD frame) and returns the count of
/// force writes; `out[6]` = force enabled (1/0), `out[7]` = watchdog setting.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fakeDhdLastCommand(out: *mut [f64; 8]) -> u64 {
    let d = dev();
    let mut v = [0.0; 8];
    v[..6].copy_from_slice(&d.force);
    v[6] = f64::from(u8::from(d.force_enabled));
    v[7] = f64::from(d.watchdog);
    // SAFETY: the test passes a valid pointer.
    unsafe { *out = v };
    d.writes
}

/// True (1) while a device is open.
#[unsafe(no_mangle)]
pub extern "C" fn fakeDhdIsOpen() -> c_int {
    c_int::from(dev().open)
}
