//! Which device the loop drives (`sim`, `sim-spacemouse`, `spacemouse`, `dhd`,
//! `openhaptics`, `driver`, `ros2:...`, `replay:FILE`), building it with an optional recorder
//! around it, and describing a device's limits. Errors name the device and what to check
//! (permissions, library path, driver).

use std::path::{Path, PathBuf};
use std::str::FromStr;

use devices::record::{Recorder, ReplayDevice};
use devices::sdk::{dhd, hd, library_path};
use devices::spacemouse::{SpaceMouse, SpaceMouseConfig};
use devices::{DeviceError, DeviceSpec, HapticDevice};

use crate::Error;
use crate::driver::{DriverConfig, DriverDevice};
use crate::session::scenario::SimInput;

/// Which device the loop drives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The simulated arm held by a simulated operator.
    Sim,
    /// A simulated SpaceMouse held by the simulated operator (rate control, no force).
    SimSpaceMouse,
    /// A 3Dconnexion SpaceMouse (rate control of an avatar).
    SpaceMouse,
    /// A Force Dimension device (or Novint Falcon) through libdhd.
    Dhd,
    /// A 3D Systems device through OpenHaptics libHD.
    OpenHaptics,
    /// A device served by an external driver over the driver services.
    Driver,
    /// A ROS 2 driver's arm: the driver services served by `hrrtc-ros2 device` (which the
    /// `haptic-loop` binary starts).
    Ros2(Ros2Device),
    /// A recorded session played back.
    Replay(PathBuf),
}

/// A device name that is none of the choices.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown device {0:?}: expected sim, sim-spacemouse, spacemouse, dhd, openhaptics, driver, ros2:pose=TOPIC,wrench=TOPIC[,...] or replay:FILE{1}"
)]
pub struct UnknownDevice(pub String, pub String);

/// A ROS 2 driver's arm: `ros2:pose=TOPIC,wrench=TOPIC[,KEY=VALUE...]`.
///
/// Keys: `pose` (its geometry_msgs/PoseStamped topic) and `wrench` (where the
/// geometry_msgs/WrenchStamped command goes), both required; `twist` (TwistStamped), `joy`
/// (sensor_msgs/Joy buttons) and `frame` (the command's frame_id); the arm's limits
/// `max_force` (N), `max_torque` (N·m), `stiffness` (N/m), `rot_stiffness` (N·m/rad),
/// `damping` (N·s/m), `workspace` (radius, m), `buttons`; `stale_ms` (a pose older than this
/// is a fault, default 20); and the ROS 2 side's `domain`, `connect`, `listen` (Zenoh
/// endpoints), `distro` (jazzy, kilted, humble), `zenoh_config`, `tls_ca`, `tls_cert`,
/// `tls_key` (files) and `insecure` (`true` to allow plain TCP, e.g. to rmw_zenoh's default
/// router). See `hrrtc-ros2 device --help`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ros2Device {
    /// The options in the order given, keys checked, values checked per key.
    pub options: Vec<(String, String)>,
}

/// Keys that take a ROS 2 topic (absolute name).
const ROS2_TOPIC_KEYS: [&str; 4] = ["pose", "wrench", "twist", "joy"];
/// Keys that take a non-negative number.
const ROS2_NUMBER_KEYS: [&str; 8] = [
    "max_force",
    "max_torque",
    "stiffness",
    "rot_stiffness",
    "damping",
    "workspace",
    "buttons",
    "stale_ms",
];
/// Keys that take another value (checked by `hrrtc-ros2`).
const ROS2_OTHER_KEYS: [&str; 10] = [
    "frame",
    "domain",
    "connect",
    "listen",
    "distro",
    "name",
    "zenoh_config",
    "tls_ca",
    "tls_cert",
    "tls_key",
];
/// Keys that take `true` or `false`.
const ROS2_SWITCH_KEYS: [&str; 1] = ["insecure"];

