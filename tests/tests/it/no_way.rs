//! "No way through" said early and soundly (issue 55): `planner solve` exits 3 with the
//! proof on a closed wall-hole, `haptic-loop demo` ends its session with the same code when
//! its planner proves it, and a scene where only the ball passes plans on.

use std::path::Path;
use std::time::Duration;

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("the JSON report")).expect("JSON")
}

fn exit_of(mut p: tests::Proc) -> Option<i32> {
    p.wait_timeout(Duration::from_secs(300))
        .expect("the process ended")
        .code()
}

#[test]
fn solve_proves_a_closed_wall_has_no_way_and_plans_on_where_only_the_ball_passes() {
    let ns = tests::unique_namespace("noway");
    let out = std::env::temp_dir().join(format!("{ns}-solve.json"));
    let out_arg = out.display().to_string();
    let closed = tests::scene_file("wall-hole-closed.toml");
    let p = tests::Proc::spawn(
        &tests::bin("planner"),
        &["solve", "--scene", &closed, "--json", &out_arg],
    );
    assert_eq!(exit_of(p), Some(3), "no way through: exit 3");
    let r = json(&out);
    assert_eq!(r["iterations"], 0, "said before the first iteration: {r}");
    let why = r["no_way"].as_str().expect("the proof's message");
    assert!(why.contains("radius 10.0 mm"), "{why}");
    assert!(
        why.contains("obstacles[4] (box)"),
        "the fifth box borders it: {why}"
    );

    // The 22 mm hole: the ball passes, the S cannot; no claim, it plans until its limit.
    let narrow = tests::scene_file("wall-hole-22mm.toml");
    let p = tests::Proc::spawn(
        &tests::bin("planner"),
        &[
            "solve",
            "--scene",
            &narrow,
            "--max-iterations",
            "2000",
            "--time-limit",
            "300",
            "--json",
            &out_arg,
        ],
    );
    assert_eq!(exit_of(p), Some(1));
    let r = json(&out);
    assert!(r.get("no_way").is_none(), "{r}");
    assert_eq!(r["iterations"], 2000);
    let _ = std::fs::remove_file(&out);
}

#[test]
fn the_demo_ends_with_no_way_through_when_its_planner_proves_it() {
    let _serial = tests::one_loop_at_a_time();
    let ns = tests::unique_namespace("noway-demo");
    let summary = std::env::temp_dir().join(format!("{ns}-summary.json"));
    let summary_arg = summary.display().to_string();
    let closed = tests::scene_file("wall-hole-closed.toml");
    let status = std::process::Command::new(tests::bin("haptic-loop"))
        .args([
            "demo",
            "--scene",
            &closed,
            "--namespace",
            &ns,
            "--no-mlock",
            "--time-limit-s",
            "120",
            "--summary-json",
            &summary_arg,
        ])
        .status()
        .expect("haptic-loop demo runs");
    assert_eq!(
        status.code(),
        Some(3),
        "the session ends with no way through"
    );
    let s = json(&summary);
    assert_eq!(s["no_way"], true, "{s}");
    assert_eq!(s["solved"], false);
    assert_eq!(s["planner_iterations"], 0, "nothing was planned: {s}");
    let _ = std::fs::remove_file(&summary);
}
