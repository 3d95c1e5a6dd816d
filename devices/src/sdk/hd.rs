//! 3D Systems OpenHaptics HD API (`libHD.so`): Touch, Touch X, Phantom Premium.
//!
//! OpenHaptics owns its own 1 kHz servo thread: we cannot call `hdGet*` from our RT thread.
//! The bridge: an asynchronous servo callback reads the device inside `hdBeginFrame` /
//! `hdEndFrame`, writes a [`ServoSample`] into one triple buffer and applies the newest
//! [`ServoCommand`] from another. Neither side waits: both ends are wait-free, newest value
//! wins. If our loop stops commanding, the callback zeroes force after
//! `command_timeout_ticks` servo ticks; if the servo thread stops, `read` reports a stale
//! device.
//!
//! HD frame: x right, y up, z toward the operator; mm, mm/s, N, rad/s; `HD_CURRENT_TRANSFORM`
//! is a column-major 4×4 with translation in mm. Ours: X right, Y away, Z up; m (see
//! [`super`]). Only force is rendered (3-DOF output); torque is dropped.

use std::ffi::{CStr, c_char, c_double, c_int, c_uint, c_ulong, c_ushort, c_void};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use libloading::Library;
use nalgebra::{Isometry3, Matrix3, Translation3, Vector3};
use triple_buffer::{Input, Output, triple_buffer};

use super::{FrameMap, SdkError, load, sym};
use crate::{
    Capabilities, DeviceError, DeviceLimits, DeviceSpec, DeviceState, HapticDevice, Wrench,
};

/// Environment variable naming the library to load instead of `libHD.so`.
pub const LIBRARY_ENV: &str = "HRRTC_HD_LIB";
/// Default library name, searched by the dynamic loader.
pub const LIBRARY_DEFAULT: &str = "libHD.so";
const HINT: &str = "Install OpenHaptics (and the Touch device driver), add its lib directory to LD_LIBRARY_PATH, or set HRRTC_HD_LIB to the library file";

/// HD → ours: X = x_hd, Y = −z_hd, Z = y_hd.
pub(crate) const FRAME: FrameMap = FrameMap::new(Matrix3::new(
    1.0, 0.0, 0.0, //
    0.0, 0.0, -1.0, //
    0.0, 1.0, 0.0,
));

// Parameter and capability codes from hdDefines.h.
const HD_CURRENT_BUTTONS: c_uint = 0x2000;
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
const HD_CALLBACK_DONE: c_uint = 0;
const HD_CALLBACK_CONTINUE: c_uint = 1;
/// `HD_MAX_SCHEDULER_PRIORITY` (USHRT_MAX): run before any other servo callback.
const HD_MAX_SCHEDULER_PRIORITY: c_ushort = c_ushort::MAX;

/// `HDErrorInfo`, returned by value from `hdGetError`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
struct HdErrorInfo {
    error_code: c_uint,
    internal_error_code: c_int,
    h_hd: c_uint,
}

type Callback = unsafe extern "C" fn(*mut c_void) -> c_uint;
type FnInit = unsafe extern "C" fn(*const c_char) -> c_uint;
type FnHandle = unsafe extern "C" fn(c_uint);
type FnCurrent = unsafe extern "C" fn() -> c_uint;
type FnVoid = unsafe extern "C" fn();
type FnGetD = unsafe extern "C" fn(c_uint, *mut c_double);
type FnGetI = unsafe extern "C" fn(c_uint, *mut c_int);
type FnSetD = unsafe extern "C" fn(c_uint, *const c_double);
type FnGetS = unsafe extern "C" fn(c_uint) -> *const c_char;
type FnCap = unsafe extern "C" fn(c_uint);
type FnErr = unsafe extern "C" fn() -> HdErrorInfo;
type FnSchedule = unsafe extern "C" fn(Callback, *mut c_void, c_ushort) -> c_ulong;
type FnUnschedule = unsafe extern "C" fn(c_ulong);

/// The HD functions we call, resolved once at load.
struct Api {
    init_device: FnInit,
    disable_device: FnHandle,
    make_current: FnHandle,
    current_device: FnCurrent,
    begin_frame: FnHandle,
    end_frame: FnHandle,
    get_doublev: FnGetD,
    get_integerv: FnGetI,
    set_doublev: FnSetD,
    get_string: FnGetS,
    enable: FnCap,
    get_error: FnErr,
    start_scheduler: FnVoid,
    stop_scheduler: FnVoid,
    schedule_async: FnSchedule,
    unschedule: FnUnschedule,
    _lib: Library,
}

