//! Issue 5 regression: a session recorded to MCAP and replayed through the loop's `Tick`
//! reproduces the loop's output bit for bit, including a device fault and its recovery.

use devices::record::{Recorder, ReplayDevice};
use devices::sim::{ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint};
use devices::{DeviceError, HapticDevice};
use haptic_loop::guidance::GuidanceConfig;
use haptic_loop::mapping::MappingConfig;
use haptic_loop::safety::SafetyConfig;
use haptic_loop::tick::{GuidanceSource, NoSink, PrevTiming, Tick, TickConfig};
use ipc_types::{FaultCode, Guidance, GuidanceMode, HapticState, Header};
use nalgebra::{Isometry3, Translation3};

const MS: u64 = 1_000_000;
const TICKS: u64 = 2000;
const FAULT_AT: u64 = 800;

struct Fixed(Guidance);
impl GuidanceSource for Fixed {
    fn latest(&mut self) -> Guidance {
        self.0
    }
}

fn guidance() -> Fixed {
    Fixed(Guidance {
        header: Header {
            sequence: 1,
            timestamp_ns: 0,
            writer_pid: 1,
            reserved: 0,
        },
        attractive: [0.02, -0.01, 0.03, 0.0, 0.0, 0.1],
        gain_n_per_m: 40.0,
        gain_nm_per_rad: 0.05,
        time_to_live_ns: 100_000 * MS,
        mode: GuidanceMode::ROADMAP,
        ..Guidance::default()
    })
}

fn config() -> TickConfig {
    TickConfig {
        mapping: MappingConfig::default(),
        guidance: GuidanceConfig::default(),
        safety: SafetyConfig::default(),
        period_s: 0.001,
    }
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
    tick: &mut Tick<D, Fixed, NoSink>,
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
    let mut t = Tick::new(recorder, &config(), guidance(), NoSink).expect("open");
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
    let mut t = Tick::new(replay, &config(), guidance(), NoSink).expect("open replay");
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
