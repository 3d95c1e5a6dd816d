//! Closed-loop tests of the simulated arm held by a scripted user: the properties the
//! haptic loop and the integration tests rely on.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::{ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint};
use crate::{DeviceState, HapticDevice, Wrench};

const MS: u64 = 1_000_000;

fn arm_with(user: ScriptedUser) -> SimulatedArm {
    let mut arm = SimulatedArm::with_user(SimulatedArmConfig::default(), user).expect("valid");
    arm.open().expect("open");
    arm
}

/// Runs `n` 1 ms ticks (read, then write what `control` returns for the state read).
fn run(arm: &mut SimulatedArm, n: u64, mut control: impl FnMut(&DeviceState) -> Wrench) {
    for k in 0..n {
        let state = arm.read(k * MS).expect("read");
        arm.write(&control(&state)).expect("write");
    }
}

fn tour() -> Vec<Waypoint> {
    let turned = Isometry3::from_parts(
        Translation3::new(0.05, 0.0, 0.0),
        UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.3)),
    );
    vec![
        Waypoint::at(0.0, 0.0, 0.0).with_dwell(0.2),
        Waypoint::new(turned).with_dwell(0.3),
        Waypoint::at(0.05, 0.05, -0.02),
    ]
}

#[test]
fn rendered_force_deflects_the_arm_from_the_hand_setpoint() {
    let user =
        ScriptedUser::holding(ScriptedUserConfig::default(), Isometry3::identity()).expect("valid");
    let mut arm = arm_with(user);
    let push = Wrench::from_force(Vector3::new(3.0, 0.0, 0.0));
    run(&mut arm, 3000, |_| push);
    // Steady state: the hand spring balances the device force, 3 N / 300 N/m = 10 mm.
    let x = arm.true_pose().translation.x;
    assert!((x - 0.01).abs() < 0.2 * 0.01, "x = {x}");
    let f_u = arm.hand_wrench().force;
    assert!(
        (f_u - Vector3::new(-3.0, 0.0, 0.0)).norm() < 0.2 * 3.0,
        "f_u = {f_u}"
    );
    assert_eq!(arm.user().map(|u| u.last_wrench()), Some(arm.hand_wrench()));
}

#[test]
fn scripted_user_brings_the_arm_to_the_last_waypoint() {
    let user = ScriptedUser::new(ScriptedUserConfig::default(), tour()).expect("valid");
    let duration = user.duration_s();
    let goal = tour()[2].pose;
    let mut arm = arm_with(user);
    let n = ((duration + 1.5) * 1000.0) as u64;
    run(&mut arm, n, |_| Wrench::ZERO);
    assert!(arm.user().is_some_and(|u| u.finished(arm.user_time_s())));
    let pose = arm.true_pose();
    let error = (pose.translation.vector - goal.translation.vector).norm();
    assert!(error < 1e-3, "position error {error} m");
    assert!(pose.rotation.angle_to(&goal.rotation) < 0.01);
}

#[test]
fn arm_follows_the_moving_setpoint_with_a_small_lag() {
    let user = ScriptedUser::new(ScriptedUserConfig::default(), tour()).expect("valid");
    let mut arm = arm_with(user);
    let mut worst: f64 = 0.0;
    for k in 0..2000 {
        arm.read(k * MS).expect("read");
        arm.write(&Wrench::ZERO).expect("write");
        if let Some(user) = arm.user() {
            let setpoint = user.setpoint(arm.user_time_s());
            let lag = (setpoint.translation.vector - arm.true_pose().translation.vector).norm();
            worst = worst.max(lag);
        }
    }
    // At 0.05 m/s the viscous lag is about c·v/k = 5.3·0.05/300 ≈ 0.9 mm, plus transients.
    assert!(worst > 1e-4 && worst < 3e-3, "worst lag {worst} m");
}

fn trembling_run(seed: u64) -> (SimulatedArm, DeviceState) {
    let config = ScriptedUserConfig {
        tremor_amplitude_m: 5e-4,
        tremor_seed: seed,
        ..Default::default()
    };
    let user = ScriptedUser::new(config, tour()).expect("valid");
    let mut arm = arm_with(user);
    let mut last = arm.read(0).expect("read");
    // A virtual spring-damper to the base origin, rendered from what `read` reports.
    for k in 1..=2000 {
        let force = -last.pose.translation.vector * 500.0 - last.linear_velocity * 2.0;
        let torque = -last.pose.rotation.scaled_axis() * 0.3;
        arm.write(&Wrench::new(force, torque)).expect("write");
        last = arm.read(k * MS).expect("read");
    }
    (arm, last)
}

#[test]
fn same_config_user_and_seed_give_bit_identical_runs() {
    let (a, sa) = trembling_run(42);
    let (b, sb) = trembling_run(42);
    assert_eq!(sa, sb);
    let bits = |arm: &SimulatedArm| {
        let p = arm.true_pose();
        let (v, w) = arm.true_twist();
        p.translation
            .vector
            .iter()
            .chain(p.rotation.coords.iter())
            .chain(v.iter())
            .chain(w.iter())
            .map(|c| c.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.hand_wrench(), b.hand_wrench());
}

#[test]
fn tremor_seed_changes_the_run() {
    let (a, _) = trembling_run(1);
    let (b, _) = trembling_run(2);
    let d = (a.true_pose().translation.vector - b.true_pose().translation.vector).norm();
    assert!(d > 1e-6, "runs too close: {d} m");
}
