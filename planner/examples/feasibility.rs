//! Feasibility run: RRT-Connect on a scene for several seeds, with an optional scripted
//! user, printing time-to-solve and iteration counts.
//!
//! ```text
//! cargo run -p planner --release --example feasibility -- \
//!     [--scene wall-hole|PATH] [--hole-mm 80] [--seeds 10] [--first-seed 1] [--limit-s 60] \
//!     [--alpha 1.0] [--user-sigma 0.03] [--user-speed 0.02]
//! ```
//!
//! With `--alpha < 1` (H-RRT-C authority sharing), a scripted user moves the object's reference point along the
//! straight line from start to goal (through the hole centre, identity orientation, passing
//! through the wall if need be, like the simulated user of I-RRT §6) at `--user-speed`
//! m/s of wall-clock time, then stays at the goal.

use planner_core::{ConfigSpace, Planner, PlannerParams, Scene};
use std::time::Instant;

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> T {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scene_arg: String = arg(&args, "--scene", "wall-hole".to_string());
    let hole_mm: f64 = arg(&args, "--hole-mm", 80.0);
    let seeds: u64 = arg(&args, "--seeds", 10);
    let first: u64 = arg(&args, "--first-seed", 1);
    let limit_s: f64 = arg(&args, "--limit-s", 60.0);
    let params = PlannerParams {
        sampling: planner_core::Sampling::Hrrtc {
            alpha: arg(&args, "--alpha", 1.0),
        },
        user_sigma: arg(&args, "--user-sigma", 0.03),
        ..Default::default()
    };
    let speed: f64 = arg(&args, "--user-speed", 0.02);
    let scene = if scene_arg == "wall-hole" && hole_mm != 80.0 {
        Scene::wall_with_square_hole(hole_mm / 1000.0)
    } else {
        match Scene::by_name_or_path(&scene_arg) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        }
    };
    println!(
        "scene {} | step {} res {} | sampling {:?} sigma {} speed {} m/s | limit {limit_s} s",
        scene.name, params.step, params.edge_resolution, params.sampling, params.user_sigma, speed
    );
    println!("seed solved time_s iterations nodes checks us/check path_len best_d");
    let mut times = Vec::new();
    for seed in first..first + seeds {
        let mut p = match Planner::new(&scene, params.clone(), seed) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(2);
            }
        };
        let line_len = (scene.goal.pos - scene.start.pos).norm();
        let t0 = Instant::now();
        let mut solved = false;
        while t0.elapsed().as_secs_f64() < limit_s {
            let t = t0.elapsed().as_secs_f64();
            let frac = (speed * t / line_len).min(1.0);
            let user = p.space().interpolate(&scene.start, &scene.goal, frac);
            let mut done = false;
            for _ in 0..64 {
                if p.iterate(Some(&user)).solved {
                    done = true;
                    break;
                }
            }
            if done {
                solved = true;
                break;
            }
        }
        let el = t0.elapsed().as_secs_f64();
        // Re-validate the solution at 1 mm / 0.01 rad with a fresh checker.
        let fine = planner_core::CollisionChecker::with_params(&scene, params.weights, 0.001)
            .with_edge_check(planner_core::EdgeCheck::Discrete);
        if let Some(path) = p.solution() {
            let bad: Vec<_> = path
                .windows(2)
                .filter(|w| !fine.edge_free(&w[0], &w[1]))
                .collect();
            // Deepest penetration along the bad edges, sampled every 0.1 mm.
            let mut depth: f64 = 0.0;
            for w in &bad {
                let n = (p.space().distance(&w[0], &w[1]) / 1e-4).ceil() as usize;
                for k in 0..=n {
                    let q = p.space().interpolate(&w[0], &w[1], k as f64 / n as f64);
                    depth = depth.max(fine.penetration_m(&q));
                }
            }
            if !bad.is_empty() {
                println!(
                    "seed {seed}: {} edges collide at 1 mm resolution, deepest {:.2} mm",
                    bad.len(),
                    depth * 1e3
                );
            }
        }
        let s = p.stats();
        let len = p.solution().map_or(0, <[_]>::len);
        println!(
            "{seed} {solved} {el:.2} {} {} {} {:.2} {len} {:.3}",
            s.iterations,
            s.nodes,
            s.collision_checks,
            el * 1e6 / s.collision_checks.max(1) as f64,
            s.best_distance_to_goal
        );
        if solved {
            times.push(el);
        }
    }
    times.sort_by(f64::total_cmp);
    if let (Some(lo), Some(hi)) = (times.first(), times.last()) {
        println!(
            "solved {}/{seeds}: min {lo:.2} s, median {:.2} s, max {hi:.2} s",
            times.len(),
            times[times.len() / 2]
        );
    } else {
        println!("solved 0/{seeds}");
    }
}
