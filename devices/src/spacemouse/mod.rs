//! 3Dconnexion SpaceMouse as an input-only [`HapticDevice`]: rate control of an avatar.
//!
//! A reader thread ([`hid`]) reads HID reports and hands the newest folded values to the RT
//! thread through a triple buffer ([`feed`]); `read` never touches HID. Each tick the held
//! deflections (sample-and-hold: the device reports only on change) drive the avatar's
//! velocity ([`rate`]); the wrench given to `write` is the guidance pseudo-force F_s, which
//! moves the avatar too (I-RRT Algorithm 2 for non-haptic devices). Nothing is rendered to
//! the hand.
//!
//! Frames: the device base frame has the scene's axes (right-handed, Z up, X to the
//! operator's right, Y away from the operator) and its origin where the avatar started.
//!
//! Faults: unplugging makes `read` return [`DeviceError::Disconnected`] and stops the
//! avatar; when the device is plugged in again, reading resumes from rest where the avatar
//! stopped (the loop ramps forces back in).

mod feed;
mod hid;
mod rate;
pub mod report;

use std::time::Duration;

use triple_buffer::Output;

pub use feed::{Feed, Snapshot};
pub use hid::{ConnectError, Found, ListError, enumerate};
pub use rate::{AxisMap, RateConfig, RateControl};

use crate::{
    Capabilities, DeviceError, DeviceLimits, DeviceSpec, DeviceState, HapticDevice, Wrench,
};

/// SpaceMouse settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpaceMouseConfig {
    /// Rate control, deadband, sensitivity and axis mapping.
    pub rate: RateConfig,
    /// Bound on the guidance pseudo-force acting on the avatar, N (reported as
    /// `max_force_n`: the loop bounds guidance by it).
    pub max_pseudo_force_n: f64,
    /// Bound on the guidance pseudo-torque acting on the avatar, N·m.
    pub max_pseudo_torque_nm: f64,
    /// Longest gap between two reads integrated at once, s (a stalled loop must not make
    /// the avatar jump).
    pub max_step_s: f64,
    /// How long `open` waits for HID enumeration, s.
    pub open_timeout_s: f64,
}

impl Default for SpaceMouseConfig {
    fn default() -> Self {
        SpaceMouseConfig {
            rate: RateConfig::default(),
            max_pseudo_force_n: 5.0,
            max_pseudo_torque_nm: 0.5,
            max_step_s: 0.02,
            open_timeout_s: 3.0,
        }
    }
}

impl SpaceMouseConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), DeviceError> {
        self.rate.validate()?;
        for (v, name) in [
            (self.max_pseudo_force_n, "max_pseudo_force_n"),
            (self.max_pseudo_torque_nm, "max_pseudo_torque_nm"),
            (self.max_step_s, "max_step_s"),
            (self.open_timeout_s, "open_timeout_s"),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(DeviceError::InvalidConfig(name));
            }
        }
        Ok(())
    }

    /// The spec a SpaceMouse named `name` with `buttons` buttons reports under this config.
    pub fn spec_for(&self, name: &str, buttons: u32) -> DeviceSpec {
        DeviceSpec {
            name: name.to_string(),
            limits: DeviceLimits {
                max_force_n: self.max_pseudo_force_n,
                max_torque_nm: self.max_pseudo_torque_nm,
                // Nothing reaches the hand: these budget the virtual coupling whose force moves
                // the avatar (through `write`, like F_s), so contact can hold it out of
                // obstacles. The avatar is first order (v = F·admittance): with 0.01 (m/s)/N it
                // is stable at 1 kHz far beyond these values (k·admittance·dt ≪ 2).
                max_stiffness_n_per_m: 2000.0,
                max_rot_stiffness_nm_per_rad: 0.5,
                max_damping_n_s_per_m: 0.0,
                max_rot_damping_nm_s_per_rad: 0.0,
                workspace_radius_m: self.rate.workspace_radius_m,
            },
            capabilities: Capabilities {
                force_output: false,
                torque_output: false,
                orientation_input: true,
                buttons: buttons.min(32),
            },
        }
    }
}

enum Source {
    /// Real HID through a reader thread (started by `open`).
    Hid(Option<hid::Reader>),
    /// Reports pushed by the caller through a [`Feed`] (tests, replays of captured bytes).
    Fed,
}

/// A SpaceMouse driving an avatar by rate control.
pub struct SpaceMouse {
    config: SpaceMouseConfig,
    spec: DeviceSpec,
    source: Source,
    output: Option<Output<Snapshot>>,
    rate: RateControl,
    open: bool,
    last_now_ns: Option<u64>,
    last_reports: u64,
    /// Tick time at which the report count last moved, ns.
    last_report_ns: u64,
}

impl std::fmt::Debug for SpaceMouse {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SpaceMouse")
            .field("spec", &self.spec.name)
            .field("open", &self.open)
            .finish()
    }
}

impl SpaceMouse {
    /// A SpaceMouse read through HID; `open` connects to the first one attached.
    pub fn new(config: SpaceMouseConfig) -> Result<Self, DeviceError> {
        config.validate()?;
        Ok(Self::build(
            config,
            Source::Hid(None),
            None,
            "SpaceMouse",
            2,
        ))
    }

