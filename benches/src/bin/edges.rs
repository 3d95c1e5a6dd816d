//! Edges: automatic RRT-Connect with discrete and with certified edge validation on the
//! same scenes and seeds (run one after the other, so both see the same machine), each
//! solution path re-checked densely; a Markdown table and the runs as JSON.
//!
//! `cargo build --release -p benches && target/release/edges --seeds 5 --time-limit 20`

use anyhow::{Context, bail};
use benches::edges::{self, EdgeRun};
use clap::Parser;
use planner_core::{EdgeCheck, Scene};
use std::path::PathBuf;

/// Discrete against certified edges: time to solve and collisions between checked states.
#[derive(Debug, Parser)]
struct Args {
    /// Scenes (built-in names or TOML files), comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "maze,tunnels,crossing-planes,silencer"
    )]
    scenes: Vec<String>,
    /// Seeds 1..=N per scene and edge check.
    #[arg(long, default_value_t = 5)]
    seeds: u64,
    /// Give up a run after this many seconds (wall clock).
    #[arg(long, default_value_t = 20.0)]
    time_limit: f64,
    /// Spacing of the re-check of each solution path, weighted m (0.2 mm, 0.002 rad).
    #[arg(long, default_value_t = 2e-4)]
    recheck_spacing: f64,
    /// Write the runs as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if args.seeds == 0 {
        bail!("--seeds must be >= 1");
    }
    for (name, v) in [
        ("--time-limit", args.time_limit),
        ("--recheck-spacing", args.recheck_spacing),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} must be finite and > 0, got {v}");
        }
    }
    let scenes: Vec<Scene> = args
        .scenes
        .iter()
        .map(|s| Scene::by_name_or_path(s).with_context(|| format!("--scenes: {s}")))
        .collect::<anyhow::Result<_>>()?;
    let mut runs: Vec<EdgeRun> = Vec::new();
    for scene in &scenes {
        for seed in 1..=args.seeds {
            for check in [EdgeCheck::Discrete, EdgeCheck::Certified] {
                let r = edges::run(scene, check, seed, args.time_limit, args.recheck_spacing)
                    .with_context(|| format!("{} seed {seed}", scene.name))?;
                eprintln!(
                    "{} {} seed {}: solved {} in {:.2} s, {} checks, {} clearance queries, {}/{} path edges collide",
                    r.scene,
                    r.edges,
                    r.seed,
                    r.solved,
                    r.time_s,
                    r.collision_checks,
                    r.clearance_queries,
                    r.colliding_edges,
                    r.path_edges
                );
                runs.push(r);
            }
        }
    }
    print!("{}", edges::summary_markdown(&runs));
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&runs)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}
