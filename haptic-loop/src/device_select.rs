//! Device selection for the binary: `--device sim|spacemouse|dhd|openhaptics|bridge|replay:FILE`,
//! optional `--record FILE`, and the `devices` listing. Errors name the device and what
//! to check (permissions, library path, driver).

use std::path::PathBuf;
use std::str::FromStr;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use devices::record::{Recorder, ReplayDevice};
use devices::sdk::{dhd, hd, library_path};
use devices::spacemouse::{self, SpaceMouse, SpaceMouseConfig};
use devices::{DeviceError, DeviceSpec, HapticDevice};

use crate::bridge::{BridgeConfig, BridgeDevice};

/// Which device the loop drives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DeviceChoice {
    /// The simulated arm with the scripted operator.
    Sim,
    /// A 3Dconnexion SpaceMouse (rate control of an avatar).
    SpaceMouse,
    /// A Force Dimension device (or Novint Falcon) through libdhd.
    Dhd,
    /// A 3D Systems device through OpenHaptics libHD.
    OpenHaptics,
    /// A device served by an external driver over the bridge services.
    Bridge,
    /// A recorded session played back.
    Replay(PathBuf),
}

impl FromStr for DeviceChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "sim" => DeviceChoice::Sim,
            "spacemouse" => DeviceChoice::SpaceMouse,
            "dhd" => DeviceChoice::Dhd,
            "openhaptics" => DeviceChoice::OpenHaptics,
            "bridge" => DeviceChoice::Bridge,
            _ => match s.strip_prefix("replay:") {
                Some(f) if !f.is_empty() => DeviceChoice::Replay(PathBuf::from(f)),
                _ => {
                    return Err(format!(
                        "unknown device {s:?}: expected sim, spacemouse, dhd, openhaptics, bridge or replay:FILE"
                    ));
                }
            },
        })
    }
}

impl DeviceChoice {
    /// A short name for messages.
    pub fn name(&self) -> String {
        match self {
            DeviceChoice::Sim => "the simulated arm".into(),
            DeviceChoice::SpaceMouse => "the SpaceMouse".into(),
            DeviceChoice::Dhd => "the Force Dimension device (libdhd)".into(),
            DeviceChoice::OpenHaptics => "the OpenHaptics device (libHD)".into(),
            DeviceChoice::Bridge => "the bridged driver".into(),
            DeviceChoice::Replay(p) => format!("the replay of {}", p.display()),
        }
    }

    /// What to check when this device does not open.
    fn hint(&self) -> &'static str {
        match self {
            DeviceChoice::Sim => "",
            DeviceChoice::SpaceMouse => {
                "check that it is plugged in (`haptic-loop devices`) and that you may open /dev/hidraw* (install devices/udev/70-hrrtc-devices.rules, re-plug)"
            }
            DeviceChoice::Dhd => {
                "check USB and power, the udev rule (devices/udev/70-hrrtc-devices.rules), and that libdhd.so is on LD_LIBRARY_PATH or given with --device-lib / HRRTC_DHD_LIB"
            }
            DeviceChoice::OpenHaptics => {
                "check that the Touch driver is installed and configured (Touch_Setup), and that libHD.so is on LD_LIBRARY_PATH or given with --device-lib / HRRTC_HD_LIB"
            }
            DeviceChoice::Bridge => {
                "start the driver with the same --namespace, e.g. `cargo run -p haptic-loop --example bridge_driver -- --namespace NAME`"
            }
            DeviceChoice::Replay(_) => "check that the file is a recording made with --record",
        }
    }

    /// The error for a device that failed to open, naming it and what to check.
    pub fn open_error(&self, e: DeviceError) -> anyhow::Error {
        anyhow::anyhow!("cannot open {}: {e}; {}", self.name(), self.hint())
    }
}

/// Device options of `haptic-loop run`.
#[derive(Debug, Args, Clone)]
pub struct DeviceArgs {
    /// Device: sim, spacemouse, dhd, openhaptics, bridge or replay:FILE.
    #[arg(long, default_value = "sim", value_parser = DeviceChoice::from_str)]
    pub device: DeviceChoice,
    /// Vendor library for dhd / openhaptics (default: $HRRTC_DHD_LIB / $HRRTC_HD_LIB, else
    /// libdhd.so / libHD.so on the loader path).
    #[arg(long)]
    pub device_lib: Option<PathBuf>,
    /// Record device states and commanded wrenches to this MCAP file.
    #[arg(long)]
    pub record: Option<PathBuf>,
}

