//! Issue 5 regression: a session recorded to MCAP and replayed through the loop's `Tick`
//! reproduces the loop's output bit for bit, including a device fault and its recovery.

use devices::record::{Recorder, ReplayDevice};
use devices::sim::{ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint};
use devices::{DeviceError, HapticDevice};
use haptic_loop::tick::{NoGuidance, NoSink, PrevTiming, Tick, TickConfig};
use ipc_types::{FaultCode, Guidance, HapticState, Header};
use nalgebra::{Isometry3, Translation3};

const MS: u64 = 1_000_000;
const TICKS: u64 = 2000;
const FAULT_AT: u64 = 800;

fn guidance() -> Guidance {
    Guidance::roadmap(
        Header::new(1, 0, 1),
        [0.02, -0.01, 0.03, 0.0, 0.0, 0.1],
        40.0,
        0.05,
        100_000 * MS,
    )
}

fn arm() -> SimulatedArm {
    let user = ScriptedUser::new(
        ScriptedUserConfig::default(),
        [
            Waypoint::new(Isometry3::identity()),
            Waypoint::new(Isometry3::from_parts(
                Translation3::new(0.03, 0.01, -0.02),
                nalgebra::UnitQuaternion::identity(),
            )),
        ],
    )
    .expect("user");
    SimulatedArm::with_user(SimulatedArmConfig::default(), user).expect("arm")
}

/// Runs the loop for TICKS ticks; `fault` injects a 3-tick read failure at FAULT_AT.
fn run<D: HapticDevice>(
    tick: &mut Tick<D, Guidance, NoSink>,
    mut fault: impl FnMut(&mut D, Option<DeviceError>),
) -> Vec<HapticState> {
    (1..=TICKS)
        .map(|i| {
            if i == FAULT_AT {
                fault(tick.device_mut(), Some(DeviceError::ReadFailed));
            }
            if i == FAULT_AT + 3 {
                fault(tick.device_mut(), None);
            }
            *tick.step(i * MS, PrevTiming::default())
        })
        .collect()
}

#[test]
fn issue_5_replayed_session_reproduces_the_loop_output() {
    let path = std::env::temp_dir().join(format!("hrrtc_issue5_{}.mcap", std::process::id()));

    let recorder = Recorder::create(arm(), &path).expect("create recording");
    let mut t = Tick::new(recorder, &TickConfig::default(), guidance(), NoSink).expect("open");
    let recorded = run(&mut t, |d: &mut Recorder<SimulatedArm>, f| {
        d.inner_mut().inject_fault(f)
    });
    let stats = t.device_mut().finish().expect("finish recording");
    assert_eq!(
        (stats.reads, stats.wrenches, stats.dropped),
        (TICKS, TICKS, 0)
    );

    // The session did something worth replaying: force was rendered, a fault latched.
    let peak = recorded
        .iter()
        .map(|s| s.commanded_wrench.force_n[0].abs())
        .fold(0.0, f64::max);
    assert!(peak > 0.1, "peak commanded force {peak} N");
    assert_eq!(
        recorded[(FAULT_AT - 1) as usize].fault,
        FaultCode::DEVICE_READ
    );
    assert_eq!(recorded[(TICKS - 1) as usize].fault, FaultCode::NONE);

    let replay = ReplayDevice::from_file(&path).expect("load recording");
    let mut t = Tick::new(replay, &TickConfig::default(), guidance(), NoSink).expect("open replay");
    let replayed = run(&mut t, |_: &mut ReplayDevice, _| {});
    for (i, (a, b)) in recorded.iter().zip(&replayed).enumerate() {
        assert_eq!(a.commanded_wrench, b.commanded_wrench, "tick {}", i + 1);
        assert_eq!(a.fault, b.fault, "tick {}", i + 1);
        assert_eq!(a.user_pose, b.user_pose, "tick {}", i + 1);
        assert_eq!(a.device_twist, b.device_twist, "tick {}", i + 1);
    }
    let dev = t.device();
    assert!(dev.finished());
    assert_eq!(dev.compared_writes(), TICKS as usize);
    assert_eq!(dev.max_wrench_deviation(), 0.0);
    let _ = std::fs::remove_file(&path);
}

mod spacemouse {
    use super::*;
    use devices::spacemouse::{SpaceMouse, SpaceMouseConfig, report};

    /// A SpaceMouse Compact fed from bytes, in the loop with F_a pulling along scene +X.
    fn setup() -> (
        Tick<SpaceMouse, Guidance, NoSink>,
        devices::spacemouse::Feed,
    ) {
        let model = report::known_model(0x256f, 0xc635).unwrap();
        let (dev, mut feed) = SpaceMouse::with_feed(SpaceMouseConfig::default(), model).unwrap();
        feed.attach();
        let g = Guidance {
            attractive: [0.05, 0.0, 0.0, 0.0, 0.0, 0.0],
            gain_n_per_m: 40.0,
            gain_nm_per_rad: 0.0,
            ..guidance()
        };
        (
            Tick::new(dev, &TickConfig::default(), g, NoSink).unwrap(),
            feed,
        )
    }

