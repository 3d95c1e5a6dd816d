//! Haptic devices for the 1 kHz controller: the [`HapticDevice`] trait, the values it
//! exchanges ([`DeviceState`], [`Wrench`], [`DeviceSpec`]), and a deterministic simulated
//! arm with a scripted operator ([`sim`]).
//!
//! This crate knows nothing about IPC or the rest of the workspace; it depends on no other
//! workspace crate.
//!
//! # Units and frames
//! SI throughout: m, s, N, N·m, rad, kg. Timestamps are `CLOCK_MONOTONIC` nanoseconds.
//! Everything a device reads or writes is expressed in the **device base frame** (fixed to
//! the device's base; for the simulated arm its origin is the centre of the workspace
//! sphere). Torques are about the **end-effector point**, the point whose pose the device
//! reports. Orientations are nalgebra [`UnitQuaternion`](nalgebra::UnitQuaternion)s, whose
//! storage order is `[i, j, k, w]` (`coords`); conversion to a wire order happens in the
//! IPC layer, not here.
//!
//! # Real-time contract
//! `open` may allocate and block; `read`, `write` and the simulator's per-sub-step work
//! ([`sim::ScriptedUser::hand_wrench`]) never allocate, lock or block: all memory
//! (waypoints included) is set up at construction.

#![warn(missing_docs)]
// Unsafe only where vendor C libraries are called (`sdk`), each block with a SAFETY note.
#![deny(unsafe_code)]

mod device;
mod error;
pub mod record;
#[allow(unsafe_code)]
pub mod sdk;
pub mod sim;
pub mod spacemouse;
mod spec;
mod types;

pub use device::HapticDevice;
pub use error::DeviceError;
/// The limits every device states (one type for the loop's devices, external drivers and
/// gateways).
pub use ipc_types::DeviceLimits;
pub use spec::{Capabilities, DeviceSpec};
pub use types::{DeviceState, Wrench, clamp_norm};