impl Ros2Device {
    /// Parses the text after `ros2:`; the error says which key or value is wrong.
    pub fn parse(spec: &str) -> Result<Self, String> {
        let mut options: Vec<(String, String)> = Vec::new();
        for item in spec.split(',').filter(|s| !s.is_empty()) {
            let Some((k, v)) = item.split_once('=') else {
                return Err(format!("{item:?} is not KEY=VALUE"));
            };
            let known = ROS2_TOPIC_KEYS
                .iter()
                .chain(&ROS2_NUMBER_KEYS)
                .chain(&ROS2_OTHER_KEYS)
                .chain(&ROS2_SWITCH_KEYS)
                .any(|key| *key == k);
            if !known {
                return Err(format!("unknown key {k:?}"));
            }
            if options.iter().any(|(key, _)| key == k) && k != "connect" && k != "listen" {
                return Err(format!("{k} given twice"));
            }
            if ROS2_TOPIC_KEYS.contains(&k) {
                let ok = v.starts_with('/')
                    && v[1..].split('/').all(|t| {
                        !t.is_empty() && t.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                    });
                if !ok {
                    return Err(format!(
                        "{k}={v:?}: a topic is an absolute ROS name (/a/b: letters, digits, '_')"
                    ));
                }
            }
            if ROS2_NUMBER_KEYS.contains(&k)
                && !v.parse::<f64>().is_ok_and(|x| x.is_finite() && x >= 0.0)
            {
                return Err(format!("{k}={v:?}: must be a number ≥ 0"));
            }
            if ROS2_SWITCH_KEYS.contains(&k) && v != "true" && v != "false" {
                return Err(format!("{k}={v:?}: must be true or false"));
            }
            if v.is_empty() {
                return Err(format!("{k}: empty value"));
            }
            options.push((k.to_owned(), v.to_owned()));
        }
        for required in ["pose", "wrench"] {
            if !options.iter().any(|(k, _)| k == required) {
                return Err(format!("{required}=TOPIC is required"));
            }
        }
        Ok(Ros2Device { options })
    }

    /// The value of `key`, if given (the first, for repeatable keys).
    pub fn get(&self, key: &str) -> Option<&str> {
        self.options
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// How old a pose may be before it is a fault, s (`stale_ms`, default 20 ms).
    pub fn stale_s(&self) -> f64 {
        self.get("stale_ms")
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| *v > 0.0)
            .map_or(0.02, |ms| ms / 1e3)
    }
}

impl FromStr for DeviceChoice {
    type Err = UnknownDevice;
    fn from_str(s: &str) -> Result<Self, UnknownDevice> {
        Ok(match s {
            "sim" => DeviceChoice::Sim,
            "sim-spacemouse" => DeviceChoice::SimSpaceMouse,
            "spacemouse" => DeviceChoice::SpaceMouse,
            "dhd" => DeviceChoice::Dhd,
            "openhaptics" => DeviceChoice::OpenHaptics,
            "driver" => DeviceChoice::Driver,
            _ => {
                if let Some(spec) = s.strip_prefix("ros2:") {
                    return Ros2Device::parse(spec)
                        .map(DeviceChoice::Ros2)
                        .map_err(|e| UnknownDevice(s.to_owned(), format!(" (ros2: {e})")));
                }
                match s.strip_prefix("replay:") {
                    Some(f) if !f.is_empty() => DeviceChoice::Replay(PathBuf::from(f)),
                    _ => return Err(UnknownDevice(s.to_owned(), String::new())),
                }
            }
        })
    }
}

impl DeviceChoice {
    /// A short name for messages.
    pub fn name(&self) -> String {
        match self {
            DeviceChoice::Sim => "the simulated arm".into(),
            DeviceChoice::SimSpaceMouse => "the simulated SpaceMouse".into(),
            DeviceChoice::SpaceMouse => "the SpaceMouse".into(),
            DeviceChoice::Dhd => "the Force Dimension device (libdhd)".into(),
            DeviceChoice::OpenHaptics => "the OpenHaptics device (libHD)".into(),
            DeviceChoice::Driver => "the external driver".into(),
            DeviceChoice::Ros2(d) => format!(
                "the ROS 2 driver's arm ({})",
                d.get("pose").unwrap_or_default()
            ),
            DeviceChoice::Replay(p) => format!("the replay of {}", p.display()),
        }
    }

    /// What to check when this device does not open.
    fn hint(&self) -> &'static str {
        match self {
            DeviceChoice::Sim | DeviceChoice::SimSpaceMouse => "",
            DeviceChoice::SpaceMouse => {
                "check that it is plugged in (`haptic-loop devices`) and that you may open /dev/hidraw* (install devices/udev/70-hrrtc-devices.rules, re-plug)"
            }
            DeviceChoice::Dhd => {
                "check USB and power, the udev rule (devices/udev/70-hrrtc-devices.rules), and that libdhd.so is on LD_LIBRARY_PATH or given with --device-lib / HRRTC_DHD_LIB"
            }
            DeviceChoice::OpenHaptics => {
                "check that the Touch driver is installed and configured (Touch_Setup), and that libHD.so is on LD_LIBRARY_PATH or given with --device-lib / HRRTC_HD_LIB"
            }
            DeviceChoice::Driver => {
                "start the driver with the same --namespace, e.g. `cargo run -p haptic-loop --example sim_driver -- --namespace NAME`"
            }
            DeviceChoice::Ros2(_) => {
                "check that the driver publishes its pose (`ros2 topic hz`), that rmw_zenoh's router runs or `connect=` names a reachable endpoint, and hrrtc-ros2's log above"
            }
            DeviceChoice::Replay(_) => "check that the file is a recording made with --record",
        }
    }

    /// The error for a device that failed to open, naming it and what to check.
    pub fn open_error(&self, source: DeviceError) -> Error {
        Error::Device {
            device: self.name(),
            error: source,
            hint: self.hint(),
        }
    }

    fn sdk_error(&self, source: devices::sdk::SdkError) -> Error {
        Error::Sdk {
            device: self.name(),
            error: source,
        }
    }
}

