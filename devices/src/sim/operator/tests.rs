//! The operator model's behaviour as values: its delay, yielding to a known force,
//! correcting a blocked orientation, retries, bounded effort, sliding, determinism.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::*;
use crate::sim::{SimulatedArm, SimulatedArmConfig, SimulatedSpaceMouse};
use crate::spacemouse::SpaceMouseConfig;
use crate::{HapticDevice, Wrench};

const MS: f64 = 1e-3;

/// A config without random mistakes or hesitations (each test turns on what it checks).
fn calm() -> OperatorConfig {
    OperatorConfig {
        hesitation_rate_per_s: 0.0,
        wrong_turn_probability: 0.0,
        wrong_orientation_probability: 0.0,
        start_hold_s: 0.0,
        ..OperatorConfig::expert()
    }
}

fn at(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::translation(x, y, z)
}

fn seen(t_s: f64, pose: Isometry3<f64>, felt: Option<Wrench>) -> Perception {
    Perception { t_s, pose, felt }
}

#[test]
fn it_reacts_one_reaction_delay_after_what_it_sees() {
    for delay in [0.1, 0.25] {
        let config = OperatorConfig {
            reaction_delay_s: delay,
            stall_time_s: 10.0, // the object seen still must not read as a block here
            ..calm()
        };
        let mut op = Operator::new(config, vec![RouteStep::to(at(0.05, 0.0, 0.0))]).unwrap();
        // The object sits at x = 0 until t = 0.5 s, then is seen past the target (x = 0.1).
        let mut switched = None;
        for k in 0..1500 {
            let t = k as f64 * MS;
            let x = if t < 0.5 { 0.0 } else { 0.1 };
            let intent = op.decide(&seen(t, at(x, 0.0, 0.0), None));
            if intent.linear_velocity.x < 0.0 && switched.is_none() {
                switched = Some(t);
            }
        }
        let switched = switched.expect("it turned back");
        assert!(
            (switched - (0.5 + delay)).abs() <= 1.5 * MS,
            "delay {delay}: reacted at {switched} s"
        );
    }
}

#[test]
fn it_holds_still_for_the_start_hold_then_moves() {
    let config = OperatorConfig {
        start_hold_s: 0.6,
        ..calm()
    };
    let mut op = Operator::new(
        config,
        vec![
            RouteStep::to(at(0.0, 0.0, 0.0)),
            RouteStep::to(at(0.05, 0.0, 0.0)),
        ],
    )
    .unwrap();
    // Decisions start at t = 2 s: the hold counts from the first one.
    let mut moved = None;
    for k in 0..1500 {
        let t = 2.0 + k as f64 * MS;
        let intent = op.decide(&seen(t, at(0.0, 0.0, 0.0), None));
        if intent.linear_velocity.norm() > 0.0 && moved.is_none() {
            moved = Some(t - 2.0);
        }
    }
    let moved = moved.expect("it set off");
    assert!((moved - 0.6).abs() <= 1.5 * MS, "set off after {moved} s");
}

/// The planner's lead may pull the object off the start while the operator still takes
/// hold: it then sets off from where the object is, with the pull, instead of fighting it
/// back to the start (each 2 N pull against the way to the start would read as a block).
#[test]
fn a_pull_during_the_start_hold_is_followed_not_fought() {
    let config = OperatorConfig {
        start_hold_s: 0.6,
        ..calm()
    };
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.1, 0.0, 0.0)),
    ];
    let mut op = Operator::new(config, route).unwrap();
    // Pulled 7 mm toward the goal by a 2 N lead, held there for 0.5 s after the hold
    // (heading back, the pull would read as a block after reaction delay + blocked_time_s
    // = 0.32 s; seen still, a stall only after stall_time_s = 0.6 s).
    let pull = Some(Wrench::from_force(Vector3::new(2.0, 0.0, 0.0)));
    let mut last = Intent::STILL;
    for k in 0..1100 {
        last = op.decide(&seen(k as f64 * MS, at(0.007, 0.0, 0.0), pull));
    }
    assert_eq!(op.step_index(), 1);
    assert_eq!(op.stats().blocks, 0, "{:?}", op.stats());
    assert!(last.linear_velocity.x > 0.0, "{last:?}");
}

