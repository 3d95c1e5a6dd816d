//! Issue 17: H-RRT-C through the live system. `haptic-loop demo` on every built-in scene:
//! the loop at 1 kHz with contact on the simulated arm, held by the reacting operator
//! following the scene's route, the planner (H-RRT-C) as its own process; and the live
//! experiment harness on a tiny sweep.

use std::path::Path;
use std::time::Duration;
use tests::{Proc, bin, one_loop_at_a_time, unique_namespace};

/// The demo's own limit, which only a hang reaches: the expert's sessions are solved in
/// 0.3–6 s at release speed; a loaded CI machine may take several times that, and how long
/// is not what these tests assert (the sweeps in docs/experiments.md measure it).
const LIMIT_S: &str = "300";

/// Runs the demo on `scene` (2 mm voxels: a quicker voxmap in this unoptimised build) and
/// returns its summary; asserts exit code 0 (solved).
fn demo(scene: &str) -> serde_json::Value {
    let _serial = one_loop_at_a_time();
    let ns = unique_namespace("live");
    let summary = std::env::temp_dir().join(format!("{ns}.json"));
    let mut p = Proc::spawn(
        &bin("haptic-loop"),
        &[
            "demo",
            "--scene",
            scene,
            "--namespace",
            &ns,
            "--voxel-mm",
            "2",
            "--no-mlock",
            "--time-limit-s",
            LIMIT_S,
            "--after-solve-s",
            "0.5",
            "--summary-json",
            summary.to_str().unwrap(),
        ],
    );
    let st = p
        .wait_timeout(Duration::from_secs(420))
        .expect("the demo ends by itself");
    let text = std::fs::read_to_string(&summary).expect("summary written");
    let _ = std::fs::remove_file(&summary);
    let s: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(st.code(), Some(0), "{scene}: not solved: {s}");
    s
}

/// Solved with H-RRT-C, with contact that holds (penetration within 2 voxels, a bounded
/// force step) and no allocation on the RT thread.
fn solves_live(scene: &str) {
    let s = demo(scene);
    assert_eq!(s["solved"], true, "{scene}: {s}");
    let t = s["time_to_solve_s"].as_f64().unwrap();
    assert!(t > 0.0, "{scene}: {t} s");
    let c = &s["contact"];
    let pen_voxels = c["max_penetration_mm"].as_f64().unwrap() / c["voxel_mm"].as_f64().unwrap();
    assert!(pen_voxels <= 2.0, "{scene}: {pen_voxels} voxels deep: {s}");
    // The safety stage's rate limit bounds a step; a switch of guidance or level blends.
    let step = s["max_force_step_n"].as_f64().unwrap();
    assert!(step.is_finite() && step <= 8.0, "{scene}: {step} N step");
    assert_eq!(s["allocations_per_tick"].as_f64(), Some(0.0), "{scene}");
    eprintln!(
        "{scene}: solved after {t:.2} s, object at goal {:?} s, {:.2} s in contact, {:.3} mm deep, largest step {step:.3} N, {} misses in {} ticks",
        s["time_to_goal_s"],
        c["contact_s"].as_f64().unwrap(),
        c["max_penetration_mm"].as_f64().unwrap(),
        s["deadline_misses"],
        s["ticks"]
    );
}

#[test]
fn issue_17_live_hrrtc_solves_wall_hole() {
    solves_live("wall-hole");
}

#[test]
fn issue_17_live_hrrtc_solves_maze() {
    solves_live("maze");
}

#[test]
fn issue_17_live_hrrtc_solves_tunnels() {
    solves_live("tunnels");
}

#[test]
fn issue_17_live_hrrtc_solves_crossing_planes() {
    solves_live("crossing-planes");
}

#[test]
fn issue_17_live_hrrtc_solves_silencer() {
    solves_live("silencer");
}

#[test]
fn issue_17_live_hrrtc_solves_bug_trap() {
    solves_live("bug-trap");
}

#[test]
fn issue_46_live_hrrtc_solves_roll_slot_window() {
    solves_live("roll-slot-window");
}

#[test]
fn issue_46_live_hrrtc_solves_twist_windows() {
    solves_live("twist-windows");
}

