//! Simulated devices for tests and benches: [`SimulatedArm`] and the [`ScriptedUser`] that
//! holds it.
//!
//! The arm's dynamics see the rendered wrench, so a rendered wall really deflects the arm
//! away from where the scripted hand wants it, as a real operator's arm would be.

mod arm;
mod body;
mod config;
mod path;
mod sensor;
mod tremor;
mod user;

pub use arm::SimulatedArm;
pub use config::SimulatedArmConfig;
pub use path::Waypoint;
pub use user::{ScriptedUser, ScriptedUserConfig};

#[cfg(test)]
mod scenarios;