#[test]
fn a_felt_pull_takes_the_stated_share_of_its_intent() {
    let config = OperatorConfig {
        stall_time_s: 10.0, // the object seen still must not read as a block here
        ..calm()
    };
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.1, 0.0, 0.0)),
        RouteStep::to(at(0.2, 0.0, 0.0)),
    ];
    let mut op = Operator::new(config, route).unwrap();
    // Arrive at the first step, then head along +x.
    op.decide(&seen(0.0, at(0.0, 0.0, 0.0), None));
    assert_eq!(op.step_index(), 1);
    let v = config.speed_m_per_s;
    // Without a force: straight along x at full speed.
    let i = op.decide(&seen(MS, at(0.0, 0.0, 0.0), Some(Wrench::ZERO)));
    assert!((i.linear_velocity - Vector3::new(v, 0.0, 0.0)).norm() < 1e-12);
    // A 2 N pull along +y (≥ guidance_full_n): 30 % of the intent comes from it.
    let pull = Wrench::from_force(Vector3::new(0.0, 2.0, 0.0));
    let mut last = Intent::STILL;
    for k in 2..400 {
        last = op.decide(&seen(k as f64 * MS, at(0.0, 0.0, 0.0), Some(pull)));
    }
    let s = config.guidance_share;
    assert!(
        (last.linear_velocity.x - (1.0 - s) * v).abs() < 1e-12,
        "{last:?} {:?}",
        op.stats()
    );
    assert!((last.linear_velocity.y - s * v).abs() < 1e-12, "{last:?}");
    // Half the full force, half the share.
    let half = Wrench::from_force(Vector3::new(0.0, 0.5 * config.guidance_full_n, 0.0));
    for k in 400..700 {
        last = op.decide(&seen(k as f64 * MS, at(0.0, 0.0, 0.0), Some(half)));
    }
    assert!(
        (last.linear_velocity.y - 0.5 * s * v).abs() < 1e-12,
        "{last:?}"
    );
    // A force straight against the motion is resistance, not a pull: no share.
    let against = Wrench::from_force(Vector3::new(-0.5, 0.0, 0.0));
    for k in 700..1000 {
        last = op.decide(&seen(k as f64 * MS, at(0.0, 0.0, 0.0), Some(against)));
    }
    assert!((last.linear_velocity - Vector3::new(v, 0.0, 0.0)).norm() < 1e-12);
}

