//! An external driver: a [`HapticDevice`] whose device lives in another process, behind the
//! iceoryx2 services [`services::DRIVER_STATE`] (driver → loop) and
//! [`services::DRIVER_COMMAND`] (loop → driver); see `ipc_types::DriverState` for the
//! contract a driver implements.
//!
//! A non-RT relay thread receives the newest [`DriverState`] and publishes the newest
//! [`DriverCommand`] (iceoryx2 0.10 `receive()` and `send_copy()` may allocate); it talks to
//! the RT thread through two triple buffers, so `read` and `write` are wait-free and
//! allocation-free. A driver that never published, stopped publishing (state older than
//! `stale_s`), or reports a fault makes `read` fail: the loop latches zero force.
//!
//! Frames: the driver's device base frame, unchanged (see `ipc_types::driver`).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use devices::{
    Capabilities, DeviceError, DeviceLimits, DeviceSpec, DeviceState, HapticDevice, Wrench,
};
use ipc_types::convert as wire;
use ipc_types::services;
use ipc_types::{DriverCommand, DriverState, DriverStatus, Header, OutputCode};
use nalgebra::Vector3;

/// Settings of the link to an external driver.
#[derive(Debug, Clone, PartialEq)]
pub struct DriverConfig {
    /// IPC namespace the driver publishes in.
    pub namespace: String,
    /// A state older than this (by its driver timestamp) is a fault, s.
    pub stale_s: f64,
    /// How long `open` waits for the driver's first valid state, s.
    pub open_timeout_s: f64,
    /// Relay thread poll period, s: the latency it adds in each direction.
    pub poll_s: f64,
}

impl DriverConfig {
    /// Defaults for `namespace`: stale after 20 ms, open waits 2 s, poll every 250 µs.
    pub fn new(namespace: &str) -> Self {
        DriverConfig {
            namespace: namespace.to_string(),
            stale_s: 0.02,
            open_timeout_s: 2.0,
            poll_s: 250e-6,
        }
    }
}

/// The DeviceSpec a driver's state announces.
pub fn spec_from_state(s: &DriverState) -> DeviceSpec {
    DeviceSpec {
        name: s
            .name_str()
            .unwrap_or("external driver's device")
            .to_string(),
        limits: s.limits(),
        capabilities: Capabilities {
            force_output: s.max_force_n > 0.0,
            torque_output: s.max_torque_nm > 0.0,
            orientation_input: s.orientation_input == 1,
            buttons: s.button_count.min(32),
        },
    }
}

struct Session {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    states: triple_buffer::Output<DriverState>,
    commands: triple_buffer::Input<DriverCommand>,
}

impl Session {
    fn shutdown(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A device served by an external driver process.
pub struct DriverDevice {
    config: DriverConfig,
    spec: DeviceSpec,
    session: Option<Session>,
    sequence: u64,
    last_now_ns: u64,
    pid: u32,
}

impl std::fmt::Debug for DriverDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DriverDevice")
            .field("namespace", &self.config.namespace)
            .field("spec", &self.spec.name)
            .field("open", &self.session.is_some())
            .finish()
    }
}

