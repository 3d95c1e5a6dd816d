//! The planner side of a bridge inside a planner's process (`run_in_planner`), against a
//! loop-side bridge in this same process (two namespaces of one iceoryx2 domain, joined
//! only through Zenoh on loopback TCP): the planner's own guidance reaches the loop's side
//! once, through its `GuidanceSender`, and guidance of other processes on its host still
//! goes through its export thread.

use hrrtc_bridge::{BridgeConfig, BridgeError, GuidanceSender, Side};
use ipc_types::{Guidance, Header, services};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tests::free_port;

fn guidance(sequence: u64, writer_pid: u32) -> Guidance {
    Guidance {
        planner_id: 7,
        ..Guidance::roadmap(
            Header::new(sequence, ipc_types::monotonic_ns(), writer_pid),
            [0.0; 6],
            0.0,
            0.0,
            100_000_000,
        )
    }
}

#[test]
fn own_guidance_goes_by_the_sender_once_and_others_by_the_export_thread() {
    let pid = std::process::id();
    let (ns_loop, ns_planner) = (format!("itb_loop_{pid}"), format!("itb_planner_{pid}"));
    let keys = format!("itb_{pid}");
    let port = free_port();
    let stop = Arc::new(AtomicBool::new(false));
    let loop_side = {
        let mut c = BridgeConfig::new(Side::Loop, &ns_loop);
        c.key_namespace = Some(keys.clone());
        c.listen = vec![format!("tcp/127.0.0.1:{port}")];
        // This test is about where guidance goes, not who may send it.
        c.security.insecure = true;
        let stop = stop.clone();
        std::thread::spawn(move || hrrtc_bridge::run(&c, stop))
    };
    // The loop's guidance service, as its relay reads it.
    let (node, _) = services::create_node("itb_relay").unwrap();
    let relay = services::subscriber::<Guidance>(&node, &ns_loop).unwrap();
    // A local publisher on the planner's host: this process's and another's samples.
    let local = services::publisher::<Guidance>(&node, &ns_planner).unwrap();
    let event = services::guidance_notifier(&node, &ns_planner).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let (tx, rx) = std::sync::mpsc::channel::<GuidanceSender>();
    let planner_side = {
        let mut c = BridgeConfig::new(Side::Planner, &ns_planner);
        c.key_namespace = Some(keys.clone());
        c.connect = vec![format!("tcp/127.0.0.1:{port}")];
        c.security.insecure = true;
        let stop = stop.clone();
        std::thread::spawn(move || hrrtc_bridge::run_in_planner(&c, stop, tx))
    };
    let sender = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the sender");
    // The link is up, and the loop side has heard this side answer its probes (it hands on
    // nothing before), once a sample sent now reaches the relay.
    let mut warm_up = 0;
    tests::wait_for("guidance across the link", Duration::from_secs(20), || {
        sender.send(&guidance(100, pid));
        warm_up += 1;
        std::thread::sleep(Duration::from_millis(20));
        let mut arrived = None;
        while let Ok(Some(g)) = relay.receive() {
            arrived = Some(g.header.sequence);
        }
        arrived
    });

    let mut seen = Vec::new();
    let mut collect = |until: Duration| {
        let end = Instant::now() + until;
        while Instant::now() < end {
            while let Ok(Some(g)) = relay.receive() {
                seen.push((g.header.sequence, g.header.writer_pid));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    };
    // Sequence 1: this process's planner sends it itself and publishes it locally too.
    let own = guidance(1, pid);
    assert!(sender.send(&own));
    local.send_copy(own).unwrap();
    event.notify().unwrap();
    collect(Duration::from_millis(400));
    // Sequence 2: another planner process on the same host publishes locally only.
    local.send_copy(guidance(2, 1)).unwrap();
    event.notify().unwrap();
    collect(Duration::from_millis(400));
    stop.store(true, Ordering::Release);
    let planner_report = planner_side.join().unwrap().unwrap();
    loop_side.join().unwrap().unwrap();

    assert_eq!(
        seen.iter().filter(|(s, _)| *s == 1).count(),
        1,
        "this process's guidance arrives exactly once: {seen:?}"
    );
    assert!(
        seen.contains(&(2, 1)),
        "another process's guidance arrives through the export thread: {seen:?}"
    );
    assert_eq!(
        planner_report.kind("guidance").sent,
        warm_up + 2,
        "{planner_report:?}"
    );
}

#[test]
fn a_bridge_inside_a_planner_is_the_planner_side() {
    let (tx, _rx) = std::sync::mpsc::channel();
    let c = BridgeConfig::new(Side::Loop, "itb_wrong_side");
    let e = hrrtc_bridge::run_in_planner(&c, Arc::new(AtomicBool::new(true)), tx).unwrap_err();
    assert!(matches!(e, BridgeError::Config(_)), "{e}");
}
