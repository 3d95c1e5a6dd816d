//! The simulated side of a session: where the device's centre sits in the scene, the
//! mapping scale that fits the operator's route into the device's workspace, who holds
//! the simulated device (the reacting operator on the scene's route, or the scripted one of
//! the wall-hole demo), and the simulated arm or SpaceMouse it holds.

use crate::Error;
use crate::mapping::{Mapping, MappingConfig};
use crate::tick::GoalZone;
use devices::HapticDevice;
use devices::sim::operator::SharedStats;
use devices::sim::{
    Operator, OperatorConfig, OperatorHand, RouteStep, ScriptedUser, ScriptedUserConfig,
    SimulatedArm, SimulatedSpaceMouse, Waypoint,
};
use devices::spacemouse::SpaceMouseConfig;
use nalgebra::{Isometry3, Translation3};
use scene::Scene;
use std::sync::Arc;

use super::LoopSetup;

/// Who holds the simulated device.
// One per session, copied at set-up only: the size of the reacting operator's config
// (with the newcomer's) costs nothing worth a box.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SimOperator {
    /// The scripted operator of the wall-hole demo ([`demo_route`]): a timed path that
    /// does not react to anything it feels.
    Scripted(ScriptedUserConfig),
    /// The reacting operator (`devices::sim::operator`) on the scene's route
    /// ([`Scene::operator_route`]), or, when its config has the newcomer's parameters, on
    /// its own coarse way ([`newcomer_way`]), never reading the route.
    Reacting(OperatorConfig),
}

/// Which simulated device the operator holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimInput {
    /// The simulated 6-DOF haptic arm: the operator feels contact and guidance.
    Arm,
    /// A simulated SpaceMouse: rate control of an avatar, nothing felt.
    SpaceMouse,
}

/// Scale (scene m per device m) used when the scene fits the arm at it.
pub const DEFAULT_SCALE: f64 = 3.0;

/// Share of the arm's workspace radius that start and goal may use, so the hand has room
/// to move around them.
pub const WORKSPACE_SHARE: f64 = 0.9;

/// Scene pose of the device's centre: the middle of the box around the operator's route
/// (start, route steps, goal), in the start's orientation, so all of it is reachable.
pub fn device_origin(scene: &Scene) -> Isometry3<f64> {
    let route = scene.operator_route();
    let (mut lo, mut hi) = (scene.start.pos, scene.start.pos);
    for step in &route {
        lo = lo.inf(&step.pose.pos);
        hi = hi.sup(&step.pose.pos);
    }
    Isometry3::from_parts(Translation3::from((lo + hi) / 2.0), scene.start.rot)
}

/// Largest distance of the operator's route (start, steps, goal) from the device's centre
/// at `scale`, device m.
pub fn device_reach_m(scene: &Scene, scale: f64) -> f64 {
    let centre = device_origin(scene).translation.vector;
    scene
        .operator_route()
        .iter()
        .map(|s| (s.pose.pos - centre).norm())
        .fold(0.0, f64::max)
        / scale
}

/// The smallest scale at which the operator's route lies within [`WORKSPACE_SHARE`] of a
/// workspace of radius `workspace_radius_m` (m).
pub fn smallest_fitting_scale(scene: &Scene, workspace_radius_m: f64) -> f64 {
    device_reach_m(scene, 1.0) / (workspace_radius_m * WORKSPACE_SHARE)
}

/// [`DEFAULT_SCALE`] when the scene fits the arm at it, else the smallest fitting scale
/// rounded up to 0.1.
pub fn fitting_scale(scene: &Scene, workspace_radius_m: f64) -> f64 {
    let needed = smallest_fitting_scale(scene, workspace_radius_m);
    if needed <= DEFAULT_SCALE {
        DEFAULT_SCALE
    } else {
        (needed * 10.0).ceil() / 10.0
    }
}

