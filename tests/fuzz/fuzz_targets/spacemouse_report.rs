//! Any stream of HID input reports from a "SpaceMouse": parsing never panics, and the
//! rate-controlled avatar they drive stays finite and within the configured speed.
#![no_main]

use devices::spacemouse::report::{RawAxes, parse};
use devices::spacemouse::{RateConfig, RateControl};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let config = RateConfig::default();
    let mut rate = RateControl::new(config);
    let mut axes = RawAxes::default();
    // Reports are length-prefixed: one byte of length, then that many bytes.
    let mut rest = data;
    while let Some((&len, tail)) = rest.split_first() {
        let n = usize::from(len).min(tail.len());
        let (report, next) = tail.split_at(n);
        rest = next;
        if let Ok(r) = parse(report) {
            axes.apply(r);
        }
        rate.step(&axes, 0.0, 0.001);
        let p = rate.pose().translation.vector;
        assert!(p.iter().all(|x| x.is_finite()));
        assert!(rate.linear_velocity().iter().all(|x| x.is_finite()));
    }
});
