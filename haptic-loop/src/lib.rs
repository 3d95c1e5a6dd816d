//! The 1 kHz haptic loop: a real-time thread that reads the device, maps it into the scene,
//! renders contact and the planner's guidance force, applies safety limits, writes the
//! device and publishes [`ipc_types::HapticState`].
//!
//! Entry points: [`tick::Tick`] (one tick, pure, driven in lockstep by tests and benches),
//! [`runner::spawn`] (the RT thread and its stats thread), [`app`] (what the binary runs:
//! `run` and `demo`).
//!
//! Architecture invariant: after [`runner::spawn`] has set the thread up, the RT thread
//! never allocates, locks, logs or blocks; [`alloc_count`] measures the first on every run.

#![warn(missing_docs)]

pub mod alloc_count;
pub mod app;
pub mod contact;
pub mod guidance;
pub mod mapping;
pub mod relay;
pub mod rt;
pub mod runner;
pub mod safety;
pub mod stats;
pub mod tick;