impl Api {
    fn load(path: &Path) -> Result<Api, SdkError> {
        let lib = load(path.as_os_str(), HINT)?;
        let name = path.to_string_lossy().into_owned();
        let n = name.as_str();
        // SAFETY: each alias is the C signature from OpenHaptics' hd.h / hdScheduler.h
        // (HDCALLBACK is empty on Linux); pointers live with the library in `Api`.
        unsafe {
            Ok(Api {
                init_device: sym(&lib, n, "hdInitDevice")?,
                disable_device: sym(&lib, n, "hdDisableDevice")?,
                make_current: sym(&lib, n, "hdMakeCurrentDevice")?,
                current_device: sym(&lib, n, "hdGetCurrentDevice")?,
                begin_frame: sym(&lib, n, "hdBeginFrame")?,
                end_frame: sym(&lib, n, "hdEndFrame")?,
                get_doublev: sym(&lib, n, "hdGetDoublev")?,
                get_integerv: sym(&lib, n, "hdGetIntegerv")?,
                set_doublev: sym(&lib, n, "hdSetDoublev")?,
                get_string: sym(&lib, n, "hdGetString")?,
                enable: sym(&lib, n, "hdEnable")?,
                get_error: sym(&lib, n, "hdGetError")?,
                start_scheduler: sym(&lib, n, "hdStartScheduler")?,
                stop_scheduler: sym(&lib, n, "hdStopScheduler")?,
                schedule_async: sym(&lib, n, "hdScheduleAsynchronous")?,
                unschedule: sym(&lib, n, "hdUnschedule")?,
                _lib: lib,
            })
        }
    }

    fn error(&self) -> Option<HdErrorInfo> {
        // SAFETY: no arguments; returns the oldest error on the stack, or HD_SUCCESS.
        let e = unsafe { (self.get_error)() };
        (e.error_code != 0).then_some(e)
    }
}

/// One servo tick's reading, in HD units and frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ServoSample {
    /// Column-major 4×4 end-effector transform, translation in mm.
    pub transform: [f64; 16],
    /// Linear velocity, mm/s.
    pub velocity_mm_s: [f64; 3],
    /// Angular velocity, rad/s.
    pub angular_velocity: [f64; 3],
    /// Button mask.
    pub buttons: u32,
    /// Servo ticks since the callback was scheduled.
    pub tick: u64,
    /// The HD error code raised in this tick (0 = none).
    pub error: u32,
}

/// The newest command for the servo thread.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ServoCommand {
    /// Force in N, HD frame.
    pub force_n: [f64; 3],
    /// Increments with every write, so the servo side sees our loop is alive.
    pub sequence: u64,
}

/// What the servo callback owns. Boxed; its address is the callback's user data.
struct Servo {
    api: *const Api,
    samples: Input<ServoSample>,
    commands: Output<ServoCommand>,
    stop: Arc<AtomicBool>,
    tick: u64,
    last_sequence: u64,
    last_sequence_tick: u64,
    command_timeout_ticks: u64,
    ticks_out: Arc<AtomicU64>,
}

/// The servo callback: read, publish, apply the newest command (zero when our loop has
/// gone quiet). Runs on OpenHaptics' servo thread; allocation-free.
unsafe extern "C" fn servo_callback(user: *mut c_void) -> c_uint {
    // SAFETY: `user` is the `Box<Servo>` leaked by `Hd::open` and reclaimed only after
    // `hdUnschedule` returned, so it is live; only this thread touches it meanwhile.
    let s = unsafe { &mut *(user as *mut Servo) };
    if s.stop.load(Ordering::Acquire) {
        return HD_CALLBACK_DONE;
    }
    // SAFETY: the Api outlives the schedule (see `Hd::close`).
    let api = unsafe { &*s.api };
    s.tick += 1;
    let mut out = ServoSample {
        tick: s.tick,
        ..ServoSample::default()
    };
    let cmd = *s.commands.read();
    if cmd.sequence != s.last_sequence {
        s.last_sequence = cmd.sequence;
        s.last_sequence_tick = s.tick;
    }
    let fresh =
        s.tick.saturating_sub(s.last_sequence_tick) <= s.command_timeout_ticks && cmd.sequence != 0;
    let force = if fresh { cmd.force_n } else { [0.0; 3] };
    let mut buttons: c_int = 0;
    // SAFETY: HD calls inside a frame on the servo thread with the current device; every
    // pointer is a live local of the size the parameter needs.
    unsafe {
        let h = (api.current_device)();
        (api.begin_frame)(h);
        (api.get_doublev)(HD_CURRENT_TRANSFORM, out.transform.as_mut_ptr());
        (api.get_doublev)(HD_CURRENT_VELOCITY, out.velocity_mm_s.as_mut_ptr());
        (api.get_doublev)(
            HD_CURRENT_ANGULAR_VELOCITY,
            out.angular_velocity.as_mut_ptr(),
        );
        (api.get_integerv)(HD_CURRENT_BUTTONS, &mut buttons);
        (api.set_doublev)(HD_CURRENT_FORCE, force.as_ptr());
        (api.end_frame)(h);
    }
    out.buttons = buttons as u32;
    out.error = api.error().map_or(0, |e| e.error_code);
    s.samples.write(out);
    s.ticks_out.store(s.tick, Ordering::Relaxed);
    HD_CALLBACK_CONTINUE
}

