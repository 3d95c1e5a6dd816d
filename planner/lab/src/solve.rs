//! `planner solve`: automatic planning (no operator) against a wall-clock limit, the files
//! asked for (the solution path as CSV / JSON, a picture of the roadmap), and a report.

use crate::LabError;
use crate::picture::{self, ColorBy, Plane};
use planner_core::memory::{MemoryBound, MemoryGuard, MemoryReport, Shed};
use planner_core::no_way::{self, NoWay};
use planner_core::portfolio::{Portfolio, PortfolioParams, PortfolioReport};
use planner_core::retraction::{ThinnedPlanner, ThinningParams};
use planner_core::{Planner, PlannerParams, Scene};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// A picture of the final roadmap (see [`crate::picture`]).
#[derive(Clone, Debug)]
pub struct Png {
    /// The PNG file (overwritten).
    pub file: PathBuf,
    /// Which label colours the nodes.
    pub color_by: ColorBy,
    /// The projection plane.
    pub plane: Plane,
}

/// What to solve and what to write, validated.
#[derive(Clone, Debug)]
pub struct SolveConfig {
    /// The scene.
    pub scene: Scene,
    /// Tree parameters (checked again by [`Planner::new`]).
    pub params: PlannerParams,
    /// RNG seed.
    pub seed: u64,
    /// Give up after this long, s (wall clock, > 0).
    pub time_limit_s: f64,
    /// Write the solution path here as CSV, if solved.
    pub path_csv: Option<PathBuf>,
    /// Write the solution path here as JSON waypoints, if solved.
    pub path_json: Option<PathBuf>,
    /// Draw the roadmap, solved or not.
    pub png: Option<Png>,
    /// Plan by small-step retraction ([`planner_core::retraction`]) instead of one
    /// RRT-Connect on the real object.
    pub thinning: Option<ThinningParams>,
    /// Plan with the narrow-passage methods taking turns ([`planner_core::portfolio`])
    /// instead (its thinning stages are its own; `thinning` is then ignored).
    pub portfolio: Option<PortfolioParams>,
    /// Also stop after this many iterations (portfolio turns, thinning steps): work
    /// counted rather than timed.
    pub max_iterations: Option<u64>,
    /// Keep the process's heap under this bound, shedding what is worth least
    /// ([`planner_core::memory`]).
    pub memory: Option<MemoryBound>,
}

/// Result of a solve; `planner solve --json` writes it.
#[derive(Debug, Clone, Serialize)]
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
    /// Clearance (distance) queries of certified edges (0 with discrete edges).
    pub clearance_queries: u64,
    /// Weighted length of the solution path (I-RRT eq. 2), if solved.
    pub path_length: Option<f64>,
    /// Waypoints of the solution path, if solved.
    pub path_waypoints: Option<usize>,
    /// Small-step retraction only: configurations retracted, joins planned, repairs
    /// tried again and thinned plans started over (after a failed repair, or out of
    /// iterations).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub thinning: Option<ThinningCounts>,
    /// Portfolio only: what each method did, and which one solved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub portfolio: Option<PortfolioReport>,
    /// Under a memory bound: the heap's baseline, peak and end, and what was shed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<MemoryReport>,
    /// Proved before the first iteration: there is no way from the start to the goal
    /// ([`planner_core::no_way`]); nothing was planned.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_way: Option<String>,
}

/// Runs `step` until `done`, the time limit or the iteration limit, keeping the heap under
/// the bound by `shed`. Returns the seconds spent and the guard's report.
fn run_bounded<P>(
    config: &SolveConfig,
    planner: &mut P,
    done: impl Fn(&P) -> bool,
    mut step: impl FnMut(&mut P) -> Result<(), LabError>,
    shed: impl Fn(&mut P, f64) -> Shed,
) -> Result<(f64, Option<MemoryReport>), LabError> {
    let mut guard = config.memory.map(MemoryGuard::new).transpose()?;
    let limit = config.max_iterations.unwrap_or(u64::MAX);
    let started = Instant::now();
    let mut steps = 0u64;
    while !done(planner) && steps < limit && started.elapsed().as_secs_f64() < config.time_limit_s {
        if let Some(g) = &mut guard
            && !g.keep(|f| shed(planner, f))
        {
            tracing::warn!(
                "the heap is at the memory bound and nothing more can be shed: planning stops"
            );
            break;
        }
        step(planner)?;
        steps += 1;
    }
    let time_s = started.elapsed().as_secs_f64();
    Ok((time_s, guard.map(|g| g.report())))
}

/// The portfolio until solved or out of time; writes the path files.
fn solve_portfolio(
    config: &SolveConfig,
    params: &PortfolioParams,
) -> Result<SolveReport, LabError> {
    let mut p = Portfolio::new(
        &config.scene,
        config.params.clone(),
        params.clone(),
        config.seed,
    )?;
    let (time_s, memory) = run_bounded(
        config,
        &mut p,
        Portfolio::solved,
        |p| {
            p.turn(None);
            Ok(())
        },
        Portfolio::shed,
    )?;
    let s = p.main().stats();
    let t = p.thinning().map(|t| t.stats()).unwrap_or_default();
    let work = Work {
        iterations: s.iterations + t.iterations,
        nodes: s.nodes as u64 + t.nodes,
        collision_checks: s.collision_checks + t.collision_checks,
        clearance_queries: s.clearance_queries + t.clearance_queries,
    };
    let mut report = finish(
        config,
        time_s,
        p.main().space(),
        p.main().solution(),
        work,
        None,
    )?;
    report.portfolio = Some(p.report());
    report.memory = memory;
    Ok(report)
}

