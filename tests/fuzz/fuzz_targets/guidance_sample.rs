//! Any bytes received as a `Guidance` sample: validation and the loop's guidance filter never
//! panic, and what the loop would render is finite and within its bound.
#![no_main]

use haptic_loop::guidance::{GuidanceConfig, GuidanceFilter};
use ipc_types::Guidance;
use libfuzzer_sys::fuzz_target;

const MAX_FORCE_N: f64 = 8.0;
const MAX_TORQUE_NM: f64 = 0.5;

fuzz_target!(|data: &[u8]| {
    let mut g = Guidance::default();
    let n = data.len().min(std::mem::size_of::<Guidance>());
    // SAFETY: Guidance is #[repr(C)] and made only of integers and floats, for which every
    // bit pattern is a valid value; at most size_of::<Guidance>() bytes are copied into it.
    unsafe {
        std::ptr::copy_nonoverlapping(data.as_ptr(), (&mut g as *mut Guidance).cast::<u8>(), n);
    }
    let _ = g.validate();
    let config = GuidanceConfig::default();
    let mut filter = GuidanceFilter::new(config, MAX_FORCE_N, MAX_TORQUE_NM);
    for now_ns in [0u64, g.header.timestamp_ns, g.header.timestamp_ns.wrapping_add(1_000_000), u64::MAX] {
        let r = filter.render(&g, now_ns);
        assert!(r.force_n.iter().all(|x| x.is_finite()));
        assert!(r.torque_nm.iter().all(|x| x.is_finite()));
        assert!(r.force_n.norm() <= MAX_FORCE_N + 1e-9);
        assert!(r.torque_nm.norm() <= MAX_TORQUE_NM + 1e-9);
    }
});