/// Settings of an OpenHaptics device.
#[derive(Debug, Clone, PartialEq)]
pub struct HdConfig {
    /// Library to load (see [`super::library_path`]).
    pub library: PathBuf,
    /// Device name from the Touch setup tool; `None` = the default device.
    pub device_name: Option<String>,
    /// Servo ticks (≈1 ms each) without a new command after which the servo side
    /// outputs zero force.
    pub command_timeout_ticks: u64,
    /// `read` reports a stale device when the servo tick count has not moved for this long,
    /// s.
    pub servo_stale_s: f64,
}

impl Default for HdConfig {
    fn default() -> Self {
        HdConfig {
            library: super::library_path(None, LIBRARY_ENV, LIBRARY_DEFAULT),
            device_name: None,
            command_timeout_ticks: 20,
            servo_stale_s: 0.05,
        }
    }
}

/// What is live between `open` and `close`.
struct Session {
    handle: c_uint,
    schedule: c_ulong,
    servo: *mut Servo,
    stop: Arc<AtomicBool>,
    samples: Output<ServoSample>,
    commands: Input<ServoCommand>,
    ticks: Arc<AtomicU64>,
}

/// A 3D Systems haptic device through OpenHaptics' HD API.
pub struct Hd {
    api: Box<Api>,
    config: HdConfig,
    spec: DeviceSpec,
    session: Option<Session>,
    sequence: u64,
    last_tick: u64,
    last_tick_ns: u64,
}

// SAFETY: the raw pointers in `Session` point to the boxed `Servo` (handed to the servo
// thread, touched there only) and to `Api` (immutable fn pointers). Moving `Hd` to another
// thread moves only the handles; the triple buffer ends are Send.
unsafe impl Send for Hd {}

impl std::fmt::Debug for Hd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Hd")
            .field("library", &self.config.library)
            .field("spec", &self.spec.name)
            .field("open", &self.session.is_some())
            .finish()
    }
}

/// Spec from the values the device reports (mm-based units converted to SI).
fn spec_from_device(
    name: &str,
    max_force_n: f64,
    stiffness_n_per_mm: f64,
    damping_n_s_per_mm: f64,
    usable_mm: [f64; 6],
) -> DeviceSpec {
    // The largest sphere inside the usable box, centred on the base origin.
    let half = |i: usize| (usable_mm[i + 3] - usable_mm[i]).abs() / 2.0;
    let radius_m = half(0).min(half(1)).min(half(2)) / 1000.0;
    let finite_or = |v: f64, d: f64| if v.is_finite() && v > 0.0 { v } else { d };
    DeviceSpec {
        name: name.to_string(),
        limits: DeviceLimits {
            max_force_n: finite_or(max_force_n, 3.3),
            max_torque_nm: 0.0,
            max_stiffness_n_per_m: finite_or(stiffness_n_per_mm * 1000.0, 1000.0),
            max_rot_stiffness_nm_per_rad: 0.0,
            max_damping_n_s_per_m: finite_or(damping_n_s_per_mm * 1000.0, 2.0),
            max_rot_damping_nm_s_per_rad: 0.0,
            workspace_radius_m: finite_or(radius_m, 0.05),
        },
        capabilities: Capabilities {
            force_output: true,
            torque_output: false,
            orientation_input: true,
            buttons: 2,
        },
    }
}

