//! Live methods, run records from summaries, and the reports.

use super::*;

const SUMMARY: &str = r#"{
  "solved": true, "time_to_solve_s": 4.5, "path_waypoints": 7, "path_length": 0.8,
  "run_s": 6.0, "ticks": 6000, "deadline_misses": 3, "allocations_per_tick": 0.0,
  "loop_report": {"ticks": 6000, "compute_us": {"p50": 20.0, "p90": 30.0, "p99": 50.0,
                  "p999": 81.5, "max": 120.0, "count": 6000}},
  "planner_iterations": 1000, "planner_nodes": 250, "planner_trees": 2,
  "planner_id": 1, "planner_switches": 0,
  "contact": {"contact_s": 1.5, "max_penetration_mm": 0.4, "voxel_mm": 1.0, "points": 10,
              "voxmap_mb": 1.0, "voxmap_build_s": 1.0, "level": 0, "level_changes": 0},
  "time_to_goal_s": 5.25, "max_force_step_n": 0.3,
  "operator": {"step": 3, "steps_reached": 3, "blocks": 2, "wrong_turns": 0,
               "wrong_orientations": 1, "corrections": 1, "retries": 1, "hesitations": 0}
}"#;

#[test]
fn a_method_may_name_its_own_alpha() {
    let m = LiveMethod::parse("hrrtc-adaptive=0.9", &[0.0, 0.5], 0.5, "newcomer").unwrap();
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].name, "hrrtc-adaptive α=0.9");
    assert_eq!(m[0].alpha, Some(0.9));
    assert_eq!(m[0].authority.as_deref(), Some("adaptive"));
    let g = LiveMethod::parse("hrrtc-noguide=0.25", &[0.5], 0.5, "expert").unwrap();
    assert_eq!(g[0].alpha, Some(0.25));
    for bad in ["hrrtc-fixed=2", "hrrtc-fixed=x", "hrrtc-fixed=NaN"] {
        let e = LiveMethod::parse(bad, &[0.5], 0.5, "expert").unwrap_err();
        assert!(e.to_string().contains("[0, 1]"), "{bad}: {e}");
    }
    assert!(LiveMethod::parse("nope=0.5", &[0.5], 0.5, "expert").is_err());
}

#[test]
fn method_names_expand_to_demo_options() {
    let h = LiveMethod::parse("hrrtc", &[0.0, 0.5], 0.5, "expert").unwrap();
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
            "0.5",
            "--planner-args",
            "--authority fixed --portfolio off"
        ]
    );
    let m = &LiveMethod::parse("irrtc-mouse", &[], 0.5, "expert").unwrap()[0];
    assert!(
        m.demo_args()
            .windows(2)
            .any(|w| w == ["--device", "sim-spacemouse"])
    );
    assert_eq!(m.alpha, Some(0.0));
    let g = &LiveMethod::parse("hrrtc-noguide", &[], 0.3, "expert").unwrap()[0];
    assert!(g.demo_args().contains(&"--no-guidance".to_owned()));
    assert_eq!(g.alpha, Some(0.3));
    let p = LiveMethod::parse("hrrtc-paper", &[0.1, 0.9], 0.5, "expert").unwrap();
    assert_eq!(p.len(), 2);
    assert_eq!(p[1].name, "hrrtc-paper α=0.9");
    let args = p[0].demo_args().join(" ");
    assert!(
        args.contains("--planner-args --authority fixed --portfolio off --human-mode every"),
        "{args}"
    );
    let a = &LiveMethod::parse("rrt-connect", &[], 0.5, "expert").unwrap()[0];
    assert_eq!(a.sampling, "cs");
    for name in METHOD_NAMES {
        assert!(
            !LiveMethod::parse(name, &[0.1], 0.5, "expert")
                .unwrap()
                .is_empty(),
            "{name}"
        );
    }
    let e = LiveMethod::parse("rrt*", &[], 0.5, "expert")
        .unwrap_err()
        .to_string();
    assert!(e.contains("rrt*") && e.contains("hrrtc"), "{e}");
}

