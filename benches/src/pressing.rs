//! What the live sessions' loop sees, in lockstep: the newcomer (the simulated operator who
//! does not know the way, `haptic-loop demo --operator newcomer`) holds the simulated arm
//! on a scene without its route, with no planner and no guidance, so it presses on the
//! first wall in its way for long stretches, slides along it, wiggles and turns, as the
//! live sweeps' sessions do. The mapping, the scale, the arm and the contact stage are the
//! demo's (`haptic_loop::session::scenario`); only the clock is the harness's.

use crate::BenchError;
use devices::HapticDevice;
use devices::sim::{OperatorConfig, OperatorHand, SimulatedArm, SimulatedArmConfig};
use haptic_loop::contact::{ContactConfig, ContactModel, ContactStage, Coupling};
use haptic_loop::guidance::GuidanceConfig;
use haptic_loop::safety::SafetyConfig;
use haptic_loop::session::scenario;
use haptic_loop::tick::TickConfig;
use scene::Scene;
use std::sync::Arc;

/// The newcomer of `seed` on `scene` with its route removed, at `rate_hz`, contact at
/// `voxel_m` (m) with the loop's default point budget: the arm it holds, the tick's
/// configuration and the contact stage.
pub fn newcomer_setup(
    scene: &Scene,
    rate_hz: f64,
    voxel_m: f64,
    seed: u64,
) -> Result<(SimulatedArm, TickConfig, ContactStage), BenchError> {
    let mut scene = scene.clone();
    scene.route.clear();
    let arm_config = SimulatedArmConfig::default();
    let radius = arm_config.workspace_radius_m;
    let scale = scenario::fitting_scale(&scene, radius);
    let tick_config = TickConfig {
        mapping: scenario::mapping_config(&scene, scale),
        guidance: GuidanceConfig::none(),
        safety: SafetyConfig::default(),
        period_s: 1.0 / rate_hz,
    };
    let operator = scenario::newcomer_operator(
        &scene,
        &tick_config.mapping,
        radius,
        OperatorConfig {
            seed,
            ..OperatorConfig::newcomer()
        },
    )?;
    let arm = SimulatedArm::with_operator(arm_config, OperatorHand::new(operator))?;
    let contact = ContactConfig::with_voxel_m(voxel_m);
    let model = ContactModel::from_scene(&scene, &contact.voxmap)?;
    let coupling = Coupling::from_spec(arm.spec(), scale, contact.coupling_fraction);
    let stage = ContactStage::new(Arc::new(model), contact, coupling);
    Ok((arm, tick_config, stage))
}