impl Hd {
    /// Loads the library and resolves its symbols; no device is touched yet.
    pub fn load(config: HdConfig) -> Result<Hd, SdkError> {
        let api = Box::new(Api::load(&config.library)?);
        Ok(Hd {
            api,
            config,
            spec: spec_from_device("OpenHaptics device", f64::NAN, f64::NAN, f64::NAN, [0.0; 6]),
            session: None,
            sequence: 0,
            last_tick: 0,
            last_tick_ns: 0,
        })
    }

    /// Servo ticks run so far in this session (0 when closed).
    pub fn servo_ticks(&self) -> u64 {
        self.session
            .as_ref()
            .map_or(0, |s| s.ticks.load(Ordering::Relaxed))
    }

    fn get_d<const N: usize>(&self, param: c_uint) -> [f64; N] {
        let mut v = [f64::NAN; N];
        // SAFETY: `v` holds as many doubles as `param` returns (caller picks N per hdDefines).
        unsafe { (self.api.get_doublev)(param, v.as_mut_ptr()) };
        v
    }
}

impl HapticDevice for Hd {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.close();
        let name = self
            .config
            .device_name
            .as_deref()
            .map(std::ffi::CString::new);
        let name = match name {
            Some(Ok(c)) => Some(c),
            Some(Err(_)) => return Err(DeviceError::InvalidConfig("device_name (contains NUL)")),
            None => None,
        };
        let ptr = name.as_ref().map_or(std::ptr::null(), |c| c.as_ptr());
        // SAFETY: null (HD_DEFAULT_DEVICE) or a live NUL-terminated string.
        let handle = unsafe { (self.api.init_device)(ptr) };
        if handle == HD_INVALID_HANDLE || self.api.error().is_some() {
            return Err(DeviceError::OpenFailed(
                "hdInitDevice failed: is the Touch driver running and the device configured (Touch_Setup)? check its USB/serial permissions",
            ));
        }
        // SAFETY: valid handle; plain queries with buffers of the documented sizes.
        unsafe { (self.api.make_current)(handle) };
        let model = {
            // SAFETY: returns a static NUL-terminated string or null.
            let p = unsafe { (self.api.get_string)(HD_DEVICE_MODEL_TYPE) };
            if p.is_null() {
                "OpenHaptics device".to_string()
            } else {
                // SAFETY: non-null, NUL-terminated, owned by the SDK.
                unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
            }
        };
        let [max_force] = self.get_d::<1>(HD_NOMINAL_MAX_FORCE);
        let [stiffness] = self.get_d::<1>(HD_NOMINAL_MAX_STIFFNESS);
        let [damping] = self.get_d::<1>(HD_NOMINAL_MAX_DAMPING);
        let usable = self.get_d::<6>(HD_USABLE_WORKSPACE_DIMENSIONS);
        self.spec = spec_from_device(&model, max_force, stiffness, damping, usable);
        // SAFETY: valid current device.
        unsafe { (self.api.enable)(HD_FORCE_OUTPUT) };

