//! Criterion benches of our IPC calls, both ends in this process (the cost of the calls,
//! not the cross-process latency: `target/release/ipc-latency` measures that):
//! - `ipc/state/update_with_copy`, `ipc/state/get`: the `HapticState` blackboard the RT
//!   thread writes and the planner polls;
//! - `ipc/guidance/send_copy`, `ipc/guidance/send_receive`: `Guidance` publish-subscribe
//!   (planner → relay), one subscriber attached; `loan_uninit` + `write_payload` + `send`
//!   as the zero-copy alternative.
//!
//! `cargo bench -p benches --bench ipc`

use criterion::{Criterion, criterion_group, criterion_main};
use ipc_types::{Guidance, HapticState, services};
use std::hint::black_box;
use std::time::Duration;

fn ns(tag: &str) -> String {
    services::unique_namespace(&format!("bench_{tag}"))
}

fn state(c: &mut Criterion) {
    let (node, _) = services::create_node("bench_ipc_state").expect("node");
    let ns = ns("state");
    let writer = services::state_writer(&node, &ns).expect("writer");
    let reader = services::state_reader(&node, &ns).expect("reader");
    let mut g = c.benchmark_group("ipc/state");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    let mut s = HapticState::default();
    g.bench_function("update_with_copy", |b| {
        b.iter(|| {
            s.header.sequence += 1;
            writer.update_with_copy(black_box(s));
        })
    });
    g.bench_function("get", |b| {
        b.iter(|| black_box(reader.get().header.sequence))
    });
    g.finish();
}

fn guidance(c: &mut Criterion) {
    let (node, _) = services::create_node("bench_ipc_guidance").expect("node");
    let ns = ns("guidance");
    let publisher = services::publisher::<ipc_types::Guidance>(&node, &ns).expect("publisher");
    let subscriber = services::subscriber::<ipc_types::Guidance>(&node, &ns).expect("subscriber");
    let mut g = c.benchmark_group("ipc/guidance");
    g.warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    let mut v = Guidance::default();
    // Safe overflow: with nobody receiving, each send recycles the subscriber's oldest
    // sample, as with a relay that polls slower than the planner publishes.
    g.bench_function("send_copy", |b| {
        b.iter(|| {
            v.header.sequence += 1;
            publisher.send_copy(black_box(v)).expect("send");
        })
    });
    while let Ok(Some(_)) = subscriber.receive() {}
    g.bench_function("loan_write_send", |b| {
        b.iter(|| {
            v.header.sequence += 1;
            let sample = publisher.loan_uninit().expect("loan");
            sample.write_payload(black_box(v)).send().expect("send");
        })
    });
    while let Ok(Some(_)) = subscriber.receive() {}
    g.bench_function("send_receive", |b| {
        b.iter(|| {
            v.header.sequence += 1;
            publisher.send_copy(v).expect("send");
            let sample = subscriber.receive().expect("receive").expect("a sample");
            black_box(sample.header.sequence)
        })
    });
    g.bench_function("receive_empty", |b| {
        b.iter(|| black_box(subscriber.receive().expect("receive").is_none()))
    });
    g.finish();
}

criterion_group!(benches, state, guidance);
criterion_main!(benches);
