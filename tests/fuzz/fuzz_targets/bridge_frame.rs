//! Any bytes received from another bridge as a frame (`hrrtc_bridge::frame`, re-stamping,
//! the probes' ping and pong): see `fuzz_checks::bridge_frame`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| fuzz_checks::bridge_frame(data));