#[test]
fn blocked_it_corrects_a_wrong_orientation_by_the_stated_share() {
    let config = OperatorConfig {
        wrong_orientation_probability: 1.0,
        stall_time_s: 10.0, // only the felt force may say "blocked" here
        ..calm()
    };
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.1, 0.0, 0.0)),
        RouteStep::to(at(0.2, 0.0, 0.0)),
    ];
    let mut op = Operator::new(config, route).unwrap();
    op.decide(&seen(0.0, at(0.0, 0.0, 0.0), None));
    let before = op.orientation_error_rad();
    assert!(before > 0.5 * config.wrong_orientation_rad, "{before}");
    // Stuck in front of a wall at x = 0.01 that pushes back with 3 N.
    let wall = Some(Wrench::from_force(Vector3::new(-3.0, 0.0, 0.0)));
    let stuck = |op: &Operator| {
        Isometry3::from_parts(Translation3::new(0.01, 0.0, 0.0), op.target().rotation)
    };
    let mut corrected_at = None;
    for k in 1..2000 {
        let t = k as f64 * MS;
        let pose = stuck(&op);
        op.decide(&seen(t, pose, wall));
        if op.stats().corrections > 0 && corrected_at.is_none() {
            corrected_at = Some(t);
        }
    }
    let t = corrected_at.expect("it corrected");
    // Felt after the reaction delay, read as a block after blocked_time_s.
    let expected = config.reaction_delay_s + config.blocked_time_s;
    assert!((t - expected).abs() < 3.0 * MS, "corrected at {t} s");
    let after = op.stats().corrections;
    assert!(after >= 1);
    // One correction keeps (1 − share) of the error, and further blocks shrink it on.
    let mut op2 = Operator::new(
        config,
        vec![
            RouteStep::to(at(0.0, 0.0, 0.0)),
            RouteStep::to(at(0.1, 0.0, 0.0)),
            RouteStep::to(at(0.2, 0.0, 0.0)),
        ],
    )
    .unwrap();
    op2.decide(&seen(0.0, at(0.0, 0.0, 0.0), None));
    let e0 = op2.orientation_error_rad();
    let mut k = 1;
    while op2.stats().corrections == 0 {
        let pose = stuck(&op2);
        op2.decide(&seen(k as f64 * MS, pose, wall));
        k += 1;
    }
    let e1 = op2.orientation_error_rad();
    assert!(
        (e1 - (1.0 - config.correction_share) * e0).abs() < 1e-9,
        "{e0} → {e1}"
    );
    assert!(op.orientation_error_rad() < e1 + 1e-12);
}

#[test]
fn without_force_feedback_a_stall_reads_as_blocked_and_it_retries() {
    let config = calm();
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.05, 0.0, 0.0)),
    ];
    let mut op = Operator::new(config, route).unwrap();
    let mut first_block = None;
    let mut backed_off = false;
    for k in 0..3000 {
        let t = k as f64 * MS;
        // Seen stuck at x = 0.01 (a SpaceMouse avatar held by contact).
        let i = op.decide(&seen(t, at(0.01, 0.0, 0.0), None));
        if op.stats().blocks > 0 && first_block.is_none() {
            first_block = Some(t);
        }
        backed_off |= i.linear_velocity.x < 0.0;
    }
    let t = first_block.expect("blocked");
    // Stalled from the first decision: blocked after stall_time_s.
    assert!((t - config.stall_time_s).abs() < 2.0 * MS, "{t}");
    assert!(backed_off, "it backed off");
    assert!(op.stats().retries >= 2, "{:?}", op.stats());
}

#[test]
fn wrong_turns_are_dropped_when_seen() {
    let config = OperatorConfig {
        wrong_turn_probability: 1.0,
        ..calm()
    };
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.05, 0.0, 0.0)),
        RouteStep::to(at(0.1, 0.0, 0.0)),
    ];
    let mut op = Operator::new(config, route).unwrap();
    op.decide(&seen(0.0, at(0.0, 0.0, 0.0), None));
    let wrong = op.target();
    let off = (wrong.translation.vector - Vector3::new(0.05, 0.0, 0.0)).norm();
    assert!((off - config.wrong_turn_m).abs() < 1e-12, "{off}");
    assert_eq!(op.stats().wrong_turns, 1);
    // Arriving at the wrong place, it sees it and aims at the right one.
    for k in 1..400 {
        op.decide(&seen(k as f64 * MS, wrong, None));
    }
    assert_eq!(op.stats().corrections, 1);
    assert!((op.target().translation.vector - Vector3::new(0.05, 0.0, 0.0)).norm() < 1e-12);
}