/// The harness on a tiny sweep (the free scene, automatic and H-RRT-C, one seed): a CSV
/// with a header and one row per session, every row as wide as the header, and a summary.
#[test]
fn issue_17_live_sweep_writes_well_formed_csv() {
    let _serial = one_loop_at_a_time();
    let out = std::env::temp_dir().join(unique_namespace("livesweep"));
    let exe = bin("haptic-loop");
    let st = std::process::Command::new(bin("planner"))
        .args([
            "experiment",
            "live",
            "--scenes",
            "free",
            "--live-methods",
            "rrt-connect,hrrtc",
            "--alphas",
            "0.5",
            "--seeds",
            "1",
            "--time-limit",
            "30",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .arg("--haptic-loop-exe")
        .arg(&exe)
        .status()
        .expect("planner experiment live");
    assert!(st.success(), "{st}");
    let csv = std::fs::read_to_string(out.join("runs.csv")).expect("runs.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    let header: Vec<&str> = lines[0].split(',').collect();
    assert_eq!(header[0], "scene");
    for col in [
        "method",
        "seed",
        "solved",
        "time_to_solve_s",
        "max_penetration_mm",
    ] {
        assert!(header.contains(&col), "{col} in {}", lines[0]);
    }
    let solved = header.iter().position(|c| *c == "solved").unwrap();
    let time = header.iter().position(|c| *c == "time_to_solve_s").unwrap();
    for row in &lines[1..] {
        let f: Vec<&str> = row.split(',').collect();
        assert_eq!(f.len(), header.len(), "{row}");
        assert_eq!(f[0], "free");
        assert_eq!(f[solved], "true", "{row}");
        let t: f64 = f[time].parse().expect("a time");
        assert!(t > 0.0 && t < 30.0, "{row}");
    }
    assert!(lines[1].contains(",rrt-connect,") && lines[2].contains(",hrrtc α=0.5,"));
    let md = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
    assert!(md.contains("| free | rrt-connect | 1/1 |"), "{md}");
    assert!(Path::new(&out.join("summaries")).is_dir());
    let _ = std::fs::remove_dir_all(out);
}

/// Issue 32's rows: the operator alone (no planner) and H-RRT-C with adaptive authority,
/// on a copy of the scene without its route; an operator the demo does not know stops the
/// sweep with the demo's own error naming `--operator`.
#[test]
fn issue_32_live_sweep_runs_the_operator_alone_and_adaptive_authority_without_a_route() {
    let _serial = one_loop_at_a_time();
    let out = std::env::temp_dir().join(unique_namespace("livesweep32"));
    let sweep = |methods: &str, operator: &str| {
        std::process::Command::new(bin("planner"))
            .args(["experiment", "live", "--scenes", "free", "--no-route"])
            .args(["--live-methods", methods, "--alphas", "0.5", "--seeds", "1"])
            .args(["--time-limit", "30", "--quiet", "--operator", operator])
            .arg("--out")
            .arg(&out)
            .arg("--haptic-loop-exe")
            .arg(bin("haptic-loop"))
            .output()
            .expect("planner experiment live")
    };
    let o = sweep("operator-alone,hrrtc-adaptive", "expert");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("runs.csv")).expect("runs.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |row: &str, name: &str| -> String {
        let i = header.iter().position(|c| *c == name).expect(name);
        row.split(',').nth(i).unwrap().to_owned()
    };
    for row in &lines[1..] {
        assert_eq!(col(row, "route"), "false", "{row}");
        let goal: f64 = col(row, "time_to_goal_s").parse().expect("at the goal");
        assert!(goal > 0.0 && goal < 30.0, "{row}");
        let p999: f64 = col(row, "compute_p999_us").parse().expect("p99.9");
        assert!(p999 > 0.0, "{row}");
    }
    assert_eq!(col(lines[1], "method"), "operator-alone");
    assert_eq!(
        (col(lines[1], "planner"), col(lines[1], "solved")),
        ("false".into(), "false".into())
    );
    assert_eq!(col(lines[2], "method"), "hrrtc-adaptive α=0.5");
    assert_eq!(col(lines[2], "solved"), "true");
    let md = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
    assert!(
        md.contains("| free (no route) | operator-alone | no planner (1) |"),
        "{md}"
    );
    assert!(out.join("scenes-no-route/free/free.toml").is_file());
    let o = sweep("rrt-connect", "nobody");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--operator"), "{err}");
    let _ = std::fs::remove_dir_all(out);
}

/// Issue 32, items 1 and 6: on a scene without a route (the built-in `free` scene has
/// none) the demo's operator is the newcomer, which the log says, with its own coarse way;
/// alone it brings the object to the goal. `planner experiment live --operator newcomer`
/// runs it.
#[test]
fn issue_32_a_scene_without_a_route_gets_the_newcomer() {
    let _serial = one_loop_at_a_time();
    let ns = unique_namespace("newcomer");
    let summary = std::env::temp_dir().join(format!("{ns}.json"));
    let o = std::process::Command::new(bin("haptic-loop"))
        .args([
            "demo",
            "--scene",
            "free",
            "--namespace",
            &ns,
            "--no-planner",
        ])
        .args(["--until-goal", "--time-limit-s", "30", "--no-mlock"])
        .args(["--voxel-mm", "2", "--summary-json"])
        .arg(&summary)
        .output()
        .expect("haptic-loop demo");
    let log = String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{log}");
    assert!(
        log.contains("has no [[route]]: the simulated operator is the newcomer"),
        "{log}"
    );
    assert!(
        log.contains("newcomer: its own coarse way on 'free'"),
        "{log}"
    );
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).expect("summary")).unwrap();
    let _ = std::fs::remove_file(&summary);
    let t = s["time_to_goal_s"].as_f64().expect("at the goal");
    assert!(t > 0.0 && t < 30.0, "{s}");

    let out = std::env::temp_dir().join(unique_namespace("livesweep32n"));
    let o = std::process::Command::new(bin("planner"))
        .args(["experiment", "live", "--scenes", "free", "--no-route"])
        .args(["--live-methods", "operator-alone", "--seeds", "1"])
        .args(["--time-limit", "30", "--quiet", "--operator", "newcomer"])
        .arg("--out")
        .arg(&out)
        .arg("--haptic-loop-exe")
        .arg(bin("haptic-loop"))
        .output()
        .expect("planner experiment live");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(out.join("runs.csv")).expect("runs.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 2, "{csv}");
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = |name: &str| -> String {
        let i = header.iter().position(|c| *c == name).expect(name);
        lines[1].split(',').nth(i).unwrap().to_owned()
    };
    assert_eq!(col("operator"), "newcomer", "{csv}");
    let goal: f64 = col("time_to_goal_s").parse().expect("at the goal");
    assert!(goal > 0.0 && goal < 30.0, "{csv}");
    let _ = std::fs::remove_dir_all(out);
}
