//! Force Dimension DHD SDK (`libdhd.so`): omega, delta, sigma, lambda and the Novint Falcon.
//!
//! DHD frame: x toward the operator, y to the right, z up; m, m/s, N, N·m, rad/s. Ours: X
//! right, Y away, Z up (see [`super`]). Calls are synchronous USB transactions inside the
//! SDK (a few tens of µs): this is device I/O, the one kind of system call the RT thread
//! makes.

use std::ffi::{CStr, c_char, c_double, c_int, c_uchar, c_uint};
use std::path::{Path, PathBuf};

use libloading::Library;
use nalgebra::{Isometry3, Matrix3, Translation3, Vector3};

use super::{FrameMap, SdkError, load, sym};
use crate::{
    Capabilities, DeviceError, DeviceLimits, DeviceSpec, DeviceState, HapticDevice, Wrench,
};

/// Environment variable naming the library to load instead of `libdhd.so`.
pub const LIBRARY_ENV: &str = "HRRTC_DHD_LIB";
/// Default library name, searched by the dynamic loader.
pub const LIBRARY_DEFAULT: &str = "libdhd.so";
const HINT: &str = "Install the Force Dimension SDK and add its lib/release/lin-x86_64 directory to LD_LIBRARY_PATH, or set HRRTC_DHD_LIB to the library file";

/// DHD → ours: X = y_dhd, Y = −x_dhd, Z = z_dhd.
pub(crate) const FRAME: FrameMap = FrameMap::new(Matrix3::new(
    0.0, 1.0, 0.0, //
    -1.0, 0.0, 0.0, //
    0.0, 0.0, 1.0,
));

type FnOpen = unsafe extern "C" fn() -> c_int;
type FnId = unsafe extern "C" fn(c_char) -> c_int;
type FnName = unsafe extern "C" fn(c_char) -> *const c_char;
type FnPosFrame = unsafe extern "C" fn(
    *mut c_double,
    *mut c_double,
    *mut c_double,
    *mut [[c_double; 3]; 3],
    c_char,
) -> c_int;
type FnVec3 = unsafe extern "C" fn(*mut c_double, *mut c_double, *mut c_double, c_char) -> c_int;
type FnButtons = unsafe extern "C" fn(c_char) -> c_uint;
type FnSetFT = unsafe extern "C" fn(
    c_double,
    c_double,
    c_double,
    c_double,
    c_double,
    c_double,
    c_char,
) -> c_int;
type FnUchar = unsafe extern "C" fn(c_uchar, c_char) -> c_int;
type FnErr = unsafe extern "C" fn() -> *const c_char;

/// The DHD functions we call, resolved once at load.
struct Api {
    get_device_count: FnOpen,
    open: FnOpen,
    close: FnId,
    system_type: FnId,
    system_name: Option<FnName>,
    position_frame: FnPosFrame,
    linear_velocity: FnVec3,
    angular_velocity: Option<FnVec3>,
    buttons: FnButtons,
    set_force_torque: FnSetFT,
    enable_force: FnUchar,
    set_watchdog: Option<FnUchar>,
    last_error: FnErr,
    // Keeps the pointers above valid; dropped last.
    _lib: Library,
}

impl Api {
    fn load(path: &Path) -> Result<Api, SdkError> {
        let lib = load(path.as_os_str(), HINT)?;
        let name = path.to_string_lossy().into_owned();
        let n = name.as_str();
        // SAFETY: each type alias is the C signature from the DHD SDK's dhdc.h; the
        // pointers live in `Api` together with the library that owns them.
        unsafe {
            Ok(Api {
                get_device_count: sym(&lib, n, "dhdGetDeviceCount")?,
                open: sym(&lib, n, "dhdOpen")?,
                close: sym(&lib, n, "dhdClose")?,
                system_type: sym(&lib, n, "dhdGetSystemType")?,
                system_name: sym(&lib, n, "dhdGetSystemName").ok(),
                position_frame: sym(&lib, n, "dhdGetPositionAndOrientationFrame")?,
                linear_velocity: sym(&lib, n, "dhdGetLinearVelocity")?,
                angular_velocity: sym(&lib, n, "dhdGetAngularVelocityRad").ok(),
                buttons: sym(&lib, n, "dhdGetButtonMask")?,
                set_force_torque: sym(&lib, n, "dhdSetForceAndTorque")?,
                enable_force: sym(&lib, n, "dhdEnableForce")?,
                set_watchdog: sym(&lib, n, "dhdSetWatchdog").ok(),
                last_error: sym(&lib, n, "dhdErrorGetLastStr")?,
                _lib: lib,
            })
        }
    }