/// The scripted operator of the demo, scene frame: from the start to the wall 12 cm beside
/// the hole, pushing 2 cm into it (contact stops the object; the hand feels the wall), back
/// out, to 10 cm before the hole, a pause to line up, straight through the hole's centre, to
/// the goal, then hold. The S does not fit through the hole in its start orientation, so
/// with contact on the object stays in front of the wall until the planner's guidance
/// turns it; the planner uses the operator's configuration as a hint (I-RRT §5, where "the
/// user \[may\] go through obstacles").
pub fn demo_route(scene: &Scene) -> Vec<(Isometry3<f64>, f64)> {
    let start = scene.start.to_isometry();
    let goal = scene.goal.to_isometry();
    let toward = |x: f64| {
        let mut p = start;
        p.translation.vector.x = x;
        p.translation.vector.y = 0.0;
        p.translation.vector.z = 0.0;
        p
    };
    let beside = |x: f64| {
        let mut p = toward(x);
        p.translation.vector.y = 0.12;
        p
    };
    vec![
        (start, 0.5),
        (beside(-0.1), 0.0),
        (beside(-0.04), 1.0),
        (beside(-0.1), 0.0),
        (toward(-0.1), 1.0),
        (toward(0.1), 0.0),
        (goal, 0.0),
    ]
}

/// The simulated arm with the scripted operator following `route` (scene frame, with a
/// dwell in s at each waypoint), mapped to the device through `setup`'s mapping.
pub fn simulated_arm(
    setup: &LoopSetup,
    user: ScriptedUserConfig,
    route: &[(Isometry3<f64>, f64)],
) -> Result<SimulatedArm, Error> {
    let mapping = Mapping::new(&setup.tick.mapping);
    let waypoints = route
        .iter()
        .map(|(p, dwell)| Waypoint::new(mapping.to_device(p)).with_dwell(*dwell));
    let user = ScriptedUser::new(user, waypoints).map_err(sim_error("the simulated arm"))?;
    SimulatedArm::with_user(setup.arm.clone(), user).map_err(sim_error("the simulated arm"))
}

fn sim_error(device: &'static str) -> impl Fn(devices::DeviceError) -> Error {
    move |source| Error::Device {
        device: device.into(),
        error: source,
        hint: "",
    }
}

/// The scene's operator route mapped to the device (poses through the mapping, press
/// forces rotated into the device frame; forces are not scaled).
pub fn device_route(setup: &LoopSetup) -> Vec<RouteStep> {
    let mapping = Mapping::new(&setup.tick.mapping);
    setup
        .scene
        .operator_route()
        .iter()
        .map(|s| RouteStep {
            pose: mapping.to_device(&s.pose.to_isometry()),
            press_n: mapping.vector_to_device(&s.press_n),
            dwell_s: s.dwell_s,
        })
        .collect()
}

/// The newcomer's way, device frame: the scene's coarse way ([`Scene::coarse_way`]) for
/// the reference point, mapped through `mapping` with the start's orientation, without its
/// first and last points (the start and goal). Logs how it was found and how long that
/// took; warns when the way leaves a workspace of radius `workspace_radius_m` (m; the
/// loop's workspace wall then pushes back).
pub fn newcomer_way(
    scene: &Scene,
    mapping: &MappingConfig,
    workspace_radius_m: f64,
) -> Vec<nalgebra::Vector3<f64>> {
    let began = std::time::Instant::now();
    let way = scene.coarse_way();
    let took_ms = began.elapsed().as_secs_f64() * 1e3;
    tracing::info!(
        "newcomer: its own coarse way on '{}' (not the scene's route): {} in {took_ms:.0} ms, \
         {} waypoints for a ball of {:.1} mm radius (the object's thinnest part), grid {}×{}×{} \
         of {:.1} mm, {} nodes blocked",
        scene.name,
        if way.found {
            "found"
        } else {
            "none through the grid, the straight line"
        },
        way.points_m.len().saturating_sub(2),
        way.body_radius_m * 1e3,
        way.nodes[0],
        way.nodes[1],
        way.nodes[2],
        way.cell_m * 1e3,
        way.blocked_nodes,
    );
    let mapping = Mapping::new(mapping);
    let to_device = |p: &nalgebra::Vector3<f64>| {
        mapping
            .to_device(&Isometry3::from_parts(
                Translation3::from(*p),
                scene.start.rot,
            ))
            .translation
            .vector
    };
    let reach = way
        .points_m
        .iter()
        .map(|p| to_device(p).norm())
        .fold(0.0, f64::max);
    if reach > workspace_radius_m {
        tracing::warn!(
            "newcomer: its way reaches {reach:.3} m from the device centre, beyond the arm's \
             {workspace_radius_m:.3} m workspace (a larger --scale brings it in)"
        );
    }
    let inner = way.points_m.len().saturating_sub(1);
    way.points_m
        .get(1..inner)
        .unwrap_or_default()
        .iter()
        .map(to_device)
        .collect()
}

