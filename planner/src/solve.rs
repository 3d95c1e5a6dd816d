//! `planner solve`: automatic planning (no operator) against the wall clock. The options
//! are validated into a [`SolveConfig`]; [`lab::solve::solve`] does the work.

use crate::common::{CoreArgs, PortfolioArgs, positive};
use anyhow::{Context, bail};
use clap::Args;
use lab::picture::{ColorBy, Plane};
use lab::solve::{Png, SolveConfig};
use planner_core::retraction::ThinningParams;
use std::path::PathBuf;

/// Options of `planner solve`.
#[derive(Debug, Args, Clone)]
pub struct SolveArgs {
    /// Scene, seed and tree parameters.
    #[command(flatten)]
    pub core: CoreArgs,
    /// Give up after this many seconds (wall clock).
    #[arg(long, default_value_t = 60.0)]
    pub time_limit: f64,
    /// Also give up after this many iterations (portfolio turns, thinning steps).
    #[arg(long, value_name = "N")]
    pub max_iterations: Option<u64>,
    /// Memory bound.
    #[command(flatten)]
    pub memory: crate::common::MemoryArgs,
    /// Grow local trees at bridge samples the two main trees cannot reach (with
    /// `--machine-sampler bridge-test`: the narrow-passage samples seed trees of their own).
    #[arg(long)]
    pub local_trees: bool,
    /// Plan by small-step retraction (Saha & Latombe 2005) for passages too narrow to
    /// sample: first with the object shrunk to this scale (each part about its centre),
    /// then carry the path to the real object in steps of --thinning-step. Off by default;
    /// `--scene bug-trap --thinning 0.45` solves the bug trap. In (0, 1).
    #[arg(long, value_name = "SCALE")]
    pub thinning: Option<f64>,
    /// The narrow-passage methods taking turns (off by default here).
    #[command(flatten)]
    pub portfolio: PortfolioArgs,
    /// Scale step between the stages of --thinning, in (0, 1).
    #[arg(long, default_value_t = 0.05)]
    pub thinning_step: f64,
    /// Write the result as JSON here: solved, time_s, iterations, nodes,
    /// collision_checks, clearance_queries, path_length (weighted m), path_waypoints.
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

impl SolveArgs {
    /// Validates the arguments into a [`SolveConfig`] (loads the scene).
    pub fn to_config(&self) -> anyhow::Result<SolveConfig> {
        let (scene, mut params) = self.core.load()?;
        params.local_trees = self.local_trees;
        let time_limit_s = positive("time-limit", self.time_limit)?;
        let color_by = ColorBy::parse(&self.png_color)
            .with_context(|| format!("--png-color: unknown `{}`", self.png_color))?;
        let plane = Plane::parse(&self.png_plane)
            .with_context(|| format!("--png-plane: unknown `{}`", self.png_plane))?;
        let thinning = match self.thinning {
            Some(first) => {
                if self.png.is_some() {
                    bail!("--png draws one roadmap; --thinning grows one per stage and join");
                }
                Some(
                    ThinningParams::from_first(first, self.thinning_step)
                        .context("--thinning / --thinning-step")?,
                )
            }
            None => None,
        };
        // Offline there is no operator: the thinned plan's authority has nothing to share.
        let portfolio = self
            .portfolio
            .params("off", planner_core::AdaptiveAuthority::default())?;
        if portfolio.is_some() && (thinning.is_some() || self.png.is_some()) {
            bail!(
                "--portfolio plans with its own thinning and roadmaps: not with --thinning or --png"
            );
        }
        Ok(SolveConfig {
            portfolio,
            scene,
            params,
            seed: self.core.seed,
            time_limit_s,
            path_csv: self.path_csv.clone(),
            path_json: self.path_json.clone(),
            png: self.png.clone().map(|file| Png {
                file,
                color_by,
                plane,
            }),
            thinning,
            max_iterations: self.max_iterations,
            memory: Some(self.memory.bound()?),
        })
    }
}

/// Exit code of `planner solve` when there is certainly no way from the start to the goal.
pub const NO_WAY_EXIT: i32 = 3;

/// Runs the command; the exit code is 0 when solved, 1 when not within the time limit,
/// [`NO_WAY_EXIT`] when proved unsolvable before the first iteration.
pub fn run(args: &SolveArgs) -> anyhow::Result<i32> {
    let oom = crate::raise_oom_score_adj();
    let report = lab::solve::solve(&args.to_config()?)?;
    if let Some(why) = &report.no_way {
        println!("{}: {why}", report.scene);
        if let Some(p) = &args.json {
            crate::write_json(p, &crate::with_oom(&report, &oom))?;
        }
        return Ok(NO_WAY_EXIT);
    }
    println!(
        "{}: solved {} in {:.3} s, {} iterations, {} nodes, {} collision checks, {} clearance queries",
        report.scene,
        report.solved,
        report.time_s,
        report.iterations,
        report.nodes,
        report.collision_checks,
        report.clearance_queries
    );
    if let Some(t) = &report.thinning {
        println!(
            "small-step retraction: {} configurations retracted, {} joins, {} repairs retried, thinned plans restarted {} times after a failed repair and {} times out of iterations",
            t.retracted, t.joins, t.retries, t.restarts, t.replans
        );
    }
    if let Some(p) = &report.portfolio {
        for m in &p.methods {
            println!("portfolio {m}");
        }
        if let Some(by) = &p.solved_by {
            println!("portfolio: solved on a {by} turn");
        }
    }
    if let Some(m) = &report.memory {
        println!("{}", crate::common::memory_line(m));
    }
    if let Some(p) = &args.json {
        crate::write_json(p, &crate::with_oom(&report, &oom))?;
    }
    Ok(if report.solved { 0 } else { 1 })
}
