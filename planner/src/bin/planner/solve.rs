//! `planner solve`: automatic planning (no operator) against the wall clock, and its report.

use crate::common::{CoreArgs, positive};
use anyhow::Context;
use clap::Args;
use planner::Planner;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Options of `planner solve`.
#[derive(Debug, Args, Clone)]
pub struct SolveArgs {
    /// Scene, seed and tree parameters.
    #[command(flatten)]
    pub core: CoreArgs,
    /// Give up after this many seconds (wall clock).
    #[arg(long, default_value_t = 60.0)]
    pub time_limit: f64,
    /// Write the result as JSON here: solved, time_s, iterations, nodes,
    /// collision_checks, path_length (weighted m), path_waypoints.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the (smoothed) solution path here as CSV: x_m,y_m,z_m,qw,qx,qy,qz,arc_length.
    #[arg(long)]
    pub path_csv: Option<PathBuf>,
    /// Write the (smoothed) solution path here as JSON waypoints.
    #[arg(long)]
    pub path_json: Option<PathBuf>,
    /// Draw the scene, the roadmap (nodes coloured by --png-color) and the path, projected
    /// on --png-plane, into this PNG file (like I-RRT Fig. 9). Drawn solved or not.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Node colour of --png: `distance` (distance label) or `collision` (collision label).
    #[arg(long, default_value = "distance", value_parser = ["distance", "collision"])]
    pub png_color: String,
    /// Projection plane of --png: `xy` (top-down), `xz` or `yz`.
    #[arg(long, default_value = "xy", value_parser = ["xy", "xz", "yz"])]
    pub png_plane: String,
}

/// Result of `planner solve`.
#[derive(Debug, Serialize)]
pub struct SolveReport {
    /// Scene name.
    pub scene: String,
    /// Seed.
    pub seed: u64,
    /// Solved within the time limit.
    pub solved: bool,
    /// Seconds spent (to the solution, or the limit).
    pub time_s: f64,
    /// Iterations.
    pub iterations: u64,
    /// Nodes in all trees.
    pub nodes: u64,
    /// Collision checks.
    pub collision_checks: u64,
    /// Weighted length of the solution path (I-RRT eq. 2), if solved.
    pub path_length: Option<f64>,
    /// Waypoints of the solution path, if solved.
    pub path_waypoints: Option<usize>,
}

/// Plans and writes the files asked for.
pub fn solve(args: &SolveArgs) -> anyhow::Result<SolveReport> {
    let (scene, params) = args.core.load()?;
    let limit = positive("time-limit", args.time_limit)?;
    let color_by = lab::picture::ColorBy::parse(&args.png_color)
        .with_context(|| format!("--png-color: unknown `{}`", args.png_color))?;
    let plane = lab::picture::Plane::parse(&args.png_plane)
        .with_context(|| format!("--png-plane: unknown `{}`", args.png_plane))?;
    let mut planner = Planner::new(&scene, params, args.core.seed)?;
    let started = Instant::now();
    while !planner.solved() && started.elapsed().as_secs_f64() < limit {
        planner.iterate(None);
    }
    let time_s = started.elapsed().as_secs_f64();
    let s = planner.stats();
    let path_length = planner
        .solution()
        .map(|p| planner::space::path_length(planner.space(), p));
    if let Some(p) = planner.solution() {
        let write = |file: &Option<PathBuf>, text: String| -> anyhow::Result<()> {
            if let Some(f) = file {
                std::fs::write(f, text).with_context(|| format!("cannot write {}", f.display()))?;
            }
            Ok(())
        };
        write(&args.path_csv, planner::path::to_csv(planner.space(), p))?;
        write(&args.path_json, planner::path::to_json(planner.space(), p))?;
    }
    if let Some(file) = &args.png {
        if !lab::register_font() {
            tracing::warn!("no TrueType font found (DejaVuSans.ttf): the PNG has no text");
        }
        let label = format!("{} seed {}", scene.name, args.core.seed);
        lab::picture::draw_planner_png(
            &scene,
            &planner,
            &label,
            color_by,
            plane,
            file,
            (1000, 1000),
        )
        .map_err(anyhow::Error::msg)?;
    }
    Ok(SolveReport {
        scene: scene.name.clone(),
        seed: args.core.seed,
        solved: planner.solved(),
        time_s,
        iterations: s.iterations,
        nodes: s.nodes as u64,
        collision_checks: s.collision_checks,
        path_length,
        path_waypoints: planner.solution().map(<[_]>::len),
    })
}

/// Runs the command; the exit code is 0 when solved, 1 when not within the time limit.
pub fn run(args: &SolveArgs) -> anyhow::Result<i32> {
    let report = solve(args)?;
    println!(
        "{}: solved {} in {:.3} s, {} iterations, {} nodes, {} collision checks",
        report.scene,
        report.solved,
        report.time_s,
        report.iterations,
        report.nodes,
        report.collision_checks
    );
    if let Some(p) = &args.json {
        crate::write_json(p, &report)?;
    }
    Ok(if report.solved { 0 } else { 1 })
}