/// The newcomer (`config.newcomer` set) on `scene` through `mapping`: its start and goal
/// mapped to the device, its own way from [`newcomer_way`]. Never reads the scene's route.
pub fn newcomer_operator(
    scene: &Scene,
    mapping: &MappingConfig,
    workspace_radius_m: f64,
    config: OperatorConfig,
) -> Result<Operator, Error> {
    let m = Mapping::new(mapping);
    let start = m.to_device(&scene.start.to_isometry());
    let goal = m.to_device(&scene.goal.to_isometry());
    let way = newcomer_way(scene, mapping, workspace_radius_m);
    Operator::newcomer(config, start, goal, &way).map_err(sim_error("the simulated operator"))
}

/// The newcomer holding the simulated arm on `scene` in lockstep with a `Tick`, as the demo
/// sets it up (its scale and mapping, the arm, contact at `voxel_m` m with the default
/// budget) at `rate_hz`, with no guidance: what the newcomer's tests and
/// `tick-budget --newcomer` drive.
pub struct NewcomerRig {
    /// The arm, held by the newcomer.
    pub arm: SimulatedArm,
    /// The tick's configuration (guidance off).
    pub tick: crate::tick::TickConfig,
    /// The contact stage.
    pub contact: crate::contact::ContactStage,
    /// The newcomer's counts (blocks, retries, ...), readable while it runs.
    pub stats: Arc<SharedStats>,
}

/// Builds a [`NewcomerRig`] for `config.newcomer` on `scene`.
pub fn newcomer_rig(
    scene: &Scene,
    config: OperatorConfig,
    rate_hz: f64,
    voxel_m: f64,
) -> Result<NewcomerRig, Error> {
    use crate::contact::{ContactConfig, ContactModel, ContactStage, Coupling};
    let arm_config = devices::sim::SimulatedArmConfig::default();
    let radius = arm_config.workspace_radius_m;
    let scale = fitting_scale(scene, radius);
    let tick = crate::tick::TickConfig {
        mapping: mapping_config(scene, scale),
        guidance: crate::guidance::GuidanceConfig::none(),
        safety: crate::safety::SafetyConfig::default(),
        period_s: 1.0 / rate_hz,
    };
    let operator = newcomer_operator(scene, &tick.mapping, radius, config)?;
    let stats = operator.shared_stats();
    let arm = SimulatedArm::with_operator(arm_config, OperatorHand::new(operator))
        .map_err(sim_error("the simulated arm"))?;
    let contact = ContactConfig::with_voxel_m(voxel_m);
    let model = ContactModel::from_scene(scene, &contact.voxmap).map_err(|e| Error::Contact {
        scene: scene.name.clone(),
        error: Box::new(e),
    })?;
    let coupling = Coupling::from_spec(arm.spec(), scale, contact.coupling_fraction);
    Ok(NewcomerRig {
        arm,
        tick,
        contact: ContactStage::new(Arc::new(model), contact, coupling),
        stats,
    })
}