/// Builds the chosen device (not yet opened; `Tick::new` opens it). `sim` comes from the
/// caller, which owns the simulated operator's set-up; `namespace` is the bridge's.
pub fn build(
    args: &DeviceArgs,
    namespace: &str,
    sim: impl FnOnce() -> anyhow::Result<Box<dyn HapticDevice>>,
) -> anyhow::Result<Box<dyn HapticDevice>> {
    let choice = &args.device;
    let what = || format!("cannot use {}", choice.name());
    let device: Box<dyn HapticDevice> = match choice {
        DeviceChoice::Sim => sim()?,
        DeviceChoice::SpaceMouse => Box::new(
            SpaceMouse::new(SpaceMouseConfig::default()).map_err(|e| choice.open_error(e))?,
        ),
        DeviceChoice::Dhd => Box::new(
            dhd::Dhd::load(dhd::DhdConfig {
                library: library_path(
                    args.device_lib.clone(),
                    dhd::LIBRARY_ENV,
                    dhd::LIBRARY_DEFAULT,
                ),
                ..dhd::DhdConfig::default()
            })
            .with_context(what)?,
        ),
        DeviceChoice::OpenHaptics => Box::new(
            hd::Hd::load(hd::HdConfig {
                library: library_path(
                    args.device_lib.clone(),
                    hd::LIBRARY_ENV,
                    hd::LIBRARY_DEFAULT,
                ),
                ..hd::HdConfig::default()
            })
            .with_context(what)?,
        ),
        DeviceChoice::Bridge => Box::new(
            BridgeDevice::new(BridgeConfig::new(namespace)).map_err(|e| choice.open_error(e))?,
        ),
        DeviceChoice::Replay(p) => Box::new(ReplayDevice::from_file(p).with_context(what)?),
    };
    match &args.record {
        Some(p) => Ok(Box::new(
            Recorder::create(device, p)
                .with_context(|| format!("cannot record to {}", p.display()))?,
        )),
        None => Ok(device),
    }
}

