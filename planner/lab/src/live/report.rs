//! Reports of a live sweep: runs as CSV, a summary per (scene, method) as markdown, and a
//! plot of every run's time to solve. Medians count an unsolved run at the time limit
//! (a lower bound then), as the lockstep reports do; a scene run without its route is
//! its own scene in the summaries (`tunnels (no route)`). The summary's ratios carry a
//! 95 % interval over the seeds resampled ([`seed_interval`]), so that a ratio of medians
//! over a handful of heavy-tailed times is not read as more than it is.

use super::LiveRun;
use crate::LabError;
use crate::experiment::report::{median, register_font};
use plotters::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Write as _;
use std::path::Path;

/// One (scene, method) of a live sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveSummary {
    /// Scene, with ` (no route)` when its route was removed.
    pub scene: String,
    /// Method.
    pub method: String,
    /// A planner ran (false: the operator alone).
    pub planner: bool,
    /// Runs.
    pub runs: usize,
    /// Solved runs.
    pub solved: usize,
    /// Median time to solve, s (unsolved at the limit).
    pub median_time_s: f64,
    /// Median nodes and tree edges.
    pub median_nodes: f64,
    /// Median edges.
    pub median_edges: f64,
    /// Runs in which the object reached the goal.
    pub reached: usize,
    /// Median time until the object reached the goal, s (not reached: the limit).
    pub median_goal_s: f64,
    /// Median time from the solution to the object at the goal, s, over runs with both:
    /// how long the operator still needed once a path existed.
    pub median_goal_after_solve_s: f64,
    /// Median share of the session in contact.
    pub median_contact_share: f64,
    /// Deepest penetration over the runs, mm, and in voxels.
    pub max_penetration_mm: f64,
    /// The same in voxels.
    pub max_penetration_voxels: f64,
    /// Largest force step between ticks over the runs, N.
    pub max_force_step_n: f64,
    /// Deadline misses over all ticks of the runs.
    pub miss_share: f64,
    /// Median times the operator was blocked per run.
    pub median_blocks: f64,
    /// Median and largest of the runs' compute-time p99.9, µs.
    pub median_compute_p999_us: f64,
    /// The largest.
    pub max_compute_p999_us: f64,
    /// Each run's seed, time to solve and time to the goal, s (unsolved and unreached at
    /// the limit): what the intervals of [`to_markdown`] resample.
    pub per_run: Vec<RunTimes>,
}

/// One run's times as the summaries count them, s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunTimes {
    /// The run's seed.
    pub seed: u64,
    /// Time to solve (unsolved: the limit).
    pub solve_s: f64,
    /// Time until the object reached the goal (not reached: the limit).
    pub goal_s: f64,
}

/// The scene of `r` as summaries name it.
fn scene_label(r: &LiveRun) -> String {
    if r.route {
        r.scene.clone()
    } else {
        format!("{} (no route)", r.scene)
    }
}

