//! Criterion benches of contact rendering: one contact step versus pointshell size (about
//! 1k, 10k and 50k points) and voxel size, in free space and in resting contact, and the
//! voxmap build. `cargo bench -p benches --bench contact`.

use benches::contact_fixture::{Fixture, Situation};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
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

criterion_group!(benches, step_vs_points, step_vs_voxel, voxmap_build);
criterion_main!(benches);