    #[test]
    fn issue_5_guidance_moves_the_spacemouse_avatar_and_deflection_steers_it() {
        let (mut t, mut feed) = setup();
        // Puck at rest: only F_s moves the avatar (I-RRT Alg. 2, non-haptic branch).
        let mut s = *t.step(MS, PrevTiming::default());
        for i in 2..=2000 {
            s = *t.step(i * MS, PrevTiming::default());
        }
        assert_eq!(s.fault, FaultCode::NONE);
        let x_guided = s.user_pose.position_m[0];
        assert!(
            x_guided > 0.005,
            "avatar pulled along +X by F_s: {x_guided} m"
        );
        assert!(s.user_pose.position_m[1].abs() < 1e-12);
        // Full push to the left (HID x = −350) for 1 s beats the guidance (0.05 m/s vs
        // at most 0.02 m/s from F_s). The device repeats its report every 16 ms while
        // deflected.
        for i in 2001..=3000 {
            if i % 16 == 1 {
                feed.push(&[1, 0xa2, 0xfe, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0])
                    .unwrap();
            }
            s = *t.step(i * MS, PrevTiming::default());
        }
        assert!(
            s.user_pose.position_m[0] < x_guided - 0.02,
            "{:?}",
            s.user_pose
        );
    }

    #[test]
    fn issue_5_unplugged_spacemouse_faults_and_stops_then_resumes() {
        let (mut t, mut feed) = setup();
        feed.push(&[1, 0, 0, 0x5e, 0x01, 0, 0, 0, 0, 0, 0, 0, 0])
            .unwrap(); // HID +y: toward the user = scene −Y
        for i in 1..=500 {
            t.step(i * MS, PrevTiming::default());
        }
        let before = *t.state();
        assert!(before.user_pose.position_m[1] < -0.01);
        feed.detach();
        let s = *t.step(501 * MS, PrevTiming::default());
        assert_eq!(s.fault, FaultCode::DEVICE_DISCONNECTED);
        assert_eq!(s.commanded_wrench, ipc_types::Wrench::ZERO);
        for i in 502..=600 {
            let s = *t.step(i * MS, PrevTiming::default());
            assert_eq!(s.fault, FaultCode::DEVICE_DISCONNECTED);
            // Zero motion: the held pose does not drift.
            assert_eq!(s.user_pose.position_m, before.user_pose.position_m);
        }
        feed.attach();
        let mut s = s;
        for i in 601..=1000 {
            s = *t.step(i * MS, PrevTiming::default());
        }
        assert_eq!(s.fault, FaultCode::NONE, "resumed after the fault clears");
        assert!(
            s.commanded_wrench.force_n[0] > 0.0,
            "guidance ramps back in"
        );
    }

    /// Contact holds the SpaceMouse avatar on a plate: the coupling force goes to `write`
    /// like F_s and moves the avatar back, so pushing down stops at the surface instead of
    /// passing through it.
    #[test]
    fn issue_5_contact_holds_the_spacemouse_avatar_on_a_plate() {
        use haptic_loop::contact::{ContactConfig, ContactModel, ContactStage, Coupling};
        use parry3d_f64::math::Pose;
        use parry3d_f64::shape::SharedShape;
        use std::sync::Arc;

        let model = report::known_model(0x046d, 0xc626).unwrap();
        let (dev, mut feed) = SpaceMouse::with_feed(SpaceMouseConfig::default(), model).unwrap();
        feed.attach();
        let spec = dev.spec().clone();
        let contact = ContactConfig::with_voxel_m(0.002);
        // A 300 × 300 mm plate with its top face at z = 0; a 100 × 20 × 20 mm bar.
        let plate = [(
            Pose::translation(0.0, 0.0, -0.01),
            SharedShape::cuboid(0.15, 0.15, 0.01),
        )];
        let bar = [(Pose::IDENTITY, SharedShape::cuboid(0.05, 0.01, 0.01))];
        let stage = ContactStage::new(
            Arc::new(ContactModel::build(&plate, &bar, &contact.voxmap).unwrap()),
            contact,
            Coupling::from_spec(&spec, 1.0, contact.coupling_fraction),
        );
        // Avatar starts 5 cm above the plate.
        let mut cfg = TickConfig::default();
        cfg.mapping.origin = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.05),
            nalgebra::UnitQuaternion::identity(),
        );
        let mut t = Tick::new(dev, &cfg, NoGuidance, NoSink)
            .unwrap()
            .with_contact(stage);
        // Push down (HID +z) at full speed for 2.5 s, the device repeating its report:
        // 0.125 m of travel, far through the plate without contact.
        // First hold still for 1 s: the loop releases its start-up latch only then.
        let mut s = *t.state();
        for i in 1..=1000 {
            s = *t.step(i * MS, PrevTiming::default());
        }
        assert_eq!(s.fault, FaultCode::NONE, "start-up latch released");
        for i in 1001..=3500 {
            if i % 16 == 1 {
                feed.push(&[1, 0, 0, 0, 0, 0x5e, 0x01]).unwrap();
            }
            s = *t.step(i * MS, PrevTiming::default());
        }
        let user_z = s.user_pose.position_m[2];
        let proxy_z = s.proxy_pose.position_m[2];
        assert!(proxy_z > 0.005, "proxy held above the plate: {proxy_z} m");
        assert!(
            user_z > -0.005,
            "avatar stopped near the surface: {user_z} m"
        );
        assert!(
            s.commanded_wrench.force_n[2] > 1.0,
            "coupling pushes the avatar up: {:?}",
            s.commanded_wrench
        );
    }
}
