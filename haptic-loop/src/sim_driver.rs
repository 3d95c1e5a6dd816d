//! An example external device driver: serves the simulated arm over
//! [`services::DRIVER_STATE`] / [`services::DRIVER_COMMAND`] exactly as a driver for a
//! real arm would (in any language iceoryx2 supports). `examples/sim_driver.rs` runs it;
//! tests run it on a thread.
//!
//! Its own safety: it applies a command only when valid, `OutputCode::ON`, and newer than
//! `command_timeout` by its timestamp; otherwise zero force.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use devices::sim::{SimulatedArm, SimulatedArmConfig};
use devices::{HapticDevice, Wrench};
use ipc_types::services;
use ipc_types::{DriverState, DriverStatus, Header, OutputCode, monotonic_ns};
use nalgebra::Vector3;

use crate::Error;
use ipc_types::convert as wire;

/// What the driver did, for its caller.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DriverReport {
    /// States published.
    pub states: u64,
    /// Commands applied (valid, on, fresh).
    pub applied: u64,
    /// Commands rejected or ignored (invalid, off, stale).
    pub ignored: u64,
    /// The last wrench applied to the arm, N (device base frame).
    pub last_force_n: [f64; 3],
}

/// Serves a simulated arm on `namespace` at `rate_hz` (10–10000 Hz) until `stop` is set.
/// Commands older than `command_timeout` are replaced by zero force. The namespace is
/// checked when the services are opened.
pub fn run(
    namespace: &str,
    rate_hz: f64,
    command_timeout: Duration,
    stop: &AtomicBool,
) -> Result<DriverReport, Error> {
    if !(rate_hz.is_finite() && (10.0..=10_000.0).contains(&rate_hz)) {
        return Err(Error::Invalid {
            what: "the driver's rate (Hz)",
            need: "within 10–10000",
            value: rate_hz,
        });
    }
    let (node, _) = services::create_node(&format!("example_driver_{}", std::process::id()))?;
    let publ = services::publisher::<ipc_types::DriverState>(&node, namespace)?;
    let sub = services::subscriber::<ipc_types::DriverCommand>(&node, namespace)?;
    let arm_error = |source| Error::Device {
        device: "the simulated arm".into(),
        error: source,
        hint: "",
    };
    let mut arm = SimulatedArm::new(SimulatedArmConfig::default()).map_err(arm_error)?;
    arm.open().map_err(arm_error)?;
    let spec = arm.spec().clone();
    let period = Duration::from_secs_f64(1.0 / rate_hz);
    let timeout_ns = command_timeout.as_nanos() as u64;
    let mut report = DriverReport::default();
    let mut command = Wrench::ZERO;
    let mut command_ns = 0u64;
    let mut next = std::time::Instant::now();
    while !stop.load(Ordering::Acquire) {
        let now = monotonic_ns();
        while let Ok(Some(c)) = sub.receive() {
            if c.validate().is_ok() && c.output == OutputCode::ON {
                command = Wrench::new(
                    Vector3::from(c.wrench.force_n),
                    Vector3::from(c.wrench.torque_nm),
                );
                command_ns = c.header.timestamp_ns.max(1);
                report.applied += 1;
            } else {
                command = Wrench::ZERO;
                command_ns = 0;
                report.ignored += 1;
            }
        }
        let fresh = command_ns != 0 && now.saturating_sub(command_ns) <= timeout_ns;
        let out = if fresh { command } else { Wrench::ZERO };
        arm.write(&out).map_err(arm_error)?;
        report.last_force_n = out.force.into();
        let s = arm.read(now).map_err(arm_error)?;
        report.states += 1;
        let mut msg = DriverState {
            header: Header::new(report.states, now, std::process::id()),
            pose: wire::pose(&s.pose),
            twist: wire::twist(&s.linear_velocity, &s.angular_velocity),
            buttons: s.buttons,
            status: DriverStatus::OK,
            button_count: spec.capabilities.buttons,
            orientation_input: u32::from(spec.capabilities.orientation_input),
            ..DriverState::default()
        }
        .with_limits(&spec.limits);
        msg.set_name("example driver: simulated arm");
        if let Err(e) = publ.send_copy(msg) {
            tracing::warn!("example driver: publish failed: {e:?}");
        }
        next += period;
        let now_i = std::time::Instant::now();
        if next > now_i {
            std::thread::sleep(next - now_i);
        } else {
            next = now_i;
        }
    }
    arm.close();
    Ok(report)
}
