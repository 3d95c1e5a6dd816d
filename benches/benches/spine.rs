//! Criterion benches of the spine: one collision check of the default scene, one haptic
//! tick without contact (simulated arm, no IPC), and the two clocks the RT thread reads
//! each tick (`clock/*`: the monotonic clock is a vDSO read, the thread's CPU clock a
//! system call). `cargo bench -p benches --bench spine`.

use criterion::{Criterion, criterion_group, criterion_main};
use devices::sim::{SimulatedArm, SimulatedArmConfig};
use haptic_loop::guidance::GuidanceConfig;
use haptic_loop::mapping::MappingConfig;
use haptic_loop::safety::SafetyConfig;
use haptic_loop::tick::{NoGuidance, NoSink, PrevTiming, Tick, TickConfig};
use planner_core::{CollisionChecker, Scene, Se3};
use std::hint::black_box;

fn collision(c: &mut Criterion) {
    let scene = Scene::wall_with_hole();
    let checker = CollisionChecker::new(&scene);
    let free = scene.start;
    let in_wall = Se3::from_xyz(0.0, 0.2, 0.0);
    c.bench_function("collision/wall-hole/free", |b| {
        b.iter(|| black_box(checker.is_free(black_box(&free))))
    });
    c.bench_function("collision/wall-hole/colliding", |b| {
        b.iter(|| black_box(checker.is_free(black_box(&in_wall))))
    });
}

fn tick(c: &mut Criterion) {
    let arm = SimulatedArm::new(SimulatedArmConfig::default()).expect("valid arm");
    let config = TickConfig {
        mapping: MappingConfig::default(),
        guidance: GuidanceConfig::default(),
        safety: SafetyConfig::default(),
        period_s: 0.001,
    };
    let mut t = Tick::new(arm, &config, NoGuidance, NoSink).expect("sim opens");
    let mut now = 1_000_000u64;
    c.bench_function("tick/no-contact/sim-arm", |b| {
        b.iter(|| {
            now += 1_000_000;
            black_box(t.step(now, PrevTiming::default()).header.sequence)
        })
    });
}

fn clock(c: &mut Criterion) {
    c.bench_function("clock/monotonic", |b| {
        b.iter(|| black_box(haptic_loop::rt::monotonic_ns()))
    });
    c.bench_function("clock/thread-cpu", |b| {
        b.iter(|| black_box(haptic_loop::rt::thread_cpu_ns()))
    });
}

criterion_group!(benches, collision, tick, clock);
criterion_main!(benches);