/// The reacting operator of `config`: on the scene's route, or the newcomer on its own way.
fn reacting_operator(setup: &LoopSetup, config: OperatorConfig) -> Result<Operator, Error> {
    if config.newcomer.is_none() {
        return Operator::new(config, device_route(setup))
            .map_err(sim_error("the simulated operator"));
    }
    newcomer_operator(
        &setup.scene,
        &setup.tick.mapping,
        setup.arm.workspace_radius_m,
        config,
    )
}

/// A simulated device and, when a reacting operator holds it, the operator's counts.
pub type SimDevice = (Box<dyn HapticDevice>, Option<Arc<SharedStats>>);

/// The simulated device of `setup`: the arm or a SpaceMouse held by its operator (the
/// scripted one only holds the arm, on the wall-hole demo's route).
pub fn simulated_device(setup: &LoopSetup, input: SimInput) -> Result<SimDevice, Error> {
    match (setup.operator, input) {
        (SimOperator::Scripted(user), SimInput::Arm) => Ok((
            Box::new(simulated_arm(setup, user, &demo_route(&setup.scene))?),
            None,
        )),
        (SimOperator::Scripted(_), SimInput::SpaceMouse) => Err(Error::Device {
            device: "the simulated SpaceMouse".into(),
            error: devices::DeviceError::InvalidConfig("operator"),
            hint: "the scripted operator only holds the arm: choose --operator expert, novice or newcomer",
        }),
        (SimOperator::Reacting(config), SimInput::Arm) => {
            let hand = OperatorHand::new(reacting_operator(setup, config)?);
            let stats = hand.operator().shared_stats();
            Ok((
                Box::new(
                    SimulatedArm::with_operator(setup.arm.clone(), hand)
                        .map_err(sim_error("the simulated arm"))?,
                ),
                Some(stats),
            ))
        }
        (SimOperator::Reacting(config), SimInput::SpaceMouse) => {
            let operator = reacting_operator(setup, config)?;
            let stats = operator.shared_stats();
            Ok((
                Box::new(
                    SimulatedSpaceMouse::new(SpaceMouseConfig::default(), operator)
                        .map_err(sim_error("the simulated SpaceMouse"))?,
                ),
                Some(stats),
            ))
        }
    }
}

/// The mapping of `scene` to a device at `scale`, with button 1 as the clutch.
pub fn mapping_config(scene: &Scene, scale: f64) -> MappingConfig {
    MappingConfig {
        position_scale: scale,
        origin: device_origin(scene),
        clutch_button: Some(1),
    }
}

/// The zone in which the object counts as at the goal: 5 mm and 0.1 rad around it.
pub fn goal_zone(scene: &Scene) -> GoalZone {
    GoalZone {
        pose: scene.goal.to_isometry(),
        position_m: 0.005,
        angle_rad: 0.1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_scene_gets_a_scale_that_fits_the_arm() {
        let radius = devices::sim::SimulatedArmConfig::default().workspace_radius_m;
        for name in scene::BUILTIN_NAMES {
            let s = Scene::builtin(name).unwrap();
            let scale = fitting_scale(&s, radius);
            assert!(scale >= DEFAULT_SCALE, "{name}: {scale}");
            let reach = device_reach_m(&s, scale);
            assert!(
                reach <= radius * WORKSPACE_SHARE + 1e-12,
                "{name}: {reach} m"
            );
        }
        // The wall-hole fits at the default; a scene that does not gets the next 0.1 up.
        let wall = Scene::wall_with_hole();
        assert_eq!(fitting_scale(&wall, radius), DEFAULT_SCALE);
        let needed = smallest_fitting_scale(&wall, radius / 4.0);
        let scale = fitting_scale(&wall, radius / 4.0);
        assert!(
            scale >= needed && scale < needed + 0.1 + 1e-12,
            "{needed} {scale}"
        );
    }
}