fn run(method: &LiveMethod, seed: u64, text: &str) -> LiveRun {
    LiveRun::from_summary("tunnels", true, method, seed, text, "s.json").unwrap()
}

#[test]
fn a_summary_becomes_a_run_and_bad_ones_are_named() {
    let m = &LiveMethod::parse("hrrtc", &[0.1], 0.5, "expert").unwrap()[0];
    let r = run(m, 3, SUMMARY);
    assert!(r.solved);
    assert_eq!(r.time_to_solve_s, 4.5);
    assert_eq!((r.nodes, r.edges), (250, 248));
    assert_eq!(r.time_to_goal_s, 5.25);
    assert_eq!(r.max_penetration_mm, 0.4);
    assert_eq!(r.alpha, 0.1);
    assert_eq!((r.blocks, r.corrections, r.retries), (2, 1, 1));
    assert_eq!(r.compute_p999_us, 81.5);
    assert!(r.route && r.planner);
    let e = LiveRun::from_summary("t", true, m, 1, "{\"solved\": true}", "bad.json")
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
    let auto = &LiveMethod::parse("rrt-connect", &[], 0.5, "expert").unwrap()[0];
    let h = &LiveMethod::parse("hrrtc", &[0.1], 0.5, "expert").unwrap()[0];
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
    assert!(
        md.contains("| 2 | 0.40 / 0.40 | 0.300 | 0.050 % | 82 / 82 |"),
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
    // Read back (a sweep run in parts is reported together): the same runs, the same CSV.
    let back = from_csv(&csv, "runs.csv").unwrap();
    assert_eq!(back.len(), runs.len());
    assert_eq!(to_csv(&back), csv);
    assert!(back[1].time_to_solve_s.is_nan() || back[1].solved);
    // A short line and a bad number are named with their line.
    let short = format!("{}\ntunnels,false\n", lines[0]);
    let e = from_csv(&short, "x.csv").unwrap_err().to_string();
    assert!(e.contains("x.csv, line 2") && e.contains("fields"), "{e}");
    let bad = csv.replacen(",false,,", ",false,soon,", 1);
    let e = from_csv(&bad, "y.csv").unwrap_err().to_string();
    assert!(
        e.contains("y.csv, line 3") && e.contains("time_to_solve_s"),
        "{e}"
    );
}

#[test]
fn an_unknown_method_is_named_with_every_known_one() {
    let e = LiveMethod::parse("hrrtc-fast", &[0.5], 0.5, "expert")
        .unwrap_err()
        .to_string();
    assert!(e.contains("`hrrtc-fast`"), "{e}");
    for name in METHOD_NAMES {
        assert!(e.contains(name), "{name} missing from: {e}");
    }
}

#[test]
fn the_issue_32_methods_and_the_operator_pass_through() {
    let alone = &LiveMethod::parse("operator-alone", &[0.5], 0.5, "newcomer").unwrap()[0];
    assert!(!alone.planner && !alone.guidance);
    assert_eq!(
        alone.demo_args(),
        ["--no-planner", "--device", "sim", "--operator", "newcomer"]
    );
    let auto = &LiveMethod::parse("rrt-connect", &[0.5], 0.5, "newcomer").unwrap()[0];
    assert_eq!(
        auto.demo_args(),
        [
            "--sampling",
            "cs",
            "--device",
            "sim",
            "--operator",
            "newcomer",
            "--planner-args",
            "--portfolio off"
        ]
    );
    let fixed = LiveMethod::parse("hrrtc-fixed", &[0.1, 0.5], 0.5, "novice").unwrap();
    assert_eq!(fixed.len(), 2);
    assert_eq!(fixed[0].name, "hrrtc-fixed α=0.1");
    let args = fixed[1].demo_args().join(" ");
    assert!(
        args.ends_with(
            "--operator novice --alpha 0.5 --planner-args --authority fixed --portfolio off"
        ),
        "{args}"
    );
    let adaptive = &LiveMethod::parse("hrrtc-adaptive", &[0.5], 0.5, "expert").unwrap()[0];
    assert_eq!(adaptive.name, "hrrtc-adaptive α=0.5");
    let args = adaptive.demo_args().join(" ");
    assert!(
        args.ends_with("--planner-args --authority adaptive --portfolio off"),
        "{args}"
    );
    let portfolio = &LiveMethod::parse("hrrtc-portfolio=0.5", &[], 0.5, "newcomer").unwrap()[0];
    assert_eq!(portfolio.name, "hrrtc-portfolio α=0.5");
    let args = portfolio.demo_args().join(" ");
    assert!(
        args.ends_with("--alpha 0.5 --planner-args --authority fixed --portfolio all"),
        "{args}"
    );
    // A method that names its operator keeps it.
    let novice = &LiveMethod::parse("hrrtc-novice", &[], 0.5, "newcomer").unwrap()[0];
    assert_eq!(novice.operator, "novice");
}

#[test]
fn the_operator_alone_is_its_own_row_and_goal_times_compare_with_both_alone() {
    let alone = &LiveMethod::parse("operator-alone", &[], 0.5, "expert").unwrap()[0];
    let auto = &LiveMethod::parse("rrt-connect", &[], 0.5, "expert").unwrap()[0];
    let h = &LiveMethod::parse("hrrtc-adaptive", &[0.5], 0.5, "expert").unwrap()[0];
    let unsolved = SUMMARY
        .replace("\"solved\": true", "\"solved\": false")
        .replace("\"time_to_solve_s\": 4.5", "\"time_to_solve_s\": null");
    let at = |t: f64| {
        unsolved.replace(
            "\"time_to_goal_s\": 5.25",
            &format!("\"time_to_goal_s\": {t}"),
        )
    };
    let no_route = |m: &LiveMethod, seed: u64, text: &str| {
        LiveRun::from_summary("tunnels", false, m, seed, text, "s.json").unwrap()
    };
    let runs = vec![
        no_route(alone, 1, &at(20.0)),
        no_route(auto, 1, &SUMMARY.replace("5.25", "12.0")),
        no_route(h, 1, &SUMMARY.replace("5.25", "3.0")),
    ];
    assert!(!runs[0].route && !runs[0].planner);
    let s = summarize(&runs, 60.0);
    assert_eq!(s[0].scene, "tunnels (no route)");
    let md = to_markdown(&s, 60.0);
    assert!(
        md.contains("| tunnels (no route) | operator-alone | no planner (1) |  |  |"),
        "{md}"
    );
    // 3 s against the better alone, rrt-connect's 12 s.
    assert!(
        md.contains("| tunnels (no route) | hrrtc-adaptive α=0.5 | 1/1 | 4.50 | 1.0× | 250 | 248 | 3.00 (1/1) | 0.25 |"),
        "{md}"
    );
    let csv = to_csv(&runs);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    for col in [
        "route",
        "planner",
        "contact_share",
        "compute_p999_us",
        "blocks",
    ] {
        assert!(header.contains(&col), "{col}");
    }
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let col = |name: &str| row[header.iter().position(|c| *c == name).unwrap()];
    assert_eq!((col("route"), col("planner")), ("false", "false"));
    assert_eq!(col("contact_share"), "0.2500");
    assert_eq!(col("compute_p999_us"), "81.5");
}

/// A run of `method` on `seed` that solved after `solve_s` and reached the goal after
/// `goal_s` (not at all: NaN).
fn timed(method: &LiveMethod, seed: u64, solve_s: f64, goal_s: f64) -> LiveRun {
    let mut r = run(method, seed, SUMMARY);
    r.time_to_solve_s = solve_s;
    r.time_to_goal_s = goal_s;
    r
}

#[test]
fn ratios_carry_an_interval_over_resampled_seeds_from_five_seeds_on() {
    let alone = &LiveMethod::parse("operator-alone", &[], 0.5, "newcomer").unwrap()[0];
    let auto = &LiveMethod::parse("rrt-connect", &[], 0.5, "newcomer").unwrap()[0];
    let h = &LiveMethod::parse("hrrtc-adaptive", &[0.9], 0.5, "newcomer").unwrap()[0];
    // Seed k: the pair solves after k s and is at the goal then, RRT-Connect takes twice
    // and its operator three times as long, the operator alone never arrives. The times
    // spread over the seeds; the ratios do not, so every draw that keeps a seed's runs
    // together gives the same ratios (drawing each method's runs apart would not).
    let sweep = |seeds: u64| {
        let mut runs = Vec::new();
        for k in 1..=seeds {
            let t = k as f64;
            runs.push(timed(alone, k, f64::NAN, f64::NAN));
            runs.push(timed(auto, k, 2.0 * t, 3.0 * t));
            runs.push(timed(h, k, t, t));
        }
        runs
    };
    let md = to_markdown(&summarize(&sweep(6), 60.0), 60.0);
    assert!(md.contains("| 6/6 | 3.50 | 2.0× (2.0–2.0) |"), "{md}");
    assert!(md.contains("| 3.50 (6/6) | 0.33 (0.33–0.33) |"), "{md}");
    // RRT-Connect against itself has no interval; against the better alone (itself) it is 1.
    assert!(md.contains("| 6/6 | 7.00 | 1.0× |"), "{md}");
    assert!(md.contains("| 10.50 (6/6) | 1.00 (1.00–1.00) |"), "{md}");
    // Under five seeds, the ratios alone.
    let md = to_markdown(&summarize(&sweep(4), 60.0), 60.0);
    assert!(md.contains("| 4/4 | 2.50 | 2.0× |"), "{md}");
    assert!(md.contains("| 2.50 (4/4) | 0.33 |"), "{md}");

    // Times that do not keep their order across seeds: the interval is wide and holds
    // the ratio of the medians.
    let mut runs = Vec::new();
    for k in 1..=9u64 {
        let t = k as f64;
        runs.push(timed(auto, k, t, t));
        runs.push(timed(h, k, 10.0 - t, 10.0 - t));
    }
    let s = summarize(&runs, 60.0);
    let ratio = |m: &[f64]| m[0] / m[1];
    let (lo, hi) = seed_interval(&[&s[0], &s[1]], |r| r.solve_s, ratio).unwrap();
    assert!(lo < 0.8 && hi > 1.25 && lo <= 1.0 && 1.0 <= hi, "{lo} {hi}");
    // One group is enough; four seeds are too few.
    assert!(seed_interval(&[&s[0]], |r| r.solve_s, |m: &[f64]| m[0]).is_some());
    let few = summarize(&runs[..8], 60.0);
    assert!(seed_interval(&[&few[0], &few[1]], |r| r.solve_s, ratio).is_none());
}

#[test]
fn a_scene_without_its_route_is_written_with_its_meshes() {
    let dir = std::env::temp_dir().join(format!("lab-no-route-{}", std::process::id()));
    for name in ["tunnels", "bug-trap"] {
        let with = scene::Scene::builtin(name).unwrap();
        assert!(!with.route.is_empty(), "{name} has a route");
        let path = write_without_route(name, &dir).unwrap();
        let back = scene::Scene::load(&path).unwrap();
        assert!(back.route.is_empty(), "{name}");
        assert_eq!(
            (back.start, back.goal, back.obstacles.len()),
            (with.start, with.goal, with.obstacles.len()),
            "{name}"
        );
    }
    let e = write_without_route("no-such-scene", &dir).unwrap_err();
    assert!(e.to_string().contains("no-such-scene"), "{e}");
    let _ = std::fs::remove_dir_all(dir);
}