/// Groups `runs` by (scene, method) in the order they first appear; `limit_s` stands in
/// for unsolved and unreached times.
pub fn summarize(runs: &[LiveRun], limit_s: f64) -> Vec<LiveSummary> {
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in runs {
        let k = (scene_label(r), r.method.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(scene, method)| {
            let g: Vec<&LiveRun> = runs
                .iter()
                .filter(|r| scene_label(r) == scene && r.method == method)
                .collect();
            let or_limit = |v: f64| if v.is_finite() { v } else { limit_s };
            let per_run: Vec<RunTimes> = g
                .iter()
                .map(|r| RunTimes {
                    seed: r.seed,
                    solve_s: if r.solved {
                        or_limit(r.time_to_solve_s)
                    } else {
                        limit_s
                    },
                    goal_s: or_limit(r.time_to_goal_s),
                })
                .collect();
            let mut t: Vec<f64> = per_run.iter().map(|r| r.solve_s).collect();
            let mut nodes: Vec<f64> = g.iter().map(|r| r.nodes as f64).collect();
            let mut edges: Vec<f64> = g.iter().map(|r| r.edges as f64).collect();
            let mut goal: Vec<f64> = per_run.iter().map(|r| r.goal_s).collect();
            let mut after: Vec<f64> = g
                .iter()
                .filter(|r| r.solved && r.time_to_goal_s.is_finite())
                .map(|r| (r.time_to_goal_s - r.time_to_solve_s).max(0.0))
                .collect();
            let mut contact: Vec<f64> = g.iter().map(|r| r.contact_s / r.run_s.max(1e-9)).collect();
            let pen = g.iter().map(|r| r.max_penetration_mm).fold(0.0, f64::max);
            let voxels = g
                .iter()
                .filter(|r| r.voxel_mm > 0.0)
                .map(|r| r.max_penetration_mm / r.voxel_mm)
                .fold(0.0, f64::max);
            let ticks: u64 = g.iter().map(|r| r.ticks).sum();
            let misses: u64 = g.iter().map(|r| r.deadline_misses).sum();
            let mut blocks: Vec<f64> = g.iter().map(|r| f64::from(r.blocks)).collect();
            let mut compute: Vec<f64> = g.iter().map(|r| r.compute_p999_us).collect();
            LiveSummary {
                planner: g.iter().any(|r| r.planner),
                median_blocks: median(&mut blocks),
                median_compute_p999_us: median(&mut compute),
                max_compute_p999_us: compute.iter().copied().fold(0.0, f64::max),
                runs: g.len(),
                solved: g.iter().filter(|r| r.solved).count(),
                median_time_s: median(&mut t),
                median_nodes: median(&mut nodes),
                median_edges: median(&mut edges),
                reached: g.iter().filter(|r| r.time_to_goal_s.is_finite()).count(),
                median_goal_s: median(&mut goal),
                median_goal_after_solve_s: median(&mut after),
                median_contact_share: median(&mut contact),
                max_penetration_mm: pen,
                max_penetration_voxels: voxels,
                max_force_step_n: g.iter().map(|r| r.max_force_step_n).fold(0.0, f64::max),
                miss_share: misses as f64 / ticks.max(1) as f64,
                per_run,
                scene,
                method,
            }
        })
        .collect()
}

/// Draws behind each interval of [`to_markdown`].
const RESAMPLES: usize = 4000;

/// Fewest seeds for which [`to_markdown`] gives an interval: below that the resamples
/// are too few distinct sets to mean anything.
pub const MIN_SEEDS_FOR_INTERVAL: usize = 5;

/// The 95 % interval (2.5th and 97.5th percentiles) of a ratio of medians over the seeds
/// resampled with replacement: a percentile bootstrap of [`RESAMPLES`] draws from a fixed
/// stream, so that a report is reproducible. Each draw takes as many seeds as the groups
/// hold (with repeats), every group's median of `value` over its runs on those seeds, and
/// `ratio` of those medians (in the order of `groups`). Seeds are drawn rather than each
/// group's runs apart because on one seed every method meets the same simulated operator:
/// a seed's runs stay together, as in the sweep. `None` under
/// [`MIN_SEEDS_FOR_INTERVAL`] seeds, or when most draws leave a group without runs.
pub fn seed_interval(
    groups: &[&LiveSummary],
    value: fn(&RunTimes) -> f64,
    ratio: impl Fn(&[f64]) -> f64,
) -> Option<(f64, f64)> {
    let mut seeds: Vec<u64> = groups
        .iter()
        .flat_map(|g| g.per_run.iter().map(|r| r.seed))
        .collect();
    seeds.sort_unstable();
    seeds.dedup();
    if seeds.len() < MIN_SEEDS_FOR_INTERVAL {
        return None;
    }
    // by_seed[g][k]: group g's values on the k-th seed.
    let by_seed: Vec<Vec<Vec<f64>>> = groups
        .iter()
        .map(|g| {
            seeds
                .iter()
                .map(|s| {
                    g.per_run
                        .iter()
                        .filter(|r| r.seed == *s)
                        .map(value)
                        .collect()
                })
                .collect()
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut drawn = vec![0; seeds.len()];
    let mut pool = Vec::new();
    let mut medians = vec![0.0; groups.len()];
    let mut ratios = Vec::with_capacity(RESAMPLES);
    for _ in 0..RESAMPLES {
        for d in &mut drawn {
            *d = rng.random_range(0..seeds.len());
        }
        for (g, m) in by_seed.iter().zip(&mut medians) {
            pool.clear();
            for &k in &drawn {
                pool.extend_from_slice(&g[k]);
            }
            *m = median(&mut pool);
        }
        // A group without runs on the seeds drawn has no median: no ratio either (f64::min
        // would quietly drop it).
        if medians.iter().all(|m| m.is_finite()) {
            let r = ratio(&medians);
            if r.is_finite() {
                ratios.push(r);
            }
        }
    }
    if ratios.len() < RESAMPLES / 2 {
        return None;
    }
    ratios.sort_by(f64::total_cmp);
    let at = |p: f64| ratios[(p * (ratios.len() - 1) as f64).round() as usize];
    Some((at(0.025), at(0.975)))
}

/// `text` with ` (lo–hi)` appended when there is an interval.
fn with_interval(text: String, interval: Option<(f64, f64)>, decimals: usize) -> String {
    match interval {
        Some((lo, hi)) => format!("{text} ({lo:.decimals$}–{hi:.decimals$})"),
        None => text,
    }
}

fn num(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        String::new()
    }
}

/// The columns of runs.csv, in order. `contact_share` is derived (contact_s / run_s): it is
/// written for readers of the file and not read back ([`from_csv`]).
const COLUMNS: [&str; 26] = [
    "scene",
    "route",
    "method",
    "planner",
    "alpha",
    "input",
    "guidance",
    "operator",
    "seed",
    "solved",
    "time_to_solve_s",
    "nodes",
    "edges",
    "time_to_goal_s",
    "contact_s",
    "contact_share",
    "max_penetration_mm",
    "voxel_mm",
    "max_force_step_n",
    "ticks",
    "deadline_misses",
    "compute_p999_us",
    "run_s",
    "blocks",
    "corrections",
    "retries",
];

/// The runs as CSV (header first); missing values are empty fields.
pub fn to_csv(runs: &[LiveRun]) -> String {
    let mut out = COLUMNS.join(",") + "\n";
    for r in runs {
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.scene,
            r.route,
            r.method,
            r.planner,
            num(r.alpha, 3),
            match r.input {
                super::Input::Arm => "arm",
                super::Input::Mouse => "mouse",
            },
            r.guidance,
            r.operator,
            r.seed,
            r.solved,
            num(r.time_to_solve_s, 3),
            r.nodes,
            r.edges,
            num(r.time_to_goal_s, 3),
            num(r.contact_s, 3),
            num(r.contact_s / r.run_s, 4),
            num(r.max_penetration_mm, 4),
            num(r.voxel_mm, 3),
            num(r.max_force_step_n, 4),
            r.ticks,
            r.deadline_misses,
            num(r.compute_p999_us, 1),
            num(r.run_s, 2),
            r.blocks,
            r.corrections,
            r.retries,
        );
    }
    out
}

/// Runs read back from a runs.csv written by [`to_csv`] (`origin` names it in errors), so
/// that sweeps run in parts (other seeds, another day) can be reported together. Columns
/// are found by their header names; an empty number is missing (NaN). Numbers come back
/// as the CSV rounded them (e.g. run times to 10 ms), so a report of read-back runs can
/// differ from the sweep's own in the last digit (a contact share in the fourth decimal).
pub fn from_csv(text: &str, origin: &str) -> Result<Vec<LiveRun>, LabError> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or_default().split(',').collect();
    let bad = |line: usize, reason: String| LabError::RunsCsv {
        origin: origin.to_owned(),
        line,
        reason,
    };
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .ok_or_else(|| bad(1, format!("no column `{name}`")))
    };
    // Every column but the derived one, in the order the fields are read below.
    let names: Vec<&str> = COLUMNS
        .into_iter()
        .filter(|c| *c != "contact_share")
        .collect();
    let at: Vec<usize> = names.iter().map(|n| col(n)).collect::<Result<_, _>>()?;
    let mut runs = Vec::new();
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let n = i + 2;
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != header.len() {
            return Err(bad(
                n,
                format!("{} fields, the header has {}", f.len(), header.len()),
            ));
        }
        let field = |k: usize| f[at[k]];
        let float = |k: usize| -> Result<f64, LabError> {
            let v = field(k);
            if v.is_empty() {
                return Ok(f64::NAN);
            }
            v.parse::<f64>()
                .map_err(|e| bad(n, format!("{} `{v}`: {e}", names[k])))
        };
        let int = |k: usize| -> Result<u64, LabError> {
            field(k)
                .parse::<u64>()
                .map_err(|e| bad(n, format!("{} `{}`: {e}", names[k], field(k))))
        };
        let small = |k: usize| -> Result<u32, LabError> {
            u32::try_from(int(k)?).map_err(|e| bad(n, format!("{}: {e}", names[k])))
        };
        let flag = |k: usize| -> Result<bool, LabError> {
            match field(k) {
                "true" => Ok(true),
                "false" => Ok(false),
                v => Err(bad(
                    n,
                    format!("{} `{v}`: expected true or false", names[k]),
                )),
            }
        };
        runs.push(LiveRun {
            scene: field(0).to_owned(),
            route: flag(1)?,
            method: field(2).to_owned(),
            planner: flag(3)?,
            alpha: float(4)?,
            input: match field(5) {
                "arm" => super::Input::Arm,
                "mouse" => super::Input::Mouse,
                v => return Err(bad(n, format!("input `{v}`: expected arm or mouse"))),
            },
            guidance: flag(6)?,
            operator: field(7).to_owned(),
            seed: int(8)?,
            solved: flag(9)?,
            time_to_solve_s: float(10)?,
            nodes: int(11)?,
            edges: int(12)?,
            time_to_goal_s: float(13)?,
            contact_s: float(14)?,
            max_penetration_mm: float(15)?,
            voxel_mm: float(16)?,
            max_force_step_n: float(17)?,
            ticks: int(18)?,
            deadline_misses: int(19)?,
            compute_p999_us: float(20)?,
            run_s: float(21)?,
            blocks: small(22)?,
            corrections: small(23)?,
            retries: small(24)?,
        });
    }
    Ok(runs)
}