    fn last_error(&self) -> String {
        // SAFETY: dhdErrorGetLastStr returns a static NUL-terminated string or null.
        let p = unsafe { (self.last_error)() };
        if p.is_null() {
            return "unknown error".into();
        }
        // SAFETY: non-null, NUL-terminated, owned by the SDK for the process lifetime.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Limits of a DHD system type (`dhdGetSystemType`), from the vendor's data sheets as
/// CHAI3D tabulates them, stiffness capped to what renders stably at 1 kHz.
pub fn spec_for_system_type(system_type: i32, name: &str) -> DeviceSpec {
    // (force N, torque N·m, stiffness N/m, rot. stiffness N·m/rad, damping N·s/m,
    //  workspace radius m, orientation input, buttons)
    let (f, t, k, kr, b, r, orient, buttons) = match system_type {
        33 => (12.0, 0.0, 5000.0, 0.0, 20.0, 0.075, false, 1), // omega.3
        34 | 36 => (12.0, 0.0, 5000.0, 0.0, 20.0, 0.075, true, 1), // omega.6
        35 | 37 => (12.0, 0.0, 5000.0, 0.0, 20.0, 0.075, true, 1), // omega.7
        63 => (20.0, 0.0, 6000.0, 0.0, 20.0, 0.15, false, 1),  // delta.3
        64 => (20.0, 0.2, 6000.0, 0.8, 20.0, 0.15, true, 1),   // delta.6
        104..=107 => (20.0, 0.4, 6000.0, 0.8, 20.0, 0.075, true, 2), // sigma.7
        60 => (8.0, 0.0, 3000.0, 0.0, 20.0, 0.04, false, 4),   // Novint Falcon
        // Unknown: conservative limits until someone measures it.
        _ => (3.0, 0.0, 1000.0, 0.0, 5.0, 0.05, false, 1),
    };
    DeviceSpec {
        name: name.to_string(),
        limits: DeviceLimits {
            max_force_n: f,
            max_torque_nm: t,
            max_stiffness_n_per_m: k,
            max_rot_stiffness_nm_per_rad: kr,
            max_damping_n_s_per_m: b,
            max_rot_damping_nm_s_per_rad: if t > 0.0 { 0.01 } else { 0.0 },
            workspace_radius_m: r,
        },
        capabilities: Capabilities {
            force_output: true,
            torque_output: t > 0.0,
            orientation_input: orient,
            buttons,
        },
    }
}

/// Settings of a DHD device.
#[derive(Debug, Clone, PartialEq)]
pub struct DhdConfig {
    /// Library to load (see [`super::library_path`]).
    pub library: PathBuf,
    /// Hardware watchdog, s: the device drops force if no new command arrives within it
    /// (set in multiples of 125 µs, at most 31.9 ms). Ignored by SDKs before 3.3.2.
    pub watchdog_s: f64,
}

impl Default for DhdConfig {
    fn default() -> Self {
        DhdConfig {
            library: super::library_path(None, LIBRARY_ENV, LIBRARY_DEFAULT),
            watchdog_s: 0.02,
        }
    }
}

/// A Force Dimension device through `libdhd`.
pub struct Dhd {
    api: Api,
    config: DhdConfig,
    spec: DeviceSpec,
    /// Device id from `dhdOpen`, −1 when closed.
    id: c_char,
}

impl std::fmt::Debug for Dhd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dhd")
            .field("library", &self.config.library)
            .field("spec", &self.spec.name)
            .field("id", &self.id)
            .finish()
    }
}

impl Dhd {
    /// Loads the library and resolves its symbols; no device is touched yet.
    pub fn load(config: DhdConfig) -> Result<Dhd, SdkError> {
        let api = Api::load(&config.library)?;
        Ok(Dhd {
            api,
            config,
            spec: spec_for_system_type(-1, "Force Dimension device"),
            id: -1,
        })
    }

    /// Devices the SDK sees (`dhdGetDeviceCount`; negative on SDK error → 0).
    pub fn device_count(&self) -> usize {
        // SAFETY: no arguments; the SDK enumerates its USB devices.
        let n = unsafe { (self.api.get_device_count)() };
        usize::try_from(n).unwrap_or(0)
    }

    /// The SDK's last error text (for logs and CLI messages; allocates).
    pub fn last_error(&self) -> String {
        self.api.last_error()
    }
}

