//! A fake `libHD.so`: exports the OpenHaptics HD functions `devices::sdk::hd` uses and
//! simulates one device with its own 1 kHz servo thread, so the real load / symbol lookup /
//! scheduler-callback path runs in tests without hardware.
//!
//! Tests drive it through extra `fakeHd*` symbols. Units and frame are HD's: mm, N;
//! x right, y up, z toward the operator; `HD_CURRENT_TRANSFORM` column-major.

#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_char, c_double, c_int, c_uint, c_ulong, c_ushort, c_void};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

const HD_CURRENT_BUTTONS: c_uint = 0x2000;
const HD_CURRENT_POSITION: c_uint = 0x2050;
const HD_CURRENT_VELOCITY: c_uint = 0x2051;
const HD_CURRENT_TRANSFORM: c_uint = 0x2052;
const HD_CURRENT_ANGULAR_VELOCITY: c_uint = 0x2053;
const HD_DEVICE_MODEL_TYPE: c_uint = 0x2501;
const HD_USABLE_WORKSPACE_DIMENSIONS: c_uint = 0x2551;
const HD_NOMINAL_MAX_STIFFNESS: c_uint = 0x2602;
const HD_NOMINAL_MAX_FORCE: c_uint = 0x2603;
const HD_NOMINAL_MAX_DAMPING: c_uint = 0x2609;
const HD_CURRENT_FORCE: c_uint = 0x2700;
const HD_FORCE_OUTPUT: c_uint = 0x4000;
const HD_INVALID_HANDLE: c_uint = 0xFFFF_FFFF;
const HD_INVALID_ENUM: c_uint = 0x0100;
const HD_COMM_ERROR: c_uint = 0x0302;
const HD_CALLBACK_CONTINUE: c_uint = 1;

#[repr(C)]
#[derive(Clone, Copy)]
pub struct HdErrorInfo {
    error_code: c_uint,
    internal_error_code: c_int,
    h_hd: c_uint,
}

type Callback = unsafe extern "C" fn(*mut c_void) -> c_uint;

#[derive(Clone, Copy)]
struct Scheduled {
    handle: c_ulong,
    callback: Callback,
    user: usize,
}

struct State {
    connected: bool,
    initialized: bool,
    force_output: bool,
    transform: [f64; 16],
    velocity: [f64; 3],
    angular_velocity: [f64; 3],
    buttons: c_int,
    force: [f64; 3],
    error: c_uint,
    callbacks: Vec<Scheduled>,
    next_handle: c_ulong,
    servo: Option<JoinHandle<()>>,
}

const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

static STATE: Mutex<State> = Mutex::new(State {
    connected: true,
    initialized: false,
    force_output: false,
    transform: IDENTITY,
    velocity: [0.0; 3],
    angular_velocity: [0.0; 3],
    buttons: 0,
    force: [0.0; 3],
    error: 0,
    callbacks: Vec::new(),
    next_handle: 1,
    servo: None,
});
static RUNNING: AtomicBool = AtomicBool::new(false);
static PAUSED: AtomicBool = AtomicBool::new(false);
static TICKS: AtomicU64 = AtomicU64::new(0);
static MODEL: &[u8] = b"Fake Touch\0";

fn st() -> std::sync::MutexGuard<'static, State> {
    STATE.lock().unwrap_or_else(|p| p.into_inner())
}

