//! Live methods, run records from summaries, and the reports.

use super::*;

const SUMMARY: &str = r#"{
  "solved": true, "time_to_solve_s": 4.5, "path_waypoints": 7, "path_length": 0.8,
  "run_s": 6.0, "ticks": 6000, "deadline_misses": 3, "allocations_per_tick": 0.0,
  "planner_iterations": 1000, "planner_nodes": 250, "planner_trees": 2,
  "planner_id": 1, "planner_switches": 0,
  "contact": {"contact_s": 1.5, "max_penetration_mm": 0.4, "voxel_mm": 1.0, "points": 10,
              "voxmap_mb": 1.0, "voxmap_build_s": 1.0, "level": 0, "level_changes": 0},
  "time_to_goal_s": 5.25, "max_force_step_n": 0.3,
  "operator": {"step": 3, "steps_reached": 3, "blocks": 2, "wrong_turns": 0,
               "wrong_orientations": 1, "corrections": 1, "retries": 1, "hesitations": 0}
}"#;

#[test]
fn method_names_expand_to_demo_options() {
    let h = LiveMethod::parse("hrrtc", &[0.0, 0.5], 0.5).unwrap();
    assert_eq!(h.len(), 2);
    assert_eq!(h[1].name, "hrrtc α=0.5");
    assert_eq!(
        h[1].demo_args(),
        [
            "--sampling",
            "hrrtc",
            "--device",
            "sim",
            "--operator",
            "expert",
            "--alpha",
            "0.5"
        ]
    );
    let m = &LiveMethod::parse("irrtc-mouse", &[], 0.5).unwrap()[0];
    assert!(
        m.demo_args()
            .windows(2)
            .any(|w| w == ["--device", "sim-spacemouse"])
    );
    assert_eq!(m.alpha, Some(0.0));
    let g = &LiveMethod::parse("hrrtc-noguide", &[], 0.3).unwrap()[0];
    assert!(g.demo_args().contains(&"--no-guidance".to_owned()));
    assert_eq!(g.alpha, Some(0.3));
    let p = LiveMethod::parse("hrrtc-paper", &[0.1, 0.9], 0.5).unwrap();
    assert_eq!(p.len(), 2);
    assert_eq!(p[1].name, "hrrtc-paper α=0.9");
    let args = p[0].demo_args().join(" ");
    assert!(args.contains("--human-mode every"), "{args}");
    let a = &LiveMethod::parse("rrt-connect", &[], 0.5).unwrap()[0];
    assert_eq!(a.sampling, "cs");
    for name in METHOD_NAMES {
        assert!(
            !LiveMethod::parse(name, &[0.1], 0.5).unwrap().is_empty(),
            "{name}"
        );
    }
    let e = LiveMethod::parse("rrt*", &[], 0.5).unwrap_err().to_string();
    assert!(e.contains("rrt*") && e.contains("hrrtc"), "{e}");
}

fn run(method: &LiveMethod, seed: u64, text: &str) -> LiveRun {
    LiveRun::from_summary("tunnels", method, seed, text, "s.json").unwrap()
}

#[test]
fn a_summary_becomes_a_run_and_bad_ones_are_named() {
    let m = &LiveMethod::parse("hrrtc", &[0.1], 0.5).unwrap()[0];
    let r = run(m, 3, SUMMARY);
    assert!(r.solved);
    assert_eq!(r.time_to_solve_s, 4.5);
    assert_eq!((r.nodes, r.edges), (250, 248));
    assert_eq!(r.time_to_goal_s, 5.25);
    assert_eq!(r.max_penetration_mm, 0.4);
    assert_eq!(r.alpha, 0.1);
    assert_eq!((r.blocks, r.corrections, r.retries), (2, 1, 1));
    let e = LiveRun::from_summary("t", m, 1, "{\"solved\": true}", "bad.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("bad.json") && e.contains("missing field"), "{e}");
    // No contact, unsolved, never at the goal.
    let unsolved = SUMMARY
        .replace("\"solved\": true", "\"solved\": false")
        .replace("\"time_to_solve_s\": 4.5", "\"time_to_solve_s\": null")
        .replace("\"time_to_goal_s\": 5.25", "\"time_to_goal_s\": null");
    let u = run(m, 4, &unsolved);
    assert!(!u.solved && u.time_to_solve_s.is_nan() && u.time_to_goal_s.is_nan());
}

#[test]
fn summaries_count_unsolved_at_the_limit_and_csv_is_well_formed() {
    let auto = &LiveMethod::parse("rrt-connect", &[], 0.5).unwrap()[0];
    let h = &LiveMethod::parse("hrrtc", &[0.1], 0.5).unwrap()[0];
    let slow = SUMMARY.replace("\"time_to_solve_s\": 4.5", "\"time_to_solve_s\": 20.0");
    let unsolved = SUMMARY
        .replace("\"solved\": true", "\"solved\": false")
        .replace("\"time_to_solve_s\": 4.5", "\"time_to_solve_s\": null");
    let runs = vec![
        run(auto, 1, &slow),
        run(auto, 2, &unsolved),
        run(auto, 3, &slow),
        run(h, 1, SUMMARY),
        run(h, 2, SUMMARY),
    ];
    let s = summarize(&runs, 30.0);
    assert_eq!(s.len(), 2);
    assert_eq!((s[0].solved, s[0].runs), (2, 3));
    assert_eq!(s[0].median_time_s, 20.0);
    assert_eq!(s[1].median_time_s, 4.5);
    assert!((s[1].median_goal_after_solve_s - 0.75).abs() < 1e-12);
    assert!((s[1].miss_share - 3.0 / 6000.0).abs() < 1e-12);
    let md = to_markdown(&s, 30.0);
    assert!(
        md.contains("| tunnels | hrrtc α=0.1 | 2/2 | 4.50 | 4.4× |"),
        "{md}"
    );
    let csv = to_csv(&runs);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 6);
    let columns = lines[0].split(',').count();
    assert!(
        lines.iter().all(|l| l.split(',').count() == columns),
        "{csv}"
    );
    assert!(
        lines[2].contains(",false,,"),
        "unsolved time is empty: {}",
        lines[2]
    );
}

#[test]
fn an_unknown_method_is_named_with_every_known_one() {
    let e = LiveMethod::parse("hrrtc-fast", &[0.5], 0.5)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`hrrtc-fast`"), "{e}");
    for name in METHOD_NAMES {
        assert!(e.contains(name), "{name} missing from: {e}");
    }
}
