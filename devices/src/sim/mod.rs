//! Simulated devices for tests, benches and the demo: [`SimulatedArm`] held by a
//! [`ScriptedUser`] (a timed path) or by a reacting [`operator`] ([`OperatorHand`]), and the
//! same operator on a rate-controlled [`SimulatedSpaceMouse`].
//!
//! The arm's dynamics see the rendered wrench, so a rendered wall really deflects the arm
//! away from where the scripted hand wants it, as a real operator's arm would be.

mod arm;
mod body;
mod config;
mod grip;
pub mod operator;
mod path;
mod sensor;
mod spacemouse;
mod tremor;
mod user;

pub use arm::SimulatedArm;
pub use config::SimulatedArmConfig;
pub use operator::{NewcomerConfig, Operator, OperatorConfig, OperatorHand, RouteStep};
pub use path::Waypoint;
pub use spacemouse::SimulatedSpaceMouse;
pub use user::{ScriptedUser, ScriptedUserConfig};

#[cfg(test)]
mod scenarios;
