//! The 1 kHz haptic loop: a real-time thread that reads the device, maps it into the scene,
//! renders contact and the planner's guidance force, applies safety limits, writes the
//! device and publishes [`ipc_types::HapticState`].
//!
//! Entry points: [`tick::Tick`] (one tick, pure, driven in lockstep by tests and benches),
//! [`runner::spawn`] (the RT thread and its stats thread), [`session`] (a whole session as
//! the binary's `run` and `demo` commands drive it). The binary (`src/bin/haptic-loop`)
//! parses arguments, validates them into a [`session::LoopSetup`], starts the planner
//! process for `demo`, and prints; this library holds no command-line code.
//!
//! Architecture invariant: after [`runner::spawn`] has set the thread up, the RT thread
//! never allocates, locks, logs or blocks; [`alloc_count`] measures the first on every run.

#![warn(missing_docs)]

pub mod alloc_count;
pub mod contact;
pub mod device_choice;
pub mod driver;
pub mod error;
pub mod guidance;
pub mod mapping;
pub mod relay;
pub mod rt;
pub mod runner;
pub mod safety;
pub mod session;
pub mod sim_driver;
pub mod stats;
pub mod tick;
pub mod work;

pub use error::Error;
