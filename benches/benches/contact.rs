//! Criterion benches of contact rendering: one contact step versus pointshell size (about
//! 1k, 10k and 50k points) and voxel size, in free space and in resting contact; the full
//! tick of each built-in scene with its object pressed flat onto its largest fitting face
//! and slid (the worst contact, `benches::face_contact`, as `tick-budget --scene`); and the
//! voxmap build. `cargo bench -p benches --bench contact`.

use benches::contact_fixture::{Fixture, Situation};
use benches::face_contact::face_setup;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use haptic_loop::tick::{NoGuidance, NoSink, PrevTiming, Tick};
use std::hint::black_box;
use std::time::Duration;

fn step_vs_points(c: &mut Criterion) {
    let mut g = c.benchmark_group("contact/step/points");
    for target in [1_000usize, 10_000, 50_000] {
        for situation in [Situation::Free, Situation::Resting] {
            let mut f = Fixture::cube_on_plate(target, 0.001, situation);
            let id = BenchmarkId::new(situation.name(), format!("{}pts", f.points()));
            g.bench_function(id, |b| b.iter(|| black_box(f.step())));
        }
    }
    g.finish();
}

fn step_vs_voxel(c: &mut Criterion) {
    let mut g = c.benchmark_group("contact/step/wall-hole-S");
    for voxel_mm in [2.0, 1.0, 0.7] {
        let mut f = Fixture::s_on_wall(voxel_mm / 1000.0);
        let id = BenchmarkId::new("sliding", format!("{voxel_mm}mm-{}pts", f.points()));
        g.bench_function(id, |b| b.iter(|| black_box(f.step())));
    }
    g.finish();
}

/// One full 1 kHz tick (1 mm voxels, the default point budget) per built-in scene, in
/// pressed, sliding face contact: the mean over the slide's cycle.
fn face_tick_per_scene(c: &mut Criterion) {
    let mut g = c.benchmark_group("contact/tick/face");
    for name in [
        "wall-hole",
        "tunnels",
        "crossing-planes",
        "maze",
        "bug-trap",
        "silencer",
    ] {
        let scene = scene::Scene::builtin(name).expect("a built-in scene");
        // An hour of sliding to and fro: longer than criterion's iterations take.
        let (arm, config, stage, _) = face_setup(&scene, 1000.0, 3600.0, 0.001).expect(name);
        let mut tick = Tick::new(arm, &config, NoGuidance, NoSink)
            .expect("the simulated arm opens")
            .with_contact(stage);
        // Pressed in and sliding before timing starts.
        let mut t_ns = 0u64;
        for _ in 0..2_000 {
            t_ns += 1_000_000;
            tick.step(t_ns, PrevTiming::default());
        }
        g.bench_function(name, |b| {
            b.iter(|| {
                t_ns += 1_000_000;
                black_box(tick.step(t_ns, PrevTiming::default()).header.sequence)
            })
        });
    }
    g.finish();
}

fn voxmap_build(c: &mut Criterion) {
    let mut g = c.benchmark_group("contact/voxmap-build/wall-hole");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for voxel_mm in [4.0, 2.0] {
        g.bench_function(format!("{voxel_mm}mm"), |b| {
            b.iter(|| black_box(Fixture::wall_hole_voxmap(voxel_mm / 1000.0).memory_bytes))
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    step_vs_points,
    step_vs_voxel,
    face_tick_per_scene,
    voxmap_build
);
criterion_main!(benches);
