//! Issue 8: `planner view` is a reader only. Three real processes (loop, planner, view):
//! the view being slow (SIGSTOP) or dying (SIGKILL) changes nothing in the loop, and a
//! view started late still gets the roadmap.

use ipc_types::FaultCode;
use ipc_types::services;
use std::time::Duration;
use tests::loop_watch::{PHASE_TICKS, PHASES, condition};
use tests::{Proc, bin, unique_namespace, wait_for};

/// The loop as the product runs it: SCHED_FIFO priority 80 when permitted (the summary
/// says whether it was); no contact rendering
/// (saves the 4 s voxmap build; the view reads the same state either way) and the `free`
/// scene, which the planner solves at once and then only publishes: the test adds no
/// planner burning a core to the other tests running beside it on two cores.
fn free_scene_loop(ns: &str, summary: &str) -> Proc {
    tests::start_loop(
        ns,
        &[
            "--priority",
            "80",
            "--no-contact",
            "--scene",
            "free",
            "--duration-s",
            "120",
            "--summary-json",
            summary,
        ],
    )
}

fn view(ns: &str, extra: &[&str]) -> Proc {
    let mut args = vec!["view", "--namespace", ns, "--scene", "free"];
    args.extend_from_slice(extra);
    Proc::spawn(&bin("planner"), &args)
}

/// Four conditions, three phases of 500 ticks each: no view (baseline), a view serving and
/// recording, the view stopped (SIGSTOP: a view that never reads again), the view killed.
/// Tolerance: a condition's median may stall as often as the baseline's median again plus
/// 2 % of the phase's ticks (this VM is shared with the other tests and other sessions),
/// and no phase raises a fault unless a baseline phase did. The
/// stopped and killed phases are always asserted (the view takes no CPU then); the
/// running phase only when the loop ran SCHED_FIFO (otherwise the view's CPU competes
/// with a normal-priority loop on two cores, which is scheduling, not coupling).
#[test]
fn issue_8_a_slow_or_dead_view_changes_nothing_in_the_loop() {
    let _serial = tests::one_loop_at_a_time();
    let ns = unique_namespace("view");
    let dir = std::env::temp_dir().join(&ns);
    std::fs::create_dir_all(&dir).unwrap();
    let summary = dir.join("loop.json");
    let mut lp = free_scene_loop(&ns, summary.to_str().unwrap());
    let (node, _) = services::create_node("it_view_watch").unwrap();
    let state = services::state_reader(&node, &ns).unwrap();
    let planner_json = dir.join("planner.json");
    let mut planner = crate::two_process::start_planner(
        &ns,
        &["--scene", "free", "--json", planner_json.to_str().unwrap()],
    );
    wait_for("the loop past start-up", Duration::from_secs(30), || {
        let s = *state.get();
        (s.header.sequence > 1000 && s.fault == FaultCode::NONE).then_some(())
    });

    let baseline = condition(&state, "baseline, no view");

    let rec = dir.join("view.mcap");
    let rec_arg = rec.to_str().unwrap().to_string();
    let mut first = view(&ns, &["--port", "0", "--record", &rec_arg]);
    wait_for("the view records", Duration::from_secs(30), || {
        std::fs::metadata(&rec)
            .is_ok_and(|m| m.len() > 0)
            .then_some(())
    });
    let running = condition(&state, "view running");
    first.signal(libc::SIGSTOP);
    let stopped = condition(&state, "view stopped (SIGSTOP)");
    first.signal(libc::SIGKILL);
    first
        .wait_timeout(Duration::from_secs(10))
        .expect("the view is gone");
    let killed = condition(&state, "view killed");
    assert!(lp.is_running() && planner.is_running());

    // A view that starts late (after a dead one) gets the state and the roadmap.
    let json = dir.join("late.json");
    let json_arg = json.to_str().unwrap().to_string();
    let late_rec = dir.join("late.mcap");
    let late_arg = late_rec.to_str().unwrap().to_string();
    let mut late = view(
        &ns,
        &[
            "--no-server",
            "--record",
            &late_arg,
            "--duration-s",
            "2",
            "--json",
            &json_arg,
        ],
    );
    let st = late
        .wait_timeout(Duration::from_secs(60))
        .expect("the late view stops after --duration-s");
    assert!(st.success(), "late view exit: {st}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(r["states_seen"].as_u64().unwrap() > 0, "{r}");
    assert!(r["roadmap_samples"].as_u64().unwrap() > 0, "{r}");
    assert!(r["nodes_known"].as_u64().unwrap() > 0, "{r}");
    assert!(r["messages"]["/view/scene"].as_u64().unwrap() > 0, "{r}");
    assert!(
        r["messages"]["/view/roadmap/nodes"].as_u64().unwrap() > 0,
        "{r}"
    );

    planner.signal(libc::SIGTERM);
    let st = planner
        .wait_timeout(Duration::from_secs(10))
        .expect("planner stops");
    assert!(st.success(), "planner exit: {st}");
    let p: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&planner_json).unwrap()).unwrap();
    assert!(p["roadmap_published"].as_u64().unwrap() > 0, "{p}");
    lp.signal(libc::SIGTERM);
    let st = lp
        .wait_timeout(Duration::from_secs(10))
        .expect("loop stops");
    assert!(st.success(), "loop exit: {st}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    let fifo = s["loop_report"]["fifo"]
        .as_bool()
        .expect("loop_report.fifo");

    eprintln!(
        "issue 8, median of {PHASES} phases of {PHASE_TICKS} ticks (SCHED_FIFO {fifo}): baseline {baseline:?}, \
         view running {running:?}, view stopped {stopped:?}, view killed {killed:?}; planner: \
         {} roadmap increments published, {} skipped, {:.1} µs mean, {:.1} µs max",
        p["roadmap_published"],
        p["roadmap_skipped"],
        p["roadmap_publish_mean_us"].as_f64().unwrap(),
        p["roadmap_publish_max_us"].as_f64().unwrap()
    );
    let mut checked = vec![("stopped", stopped), ("killed", killed)];
    if fifo {
        checked.push(("running", running));
    }
    for (name, p) in checked {
        p.assert_like(&baseline, &format!("view {name}"));
    }
    let _ = std::fs::remove_dir_all(dir);
}
