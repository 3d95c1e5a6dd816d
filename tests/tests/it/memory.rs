//! The planner's memory bound (issue 55), counted by the planner's own heap meter (its
//! global allocator): over a long run on a scene with no way through (the 22 mm hole: a ball
//! inside the object passes, so no proof ends it early), its live heap never
//! passes the bound, and what it shed is reported.

use std::path::Path;
use std::time::Duration;

const MB: u64 = 1 << 20;

fn run_json(args: &[&str], json: &Path) -> serde_json::Value {
    let mut p = tests::Proc::spawn(&tests::bin("planner"), args);
    let status = p
        .wait_timeout(Duration::from_secs(600))
        .expect("planner solve ended");
    assert_eq!(status.code(), Some(1), "not solved: exit 1");
    serde_json::from_str(&std::fs::read_to_string(json).expect("the JSON report")).expect("JSON")
}

/// `planner solve` of every method on the 22 mm wall-hole for 400 000 iterations under a
/// bound of `bound_mb`, its JSON report.
fn solve_bounded(ns: &str, bound_mb: &str) -> serde_json::Value {
    let json = std::env::temp_dir().join(format!("{ns}-{bound_mb}.json"));
    let (scene, json_arg) = (
        tests::scene_file("wall-hole-22mm.toml"),
        json.display().to_string(),
    );
    // Every method: the main planner's trees and the thinned plans both shed.
    let r = run_json(
        &[
            "solve",
            "--scene",
            &scene,
            "--portfolio",
            "all",
            "--max-memory-mb",
            bound_mb,
            "--max-iterations",
            "400000",
            "--time-limit",
            "600",
            "--json",
            &json_arg,
        ],
        &json,
    );
    let _ = std::fs::remove_file(&json);
    r
}

#[test]
fn a_bounded_planner_keeps_its_heap_under_the_bound_on_a_scene_with_no_way_through() {
    let ns = tests::unique_namespace("memory");
    let r = solve_bounded(&ns, "8");
    assert_eq!(r["solved"], false);
    let m = &r["memory"];
    let n = |v: &serde_json::Value| v.as_u64().unwrap_or_else(|| panic!("a count: {v}"));
    assert_eq!(n(&m["bound_bytes"]), 8 * MB);
    // The heap meter's peak over the whole process, start-up included.
    assert!(n(&m["peak_bytes"]) <= 8 * MB, "{m}");
    assert!(n(&m["live_bytes"]) <= 8 * MB, "{m}");
    let dropped = &m["dropped"];
    assert!(n(&dropped["sheds"]) >= 3, "{m}");
    // More nodes were grown than the bound holds: far more were dropped than kept.
    assert!(n(&dropped["nodes"]) > n(&r["nodes"]), "{r}");
    assert_eq!(n(&m["full_stops"]), 0, "{m}");
    // The portfolio ran its turns (work counted): 400 000 iterations and thinning steps.
    assert!(n(&r["iterations"]) > 300_000, "{r}");

    // The same run unbounded would hold every node: the bound is what kept it small.
    let f = solve_bounded(&ns, "4096");
    assert_eq!(n(&f["memory"]["dropped"]["sheds"]), 0, "{f}");
    assert!(n(&f["memory"]["peak_bytes"]) > 8 * MB, "{f}");
}