/// The device, its vendor library and an optional recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceOptions {
    /// Which device.
    pub device: DeviceChoice,
    /// Vendor library for dhd / openhaptics (`None`: `$HRRTC_DHD_LIB` / `$HRRTC_HD_LIB`,
    /// else `libdhd.so` / `libHD.so` on the loader path).
    pub device_lib: Option<PathBuf>,
    /// Record device states and commanded wrenches to this MCAP file.
    pub record: Option<PathBuf>,
}

/// Builds the chosen device (not yet opened; `Tick::new` opens it). Simulated devices come
/// from `sim`, given which one: the caller owns the simulated operator's set-up;
/// `namespace` is the external driver's.
pub fn build(
    args: &DeviceOptions,
    namespace: &str,
    sim: impl FnOnce(SimInput) -> Result<Box<dyn HapticDevice>, Error>,
) -> Result<Box<dyn HapticDevice>, Error> {
    let choice = &args.device;
    let device: Box<dyn HapticDevice> = match choice {
        DeviceChoice::Sim => sim(SimInput::Arm)?,
        DeviceChoice::SimSpaceMouse => sim(SimInput::SpaceMouse)?,
        DeviceChoice::SpaceMouse => Box::new(
            SpaceMouse::new(SpaceMouseConfig::default()).map_err(|e| choice.open_error(e))?,
        ),
        DeviceChoice::Dhd => Box::new(
            dhd::Dhd::load(dhd::DhdConfig {
                library: vendor_library(args.device_lib.as_deref(), Sdk::Dhd),
                ..dhd::DhdConfig::default()
            })
            .map_err(|e| choice.sdk_error(e))?,
        ),
        DeviceChoice::OpenHaptics => Box::new(
            hd::Hd::load(hd::HdConfig {
                library: vendor_library(args.device_lib.as_deref(), Sdk::Hd),
                ..hd::HdConfig::default()
            })
            .map_err(|e| choice.sdk_error(e))?,
        ),
        DeviceChoice::Driver => Box::new(
            DriverDevice::new(DriverConfig::new(namespace)).map_err(|e| choice.open_error(e))?,
        ),
        // The gateway process needs its Zenoh session and the driver's first pose.
        DeviceChoice::Ros2(d) => Box::new(
            DriverDevice::new(DriverConfig {
                open_timeout_s: 10.0,
                stale_s: d.stale_s(),
                ..DriverConfig::new(namespace)
            })
            .map_err(|e| choice.open_error(e))?,
        ),
        DeviceChoice::Replay(p) => {
            Box::new(ReplayDevice::from_file(p).map_err(|source| Error::Record {
                what: format!("cannot use {}", choice.name()),
                error: source,
            })?)
        }
    };
    match &args.record {
        Some(p) => Ok(Box::new(Recorder::create(device, p).map_err(|source| {
            Error::Record {
                what: format!("cannot record to {}", p.display()),
                error: source,
            }
        })?)),
        None => Ok(device),
    }
}

/// The vendor library of `sdk` to load: `explicit`, else the SDK's environment variable
/// (`HRRTC_DHD_LIB`, `HRRTC_HD_LIB`), else the loader's default name.
pub fn vendor_library(explicit: Option<&Path>, sdk: Sdk) -> PathBuf {
    let (env, default) = match sdk {
        Sdk::Dhd => (dhd::LIBRARY_ENV, dhd::LIBRARY_DEFAULT),
        Sdk::Hd => (hd::LIBRARY_ENV, hd::LIBRARY_DEFAULT),
    };
    library_path(explicit.map(Path::to_path_buf), env, default)
}

/// A vendor SDK.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sdk {
    /// Force Dimension's libdhd.
    Dhd,
    /// 3D Systems' OpenHaptics libHD.
    Hd,
}