        let (sample_in, sample_out) = triple_buffer(&ServoSample::default());
        let (cmd_in, cmd_out) = triple_buffer(&ServoCommand::default());
        let stop = Arc::new(AtomicBool::new(false));
        let ticks = Arc::new(AtomicU64::new(0));
        let servo = Box::into_raw(Box::new(Servo {
            api: &*self.api,
            samples: sample_in,
            commands: cmd_out,
            stop: stop.clone(),
            tick: 0,
            last_sequence: 0,
            last_sequence_tick: 0,
            command_timeout_ticks: self.config.command_timeout_ticks,
            ticks_out: ticks.clone(),
        }));
        // SAFETY: the callback matches HDSchedulerCallback; `servo` stays alive until
        // `close` has unscheduled it.
        let schedule = unsafe {
            (self.api.schedule_async)(
                servo_callback,
                servo as *mut c_void,
                HD_MAX_SCHEDULER_PRIORITY,
            )
        };
        // SAFETY: starts OpenHaptics' servo thread.
        unsafe { (self.api.start_scheduler)() };
        self.session = Some(Session {
            handle,
            schedule,
            servo,
            stop,
            samples: sample_out,
            commands: cmd_in,
            ticks,
        });
        if self.api.error().is_some() {
            self.close();
            return Err(DeviceError::OpenFailed(
                "OpenHaptics servo scheduler failed to start",
            ));
        }
        // Wait (open may block) for the first servo tick, so the loop's first read has a
        // sample.
        let deadline = std::time::Instant::now() + std::time::Duration::from_millis(500);
        while self.servo_ticks() == 0 {
            if std::time::Instant::now() > deadline {
                self.close();
                return Err(DeviceError::OpenFailed(
                    "OpenHaptics servo scheduler did not run within 0.5 s",
                ));
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        self.sequence = 0;
        self.last_tick = 0;
        self.last_tick_ns = 0;
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        let stale_ns = (self.config.servo_stale_s * 1e9) as u64;
        let Some(s) = self.session.as_mut() else {
            return Err(DeviceError::NotOpen);
        };
        let sample = *s.samples.read();
        if sample.tick != self.last_tick || self.last_tick_ns == 0 {
            self.last_tick = sample.tick;
            self.last_tick_ns = now_ns;
        }
        if sample.tick == 0 || now_ns.saturating_sub(self.last_tick_ns) > stale_ns {
            // No servo tick yet, or the servo thread stopped: nothing fresh to report.
            return Err(DeviceError::ReadFailed);
        }
        if sample.error != 0 {
            return Err(DeviceError::ReadFailed);
        }
        let t = &sample.transform;
        // Column-major: element (row, col) is t[col * 4 + row].
        let r = Matrix3::new(t[0], t[4], t[8], t[1], t[5], t[9], t[2], t[6], t[10]);
        let rotation = FRAME.rotation_to_ours(r).ok_or(DeviceError::InvalidData)?;
        let pos = FRAME.to_ours(Vector3::new(t[12], t[13], t[14]) / 1000.0);
        Ok(DeviceState {
            pose: Isometry3::from_parts(Translation3::from(pos), rotation),
            linear_velocity: FRAME.to_ours(Vector3::from(sample.velocity_mm_s) / 1000.0),
            angular_velocity: FRAME.to_ours(Vector3::from(sample.angular_velocity)),
            buttons: sample.buttons,
            timestamp_ns: now_ns,
        })
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        let Some(s) = self.session.as_mut() else {
            return Err(DeviceError::NotOpen);
        };
        if !wrench.is_finite() {
            return Err(DeviceError::InvalidData);
        }
        let f = FRAME.to_vendor(self.spec.saturate(wrench).force);
        self.sequence += 1;
        s.commands.write(ServoCommand {
            force_n: [f.x, f.y, f.z],
            sequence: self.sequence,
        });
        Ok(())
    }

    fn close(&mut self) {
        if let Some(s) = self.session.take() {
            s.stop.store(true, Ordering::Release);
            // SAFETY: stop the servo thread, remove our callback, then release the device;
            // after hdUnschedule/hdStopScheduler return the callback no longer runs, so the
            // Servo box can be reclaimed.
            unsafe {
                (self.api.stop_scheduler)();
                (self.api.unschedule)(s.schedule);
                (self.api.disable_device)(s.handle);
                drop(Box::from_raw(s.servo));
            }
        }
    }
}

impl Drop for Hd {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_converts_mm_units() {
        // Touch: 3.3 N, 0.5 N/mm stiffness (500 N/m), usable box 320 × 240 × 120 mm.
        let s = spec_from_device(
            "Touch",
            3.3,
            0.5,
            0.002,
            [-160.0, -120.0, -60.0, 160.0, 120.0, 60.0],
        );
        assert_eq!(s.limits.max_stiffness_n_per_m, 500.0);
        assert!((s.limits.max_damping_n_s_per_m - 2.0).abs() < 1e-12);
        assert!((s.limits.workspace_radius_m - 0.06).abs() < 1e-12);
        assert!(s.validate().is_ok());
        // Garbage from the device falls back to conservative values.
        let s = spec_from_device("?", f64::NAN, -1.0, f64::INFINITY, [0.0; 6]);
        assert!(s.validate().is_ok());
        assert_eq!(s.limits.workspace_radius_m, 0.05);
    }

    #[test]
    fn hd_frame_relabels_axes() {
        // HD z (toward the operator) is our −Y; HD y (up) is our Z.
        assert_eq!(
            FRAME.to_ours(Vector3::new(0.0, 0.0, 1.0)),
            Vector3::new(0.0, -1.0, 0.0)
        );
        assert_eq!(
            FRAME.to_ours(Vector3::new(0.0, 1.0, 0.0)),
            Vector3::new(0.0, 0.0, 1.0)
        );
    }
}
