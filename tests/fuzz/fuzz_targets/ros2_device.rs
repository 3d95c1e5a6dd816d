//! Any stream of pose, velocity and button samples on the ROS 2 device gateway's topics,
//! into the arm's `DriverState`s: see `fuzz_checks::ros2_device`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| fuzz_checks::ros2_device(data));
