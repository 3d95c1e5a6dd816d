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
