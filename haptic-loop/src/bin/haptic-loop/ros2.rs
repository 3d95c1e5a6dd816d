//! `--device ros2:...`: the `hrrtc-ros2 device` process that serves a ROS 2 driver's arm on
//! the external driver's services. It lives beside `haptic-loop` (cargo builds both into one folder) and
//! links Zenoh, which this binary must not.

use anyhow::Context;
use haptic_loop::device_choice::Ros2Device;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

/// The `hrrtc-ros2` executable: `given`, else beside this one.
fn exe(given: Option<&Path>) -> anyhow::Result<PathBuf> {
    if let Some(p) = given {
        anyhow::ensure!(
            p.is_file(),
            "--ros2-exe {}: no such file; build it with `cargo build --release -p hrrtc-ros2`",
            p.display()
        );
        return Ok(p.to_path_buf());
    }
    let me = std::env::current_exe().context("cannot find the haptic-loop executable")?;
    let exe = me
        .parent()
        .context("the haptic-loop executable has no folder")?
        .join("hrrtc-ros2");
    anyhow::ensure!(
        exe.is_file(),
        "the hrrtc-ros2 executable is not beside haptic-loop ({} is missing): build it with \
         `cargo build --release -p hrrtc-ros2` (or the same profile as haptic-loop), or give \
         its path with --ros2-exe",
        exe.display()
    );
    Ok(exe)
}

/// `hrrtc-ros2 device`'s flag for each `ros2:` key (`stale_ms` is the loop's own).
fn flag(key: &str) -> Option<&'static str> {
    Some(match key {
        "pose" => "--pose-topic",
        "wrench" => "--wrench-topic",
        "twist" => "--twist-topic",
        "joy" => "--joy-topic",
        "frame" => "--wrench-frame",
        "max_force" => "--max-force-n",
        "max_torque" => "--max-torque-nm",
        "stiffness" => "--stiffness-n-per-m",
        "rot_stiffness" => "--rot-stiffness-nm-per-rad",
        "damping" => "--damping-n-s-per-m",
        "workspace" => "--workspace-radius-m",
        "buttons" => "--buttons",
        "domain" => "--domain-id",
        "connect" => "--connect",
        "listen" => "--listen",
        "distro" => "--ros-distro",
        "name" => "--name",
        "zenoh_config" => "--zenoh-config",
        "tls_ca" => "--tls-ca",
        "tls_cert" => "--tls-cert",
        "tls_key" => "--tls-key",
        _ => return None,
    })
}

/// The running `hrrtc-ros2 device`; asked to stop (SIGTERM) when dropped.
pub struct Gateway {
    child: Child,
    exited: bool,
}

impl Gateway {
    /// Starts `hrrtc-ros2 device` for `device` on the loop's `namespace`.
    pub fn start(
        device: &Ros2Device,
        namespace: &str,
        given: Option<&Path>,
    ) -> anyhow::Result<Self> {
        let exe = exe(given)?;
        let mut command = Command::new(&exe);
        command.args(["device", "--namespace", namespace]);
        for (k, v) in &device.options {
            if k == "insecure" {
                if v == "true" {
                    command.arg("--insecure");
                }
            } else if let Some(f) = flag(k) {
                command.args([f, v.as_str()]);
            }
        }
        let child = command
            .spawn()
            .with_context(|| format!("cannot start {}", exe.display()))?;
        tracing::info!("hrrtc-ros2 device started (pid {})", child.id());
        Ok(Gateway {
            child,
            exited: false,
        })
    }

    /// Logs once when the process has exited (the loop then sees the arm go stale).
    pub fn watch(&mut self) {
        if !self.exited
            && let Ok(Some(status)) = self.child.try_wait()
        {
            tracing::warn!("hrrtc-ros2 device exited ({status}): the arm is no longer served");
            self.exited = true;
        }
    }
}

impl Drop for Gateway {
    fn drop(&mut self) {
        // SAFETY: kill(2) with a pid we spawned and still own (not yet reaped).
        unsafe { libc::kill(self.child.id() as libc::pid_t, libc::SIGTERM) };
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline && matches!(self.child.try_wait(), Ok(None)) {
            std::thread::sleep(Duration::from_millis(20));
        }
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}
