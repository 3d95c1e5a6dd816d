//! Discrete against certified edge validation ([`planner_core::EdgeCheck`]) for the `edges`
//! harness: time to solve, the checks each spends, and whether the solved paths collide
//! anywhere when re-checked densely by a checker of their own.

use planner_core::{CollisionChecker, EdgeCheck, Planner, PlannerParams, Scene, Weights};
use serde::Serialize;
use std::fmt::Write as _;
use std::time::Instant;

/// One automatic RRT-Connect run.
#[derive(Debug, Clone, Serialize)]
pub struct EdgeRun {
    /// Scene name.
    pub scene: String,
    /// `discrete` or `certified`.
    pub edges: &'static str,
    /// RNG seed.
    pub seed: u64,
    /// Solved within the time limit.
    pub solved: bool,
    /// Wall-clock time to the solution or the limit, s.
    pub time_s: f64,
    /// Planner iterations.
    pub iterations: u64,
    /// `is_free` checks.
    pub collision_checks: u64,
    /// Clearance (distance) queries of the certification.
    pub clearance_queries: u64,
    /// Edges of the (shortcut) solution path.
    pub path_edges: usize,
    /// Of those, edges with a colliding configuration on the dense re-check.
    pub colliding_edges: usize,
}

/// Solves `scene` with `check` edges and `seed` until solved or `time_limit_s` (wall
/// clock); re-checks the solution path every `recheck_spacing` (weighted m).
pub fn run(
    scene: &Scene,
    check: EdgeCheck,
    seed: u64,
    time_limit_s: f64,
    recheck_spacing: f64,
) -> Result<EdgeRun, planner_core::PlannerError> {
    let params = PlannerParams {
        edge_check: check,
        ..PlannerParams::default()
    };
    let mut p = Planner::new(scene, params, seed)?;
    let started = Instant::now();
    while !p.solved() && started.elapsed().as_secs_f64() < time_limit_s {
        p.iterate(None);
    }
    let time_s = started.elapsed().as_secs_f64();
    let s = p.stats();
    let (path_edges, colliding_edges) = match p.solution() {
        Some(path) => {
            let dense = CollisionChecker::with_params(scene, Weights::default(), recheck_spacing)
                .with_edge_check(EdgeCheck::Discrete);
            let bad = path
                .windows(2)
                .filter(|w| !dense.edge_free(&w[0], &w[1]))
                .count();
            (path.len() - 1, bad)
        }
        None => (0, 0),
    };
    Ok(EdgeRun {
        scene: scene.name.clone(),
        edges: check.name(),
        seed,
        solved: p.solved(),
        time_s,
        iterations: s.iterations,
        collision_checks: s.collision_checks,
        clearance_queries: s.clearance_queries,
        path_edges,
        colliding_edges,
    })
}

/// The median of `v`, `None` when empty (the experiments' median, which gives NaN).
fn median(mut v: Vec<f64>) -> Option<f64> {
    let m = lab::experiment::report::median(&mut v);
    (!m.is_nan()).then_some(m)
}

/// A Markdown table, one row per scene and edge check in the order first seen: solved
/// runs, medians over the solved runs (time, checks, clearance queries, µs per
/// iteration) and solved paths with a colliding configuration.
pub fn summary_markdown(runs: &[EdgeRun]) -> String {
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for r in runs {
        if !keys.contains(&(r.scene.as_str(), r.edges)) {
            keys.push((&r.scene, r.edges));
        }
    }
    let mut out = String::from(
        "| scene | edges | solved | median time (s) | median checks | median clearance queries | µs / iteration | paths colliding on re-check |\n|---|---|---|---|---|---|---|---|\n",
    );
    for (scene, edges) in keys {
        let these: Vec<&EdgeRun> = runs
            .iter()
            .filter(|r| r.scene == scene && r.edges == edges)
            .collect();
        let solved: Vec<&&EdgeRun> = these.iter().filter(|r| r.solved).collect();
        let med = |f: &dyn Fn(&EdgeRun) -> f64| median(solved.iter().map(|r| f(r)).collect());
        let show = |v: Option<f64>, digits: usize| {
            v.map_or_else(|| "–".to_string(), |v| format!("{v:.digits$}"))
        };
        let per_iter = median(
            these
                .iter()
                .map(|r| r.time_s * 1e6 / r.iterations.max(1) as f64)
                .collect(),
        );
        let colliding = solved.iter().filter(|r| r.colliding_edges > 0).count();
        let _ = writeln!(
            out,
            "| {scene} | {edges} | {}/{} | {} | {} | {} | {} | {colliding}/{} |",
            solved.len(),
            these.len(),
            show(med(&|r| r.time_s), 2),
            show(med(&|r| r.collision_checks as f64), 0),
            show(med(&|r| r.clearance_queries as f64), 0),
            show(per_iter, 1),
            solved.len(),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn certified_runs_spend_clearance_queries_and_the_table_counts_them() {
        let scene = Scene::wall_with_square_hole(0.3);
        let runs: Vec<EdgeRun> = [EdgeCheck::Discrete, EdgeCheck::Certified]
            .into_iter()
            .map(|c| run(&scene, c, 1, 30.0, 1e-3).expect("run"))
            .collect();
        assert!(runs.iter().all(|r| r.solved && r.colliding_edges == 0));
        assert_eq!(runs[0].clearance_queries, 0);
        assert!(runs[1].clearance_queries > 0);
        let table = summary_markdown(&runs);
        assert_eq!(table.lines().count(), 4, "{table}");
        assert!(
            table.contains("| wall-hole-300 | certified | 1/1 |"),
            "{table}"
        );
        assert_eq!(median(vec![3.0, 1.0, 2.0, 10.0]), Some(2.5));
        assert_eq!(median(Vec::new()), None);
    }
}