/// One line per limit of `spec`.
pub fn describe(spec: &DeviceSpec) -> String {
    let c = &spec.capabilities;
    format!(
        "    max force {:.2} N, max torque {:.2} N·m, stiffness ≤ {:.0} N/m, damping ≤ {:.1} N·s/m, workspace radius {:.3} m\n    outputs: {}{}; orientation input: {}; buttons: {}",
        spec.limits.max_force_n,
        spec.limits.max_torque_nm,
        spec.limits.max_stiffness_n_per_m,
        spec.limits.max_damping_n_s_per_m,
        spec.limits.workspace_radius_m,
        if c.force_output {
            "force"
        } else {
            "none (input only: the guidance force moves the avatar)"
        },
        if c.torque_output { " + torque" } else { "" },
        if c.orientation_input { "yes" } else { "no" },
        c.buttons
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_choices_parse_and_bad_ones_are_explained() {
        assert_eq!("sim".parse::<DeviceChoice>(), Ok(DeviceChoice::Sim));
        assert_eq!(
            "sim-spacemouse".parse::<DeviceChoice>(),
            Ok(DeviceChoice::SimSpaceMouse)
        );
        assert_eq!(
            "openhaptics".parse::<DeviceChoice>(),
            Ok(DeviceChoice::OpenHaptics)
        );
        assert_eq!(
            "replay:/tmp/a.mcap".parse::<DeviceChoice>(),
            Ok(DeviceChoice::Replay("/tmp/a.mcap".into()))
        );
        let e = "replay:".parse::<DeviceChoice>().unwrap_err().to_string();
        assert!(e.contains("replay:FILE"));
        let e = "phantom".parse::<DeviceChoice>().unwrap_err().to_string();
        assert!(e.contains("\"phantom\"") && e.contains("spacemouse"));
    }

    #[test]
    fn ros2_devices_parse_and_bad_specs_say_what_is_wrong() {
        let d = match "ros2:pose=/arm/pose,wrench=/arm/wrench,max_force=8,connect=tcp/a:1,connect=tcp/b:2,stale_ms=50"
            .parse::<DeviceChoice>()
        {
            Ok(DeviceChoice::Ros2(d)) => d,
            other => panic!("{other:?}"),
        };
        assert_eq!(d.get("pose"), Some("/arm/pose"));
        assert_eq!(d.get("max_force"), Some("8"));
        assert_eq!(d.options.iter().filter(|(k, _)| k == "connect").count(), 2);
        assert_eq!(d.stale_s(), 0.05);
        let secure = Ros2Device::parse("pose=/a,wrench=/b,tls_ca=c.pem,insecure=false").unwrap();
        assert_eq!(secure.get("tls_ca"), Some("c.pem"));
        assert_eq!(secure.get("insecure"), Some("false"));
        assert_eq!(
            Ros2Device::parse("pose=/a,wrench=/b").unwrap().stale_s(),
            0.02
        );
        for (spec, says) in [
            ("ros2:pose=/a", "wrench=TOPIC is required"),
            ("ros2:pose=a,wrench=/b", "absolute"),
            ("ros2:pose=/a//b,wrench=/b", "absolute"),
            ("ros2:pose=/a,wrench=/b,max_force=-1", "max_force"),
            ("ros2:pose=/a,wrench=/b,max_force=nan", "max_force"),
            (
                "ros2:pose=/a,wrench=/b,colour=red",
                "unknown key \"colour\"",
            ),
            ("ros2:pose=/a,wrench=/b,pose=/c", "pose given twice"),
            ("ros2:pose=/a,wrench", "not KEY=VALUE"),
            ("ros2:pose=/a,wrench=/b,insecure=yes", "true or false"),
        ] {
            let e = spec.parse::<DeviceChoice>().unwrap_err().to_string();
            assert!(e.contains(says), "{spec}: {e}");
        }
    }

    #[test]
    fn absent_devices_give_errors_naming_what_to_check() {
        let args = |device, lib: Option<&str>| DeviceOptions {
            device,
            device_lib: lib.map(PathBuf::from),
            record: None,
        };
        let no_sim = |_| -> Result<Box<dyn HapticDevice>, Error> { unreachable!("not sim") };
        let e = build(
            &args(DeviceChoice::Dhd, Some("/nonexistent/libdhd.so")),
            "default",
            no_sim,
        )
        .err()
        .expect("no SDK here");
        let text = e.to_string();
        assert!(
            text.contains("Force Dimension")
                && text.contains("/nonexistent/libdhd.so")
                && text.contains("LD_LIBRARY_PATH"),
            "{text}"
        );
        let e = build(
            &args(DeviceChoice::OpenHaptics, Some("/nonexistent/libHD.so")),
            "default",
            no_sim,
        )
        .err()
        .expect("no SDK here");
        assert!(e.to_string().contains("HRRTC_HD_LIB"));
        let e = build(
            &args(DeviceChoice::Replay("/nonexistent/r.mcap".into()), None),
            "default",
            no_sim,
        )
        .err()
        .expect("no file");
        assert!(e.to_string().contains("/nonexistent/r.mcap"));
        let e = DeviceChoice::SpaceMouse
            .open_error(DeviceError::OpenFailed("no 3Dconnexion SpaceMouse found"));
        assert!(e.to_string().contains("hidraw"));
    }
}