/// An arm held by `hand`, in front of a stiff wall at x = `wall_x` (rendered by the test
/// as the loop would: a spring pushing back), for `seconds`; returns the arm and the
/// largest hand force seen.
fn against_wall(hand: OperatorHand, wall_x: f64, seconds: f64) -> (SimulatedArm, f64) {
    let mut arm = SimulatedArm::with_operator(SimulatedArmConfig::default(), hand).unwrap();
    arm.open().unwrap();
    let mut state = arm.read(0).unwrap();
    let mut max_hand: f64 = 0.0;
    let n = (seconds * 1000.0) as u64;
    for k in 1..=n {
        let x = state.pose.translation.x;
        let f = if x > wall_x {
            -2000.0 * (x - wall_x)
        } else {
            0.0
        };
        let damp = -state.linear_velocity * 2.0;
        arm.write(&Wrench::from_force(Vector3::new(f, 0.0, 0.0) + damp))
            .unwrap();
        state = arm.read(k * 1_000_000).unwrap();
        max_hand = max_hand.max(arm.hand_wrench().force.norm());
    }
    (arm, max_hand)
}

#[test]
fn held_by_the_operator_the_arm_reaches_the_route_end() {
    let config = OperatorConfig::expert();
    let turned = Isometry3::from_parts(
        Translation3::new(0.04, 0.02, 0.0),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.4)),
    );
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(turned),
        RouteStep::to(at(0.06, -0.02, 0.01)),
    ];
    let hand = OperatorHand::with_route(config, route.clone()).unwrap();
    let (arm, max_hand) = against_wall(hand, 1.0, 6.0);
    let op = arm.operator_hand().unwrap().operator();
    assert!(op.finished(), "{:?}", op.stats());
    let err = (arm.true_pose().translation.vector - route[2].pose.translation.vector).norm();
    assert!(err < 3e-3, "{err} m from the end");
    assert!(max_hand <= config.max_force_n + 1e-9);
}

#[test]
fn a_blocked_hand_pushes_with_bounded_force_and_keeps_trying() {
    let config = OperatorConfig {
        stall_time_s: 0.6,
        ..calm()
    };
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.05, 0.0, 0.0)),
    ];
    let hand = OperatorHand::with_route(config, route).unwrap();
    let (arm, max_hand) = against_wall(hand, 0.02, 5.0);
    let op = arm.operator_hand().unwrap().operator();
    assert!(!op.finished());
    // The wall holds the arm near x = 0.02 (6 N at most into a 2 kN/m wall: 3 mm).
    let x = arm.true_pose().translation.x;
    assert!(x < 0.02 + 0.004, "x = {x}");
    assert!(max_hand <= config.max_force_n + 1e-9, "{max_hand}");
    assert!(max_hand > 0.8 * config.max_force_n, "it pushed: {max_hand}");
    let s = op.stats();
    assert!(s.blocks >= 3 && s.retries >= 3, "{s:?}");
}

#[test]
fn on_a_sliding_step_it_presses_and_slides() {
    let config = calm();
    // Slide along a floor at z = 0 (the arm starts 2 mm above it, within the press slack),
    // pressing down with 2 N.
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.002)),
        RouteStep {
            pose: at(0.06, 0.0, 0.002),
            press_n: Vector3::new(0.0, 0.0, -2.0),
            dwell_s: 0.0,
        },
        RouteStep::to(at(0.06, 0.0, 0.02)),
    ];
    let hand = OperatorHand::with_route(config, route).unwrap();
    let mut arm = SimulatedArm::with_operator(SimulatedArmConfig::default(), hand).unwrap();
    arm.open().unwrap();
    let mut state = arm.read(0).unwrap();
    let mut pressed = Vec::new();
    let mut reached_end = false;
    for k in 1..=4000u64 {
        let z = state.pose.translation.z;
        let f = if z < 0.0 { -3000.0 * z } else { 0.0 } - 3.0 * state.linear_velocity.z;
        arm.write(&Wrench::from_force(Vector3::new(0.0, 0.0, f)))
            .unwrap();
        state = arm.read(k * 1_000_000).unwrap();
        let op = arm.operator_hand().unwrap().operator();
        if op.step_index() == 1 && state.pose.translation.x > 0.02 {
            pressed.push((z, arm.hand_wrench().force.z));
        }
        reached_end |= op.step_index() == 2;
    }
    assert!(reached_end, "it slid to the end of the sliding step");
    // While sliding: on the floor (within 1.5 mm) and pressing about 2 N into it.
    assert!(pressed.len() > 100);
    for (z, fz) in &pressed[pressed.len() / 2..] {
        assert!(z.abs() < 1.5e-3, "z = {z}");
        assert!((fz + 2.0).abs() < 0.6, "fz = {fz}");
    }
}

