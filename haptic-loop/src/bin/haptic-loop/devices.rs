//! `haptic-loop devices`: what is attached (SpaceMouse, Force Dimension, OpenHaptics, a
//! external driver), each with its limits. Exit code 0, also when none is found.

use crate::args::DevicesArgs;
use devices::HapticDevice;
use devices::sdk::{dhd, hd};
use devices::spacemouse::{self, SpaceMouseConfig};
use haptic_loop::device_choice::{Sdk, describe, vendor_library};
use haptic_loop::driver::{DriverConfig, DriverDevice};
use std::time::Duration;

/// `haptic-loop devices`: prints what is attached with its spec; exit code 0 either way.
pub fn run(args: &DevicesArgs) -> anyhow::Result<i32> {
    crate::args::namespace(&args.namespace)?;
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

    let dhd_lib = vendor_library(args.device_lib.as_deref(), Sdk::Dhd);
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

    let hd_lib = vendor_library(args.device_lib.as_deref(), Sdk::Hd);
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

    let mut driver_cfg = DriverConfig::new(&args.namespace);
    driver_cfg.open_timeout_s = 0.3;
    let mut b = DriverDevice::new(driver_cfg).map_err(|e| anyhow::anyhow!("driver: {e}"))?;
    match b.open() {
        Ok(()) => {
            found += 1;
            println!(
                "driver       {} (external driver on namespace '{}')",
                b.spec().name,
                args.namespace
            );
            println!("{}", describe(b.spec()));
            b.close();
        }
        Err(_) => notes.push(format!(
            "driver: no external driver on namespace '{}'",
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