/// The summaries as a markdown table, with each scene's speed-up of every method over
/// automatic RRT-Connect (ratio of medians of the time to solve) when that was run, and
/// each method's median time to the goal over the better of `operator-alone` and
/// `rrt-connect` (the two alone) when both were run; from [`MIN_SEEDS_FOR_INTERVAL`] seeds
/// on, each ratio with its 95 % interval ([`seed_interval`]; in each draw the better alone
/// is the one with the shorter median of that draw).
pub fn to_markdown(summaries: &[LiveSummary], limit_s: f64) -> String {
    let mut out = format!(
        "Medians over seeds; unsolved runs count at the {limit_s} s limit, an object that \
         never reached the goal at the limit too. Speed-up: automatic RRT-Connect's median \
         time to solve over the method's, same scene. Goal vs alone: the method's median \
         time to the goal over the shorter of operator-alone's and rrt-connect's. In \
         brackets, from {MIN_SEEDS_FOR_INTERVAL} seeds on: the ratio's 95 % interval over the \
         seeds resampled with replacement ({RESAMPLES} draws; a seed's runs stay together); \
         an interval that holds 1 does not tell the two apart.\n\n\
         | scene | method | solved | median time to solve (s) | speed-up | nodes | edges | \
         object at goal (s) | goal vs alone | goal after solution (s) | in contact | blocks | \
         peak penetration (mm / voxels) | largest force step (N) | deadline misses | \
         compute p99.9 (µs, median / max) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for s in summaries {
        let median_of = |method: &str| {
            summaries
                .iter()
                .find(|a| a.scene == s.scene && a.method == method)
        };
        let speedup = match median_of("rrt-connect") {
            Some(a) if s.planner => {
                let ratio = |m: &[f64]| m[0] / m[1].max(1e-9);
                let text = format!("{:.1}×", ratio(&[a.median_time_s, s.median_time_s]));
                // RRT-Connect against itself is 1 in every draw.
                let interval = (a.method != s.method)
                    .then(|| seed_interval(&[a, s], |r| r.solve_s, ratio))
                    .flatten();
                with_interval(text, interval, 1)
            }
            _ => String::new(),
        };
        let vs_alone = match (median_of("operator-alone"), median_of("rrt-connect")) {
            (Some(o), Some(r)) => {
                let ratio = |m: &[f64]| m[0] / m[1].min(m[2]).max(1e-9);
                let text = format!(
                    "{:.2}",
                    ratio(&[s.median_goal_s, o.median_goal_s, r.median_goal_s])
                );
                with_interval(text, seed_interval(&[s, o, r], |r| r.goal_s, ratio), 2)
            }
            _ => String::new(),
        };
        let (solved, time) = if s.planner {
            (
                format!("{}/{}", s.solved, s.runs),
                format!("{:.2}", s.median_time_s),
            )
        } else {
            (format!("no planner ({})", s.runs), String::new())
        };
        let _ = writeln!(
            out,
            "| {} | {} | {solved} | {time} | {speedup} | {:.0} | {:.0} | {:.2} ({}/{}) | {vs_alone} | {} | {:.0} % | {:.0} | {:.2} / {:.2} | {:.3} | {:.3} % | {:.0} / {:.0} |",
            s.scene,
            s.method,
            s.median_nodes,
            s.median_edges,
            s.median_goal_s,
            s.reached,
            s.runs,
            num(s.median_goal_after_solve_s, 2),
            100.0 * s.median_contact_share,
            s.median_blocks,
            s.max_penetration_mm,
            s.max_penetration_voxels,
            s.max_force_step_n,
            100.0 * s.miss_share,
            s.median_compute_p999_us,
            s.max_compute_p999_us,
        );
    }
    out
}