#[test]
fn far_off_the_pressed_surface_it_stops_pressing_and_comes_back() {
    let config = calm();
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep {
            pose: at(0.05, 0.0, 0.0),
            press_n: Vector3::new(0.0, 0.0, -1.0),
            dwell_s: 0.0,
        },
    ];
    let mut op = Operator::new(config, route).unwrap();
    op.decide(&seen(0.0, at(0.0, 0.0, 0.0), None));
    // Within the slack: pressing, no vertical intent.
    let i = op.decide(&seen(MS, at(0.0, 0.0, -0.002), None));
    assert_eq!(i.press_n, Vector3::new(0.0, 0.0, -1.0));
    assert_eq!(i.linear_velocity.z, 0.0);
    // Sunk 10 mm below (past the surface's edge): no press, it lifts the object back.
    for k in 2..300 {
        op.decide(&seen(k as f64 * MS, at(0.0, 0.0, -0.01), None));
    }
    let i = op.intent();
    assert_eq!(i.press_n, Vector3::zeros());
    assert!(i.linear_velocity.z > 0.0, "{i:?}");
}

#[test]
fn same_seed_same_run_and_presets_differ() {
    let route = vec![
        RouteStep::to(at(0.0, 0.0, 0.0)),
        RouteStep::to(at(0.03, 0.0, 0.0)),
        RouteStep::to(at(0.03, 0.03, 0.0)),
        RouteStep::to(at(0.0, 0.03, 0.02)),
    ];
    let run = |config: OperatorConfig| {
        let hand = OperatorHand::with_route(config, route.clone()).unwrap();
        let (arm, _) = against_wall(hand, 1.0, 4.0);
        let op = arm.operator_hand().unwrap().operator();
        (arm.true_pose(), op.stats(), op.step_index())
    };
    let novice = |seed| OperatorConfig {
        seed,
        ..OperatorConfig::novice()
    };
    assert_eq!(run(novice(3)), run(novice(3)));
    assert_ne!(run(novice(3)).0, run(novice(4)).0);
    assert!(OperatorConfig::novice().validate().is_ok());
    assert_eq!(
        OperatorConfig::preset("expert"),
        Some(OperatorConfig::expert())
    );
    assert!(OperatorConfig::preset("pro").is_none());
}

