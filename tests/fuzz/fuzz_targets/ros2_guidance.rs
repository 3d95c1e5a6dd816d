//! Any attachment and CDR payload on the ROS 2 gateway's guidance topic, through
//! `GuidanceInput::accept`: see `fuzz_checks::ros2_guidance`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| fuzz_checks::ros2_guidance(data));