impl HapticDevice for Dhd {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.close();
        // SAFETY: dhdOpen() takes no arguments and returns an id or -1.
        let id = unsafe { (self.api.open)() };
        if id < 0 {
            return Err(DeviceError::OpenFailed(
                "libdhd found no Force Dimension device: check USB and power, and the udev rule (devices/udev)",
            ));
        }
        let id = c_char::try_from(id)
            .map_err(|_| DeviceError::OpenFailed("libdhd returned an invalid device id"))?;
        // SAFETY: valid id from dhdOpen.
        let system_type = unsafe { (self.api.system_type)(id) };
        let name = match self.api.system_name {
            Some(f) => {
                // SAFETY: valid id; returns a static NUL-terminated string or null.
                let p = unsafe { f(id) };
                if p.is_null() {
                    format!("DHD system type {system_type}")
                } else {
                    // SAFETY: non-null and NUL-terminated per the SDK contract.
                    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
                }
            }
            None => format!("DHD system type {system_type}"),
        };
        self.spec = spec_for_system_type(system_type, &name);
        self.id = id;
        if let Some(f) = self.api.set_watchdog {
            let ticks = (self.config.watchdog_s / 125e-6).ceil().clamp(1.0, 255.0) as c_uchar;
            // SAFETY: valid id.
            if unsafe { f(ticks, id) } < 0 {
                self.close();
                return Err(DeviceError::OpenFailed("dhdSetWatchdog failed"));
            }
        }
        // SAFETY: valid id; zero force first, then enable.
        let ok = unsafe {
            (self.api.set_force_torque)(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, id) >= 0
                && (self.api.enable_force)(1, id) >= 0
        };
        if !ok {
            self.close();
            return Err(DeviceError::OpenFailed(
                "libdhd could not enable force output",
            ));
        }
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        if self.id < 0 {
            return Err(DeviceError::NotOpen);
        }
        let (mut p, mut v, mut w) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        let mut r = [[0.0f64; 3]; 3];
        // SAFETY: every pointer is a live local of the right size; valid id.
        let rc =
            unsafe {
                (self.api.position_frame)(&mut p[0], &mut p[1], &mut p[2], &mut r, self.id).min(
                    (self.api.linear_velocity)(&mut v[0], &mut v[1], &mut v[2], self.id),
                )
            };
        if rc < 0 {
            return Err(DeviceError::ReadFailed);
        }
        if let Some(f) = self.api.angular_velocity {
            // SAFETY: as above.
            if unsafe { f(&mut w[0], &mut w[1], &mut w[2], self.id) } < 0 {
                return Err(DeviceError::ReadFailed);
            }
        }
        // SAFETY: valid id.
        let buttons = unsafe { (self.api.buttons)(self.id) };
        // dhd's matrix[3][3] is row-major: r[row][col].
        let m = Matrix3::new(
            r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2],
        );
        let rotation = FRAME.rotation_to_ours(m).ok_or(DeviceError::InvalidData)?;
        let pos = FRAME.to_ours(Vector3::from(p));
        Ok(DeviceState {
            pose: Isometry3::from_parts(Translation3::from(pos), rotation),
            linear_velocity: FRAME.to_ours(Vector3::from(v)),
            angular_velocity: FRAME.to_ours(Vector3::from(w)),
            buttons,
            // The SDK samples synchronously inside the call.
            timestamp_ns: now_ns,
        })
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        if self.id < 0 {
            return Err(DeviceError::NotOpen);
        }
        if !wrench.is_finite() {
            return Err(DeviceError::InvalidData);
        }
        let w = self.spec.saturate(wrench);
        let f = FRAME.to_vendor(w.force);
        let t = FRAME.to_vendor(w.torque);
        // SAFETY: plain doubles; valid id.
        let rc = unsafe { (self.api.set_force_torque)(f.x, f.y, f.z, t.x, t.y, t.z, self.id) };
        // DHD_MOTOR_SATURATED (2) means applied but saturated: success.
        if rc < 0 {
            return Err(DeviceError::WriteFailed);
        }
        Ok(())
    }

    fn close(&mut self) {
        if self.id >= 0 {
            // SAFETY: valid id; zero force before releasing the device.
            unsafe {
                (self.api.set_force_torque)(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, self.id);
                (self.api.enable_force)(0, self.id);
                (self.api.close)(self.id);
            }
            self.id = -1;
        }
    }
}

impl Drop for Dhd {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_by_system_type() {
        let falcon = spec_for_system_type(60, "Falcon");
        assert_eq!(falcon.limits.max_force_n, 8.0);
        assert_eq!(falcon.capabilities.buttons, 4);
        assert!(!falcon.capabilities.torque_output);
        let sigma = spec_for_system_type(104, "sigma.7");
        assert!(sigma.capabilities.torque_output && sigma.limits.max_torque_nm > 0.0);
        for t in [-1, 0, 33, 34, 35, 60, 63, 64, 104, 999] {
            spec_for_system_type(t, "x").validate().expect("valid spec");
        }
    }

    #[test]
    fn dhd_frame_relabels_axes() {
        // Toward the operator in DHD (+x) is −Y in ours; DHD right (+y) is our +X.
        assert_eq!(
            FRAME.to_ours(Vector3::new(1.0, 0.0, 0.0)),
            Vector3::new(0.0, -1.0, 0.0)
        );
        assert_eq!(
            FRAME.to_ours(Vector3::new(0.0, 1.0, 0.0)),
            Vector3::new(1.0, 0.0, 0.0)
        );
        assert_eq!(
            FRAME.to_ours(Vector3::new(0.0, 0.0, 1.0)),
            Vector3::new(0.0, 0.0, 1.0)
        );
    }
}