#[test]
fn bad_configs_and_routes_are_refused_naming_the_field() {
    let route = vec![RouteStep::to(at(0.0, 0.0, 0.0))];
    let bad = [
        (
            OperatorConfig {
                reaction_delay_s: 2.0,
                ..calm()
            },
            "reaction_delay_s",
        ),
        (
            OperatorConfig {
                guidance_share: 1.5,
                ..calm()
            },
            "guidance_share",
        ),
        (
            OperatorConfig {
                speed_m_per_s: f64::NAN,
                ..calm()
            },
            "speed_m_per_s",
        ),
        (
            OperatorConfig {
                newcomer: Some(NewcomerConfig {
                    waypoint_reach_m: f64::NAN,
                    ..NewcomerConfig::default()
                }),
                ..calm()
            },
            "newcomer.waypoint_reach_m",
        ),
        (
            OperatorConfig {
                newcomer: Some(NewcomerConfig {
                    trial_rad: 4.0,
                    ..NewcomerConfig::default()
                }),
                ..calm()
            },
            "trial_rad",
        ),
    ];
    for (c, field) in bad {
        let e = Operator::new(c, route.clone()).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
    assert!(Operator::new(calm(), vec![]).is_err());
    let nan = RouteStep::to(Isometry3::translation(f64::NAN, 0.0, 0.0));
    assert!(Operator::new(calm(), vec![nan]).is_err());
}

#[test]
fn on_a_simulated_spacemouse_the_operator_drives_the_avatar_to_the_end() {
    let route = vec![
        RouteStep::to(at(0.01, 0.0, 0.0)),
        RouteStep::to(at(0.05, 0.02, 0.0)),
        RouteStep::to(Isometry3::from_parts(
            Translation3::new(0.05, 0.02, 0.03),
            UnitQuaternion::from_scaled_axis(Vector3::new(0.3, 0.0, 0.0)),
        )),
    ];
    let op = Operator::new(calm(), route.clone()).unwrap();
    let mut mouse = SimulatedSpaceMouse::new(SpaceMouseConfig::default(), op).unwrap();
    mouse.open().unwrap();
    let first = mouse.read(0).unwrap();
    assert_eq!(first.pose, route[0].pose);
    let mut state = first;
    for k in 1..=5000u64 {
        mouse.write(&Wrench::ZERO).unwrap();
        state = mouse.read(k * 1_000_000).unwrap();
        let (t, r) = mouse.deflection();
        assert!(t.amax() <= 1.0 + 1e-12 || t.norm() > 0.0);
        assert!(r.iter().all(|v| v.is_finite()));
    }
    assert!(
        mouse.operator().finished(),
        "{:?}",
        mouse.operator().stats()
    );
    let err = (state.pose.translation.vector - route[2].pose.translation.vector).norm();
    assert!(err < 3e-3, "{err}");
    // A written pseudo-force moves the avatar (admittance), as on the real device.
    let before = state.pose.translation.vector;
    mouse
        .write(&Wrench::from_force(Vector3::new(0.0, 0.0, 2.0)))
        .unwrap();
    let after = mouse.read(5001 * 1_000_000).unwrap();
    assert!(after.pose.translation.vector.z > before.z);
}

/// The newcomer without mistakes, hesitations, start hold or goal-orientation error.
fn calm_newcomer() -> OperatorConfig {
    OperatorConfig {
        hesitation_rate_per_s: 0.0,
        wrong_turn_probability: 0.0,
        start_hold_s: 0.0,
        newcomer: Some(NewcomerConfig {
            goal_orientation_error_rad: 0.0,
            ..NewcomerConfig::default()
        }),
        ..OperatorConfig::newcomer()
    }
}

#[test]
fn the_newcomer_turns_toward_the_goal_as_perceived_along_its_way() {
    let goal = Isometry3::from_parts(
        Translation3::new(0.1, 0.0, 0.0),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 1.0)),
    );
    let way = [Vector3::new(0.05, 0.05, 0.0)];
    let config = OperatorConfig::newcomer();
    let op = Operator::newcomer(config, Isometry3::identity(), goal, &way).unwrap();
    let route = op.route();
    assert_eq!(route.len(), 3);
    assert_eq!(route[1].pose.translation.vector, way[0]);
    // Halfway along the way (two legs of equal length): half the turn, near enough.
    let half = route[1].pose.rotation.angle();
    assert!((half - 0.5).abs() < 0.06 + 1e-9, "{half}");
    // At the goal: the goal's orientation off by exactly the stated error.
    let error = route[2].pose.rotation.angle_to(&goal.rotation);
    let stated = config.newcomer.unwrap().goal_orientation_error_rad;
    assert!((error - stated).abs() < 1e-9, "{error}");
    // Another seed, another axis of the error; the same seed, the same route.
    let again = Operator::newcomer(config, Isometry3::identity(), goal, &way).unwrap();
    assert_eq!(again.route(), route);
    let other = OperatorConfig { seed: 2, ..config };
    let other = Operator::newcomer(other, Isometry3::identity(), goal, &way).unwrap();
    assert_ne!(other.route()[2].pose.rotation, route[2].pose.rotation);
    // Without the newcomer's parameters there is no newcomer.
    let e = Operator::newcomer(calm(), Isometry3::identity(), goal, &way).unwrap_err();
    assert!(e.to_string().contains("newcomer"), "{e}");
}

