//! OR-parallel planning: time to solve with N planner processes at once on one query,
//! each with its own seed, the first to solve wins (the rule the loop follows with
//! several planners). Automatic planning (`planner solve`, no operator), so the figures
//! say what N planners buy on this machine's cores, apart from the operator.
//!
//! For each scene, N and trial: N `planner solve` processes start together (seeds
//! `trial × 100 + i`); the wall time until the first exits solved is the trial's time; the
//! others are then killed. Also reported: the winner's own iterations. The seeds of N
//! include those of every smaller N, so a larger N can only add chances; on a machine with
//! fewer cores than N the planners share them, which is what the wall time shows.
//!
//! `cargo build --release -p planner -p benches && target/release/or-parallel --scenes tunnels,crossing-planes --planners 1,2,4 --trials 5`

use anyhow::{Context, bail};
use clap::Parser;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Time to solve versus the number of planners running at once.
#[derive(Debug, Parser)]
struct Args {
    /// Scenes (built-in names or TOML files), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "tunnels,crossing-planes")]
    scenes: Vec<String>,
    /// Numbers of planners at once, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4")]
    planners: Vec<u32>,
    /// Trials per scene and N (different seeds each).
    #[arg(long, default_value_t = 5)]
    trials: u32,
    /// Each planner's time limit, s.
    #[arg(long, default_value_t = 60.0)]
    time_limit: f64,
    /// The `planner` executable (default: beside this one).
    #[arg(long)]
    planner: Option<PathBuf>,
}

struct Run {
    child: Child,
    json: PathBuf,
}

impl Drop for Run {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.json);
    }
}

/// One trial: wall time to the first solution (s) and the winner's iterations, if solved.
fn trial(
    args: &Args,
    planner: &PathBuf,
    scene: &str,
    n: u32,
    t: u32,
) -> anyhow::Result<Option<(f64, u64)>> {
    let limit = args.time_limit.to_string();
    let started = Instant::now();
    let mut runs = Vec::new();
    for i in 0..n {
        let seed = (u64::from(t) * 100 + u64::from(i)).to_string();
        let json =
            std::env::temp_dir().join(format!("or-parallel-{}-{t}-{i}.json", std::process::id()));
        let child = Command::new(planner)
            .args([
                "solve",
                "--scene",
                scene,
                "--seed",
                &seed,
                "--time-limit",
                &limit,
            ])
            .arg("--json")
            .arg(&json)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .with_context(|| format!("starting {}", planner.display()))?;
        runs.push(Run { child, json });
    }
    let mut running = n;
    while running > 0 {
        running = 0;
        for r in &mut runs {
            match r.child.try_wait()? {
                Some(status) if status.code() == Some(0) => {
                    let wall = started.elapsed().as_secs_f64();
                    let report: serde_json::Value =
                        serde_json::from_str(&std::fs::read_to_string(&r.json)?)?;
                    let iterations = report["iterations"].as_u64().unwrap_or(0);
                    return Ok(Some((wall, iterations)));
                }
                Some(_) => {}
                None => running += 1,
            }
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    Ok(None)
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    anyhow::ensure!(args.trials > 0, "--trials must be at least 1");
    anyhow::ensure!(
        args.planners.iter().all(|&n| (1..=16).contains(&n)),
        "--planners: each between 1 and 16"
    );
    let planner = match &args.planner {
        Some(p) => p.clone(),
        None => std::env::current_exe()?
            .parent()
            .context("this executable's folder")?
            .join("planner"),
    };
    if !planner.exists() {
        bail!(
            "{} not found: build it or give --planner",
            planner.display()
        );
    }
    println!(
        "{} cores; each planner's limit {} s; seeds trial×100 + i",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        args.time_limit
    );
    println!(
        "{:<18} {:>3} {:>8} {:>14} {:>16}",
        "scene", "N", "solved", "median wall s", "winner's median iterations"
    );
    for scene in &args.scenes {
        for &n in &args.planners {
            let mut walls = Vec::new();
            let mut iterations = Vec::new();
            let mut solved = 0;
            for t in 1..=args.trials {
                match trial(&args, &planner, scene, n, t)? {
                    Some((w, it)) => {
                        solved += 1;
                        walls.push(w);
                        iterations.push(it as f64);
                    }
                    None => walls.push(args.time_limit),
                }
            }
            let fmt =
                |m: Option<f64>, prec: usize| m.map_or("-".to_owned(), |v| format!("{v:.prec$}"));
            println!(
                "{scene:<18} {n:>3} {:>5}/{:<2} {:>14} {:>16}",
                solved,
                args.trials,
                fmt(median(walls), 2),
                fmt(median(iterations), 0)
            );
        }
    }
    Ok(())
}
