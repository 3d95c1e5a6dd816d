//! The simulated side of a session: where the device's centre sits in the scene, the
//! mapping scale that fits start and goal into the arm's workspace, the scripted operator's
//! route of the demo, and the simulated arm that carries it.

use crate::Error;
use crate::mapping::{Mapping, MappingConfig};
use devices::sim::{ScriptedUser, SimulatedArm, Waypoint};
use nalgebra::{Isometry3, Translation3};
use scene::Scene;

use super::LoopSetup;

/// Scale (scene m per device m) used when the scene fits the arm at it.
pub const DEFAULT_SCALE: f64 = 3.0;

/// Share of the arm's workspace radius that start and goal may use, so the hand has room
/// to move around them.
pub const WORKSPACE_SHARE: f64 = 0.9;

/// Scene pose of the device's centre: the middle of start and goal, in the start's
/// orientation, so both are reachable.
pub fn device_origin(scene: &Scene) -> Isometry3<f64> {
    let mid = (scene.start.pos + scene.goal.pos) / 2.0;
    Isometry3::from_parts(Translation3::from(mid), scene.start.rot)
}

/// Distance of start and goal from the device's centre at `scale`, device m.
pub fn device_reach_m(scene: &Scene, scale: f64) -> f64 {
    ((scene.goal.pos - scene.start.pos).norm() / 2.0) / scale
}

/// The smallest scale at which start and goal lie within [`WORKSPACE_SHARE`] of a workspace
/// of radius `workspace_radius_m` (m).
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
    route: &[(Isometry3<f64>, f64)],
) -> Result<SimulatedArm, Error> {
    let mapping = Mapping::new(&setup.tick.mapping);
    let waypoints = route
        .iter()
        .map(|(p, dwell)| Waypoint::new(mapping.to_device(p)).with_dwell(*dwell));
    let sim_error = |source| Error::Device {
        device: "the simulated arm".into(),
        error: source,
        hint: "",
    };
    let user = ScriptedUser::new(setup.user, waypoints).map_err(sim_error)?;
    SimulatedArm::with_user(setup.arm.clone(), user).map_err(sim_error)
}

/// The mapping of `scene` to a device at `scale`, with button 1 as the clutch.
pub fn mapping_config(scene: &Scene, scale: f64) -> MappingConfig {
    MappingConfig {
        position_scale: scale,
        origin: device_origin(scene),
        clutch_button: Some(1),
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