impl DriverDevice {
    /// A link to a driver on `config.namespace`; nothing is opened yet.
    pub fn new(config: DriverConfig) -> Result<Self, DeviceError> {
        services::validate_namespace(&config.namespace)
            .map_err(|_| DeviceError::InvalidConfig("namespace"))?;
        for (v, name) in [
            (config.stale_s, "stale_s"),
            (config.open_timeout_s, "open_timeout_s"),
            (config.poll_s, "poll_s"),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        Ok(DriverDevice {
            config,
            spec: DeviceSpec {
                name: "external driver's device".into(),
                limits: DeviceLimits::none(0.1),
                capabilities: Capabilities {
                    force_output: false,
                    torque_output: false,
                    orientation_input: false,
                    buttons: 0,
                },
            },
            session: None,
            sequence: 0,
            last_now_ns: 0,
            pid: std::process::id(),
        })
    }

    fn spawn_relay(&self) -> Result<Session, DeviceError> {
        let (mut state_in, state_out) = triple_buffer::triple_buffer(&DriverState::default());
        let (cmd_in, mut cmd_out) = triple_buffer::triple_buffer(&DriverCommand::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (ready_tx, ready_rx) = std::sync::mpsc::channel();
        let namespace = self.config.namespace.clone();
        let poll = Duration::from_secs_f64(self.config.poll_s);
        let thread = {
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("driver-link".into())
                .spawn(move || {
                    // iceoryx2 ports are not Send: create them on this thread.
                    let ports =
                        services::create_node(&format!("haptic_driver_{}", std::process::id()))
                            .and_then(|(node, _)| {
                                let sub = services::subscriber::<ipc_types::DriverState>(
                                    &node, &namespace,
                                )?;
                                let publ = services::publisher::<ipc_types::DriverCommand>(
                                    &node, &namespace,
                                )?;
                                Ok((node, sub, publ))
                            });
                    let (_node, sub, publ) = match ports {
                        Ok(p) => {
                            let _ = ready_tx.send(true);
                            p
                        }
                        Err(e) => {
                            tracing::error!("external driver: {e}");
                            let _ = ready_tx.send(false);
                            return;
                        }
                    };
                    let mut sent = 0u64;
                    while !stop.load(Ordering::Acquire) {
                        let mut newest = None;
                        while let Ok(Some(s)) = sub.receive() {
                            newest = Some(*s);
                        }
                        if let Some(s) = newest {
                            state_in.write(s);
                        }
                        let cmd = *cmd_out.read();
                        if cmd.header.sequence != sent {
                            sent = cmd.header.sequence;
                            if let Err(e) = publ.send_copy(cmd) {
                                tracing::warn!("external driver: send failed: {e:?}");
                            }
                        }
                        std::thread::sleep(poll);
                    }
                    // Leave the driver a zero command so it stops pushing at once.
                    let mut off = *cmd_out.read();
                    off.header.sequence = sent + 1;
                    off.header.timestamp_ns = ipc_types::monotonic_ns();
                    off.wrench = ipc_types::Wrench::ZERO;
                    off.output = OutputCode::OFF;
                    let _ = publ.send_copy(off);
                })
                .map_err(|_| {
                    DeviceError::OpenFailed("cannot start the external driver's relay thread")
                })?
        };
        match ready_rx.recv() {
            Ok(true) => Ok(Session {
                stop,
                thread: Some(thread),
                states: state_out,
                commands: cmd_in,
            }),
            _ => {
                let _ = thread.join();
                Err(DeviceError::OpenFailed(
                    "cannot open the external driver's services (iceoryx2; see the log)",
                ))
            }
        }
    }
}

impl HapticDevice for DriverDevice {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.close();
        let mut session = self.spawn_relay()?;
        let deadline = Instant::now() + Duration::from_secs_f64(self.config.open_timeout_s);
        let first = loop {
            let s = *session.states.read();
            if s.validate().is_ok() {
                break s;
            }
            if Instant::now() > deadline {
                session.shutdown();
                return Err(DeviceError::OpenFailed(
                    "no driver publishes a valid state on hrrtc/<namespace>/driver/state (start one, e.g. the sim_driver example)",
                ));
            }
            std::thread::sleep(Duration::from_millis(1));
        };
        let spec = spec_from_state(&first);
        if spec.validate().is_err() {
            session.shutdown();
            return Err(DeviceError::OpenFailed(
                "the driver announced invalid limits",
            ));
        }
        self.spec = spec;
        self.session = Some(session);
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        let stale_ns = (self.config.stale_s * 1e9) as u64;
        let Some(s) = self.session.as_mut() else {
            return Err(DeviceError::NotOpen);
        };
        self.last_now_ns = now_ns;
        let st = *s.states.read();
        if st.header.sequence == 0 || now_ns.saturating_sub(st.header.timestamp_ns) > stale_ns {
            return Err(DeviceError::Disconnected);
        }
        if st.validate().is_err() {
            return Err(DeviceError::InvalidData);
        }
        if st.status != DriverStatus::OK {
            return Err(DeviceError::ReadFailed);
        }
        let pose = wire::isometry(&st.pose).ok_or(DeviceError::InvalidData)?;
        Ok(DeviceState {
            pose,
            linear_velocity: Vector3::from(st.twist.linear_m_s),
            angular_velocity: Vector3::from(st.twist.angular_rad_s),
            buttons: st.buttons,
            // Held samples are checked against `stale_s` above; the loop sees tick time.
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
        let w = self.spec.saturate(wrench);
        self.sequence += 1;
        s.commands.write(DriverCommand {
            header: Header::new(self.sequence, self.last_now_ns, self.pid),
            wrench: wire::wrench(&w.force, &w.torque),
            output: OutputCode::ON,
            reserved: 0,
        });
        Ok(())
    }

    fn close(&mut self) {
        if let Some(mut s) = self.session.take() {
            s.shutdown();
        }
    }
}

impl Drop for DriverDevice {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim_driver;
    use ipc_types::monotonic_ns;

    fn namespace(tag: &str) -> String {
        services::unique_namespace(&format!("test_driver_{tag}"))
    }

    #[test]
    fn a_missing_driver_fails_open_with_what_to_do() {
        let mut c = DriverConfig::new(&namespace("none"));
        c.open_timeout_s = 0.2;
        let mut dev = DriverDevice::new(c).unwrap();
        match dev.open() {
            Err(DeviceError::OpenFailed(msg)) => assert!(msg.contains("driver/state")),
            other => panic!("expected OpenFailed, got {other:?}"),
        }
        assert_eq!(dev.read(0), Err(DeviceError::NotOpen));
        let mut bad = DriverConfig::new("a/b");
        assert!(DriverDevice::new(bad.clone()).is_err());
        bad.namespace = "ok".into();
        bad.stale_s = f64::NAN;
        assert!(DriverDevice::new(bad).is_err());
    }

    #[test]
    fn driver_round_trip_with_the_example_driver_and_stale_fault() {
        let ns = namespace("rt");
        let stop = Arc::new(AtomicBool::new(false));
        let driver = {
            let ns = ns.clone();
            let stop = stop.clone();
            std::thread::spawn(move || {
                sim_driver::run(&ns, 1000.0, Duration::from_millis(50), &stop)
            })
        };
        let mut dev = DriverDevice::new(DriverConfig::new(&ns)).unwrap();
        dev.open().expect("driver is publishing");
        assert_eq!(dev.spec().name, "example driver: simulated arm");
        assert_eq!(
            dev.spec().limits.max_force_n,
            8.0,
            "the simulated arm's limit"
        );

        // Push the remote arm (0.2 kg) along +X with 0.2 N for 0.2 s: it must move that way
        // (about 2 cm, well inside its 0.12 m workspace).
        let start = dev.read(monotonic_ns()).expect("fresh state");
        let t_end = Instant::now() + Duration::from_millis(200);
        while Instant::now() < t_end {
            let now = monotonic_ns();
            dev.read(now).expect("fresh state while driven");
            dev.write(&Wrench::from_force(Vector3::new(0.2, 0.0, 0.0)))
                .unwrap();
            std::thread::sleep(Duration::from_millis(1));
        }
        let moved = dev.read(monotonic_ns()).unwrap();
        let dx = moved.pose.translation.x - start.pose.translation.x;
        assert!(dx > 1e-3, "arm moved {dx} m along +X");
        assert!(moved.linear_velocity.x > 0.0);
        // Limits are enforced on our side too: 100 N is sent as 8 N.
        dev.write(&Wrench::from_force(Vector3::new(100.0, 0.0, 0.0)))
            .unwrap();
        std::thread::sleep(Duration::from_millis(20));

        stop.store(true, Ordering::Release);
        let report = driver.join().unwrap().expect("driver ran");
        assert!(report.applied > 50, "{report:?}");
        assert!((report.last_force_n[0] - 8.0).abs() < 1e-9, "{report:?}");
        // The driver is gone: its last state goes stale → a fault.
        std::thread::sleep(Duration::from_millis(30));
        assert_eq!(dev.read(monotonic_ns()), Err(DeviceError::Disconnected));
        dev.close();
    }
}