#[test]
fn the_newcomer_takes_a_faint_pull_and_twist_below_the_experts_full_share() {
    let config = calm_newcomer();
    let goal = Isometry3::translation(0.1, 0.0, 0.0);
    let mut op = Operator::newcomer(config, Isometry3::identity(), goal, &[]).unwrap();
    let v = config.speed_m_per_s;
    let w = config.angular_speed_rad_per_s;
    // 0.15 N and 0.0075 N·m: half of its full-share force and torque (the expert takes
    // a tenth of its share from 0.15 N: it is at full share only from 1 N).
    let faint = Wrench {
        force: Vector3::new(0.0, 0.15, 0.0),
        torque: Vector3::new(0.0, 0.0, 0.0075),
    };
    let mut last = Intent::STILL;
    for k in 0..500 {
        last = op.decide(&seen(k as f64 * MS, at(0.0, 0.0, 0.0), Some(faint)));
    }
    let s = 0.5 * config.guidance_share;
    assert!((last.linear_velocity.y - s * v).abs() < 1e-12, "{last:?}");
    assert!(
        (last.linear_velocity.x - (1.0 - s) * v).abs() < 1e-12,
        "{last:?}"
    );
    assert!((last.angular_velocity.z - s * w).abs() < 1e-12, "{last:?}");
    assert_eq!(op.stats().blocks, 0);
}

/// The arm held by a calm newcomer heading 10 cm along +x, the device pushing the hand with
/// `felt` for `seconds`; returns the end effector's final pose.
fn newcomer_under(felt: Wrench, seconds: f64) -> Isometry3<f64> {
    let goal = Isometry3::translation(0.1, 0.0, 0.0);
    let op = Operator::newcomer(calm_newcomer(), Isometry3::identity(), goal, &[]).unwrap();
    let mut arm =
        SimulatedArm::with_operator(SimulatedArmConfig::default(), OperatorHand::new(op)).unwrap();
    arm.open().unwrap();
    let mut state = arm.read(0).unwrap();
    for k in 1..=(seconds * 1000.0) as u64 {
        let damp = -state.linear_velocity * 2.0;
        arm.write(&Wrench {
            force: felt.force + damp,
            torque: felt.torque,
        })
        .unwrap();
        state = arm.read(k * 1_000_000).unwrap();
    }
    arm.true_pose()
}

#[test]
fn held_by_the_newcomer_the_arm_follows_a_known_guidance_force_and_torque() {
    // 0.3 N along +y and 0.015 N·m about +z: its full share, far below the 2 N and 0.1 N·m
    // the planner's lead saturates at.
    let guided = Wrench {
        force: Vector3::new(0.0, 0.3, 0.0),
        torque: Vector3::new(0.0, 0.0, 0.015),
    };
    let free = newcomer_under(Wrench::ZERO, 1.5);
    let led = newcomer_under(guided, 1.5);
    // Unguided: along x, no turn.
    assert!(free.translation.y.abs() < 1e-3, "{free:?}");
    assert!(free.rotation.angle() < 0.01, "{free:?}");
    // Guided: a grip of 300 N/m and 0.5 N·m/rad alone would give 1 mm and 0.03 rad; the
    // hand goes along instead (half its intent at full share: 25 mm/s and 0.3 rad/s).
    let dy = led.translation.y - free.translation.y;
    let turn = led.rotation.scaled_axis();
    assert!(dy > 0.012, "moved {dy} m along the force");
    assert!(turn.z > 0.2, "turned {turn:?} rad");
    assert!(turn.x.abs() < 0.02 && turn.y.abs() < 0.02, "{turn:?}");
    // Still on its way: it kept most of its own motion along x.
    assert!(
        led.translation.x > 0.5 * free.translation.x,
        "{led:?} {free:?}"
    );
}

