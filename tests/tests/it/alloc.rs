//! Invariant 1: the RT thread allocates nothing after init, with IPC live on both sides and
//! contact rendering on (the simulated operator drives the S into the wall).

use devices::sim::{ScriptedUser, ScriptedUserConfig, SimulatedArm, SimulatedArmConfig, Waypoint};
use haptic_loop::contact::{ContactConfig, ContactModel, ContactStage, Coupling, Resolution};
use haptic_loop::guidance::GuidanceConfig;
use haptic_loop::mapping::MappingConfig;
use haptic_loop::rt::RtOptions;
use haptic_loop::runner::{self, RunnerConfig};
use haptic_loop::safety::SafetyConfig;
use haptic_loop::tick::{Tick, TickConfig};
use ipc_types::services;
use ipc_types::{Guidance, Header};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

#[test]
fn rt_thread_allocates_nothing_over_6000_ticks_with_ipc_and_contact() {
    let _serial = tests::one_loop_at_a_time();
    assert!(
        haptic_loop::alloc_count::is_installed(),
        "the counting allocator must be the global allocator of this test binary"
    );
    let ns = tests::unique_namespace("alloc");
    let (node, _) = services::create_node("it_alloc_loop").unwrap();
    let state_writer = services::state_writer(&node, &ns).unwrap();
    let (_relay, guidance_source) =
        haptic_loop::relay::Relay::spawn(&ns, haptic_loop::relay::Relay::LOOP_POLL).unwrap();

    // A "planner" on another node and thread: reads every state, writes guidance at 200 Hz.
    let stop = Arc::new(AtomicBool::new(false));
    let peer = {
        let ns = ns.clone();
        let stop = stop.clone();
        std::thread::spawn(move || {
            let (node, _) = services::create_node("it_alloc_peer").unwrap();
            let reader = services::state_reader(&node, &ns).unwrap();
            let publisher = services::publisher::<ipc_types::Guidance>(&node, &ns).unwrap();
            let mut seen = 0u64;
            let mut seq = 0u64;
            while !stop.load(Ordering::Acquire) {
                let s = *reader.get();
                seen = seen.max(s.header.sequence);
                seq += 1;
                publisher
                    .send_copy(Guidance::roadmap(
                        Header::new(seq, ipc_types::monotonic_ns(), std::process::id()),
                        [0.01, -0.02, 0.0, 0.0, 0.1, 0.0],
                        20.0,
                        0.05,
                        100_000_000,
                    ))
                    .unwrap();
                std::thread::sleep(Duration::from_millis(5));
            }
            seen
        })
    };

    let user = ScriptedUser::new(
        ScriptedUserConfig::default(),
        [Waypoint::at(-0.05, 0.0, 0.0), Waypoint::at(0.05, 0.02, 0.0)],
    )
    .unwrap();
    let arm = SimulatedArm::with_user(SimulatedArmConfig::default(), user).unwrap();
    let config = TickConfig {
        mapping: MappingConfig::default(),
        guidance: GuidanceConfig::default(),
        safety: SafetyConfig::default(),
        period_s: 1.0 / 2000.0,
    };
    // A point budget small enough (50 points per tick at 2 kHz) that the stage changes
    // level of detail and blends while the S is at the wall.
    let contact_config = ContactConfig {
        resolution: Resolution::budget(100.0),
        ..ContactConfig::with_voxel_m(0.002)
    };
    let model =
        ContactModel::from_scene(&scene::Scene::wall_with_hole(), &contact_config.voxmap).unwrap();
    let coupling = Coupling::from_spec(&SimulatedArmConfig::default().spec(), 1.0, 0.75);
    let stage = ContactStage::new(Arc::new(model), contact_config, coupling);
    let tick = Tick::new(arm, &config, guidance_source, state_writer)
        .unwrap()
        .with_contact(stage);
    let handle = runner::spawn(
        tick,
        RunnerConfig {
            rate_hz: 2000.0,
            rt: RtOptions {
                fifo_priority: None,
                cpu: None,
                lock_memory: false,
                cpu_latency_us: None,
            },
            spin_ns: 0,
            max_ticks: Some(6000),
        },
        |_| {},
    )
    .unwrap();
    while !handle.is_finished() {
        std::thread::sleep(Duration::from_millis(20));
    }
    let (tick, report) = handle.join();
    stop.store(true, Ordering::Release);
    let seen = peer.join().unwrap();

    assert_eq!(report.ticks, 6000);
    assert_eq!(
        report.rt_allocations,
        Some(0),
        "RT thread allocated: {report:?}"
    );
    assert!(
        seen > 1000,
        "the peer read the published states (saw up to {seen})"
    );
    assert!(
        tick.state().guidance_sequence > 0,
        "the loop rendered the peer's guidance"
    );
    assert!(
        tick.contact_ticks() > 100,
        "the S touched the wall (only {} ticks in contact)",
        tick.contact_ticks()
    );
    let changes = tick.contact().map_or(0, |c| c.level_changes());
    assert!(changes >= 1, "the level of detail never changed");
}
