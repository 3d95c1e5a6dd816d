//! The per-tick device API used by the 1 kHz real-time thread.

use crate::{DeviceError, DeviceSpec, DeviceState, Wrench};

/// A haptic (or input-only) device driven by a hard-real-time loop.
///
/// # Lifecycle and per-tick contract
///
/// 1. [`open`](HapticDevice::open) once, before the real-time loop starts. It may allocate,
///    block and fail richly.
/// 2. Every tick (typically 1 ms): exactly one [`read`](HapticDevice::read), then exactly
///    one [`write`](HapticDevice::write). `now_ns` is the tick's `CLOCK_MONOTONIC` time in
///    ns; it never decreases from one call to the next.
/// 3. [`close`](HapticDevice::close) once after the loop; it leaves the device outputting
///    zero force.
///
/// `read` and `write` **must not allocate, lock a contended mutex, log or block**: they
/// run on the real-time thread. `write` must itself saturate the wrench to the device's
/// [`DeviceSpec`] limits, so a bug upstream cannot exceed the hardware's rating; a
/// non-finite wrench is rejected with [`DeviceError::InvalidData`] and not applied. Any
/// error from `read` or `write` is a fault for the loop (latch zero force).
///
/// All poses, velocities and wrenches are in the device base frame (see the crate docs).
pub trait HapticDevice: Send {
    /// Connects to the device and prepares it for the loop. May allocate and block. Calling
    /// it again on an open device is allowed and re-opens it.
    fn open(&mut self) -> Result<(), DeviceError>;

    /// The device's limits and capabilities. Valid before `open`.
    fn spec(&self) -> &DeviceSpec;

    /// Samples the device at tick time `now_ns` (`CLOCK_MONOTONIC` ns). No allocation, no
    /// blocking.
    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError>;

    /// Commands `wrench` (N and N·m at the end-effector point, base frame) until the next
    /// write. The device saturates it to its spec. No allocation, no blocking.
    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError>;

    /// Commands zero force and releases the device. Idempotent.
    fn close(&mut self);
}

impl<D: HapticDevice + ?Sized> HapticDevice for Box<D> {
    fn open(&mut self) -> Result<(), DeviceError> {
        (**self).open()
    }
    fn spec(&self) -> &DeviceSpec {
        (**self).spec()
    }
    fn read(&mut self, now_ns: u64) -> Result<DeviceState, DeviceError> {
        (**self).read(now_ns)
    }
    fn write(&mut self, wrench: &Wrench) -> Result<(), DeviceError> {
        (**self).write(wrench)
    }
    fn close(&mut self) {
        (**self).close()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{SimulatedArm, SimulatedArmConfig};

    #[test]
    fn boxed_device_forwards_the_contract() {
        let arm = SimulatedArm::new(SimulatedArmConfig::default()).expect("valid config");
        let mut dev: Box<dyn HapticDevice> = Box::new(arm);
        assert_eq!(dev.read(0), Err(DeviceError::NotOpen));
        dev.open().expect("sim opens");
        assert_eq!(dev.spec().name, "simulated-arm");
        let s = dev.read(1_000_000).expect("read");
        assert_eq!(s.timestamp_ns, 1_000_000);
        dev.write(&Wrench::ZERO).expect("write");
        dev.close();
        assert_eq!(dev.write(&Wrench::ZERO), Err(DeviceError::NotOpen));
    }
}