#[test]
fn blocked_and_not_led_the_newcomer_tries_turns_in_a_seeded_order() {
    let config = OperatorConfig {
        stall_time_s: 0.3,
        ..calm_newcomer()
    };
    let goal = Isometry3::translation(0.1, 0.0, 0.0);
    let trials = |seed: u64| {
        let config = OperatorConfig { seed, ..config };
        let mut op = Operator::newcomer(config, Isometry3::identity(), goal, &[]).unwrap();
        let mut turns = Vec::new();
        let mut blocks = 0;
        // Seen stuck at the start (a wall in front), nothing felt: stalls.
        for k in 0..20_000 {
            op.decide(&seen(k as f64 * MS, at(0.0, 0.0, 0.0), Some(Wrench::ZERO)));
            if op.stats().blocks > blocks {
                blocks = op.stats().blocks;
                turns.push(op.target().rotation.scaled_axis());
            }
        }
        (turns, op.stats())
    };
    let (turns, stats) = trials(5);
    assert!(turns.len() >= 7, "{stats:?}");
    assert_eq!(stats.retries, stats.blocks);
    // The first seven: each quarter turn about each axis once and one without a turn,
    // every one wiggled by about retry_jitter_rad (σ per axis).
    let quarter = std::f64::consts::FRAC_PI_2;
    let mut seen_axes = [false; 7];
    for t in &turns[..7] {
        let big = t.iamax();
        let k = if t[big].abs() < 0.5 * quarter {
            0
        } else {
            1 + 2 * big + usize::from(t[big] < 0.0)
        };
        assert!(!seen_axes[k], "{k} twice: {turns:?}");
        seen_axes[k] = true;
        let expected = if k == 0 { 0.0 } else { quarter };
        assert!(
            (t.norm() - expected).abs() < 5.0 * config.retry_jitter_rad,
            "{t:?}"
        );
    }
    // Same seed, same order; another seed, another one.
    assert_eq!(trials(5).0, turns);
    assert_ne!(trials(6).0[..7], turns[..7]);
}

#[test]
fn led_when_blocked_the_newcomer_keeps_the_guided_orientation_until_the_goal() {
    let config = calm_newcomer();
    let goal = Isometry3::translation(0.05, 0.0, 0.0);
    let mut op = Operator::newcomer(config, Isometry3::identity(), goal, &[]).unwrap();
    // Seen still, turned 0.5 rad about z by a guidance it feels (0.5 N sideways, above
    // its 0.3 N of full share): a stall, and it keeps that orientation.
    let turned = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.5));
    let pose = |x: f64| Isometry3::from_parts(Translation3::new(x, 0.0, 0.0), turned);
    let pull = Some(Wrench::from_force(Vector3::new(0.0, 0.5, 0.0)));
    let mut k = 0;
    while op.stats().blocks == 0 {
        op.decide(&seen(k as f64 * MS, pose(0.0), pull));
        k += 1;
        assert!(k < 5000, "never blocked: {:?}", op.stats());
    }
    assert_eq!(
        op.stats().retries,
        0,
        "led, it does not back off and try turns"
    );
    assert!(op.target().rotation.angle_to(&turned) < 1e-9);
    // 5 mm from the goal (within waypoint_reach_m): the goal's orientation again.
    for j in 0..300 {
        op.decide(&seen((k + j) as f64 * MS, pose(0.045), pull));
    }
    assert!(op.target().rotation.angle_to(&goal.rotation) < 1e-9);
    assert!((op.target().translation.vector - goal.translation.vector).norm() < 1e-12);
}
