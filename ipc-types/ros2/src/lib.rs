//! `hrrtc-ros2`: the haptic loop and planner as a ROS 2 participant on rmw_zenoh's wire, on
//! the Zenoh we already link, with no ROS install. This is the wire: [`rmw`] (keys, liveliness
//! tokens, QoS text, attachments, GIDs), [`cdr`] and [`msgs`] (payloads), [`typehash`]
//! (RIHS01), [`participant`] (session and endpoints), [`clock`] (ROS time).
#![warn(missing_docs)]

pub mod cdr;
pub mod clock;
pub mod msgs;
pub mod participant;
pub mod rmw;
pub mod typehash;