/// One line per limit of `spec`.
pub fn describe(spec: &DeviceSpec) -> String {
    let c = &spec.capabilities;
    format!(
        "    max force {:.2} N, max torque {:.2} N·m, stiffness ≤ {:.0} N/m, damping ≤ {:.1} N·s/m, workspace radius {:.3} m\n    outputs: {}{}; orientation input: {}; buttons: {}",
        spec.max_force_n,
        spec.max_torque_nm,
        spec.max_stiffness_n_per_m,
        spec.max_damping_n_s_per_m,
        spec.workspace_radius_m,
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

/// Options of `haptic-loop devices`.
#[derive(Debug, Args, Clone)]
pub struct DevicesArgs {
    /// Namespace in which to look for a bridged driver.
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Vendor library to probe for dhd / openhaptics (as for `run --device-lib`).
    #[arg(long)]
    pub device_lib: Option<PathBuf>,
}

/// `haptic-loop devices`: prints what is attached with its spec; exit code 0 either way.
pub fn list(args: &DevicesArgs) -> anyhow::Result<i32> {
    ipc_types::services::validate_namespace(&args.namespace)
        .map_err(|e| anyhow::anyhow!("--namespace: {e}"))?;
    let mut found = 0;
    let mut notes = Vec::new();

    match spacemouse::enumerate() {
        Ok(list) if list.is_empty() => notes.push("SpaceMouse: none attached".to_string()),
        Ok(list) => {
            for f in list {
                found += 1;
                let buttons = f.model.map_or(2, |m| m.buttons);
                println!(
                    "spacemouse   {} ({:04x}:{:04x}) at {}",
                    f.name, f.vendor_id, f.product_id, f.path
                );
                println!(
                    "{}",
                    describe(&SpaceMouseConfig::default().spec_for(&f.name, buttons))
                );
            }
        }
        Err(e) => notes.push(format!("SpaceMouse: {e}")),
    }

    let dhd_lib = library_path(
        args.device_lib.clone(),
        dhd::LIBRARY_ENV,
        dhd::LIBRARY_DEFAULT,
    );
    match dhd::Dhd::load(dhd::DhdConfig {
        library: dhd_lib.clone(),
        ..dhd::DhdConfig::default()
    }) {
        Err(_) => notes.push(format!(
            "Force Dimension: {} not found (SDK not installed?)",
            dhd_lib.display()
        )),
        Ok(mut d) if d.device_count() > 0 => match d.open() {
            Ok(()) => {
                found += 1;
                println!("dhd          {} via {}", d.spec().name, dhd_lib.display());
                println!("{}", describe(d.spec()));
                d.close();
            }
            Err(e) => notes.push(format!(
                "Force Dimension: a device is seen but does not open ({e}: {})",
                d.last_error()
            )),
        },
        Ok(_) => notes.push("Force Dimension: SDK present, no device attached".into()),
    }

    let hd_lib = library_path(
        args.device_lib.clone(),
        hd::LIBRARY_ENV,
        hd::LIBRARY_DEFAULT,
    );
    match hd::Hd::load(hd::HdConfig {
        library: hd_lib.clone(),
        ..hd::HdConfig::default()
    }) {
        Err(_) => notes.push(format!(
            "OpenHaptics: {} not found (SDK not installed?)",
            hd_lib.display()
        )),
        Ok(mut d) => match d.open() {
            Ok(()) => {
                found += 1;
                println!("openhaptics  {} via {}", d.spec().name, hd_lib.display());
                println!("{}", describe(d.spec()));
                d.close();
            }
            Err(_) => notes.push("OpenHaptics: SDK present, no device initialises".into()),
        },
    }

    let mut bridge_cfg = BridgeConfig::new(&args.namespace);
    bridge_cfg.open_timeout_s = 0.3;
    let mut b = BridgeDevice::new(bridge_cfg).map_err(|e| anyhow::anyhow!("bridge: {e}"))?;
    match b.open() {
        Ok(()) => {
            found += 1;
            println!(
                "bridge       {} (driver on namespace '{}')",
                b.spec().name,
                args.namespace
            );
            println!("{}", describe(b.spec()));
            b.close();
        }
        Err(_) => notes.push(format!(
            "bridge: no driver on namespace '{}'",
            args.namespace
        )),
    }
    // Let the relay's goodbye command leave before the process exits.
    std::thread::sleep(Duration::from_millis(1));

    if found == 0 {
        println!("none found: no haptic device or SpaceMouse is attached.");
    }
    for n in &notes {
        println!("  - {n}");
    }
    println!("The simulated arm is always available (--device sim).");
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_choices_parse_and_bad_ones_are_explained() {
        assert_eq!("sim".parse::<DeviceChoice>(), Ok(DeviceChoice::Sim));
        assert_eq!(
            "openhaptics".parse::<DeviceChoice>(),
            Ok(DeviceChoice::OpenHaptics)
        );
        assert_eq!(
            "replay:/tmp/a.mcap".parse::<DeviceChoice>(),
            Ok(DeviceChoice::Replay("/tmp/a.mcap".into()))
        );
        let e = "replay:".parse::<DeviceChoice>().unwrap_err();
        assert!(e.contains("replay:FILE"));
        let e = "phantom".parse::<DeviceChoice>().unwrap_err();
        assert!(e.contains("\"phantom\"") && e.contains("spacemouse"));
    }

    #[test]
    fn absent_devices_give_errors_naming_what_to_check() {
        let args = |device, lib: Option<&str>| DeviceArgs {
            device,
            device_lib: lib.map(PathBuf::from),
            record: None,
        };
        let no_sim = || -> anyhow::Result<Box<dyn HapticDevice>> { unreachable!("not sim") };
        let e = build(
            &args(DeviceChoice::Dhd, Some("/nonexistent/libdhd.so")),
            "default",
            no_sim,
        )
        .err()
        .expect("no SDK here");
        let text = format!("{e:#}");
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
        assert!(format!("{e:#}").contains("HRRTC_HD_LIB"));
        let e = build(
            &args(DeviceChoice::Replay("/nonexistent/r.mcap".into()), None),
            "default",
            no_sim,
        )
        .err()
        .expect("no file");
        assert!(format!("{e:#}").contains("/nonexistent/r.mcap"));
        let e = DeviceChoice::SpaceMouse
            .open_error(DeviceError::OpenFailed("no 3Dconnexion SpaceMouse found"));
        assert!(e.to_string().contains("hidraw"));
    }
}