#[unsafe(no_mangle)]
pub extern "C" fn hdInitDevice(_name: *const c_char) -> c_uint {
    let mut s = st();
    if !s.connected {
        s.error = HD_COMM_ERROR;
        return HD_INVALID_HANDLE;
    }
    s.initialized = true;
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn hdDisableDevice(_h: c_uint) {
    let mut s = st();
    s.initialized = false;
    s.force_output = false;
}

#[unsafe(no_mangle)]
pub extern "C" fn hdMakeCurrentDevice(_h: c_uint) {}

#[unsafe(no_mangle)]
pub extern "C" fn hdGetCurrentDevice() -> c_uint {
    0
}

#[unsafe(no_mangle)]
pub extern "C" fn hdBeginFrame(_h: c_uint) {}

#[unsafe(no_mangle)]
pub extern "C" fn hdEndFrame(_h: c_uint) {}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn hdGetDoublev(param: c_uint, out: *mut c_double) {
    let mut s = st();
    let values: Vec<f64> = match param {
        HD_CURRENT_POSITION => s.transform[12..15].to_vec(),
        HD_CURRENT_TRANSFORM => s.transform.to_vec(),
        HD_CURRENT_VELOCITY => s.velocity.to_vec(),
        HD_CURRENT_ANGULAR_VELOCITY => s.angular_velocity.to_vec(),
        HD_NOMINAL_MAX_FORCE => vec![3.3],
        HD_NOMINAL_MAX_STIFFNESS => vec![0.5],
        HD_NOMINAL_MAX_DAMPING => vec![0.002],
        HD_USABLE_WORKSPACE_DIMENSIONS => vec![-160.0, -120.0, -60.0, 160.0, 120.0, 60.0],
        HD_CURRENT_FORCE => s.force.to_vec(),
        _ => {
            s.error = HD_INVALID_ENUM;
            return;
        }
    };
    // SAFETY: the caller passes room for the parameter's documented count.
    unsafe { std::ptr::copy_nonoverlapping(values.as_ptr(), out, values.len()) };
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn hdGetIntegerv(param: c_uint, out: *mut c_int) {
    let mut s = st();
    match param {
        // SAFETY: one int, as documented.
        HD_CURRENT_BUTTONS => unsafe { *out = s.buttons },
        _ => s.error = HD_INVALID_ENUM,
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn hdSetDoublev(param: c_uint, value: *const c_double) {
    let mut s = st();
    match param {
        // SAFETY: three doubles, as documented.
        HD_CURRENT_FORCE => unsafe {
            s.force = [*value, *value.add(1), *value.add(2)];
        },
        _ => s.error = HD_INVALID_ENUM,
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn hdGetString(param: c_uint) -> *const c_char {
    if param == HD_DEVICE_MODEL_TYPE {
        MODEL.as_ptr().cast()
    } else {
        std::ptr::null()
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn hdEnable(cap: c_uint) {
    let mut s = st();
    if cap == HD_FORCE_OUTPUT {
        s.force_output = true;
    } else {
        s.error = HD_INVALID_ENUM;
    }
}

#[unsafe(no_mangle)]
pub extern "C" fn hdGetError() -> HdErrorInfo {
    let mut s = st();
    let e = HdErrorInfo {
        error_code: s.error,
        internal_error_code: 0,
        h_hd: 0,
    };
    s.error = 0;
    e
}

#[unsafe(no_mangle)]
pub extern "C" fn hdScheduleAsynchronous(
    callback: Callback,
    user: *mut c_void,
    _priority: c_ushort,
) -> c_ulong {
    let mut s = st();
    let handle = s.next_handle;
    s.next_handle += 1;
    s.callbacks.push(Scheduled {
        handle,
        callback,
        user: user as usize,
    });
    handle
}

#[unsafe(no_mangle)]
pub extern "C" fn hdUnschedule(handle: c_ulong) {
    st().callbacks.retain(|c| c.handle != handle);
}

/// The servo thread: every ~1 ms, run each callback; drop those that return DONE.
#[unsafe(no_mangle)]
pub extern "C" fn hdStartScheduler() {
    if RUNNING.swap(true, Ordering::AcqRel) {
        return;
    }
    let t = std::thread::spawn(|| {
        while RUNNING.load(Ordering::Acquire) {
            std::thread::sleep(Duration::from_millis(1));
            if PAUSED.load(Ordering::Acquire) {
                continue;
            }
            let list: Vec<Scheduled> = st().callbacks.clone();
            for c in list {
                // SAFETY: the client registered this callback with this user data and keeps
                // it valid until hdUnschedule / hdStopScheduler.
                let code = unsafe { (c.callback)(c.user as *mut c_void) };
                if code != HD_CALLBACK_CONTINUE {
                    st().callbacks.retain(|x| x.handle != c.handle);
                }
            }
            TICKS.fetch_add(1, Ordering::Relaxed);
        }
    });
    st().servo = Some(t);
}

#[unsafe(no_mangle)]
pub extern "C" fn hdStopScheduler() {
    RUNNING.store(false, Ordering::Release);
    let t = st().servo.take();
    if let Some(t) = t {
        let _ = t.join();
    }
}

// ---- test controls (not part of the HD API) ----

/// Sets the stylus transform (column-major, mm), velocity (mm/s), angular velocity (rad/s)
/// and buttons.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fakeHdSetState(
    transform: *const [f64; 16],
    velocity: *const [f64; 3],
    angular_velocity: *const [f64; 3],
    buttons: c_int,
) {
    let mut s = st();
    // SAFETY: the test passes valid pointers.
    unsafe {
        s.transform = *transform;
        s.velocity = *velocity;
        s.angular_velocity = *angular_velocity;
    }
    s.buttons = buttons;
}

/// Copies the force last set by a servo callback (N, HD frame); returns servo ticks so far.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fakeHdLastForce(out: *mut [f64; 3]) -> u64 {
    let s = st();
    // SAFETY: the test passes a valid pointer.
    unsafe { *out = s.force };
    TICKS.load(Ordering::Relaxed)
}

/// Connects (1) or disconnects (0) the device for the next hdInitDevice.
#[unsafe(no_mangle)]
pub extern "C" fn fakeHdSetConnected(connected: c_int) {
    st().connected = connected != 0;
}

/// Pauses (1) or resumes (0) the servo loop, as a stalled driver would.
#[unsafe(no_mangle)]
pub extern "C" fn fakeHdPauseServo(paused: c_int) {
    PAUSED.store(paused != 0, Ordering::Release);
}

/// Raises an HD error code that the next hdGetError reports (e.g. 0x0302 comm error).
#[unsafe(no_mangle)]
pub extern "C" fn fakeHdRaiseError(code: c_uint) {
    st().error = code;
}

/// Callbacks currently scheduled.
#[unsafe(no_mangle)]
pub extern "C" fn fakeHdScheduled() -> c_int {
    c_int::try_from(st().callbacks.len()).unwrap_or(c_int::MAX)
}
