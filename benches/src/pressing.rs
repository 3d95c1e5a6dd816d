//! What the live sessions' loop sees, in lockstep: the newcomer (the simulated operator who
//! does not know the way, `haptic-loop demo --operator newcomer`) holds the simulated arm
//! on a scene without its route, with no planner and no guidance, so it presses on the
//! first wall in its way for long stretches, slides along it, wiggles and turns, as the
//! live sweeps' sessions do. The mapping, the scale, the arm and the contact stage are the
//! demo's (`haptic_loop::session::scenario`); only the clock is the harness's.

use crate::BenchError;
use devices::sim::{OperatorConfig, SimulatedArm};
use haptic_loop::contact::ContactStage;
use haptic_loop::session::scenario;
use haptic_loop::tick::TickConfig;
use scene::Scene;

/// The newcomer of `seed` on `scene` with its route removed (so the mapping is the one of a
/// `--no-route` session), at `rate_hz`, contact at `voxel_m` (m) with the loop's default
/// point budget: the arm it holds, the tick's configuration and the contact stage
/// (`scenario::newcomer_rig`).
pub fn newcomer_setup(
    scene: &Scene,
    rate_hz: f64,
    voxel_m: f64,
    seed: u64,
) -> Result<(SimulatedArm, TickConfig, ContactStage), BenchError> {
    let mut scene = scene.clone();
    scene.route.clear();
    let config = OperatorConfig {
        seed,
        ..OperatorConfig::newcomer()
    };
    let rig = scenario::newcomer_rig(&scene, config, rate_hz, voxel_m)?;
    Ok((rig.arm, rig.tick, rig.contact))
}