/// What small-step retraction did ([`planner_core::retraction::ThinningStats`]).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ThinningCounts {
    /// Configurations retracted to free space.
    pub retracted: u64,
    /// Joins planned by RRT-Connect.
    pub joins: u64,
    /// Repairs tried again from the same path.
    pub retries: u64,
    /// New thinned plans after a repair failed every try.
    pub restarts: u64,
    /// New thinned plans after one ran out of iterations.
    pub replans: u64,
}

/// Small-step retraction until solved or out of time; writes the path files. A picture
/// of the roadmap is not drawn (there is one roadmap per stage and join).
fn solve_thinned(config: &SolveConfig, thinning: &ThinningParams) -> Result<SolveReport, LabError> {
    let mut planner = ThinnedPlanner::new(
        &config.scene,
        config.params.clone(),
        thinning.clone(),
        config.seed,
    )?;
    let (time_s, memory) = run_bounded(
        config,
        &mut planner,
        ThinnedPlanner::solved,
        |p| Ok(p.step()?),
        ThinnedPlanner::shed,
    )?;
    let space = planner_core::Space::for_scene(&config.scene, config.params.weights);
    let s = planner.stats();
    let work = Work {
        iterations: s.iterations,
        nodes: s.nodes,
        collision_checks: s.collision_checks,
        clearance_queries: s.clearance_queries,
    };
    let thinning = ThinningCounts {
        retracted: s.retracted,
        joins: s.joins,
        retries: s.retries,
        restarts: s.restarts,
        replans: s.replans,
    };
    let mut report = finish(
        config,
        time_s,
        &space,
        planner.solution(),
        work,
        Some(thinning),
    )?;
    report.memory = memory;
    Ok(report)
}

/// What a solve counted.
struct Work {
    iterations: u64,
    nodes: u64,
    collision_checks: u64,
    clearance_queries: u64,
}

/// Writes the path files asked for and makes the report.
fn finish(
    config: &SolveConfig,
    time_s: f64,
    space: &dyn planner_core::ConfigSpace,
    solution: Option<&[planner_core::Se3]>,
    work: Work,
    thinning: Option<ThinningCounts>,
) -> Result<SolveReport, LabError> {
    if let Some(p) = solution {
        write_paths(config, space, p)?;
    }
    Ok(SolveReport {
        scene: config.scene.name.clone(),
        seed: config.seed,
        solved: solution.is_some(),
        time_s,
        iterations: work.iterations,
        nodes: work.nodes,
        collision_checks: work.collision_checks,
        clearance_queries: work.clearance_queries,
        path_length: solution.map(|p| planner_core::space::path_length(space, p)),
        path_waypoints: solution.map(<[_]>::len),
        thinning,
        portfolio: None,
        memory: None,
        no_way: None,
    })
}

/// Writes the solution path files asked for.
fn write_paths(
    config: &SolveConfig,
    space: &dyn planner_core::ConfigSpace,
    path: &[planner_core::Se3],
) -> Result<(), LabError> {
    let write = |file: &Option<PathBuf>, text: String| -> Result<(), LabError> {
        match file {
            Some(f) => std::fs::write(f, text).map_err(LabError::write(f)),
            None => Ok(()),
        }
    };
    write(&config.path_csv, planner_core::path::to_csv(space, path))?;
    write(&config.path_json, planner_core::path::to_json(space, path))
}

/// Iterates until solved or out of time, then writes the files asked for.
pub fn solve(config: &SolveConfig) -> Result<SolveReport, LabError> {
    let started = Instant::now();
    if let NoWay::Certain(proof) = no_way::prove(&config.scene, &|| false) {
        return Ok(SolveReport {
            scene: config.scene.name.clone(),
            seed: config.seed,
            solved: false,
            time_s: started.elapsed().as_secs_f64(),
            iterations: 0,
            nodes: 0,
            collision_checks: 0,
            clearance_queries: 0,
            path_length: None,
            path_waypoints: None,
            thinning: None,
            portfolio: None,
            memory: None,
            no_way: Some(proof.to_string()),
        });
    }
    if let Some(p) = &config.portfolio {
        return solve_portfolio(config, p);
    }
    if let Some(t) = &config.thinning {
        return solve_thinned(config, t);
    }
    let mut planner = Planner::new(&config.scene, config.params.clone(), config.seed)?;
    let (time_s, memory) = run_bounded(
        config,
        &mut planner,
        Planner::solved,
        |p| {
            p.iterate(None);
            Ok(())
        },
        Planner::shed,
    )?;
    let s = planner.stats();
    let work = Work {
        iterations: s.iterations,
        nodes: s.nodes as u64,
        collision_checks: s.collision_checks,
        clearance_queries: s.clearance_queries,
    };
    let mut report = finish(
        config,
        time_s,
        planner.space(),
        planner.solution(),
        work,
        None,
    )?;
    report.memory = memory;
    if let Some(png) = &config.png {
        if !crate::register_font() {
            tracing::warn!("no TrueType font found (DejaVuSans.ttf): the PNG has no text");
        }
        let label = format!("{} seed {}", config.scene.name, config.seed);
        picture::draw_planner_png(
            &config.scene,
            &planner,
            &label,
            png.color_by,
            png.plane,
            &png.file,
            (1000, 1000),
        )?;
    }
    Ok(report)
}