/// Every run's time to solve (log scale; unsolved at the limit, hollow) per method, one
/// panel per scene, with each method's median as a bar. The error names the file.
pub fn plot(runs: &[LiveRun], limit_s: f64, path: &Path) -> Result<(), LabError> {
    if !register_font() {
        return Err(LabError::NoFont);
    }
    draw(runs, limit_s, path).map_err(|source| LabError::Draw {
        path: path.to_path_buf(),
        source,
    })
}

type PlotResult = Result<(), Box<dyn std::error::Error + Send + Sync>>;

fn draw(runs: &[LiveRun], limit_s: f64, path: &Path) -> PlotResult {
    let summaries = summarize(runs, limit_s);
    let mut scenes: Vec<String> = Vec::new();
    let mut methods: Vec<String> = Vec::new();
    // The operator alone has no time to solve.
    let runs: Vec<LiveRun> = runs.iter().filter(|r| r.planner).cloned().collect();
    let runs = &runs[..];
    for r in runs {
        if !scenes.contains(&scene_label(r)) {
            scenes.push(scene_label(r));
        }
        if !methods.contains(&r.method) {
            methods.push(r.method.clone());
        }
    }
    let height = 420 * scenes.len().max(1) as u32;
    let root = BitMapBackend::new(path, (1400, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((scenes.len().max(1), 1));
    let shortest = runs
        .iter()
        .filter(|r| r.solved && r.time_to_solve_s > 0.0)
        .map(|r| r.time_to_solve_s)
        .fold(limit_s, f64::min);
    let y = (shortest * 0.5).max(1e-3)..limit_s * 1.5;
    let n = methods.len();
    for (scene, panel) in scenes.iter().zip(panels.iter()) {
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{scene}: time to solve in live sessions"),
                ("sans-serif", 22),
            )
            .margin(10)
            .x_label_area_size(50)
            .y_label_area_size(60)
            .build_cartesian_2d(-0.5..(n as f64 - 0.5), y.clone().log_scale())?;
        let names = methods.clone();
        chart
            .configure_mesh()
            .x_labels(n)
            .x_label_formatter(&move |v| {
                let i = v.round();
                if (v - i).abs() < 1e-6 && i >= 0.0 {
                    names.get(i as usize).cloned().unwrap_or_default()
                } else {
                    String::new()
                }
            })
            .y_desc("time to solve (s), log")
            .y_label_formatter(&|v| format!("{v:.2}"))
            .draw()?;
        for (i, m) in methods.iter().enumerate() {
            let x = i as f64;
            if let Some(s) = summaries
                .iter()
                .find(|s| &s.scene == scene && &s.method == m)
            {
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x - 0.3, s.median_time_s), (x + 0.3, s.median_time_s)],
                    BLACK.stroke_width(3),
                )))?;
            }
            let pts: Vec<(f64, f64, bool)> = runs
                .iter()
                .filter(|r| &scene_label(r) == scene && &r.method == m)
                .enumerate()
                .map(|(k, r)| {
                    let jitter = ((k % 7) as f64 - 3.0) * 0.04;
                    let t = if r.solved { r.time_to_solve_s } else { limit_s };
                    (x + jitter, t, r.solved)
                })
                .collect();
            let c = if m == "rrt-connect" { RED } else { BLUE };
            chart.draw_series(pts.iter().map(|&(px, py, solved)| {
                if solved {
                    Circle::new((px, py), 4, c.filled())
                } else {
                    Circle::new((px, py), 4, c.stroke_width(1))
                }
            }))?;
        }
    }
    root.present()?;
    Ok(())
}