    /// A SpaceMouse fed by the returned [`Feed`] instead of HID (reports as bytes), named
    /// after `model`. The feed starts detached: call [`Feed::attach`].
    pub fn with_feed(
        config: SpaceMouseConfig,
        model: &report::Model,
    ) -> Result<(Self, Feed), DeviceError> {
        config.validate()?;
        let (feed, output) = feed::channel();
        let dev = Self::build(config, Source::Fed, Some(output), model.name, model.buttons);
        Ok((dev, feed))
    }

    fn build(
        config: SpaceMouseConfig,
        source: Source,
        output: Option<Output<Snapshot>>,
        name: &str,
        buttons: u32,
    ) -> Self {
        SpaceMouse {
            spec: config.spec_for(name, buttons),
            rate: RateControl::new(config.rate),
            config,
            source,
            output,
            open: false,
            last_now_ns: None,
            last_reports: 0,
            last_report_ns: 0,
        }
    }

    /// Age of the held deflection at the last `read`, s (time since its report count
    /// last changed, at tick resolution).
    pub fn report_age_s(&self) -> f64 {
        match self.last_now_ns {
            Some(now) => now.saturating_sub(self.last_report_ns) as f64 * 1e-9,
            None => 0.0,
        }
    }

    /// The avatar's rate control (pose, velocities).
    pub fn rate_control(&self) -> &RateControl {
        &self.rate
    }
}

/// What to tell a user whose SpaceMouse did not open.
fn open_error(e: &ConnectError) -> DeviceError {
    DeviceError::OpenFailed(match e {
        ConnectError::Hid(_) => "cannot list HID devices (is /sys/class/hidraw present?)",
        ConnectError::NoneFound => "no 3Dconnexion SpaceMouse found (is it plugged in?)",
        ConnectError::CannotOpen { .. } => {
            "SpaceMouse found but /dev/hidraw* cannot be opened: install devices/udev/70-hrrtc-devices.rules and re-plug, or run with access to /dev/hidraw*"
        }
    })
}

impl HapticDevice for SpaceMouse {
    fn open(&mut self) -> Result<(), DeviceError> {
        self.close();
        if let Source::Hid(reader) = &mut self.source {
            let (feed, output) = feed::channel();
            let timeout = Duration::from_secs_f64(self.config.open_timeout_s);
            let (r, found) = hid::Reader::start(feed, timeout).map_err(|e| open_error(&e))?;
            let buttons = found.model.map_or(2, |m| m.buttons);
            self.spec = self.config.spec_for(&found.name, buttons);
            *reader = Some(r);
            self.output = Some(output);
        }
        self.rate = RateControl::new(self.config.rate);
        self.last_now_ns = None;
        self.open = true;
        Ok(())
    }

    fn spec(&self) -> &DeviceSpec {
        &self.spec
    }

    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        if !self.open {
            return Err(DeviceError::NotOpen);
        }
        let Some(output) = self.output.as_mut() else {
            return Err(DeviceError::NotOpen);
        };
        let snap = *output.read();
        let dt_s = self
            .last_now_ns
            .map_or(0.0, |t| now_ns.saturating_sub(t) as f64 * 1e-9)
            .min(self.config.max_step_s);
        self.last_now_ns = Some(now_ns);
        if !snap.connected {
            self.rate.halt();
            return Err(DeviceError::Disconnected);
        }
        if snap.reports != self.last_reports {
            self.last_reports = snap.reports;
            self.last_report_ns = now_ns;
        }
        let age_s = now_ns.saturating_sub(self.last_report_ns) as f64 * 1e-9;
        self.rate.step(&snap.axes, age_s, dt_s);
        let mask = if self.spec.capabilities.buttons >= 32 {
            u32::MAX
        } else {
            (1u32 << self.spec.capabilities.buttons) - 1
        };
        Ok(DeviceState {
            pose: *self.rate.pose(),
            linear_velocity: self.rate.linear_velocity(),
            angular_velocity: self.rate.angular_velocity(),
            buttons: snap.axes.buttons & mask,
            // The avatar is integrated to the tick time, so the state is that fresh.
            timestamp_ns: now_ns,
        })
    }

    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        if !self.open {
            return Err(DeviceError::NotOpen);
        }
        apply_pseudo_force(&mut self.rate, &self.config, wrench)
    }

    fn close(&mut self) {
        if let Source::Hid(reader) = &mut self.source {
            if let Some(mut r) = reader.take() {
                r.stop();
            }
            self.output = None;
        }
        self.rate.halt();
        self.open = false;
    }
}

#[cfg(test)]
mod tests;

/// A SpaceMouse's `write`: the device is input-only, so the wrench is the pseudo-force on
/// the rate-controlled avatar, bounded by the config's limits (`spec.saturate` would zero
/// it, there being no force output). A non-finite wrench is refused.
pub(crate) fn apply_pseudo_force(
    rate: &mut RateControl,
    config: &SpaceMouseConfig,
    wrench: &Wrench,
) -> Result<(), DeviceError> {
    if !wrench.is_finite() {
        return Err(DeviceError::InvalidData);
    }
    rate.set_guidance(wrench.saturated(config.max_pseudo_force_n, config.max_pseudo_torque_nm));
    Ok(())
}
