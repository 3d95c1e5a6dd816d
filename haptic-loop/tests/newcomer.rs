//! The newcomer (issue 32, item 1) holding the simulated arm in lockstep with the loop's
//! `Tick`, contact rendered from the scene, no planner: on a scene without a route it
//! reaches the goal around an obstacle with its own coarse way; on its own it does not get
//! through a ±0.05 rad slot, though the slot lets the object through at the right angle.

use devices::sim::operator::OperatorStats;
use devices::sim::{NewcomerConfig, OperatorConfig};
use haptic_loop::session::scenario;
use haptic_loop::tick::{NoGuidance, NoSink, PrevTiming, Tick};
use nalgebra::{UnitQuaternion, Vector3};
use scene::{Bounds, Part, Primitive, Scene, Se3, SpaceKind};

/// What a session showed.
struct Outcome {
    time_to_goal_s: Option<f64>,
    /// Largest x the object's reference point reached, m (scene frame).
    max_x_m: f64,
    stats: OperatorStats,
}

/// `seconds` of the loop at 1 kHz on `scene`, the arm held by the newcomer of `config`,
/// contact at 2 mm voxels, no guidance.
fn session(scene: &Scene, config: OperatorConfig, seconds: f64) -> Outcome {
    let rig = scenario::newcomer_rig(scene, config, 1000.0, 0.002).expect("the newcomer");
    let stats = rig.stats;
    let mut tick = Tick::new(rig.arm, &rig.tick, NoGuidance, NoSink)
        .unwrap()
        .with_contact(rig.contact)
        .with_goal(scenario::goal_zone(scene));
    let mut max_x_m = f64::NEG_INFINITY;
    for i in 1..=(seconds * 1000.0) as u64 {
        let s = *tick.step(i * 1_000_000, PrevTiming::default());
        if let Some(p) = ipc_types::convert::isometry(&s.proxy_pose) {
            max_x_m = max_x_m.max(p.translation.x);
        }
    }
    Outcome {
        time_to_goal_s: tick.time_to_goal_s(),
        max_x_m,
        stats: stats.read().0,
    }
}

/// Rolls of the slit about x, rad.
const SLOT_ROLL_RAD: f64 = 0.6;

/// A 10 mm wall at x = 0 with a 120 × 13 mm slit, the whole wall rolled by
/// [`SLOT_ROLL_RAD`] about x; the object a 60 × 100 × 8 mm plate, which passes the slit
/// only rolled to the slit's angle within about ±0.05 rad (100·sin θ + 8·cos θ ≤ 13 mm).
/// Start and goal 0.12 m either side, both at `roll` about x; no route.
fn tilted_slot(roll: f64) -> Scene {
    let r = UnitQuaternion::from_euler_angles(SLOT_ROLL_RAD, 0.0, 0.0);
    let (t, w, gy, gz) = (0.005, 0.25, 0.06, 0.0065);
    let part = |half: [f64; 3], centre: [f64; 3]| Part {
        primitive: Primitive::Box {
            half_extents_m: Vector3::from(half),
        },
        pose: Se3::new(r * Vector3::from(centre), r),
    };
    let (hz, cz) = (0.5 * (w - gz), 0.5 * (w + gz));
    let (hy, cy) = (0.5 * (w - gy), 0.5 * (w + gy));
    let turned = UnitQuaternion::from_euler_angles(roll, 0.0, 0.0);
    Scene {
        name: "tilted-slot".into(),
        obstacles: vec![
            part([t, w, hz], [0.0, 0.0, cz]),
            part([t, w, hz], [0.0, 0.0, -cz]),
            part([t, hy, gz], [0.0, cy, 0.0]),
            part([t, hy, gz], [0.0, -cy, 0.0]),
        ],
        moving_object: vec![Part::axis_box([0.03, 0.05, 0.004], [0.0, 0.0, 0.0])],
        bounds: Bounds {
            min_m: Vector3::new(-0.15, -0.06, -0.06),
            max_m: Vector3::new(0.15, 0.06, 0.06),
        },
        start: Se3::new(Vector3::new(-0.12, 0.0, 0.0), turned),
        goal: Se3::new(Vector3::new(0.12, 0.0, 0.0), turned),
        space: SpaceKind::Se3,
        route: Vec::new(),
    }
}

#[test]
fn without_a_route_the_newcomer_reaches_the_goal_around_a_box() {
    let scene = Scene::box_between();
    for seed in [1, 2] {
        let config = OperatorConfig {
            seed,
            ..OperatorConfig::newcomer()
        };
        let out = session(&scene, config, 40.0);
        let t = out.time_to_goal_s;
        assert!(
            t.is_some_and(|t| t < 40.0),
            "seed {seed}: not at the goal in 40 s; {:?}, x up to {:.3} m",
            out.stats,
            out.max_x_m
        );
    }
}

#[test]
fn on_its_own_the_newcomer_does_not_pass_a_slot_of_a_twentieth_of_a_radian() {
    // The stated time: 40 s of trying (a session's limit is 60–120 s with a planner).
    let seconds = 40.0;
    let scene = tilted_slot(0.0);
    for seed in [1, 2, 3] {
        let config = OperatorConfig {
            seed,
            ..OperatorConfig::newcomer()
        };
        let out = session(&scene, config, seconds);
        // Through means the plate's back edge (30 mm behind its centre) past the wall's
        // far face (5 mm): the centre beyond 35 mm.
        assert!(
            out.max_x_m < 0.035,
            "seed {seed}: through the slot, x {:.3} m",
            out.max_x_m
        );
        assert!(out.time_to_goal_s.is_none());
        // Not idle: it kept trying turns.
        assert!(
            out.stats.blocks >= 5 && out.stats.retries >= 3,
            "seed {seed}: {:?}",
            out.stats
        );
    }
    // The slot is passable: a newcomer whose guess of the orientation is the slot's (no
    // perception error) takes the plate through it to the goal in the same time.
    let right = tilted_slot(SLOT_ROLL_RAD);
    let config = OperatorConfig {
        newcomer: Some(NewcomerConfig {
            goal_orientation_error_rad: 0.0,
            ..NewcomerConfig::default()
        }),
        ..OperatorConfig::newcomer()
    };
    let out = session(&right, config, seconds);
    assert!(
        out.max_x_m > 0.035,
        "x {:.3} m; {:?}",
        out.max_x_m,
        out.stats
    );
}
