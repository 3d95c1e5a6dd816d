//! `hrrtc-ros2`: the haptic loop and planner as a ROS 2 participant on rmw_zenoh's wire, on
//! the Zenoh we already link, with no ROS install; and ROS 2 arm drivers as the loop's
//! devices. A separate, non-RT process: the loop's RT thread stays on iceoryx2.
//!
//! - [`serve`]: `hrrtc-ros2 serve`, the loop's state, the planner's path and roadmap and the
//!   scene on ROS 2 topics, guidance from ROS 2 into the loop.
//! - [`device`]: `hrrtc-ros2 device`, a ROS 2 driver's arm behind the driver bridge
//!   (`haptic-loop run --device ros2:...` starts it).
//! - The wire: [`rmw`] (keys, liveliness tokens, QoS text, attachments, GIDs), [`cdr`] and
//!   [`msgs`] (payloads), [`typehash`] (RIHS01), [`participant`] (session and endpoints),
//!   [`clock`] (ROS time); [`rejections`] counts and logs refused samples by kind.
#![warn(missing_docs)]

pub mod cdr;
pub mod clock;
pub mod device;
mod error;
pub mod msgs;
pub mod participant;
pub mod rejections;
pub mod rmw;
pub mod serve;
pub mod typehash;

pub use error::GatewayError;
