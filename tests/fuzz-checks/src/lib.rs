//! The properties the fuzz targets of the network decoders check, one function per target
//! (`tests/fuzz/fuzz_targets/<target>.rs` calls it on every input). Each panics when a
//! property fails: that is what libFuzzer reports as a crash. The main workspace's test
//! `tests/corpora.rs` runs every file of `tests/fuzz/corpus/<target>/` through the same
//! function, so a corpus kept from fuzzing is an ordinary regression test.
//!
//! | target | bytes | checks |
//! |---|---|---|
//! | [`bridge_frame`] | one frame from Zenoh | `hrrtc_bridge::frame` for every kind, the re-stamping of [`hrrtc_bridge::clock`], the probes' ping and pong |
//! | [`ros2_guidance`] | attachment and CDR payload | `hrrtc_ros2::rmw::Attachment`, `WrenchStamped`, `serve::guidance::GuidanceInput::accept` |
//! | [`ros2_device`] | samples on the device gateway's topics | `PoseStamped`, `TwistStamped`, `Joy` with attachments, through the pose, velocity and button callbacks' checks into `DriverState`s |
//!
//! [`seeds`] has valid samples of each target's format, made by the gateways' own encoders:
//! the corpora start from them (`cargo run -p fuzz-checks --example write_seeds`).

mod bridge;
mod device;
mod guidance;
mod ros2;
pub mod seeds;

pub use bridge::bridge_frame;
pub use device::ros2_device;
pub use guidance::ros2_guidance;

/// A target's check: panics when the input breaks a property.
pub type Check = fn(&[u8]);

/// Every target: its name (the fuzz target's and its corpus folder's) and its check.
pub const TARGETS: &[(&str, Check)] = &[
    ("bridge_frame", bridge_frame),
    ("ros2_guidance", ros2_guidance),
    ("ros2_device", ros2_device),
];
