//! Compute time of the full haptic tick with contact rendering on, in lockstep (no RT
//! scheduling, so wake-up latency is not part of it): the simulated operator pushes the
//! wall-hole scene's S against the wall beside the hole and slides it along the wall, the
//! hardest steady case for the contact stage (`benches::harness::wall_setup`). Prints p50 / p90 / p99 / p99.9 / max of the
//! compute time per tick from an HDR histogram.
//!
//! With `--cube-points N` the object is instead a cube of about N pointshell points that the
//! operator presses face-down onto a plate with the arm's maximum force and slides back and
//! forth (`benches::harness::cube_setup`): a whole face in contact, the "≥ 10 000 points"
//! case of the tick budget.
//!
//! With `--scene NAME` the object is a built-in scene's (or a scene file's) moving object,
//! pressed with its largest flat face onto the largest box obstacle face it fits against
//! and slid along it (`benches::face_contact`): the scene's worst steady contact.
//!
//! With `--scene NAME --newcomer` the scene's route is removed and the arm is held by the
//! newcomer (the operator who does not know the way) as in `haptic-loop demo --operator
//! newcomer --no-planner` (`benches::pressing`): minutes of pressing on the first walls in
//! its way, sliding, wiggling and turning, what the live sessions' loop sees. Add
//! `--paced --planner "ARGS"` to run a planner process beside the ticks as a live session
//! does (`planner serve` on the scene without its route, the newcomer's seed and ARGS, e.g.
//! `--sampling hrrtc --alpha 0.5`): the ticks publish their state to it over iceoryx2 and
//! render its guidance through the loop's relay, so its trees grow from what the newcomer
//! does and the newcomer feels and follows its guidance, on the same 2 cores.
//!
//! The contact stage renders at the default point budget (`Resolution::DEFAULT`, scaled
//! by the tick period) unless `--level L` fixes a level of detail or `--points-per-ms P`
//! sets another budget; the report says how many ticks each level rendered.
//!
//! `cargo run --release -p benches --bin tick-budget -- --seconds 20 [--voxel-mm 1] [--rate-hz 1000] [--level L | --points-per-ms P] [--cube-points N | --scene NAME [--newcomer [--seed S] [--paced --planner ARGS]]] [--cpu-time] [--paced] [--slowest N] [--json F]`

use anyhow::{Context, bail};
use benches::face_contact::face_setup;
use benches::harness::{PlannerChild, cube_setup, wall_setup};
use benches::pressing::newcomer_setup;
use clap::Parser;
use devices::sim::SimulatedArm;
use haptic_loop::contact::{LEVELS, Resolution};
use haptic_loop::relay::Relay;
use haptic_loop::rt;
use haptic_loop::tick::{GuidanceSource, NoGuidance, NoSink, PrevTiming, StateSink, Tick};
use haptic_loop::work::TickWork;
use hdrhistogram::Histogram;
use ipc_types::ContactCode;
use ipc_types::services;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Tick compute budget with contact rendering (lockstep, simulated arm).
#[derive(Debug, Parser)]
struct Args {
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Tick rate, Hz (100–10000).
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// Render this level of detail always (0 = every point).
    #[arg(long, conflicts_with = "points_per_ms")]
    level: Option<u8>,
    /// Point budget per millisecond of tick period, instead of the default.
    #[arg(long)]
    points_per_ms: Option<f64>,
    /// Voxel size and pointshell spacing, mm.
    #[arg(long, default_value_t = 1.0)]
    voxel_mm: f64,
    /// Time the full tick with a cube of about this many points pressed onto a plate and
    /// slid, instead of the wall-hole scene's S.
    #[arg(long, conflicts_with = "scene")]
    cube_points: Option<usize>,
    /// Time the full tick with this scene's object pressed flat onto an obstacle face and
    /// slid (a built-in scene name or a TOML scene file).
    #[arg(long)]
    scene: Option<String>,
    /// With --scene: the newcomer holds the arm on the scene without its route (no
    /// planner, no guidance) instead of the flat-face press.
    #[arg(long, requires = "scene")]
    newcomer: bool,
    /// The newcomer's seed.
    #[arg(long, default_value_t = 1, requires = "newcomer")]
    seed: u64,
    /// Also time each tick by the thread's CPU time (CLOCK_THREAD_CPUTIME_ID), which leaves
    /// out time the thread was not running: on a shared VM the wall-clock tail is mostly
    /// other work's preemption, and this column shows what the tick itself costs.
    #[arg(long)]
    cpu_time: bool,
    /// Run each tick at its time on the wall clock, as the loop's RT thread does: set up
    /// as the loop sets it up (SCHED_FIFO 80, memory locked, CPU wake-up latency request
    /// 0 µs, where permitted; the report says what was) and sleeping to each absolute
    /// deadline between ticks, each tick taking its wake-up as its time. The run then takes
    /// --seconds of wall time, and the newcomer's trajectory and level changes are those
    /// a live session has (back to back they differ).
    #[arg(long)]
    paced: bool,
    /// With --newcomer --paced: run `planner serve` (from the same target directory) beside
    /// the ticks as a live session does, on the scene without its route, with the
    /// newcomer's seed and these arguments (e.g. "--sampling hrrtc --alpha 0.5"; "" for
    /// its defaults). The ticks publish their state to it and render its guidance.
    #[arg(
        long,
        value_name = "ARGS",
        allow_hyphen_values = true,
        requires_all = ["newcomer", "paced"]
    )]
    planner: Option<String>,
    /// Also list the N slowest ticks with what each rendered and did (its work counts),
    /// ranked by the thread's CPU time with --cpu-time, else by the wall clock.
    #[arg(long, default_value_t = 0)]
    slowest: usize,
    /// Write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Debug, Serialize)]
struct Report {
    /// What was timed.
    scenario: String,
    ticks: u64,
    rate_hz: f64,
    points: usize,
    voxel_mm: f64,
    /// How the level of detail was chosen.
    resolution: String,
    /// Share of ticks rendered at each level.
    level_fraction: Vec<f64>,
    contact_fraction: f64,
    max_penetration_mm: f64,
    compute_us: Percentiles,
    /// The same by the thread's CPU time (with `--cpu-time`).
    cpu_us: Option<Percentiles>,
    points_tested_max: u32,
    /// The most of each kind of work any one tick did (each kind's own worst tick).
    work_max: TickWork,
    /// The slowest ticks, slowest first (`--slowest`).
    slowest: Vec<SlowTick>,
    /// Deadlines missed, counted as the loop counts them (with `--paced`).
    deadline_misses: Option<u64>,
    /// The planner beside the ticks (`--planner`), from its own report.
    planner: Option<PlannerFigures>,
}

#[derive(Debug, Serialize)]
struct PlannerFigures {
    /// `planner serve` arguments after the namespace, scene and seed.
    args: String,
    solved: bool,
    nodes: u64,
    iterations: u64,
    /// Fresh haptic states it read per second.
    state_rate_hz: f64,
}

/// One of the slowest ticks.
#[derive(Debug, Clone, Copy, Serialize)]
struct SlowTick {
    /// Tick number from 1.
    tick: u64,
    compute_us: f64,
    /// By the thread's CPU clock (with `--cpu-time`).
    cpu_us: Option<f64>,
    /// What it did, counted where it was done.
    work: TickWork,
    /// Level of detail after the tick, and pointshell points the search looked at.
    level: usize,
    points_tested: u32,
    in_contact: bool,
}

/// What the ticks measured.
struct Measured {
    /// The slowest ticks, slowest first (`--slowest`).
    slowest: Vec<SlowTick>,
    /// Deadlines missed (`--paced`).
    misses: u64,
    hist: Histogram<u64>,
    cpu_hist: Histogram<u64>,
    in_contact: u64,
    tested_max: u32,
    work_max: TickWork,
    at_level: [u64; LEVELS],
    max_penetration_m: f64,
}

#[derive(Debug, Serialize)]
struct Percentiles {
    p50: f64,
    p90: f64,
    p99: f64,
    p999: f64,
    p9999: f64,
    max: f64,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !(args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 3600.0) {
        bail!("--seconds must be within (0, 3600], got {}", args.seconds);
    }
    if !(args.voxel_mm.is_finite() && (0.25..=20.0).contains(&args.voxel_mm)) {
        bail!("--voxel-mm must be within 0.25–20, got {}", args.voxel_mm);
    }
    if !(args.rate_hz.is_finite() && (100.0..=10_000.0).contains(&args.rate_hz)) {
        bail!("--rate-hz must be within 100–10000, got {}", args.rate_hz);
    }
    let resolution = match (args.level, args.points_per_ms) {
        (Some(l), _) => Resolution::Level(l),
        (None, Some(points_per_ms)) => Resolution::budget(points_per_ms),
        (None, None) => Resolution::DEFAULT,
    };
    resolution
        .validate()
        .map_err(|e| anyhow::anyhow!("--level / --points-per-ms: {e}"))?;
    let ticks = (args.seconds * args.rate_hz) as u64;
    let period_ns = (1e9 / args.rate_hz).round() as u64;
    if let Some(n) = args.cube_points
        && !(100..=1_000_000).contains(&n)
    {
        bail!("--cube-points must be within 100–1000000, got {n}");
    }
    let voxel_m = args.voxel_mm / 1000.0;
    let (arm, tick_config, stage, scenario) = match (args.cube_points, &args.scene) {
        (Some(n), _) => {
            let (arm, config, stage) = cube_setup(n, args.rate_hz, args.seconds, voxel_m)?;
            let what = "full tick: cube pressed onto a plate and slid".to_string();
            (arm, config, stage, what)
        }
        (None, Some(name)) if args.newcomer => {
            let scene =
                scene::Scene::by_name_or_path(name).with_context(|| format!("--scene {name}"))?;
            let (arm, config, stage) = newcomer_setup(&scene, args.rate_hz, voxel_m, args.seed)?;
            let what = format!(
                "full tick: the newcomer (seed {}) on {} without its route, {}",
                args.seed,
                scene.name,
                args.planner
                    .as_ref()
                    .map_or("no planner".to_owned(), |a| format!(
                        "`planner serve {}` beside it",
                        a.trim()
                    ))
            );
            (arm, config, stage, what)
        }
        (None, Some(name)) => {
            let scene =
                scene::Scene::by_name_or_path(name).with_context(|| format!("--scene {name}"))?;
            let (arm, config, stage, p) = face_setup(&scene, args.rate_hz, args.seconds, voxel_m)?;
            let what = format!(
                "full tick: {}'s object, {} points on its largest face, pressed onto a {:.0} cm² face (outward normal {:.2} {:.2} {:.2}) and slid",
                scene.name,
                p.face_points,
                p.face_area_m2 * 1e4,
                p.face_normal.x,
                p.face_normal.y,
                p.face_normal.z
            );
            (arm, config, stage, what)
        }
        (None, None) => {
            let (arm, config, stage) = wall_setup(args.rate_hz, args.seconds, Some(voxel_m))?;
            let what = "full tick: wall-hole S pushed along the wall".to_string();
            (arm, config, stage.context("contact stage")?, what)
        }
    };
    let mut stage = stage;
    stage.set_resolution(resolution)?;
    let points = stage.model().pointshell().len();
    let (m, planner) = match &args.planner {
        None => {
            let tick = Tick::new(arm, &tick_config, NoGuidance, NoSink)
                .context("open the simulated arm")?
                .with_contact(stage);
            (run_ticks(tick, &args, ticks, period_ns)?, None)
        }
        Some(planner_args) => {
            let name = args.scene.as_deref().unwrap_or_default();
            let dir = std::env::temp_dir().join(format!("tick-budget-{}", std::process::id()));
            let result = with_planner(&args, name, planner_args, &dir, |guidance, writer| {
                let tick = Tick::new(arm, &tick_config, guidance, writer)
                    .context("open the simulated arm")?
                    .with_contact(stage);
                run_ticks(tick, &args, ticks, period_ns)
            });
            let _ = std::fs::remove_dir_all(&dir);
            let (m, figures) = result?;
            (m, Some(figures))
        }
    };
    let percentiles = |h: &Histogram<u64>| {
        let us = |q: f64| h.value_at_quantile(q) as f64 / 1000.0;
        Percentiles {
            p50: us(0.5),
            p90: us(0.9),
            p99: us(0.99),
            p999: us(0.999),
            p9999: us(0.9999),
            max: h.max() as f64 / 1000.0,
        }
    };
    let report = Report {
        scenario,
        ticks,
        rate_hz: args.rate_hz,
        points,
        voxel_mm: args.voxel_mm,
        resolution: format!("{resolution:?}"),
        level_fraction: m
            .at_level
            .iter()
            .map(|&n| n as f64 / ticks as f64)
            .collect(),
        contact_fraction: m.in_contact as f64 / ticks as f64,
        max_penetration_mm: m.max_penetration_m * 1e3,
        compute_us: percentiles(&m.hist),
        cpu_us: args.cpu_time.then(|| percentiles(&m.cpu_hist)),
        points_tested_max: m.tested_max,
        work_max: m.work_max,
        deadline_misses: args.paced.then_some(m.misses),
        slowest: m.slowest,
        planner,
    };
    println!(
        "{}: {} ticks at {} Hz, {} points at {} mm, in contact {:.0} % of ticks, max penetration {:.3} mm, up to {} points tested per tick",
        report.scenario,
        report.ticks,
        report.rate_hz,
        report.points,
        report.voxel_mm,
        report.contact_fraction * 100.0,
        report.max_penetration_mm,
        report.points_tested_max
    );
    let levels: Vec<String> = report
        .level_fraction
        .iter()
        .enumerate()
        .filter(|(_, f)| **f > 0.0)
        .map(|(l, f)| format!("level {l} {:.1} %", f * 100.0))
        .collect();
    println!("{}: {}", report.resolution, levels.join(", "));
    println!("| clock | p50 | p90 | p99 | p99.9 | p99.99 | max |");
    println!("|---|---|---|---|---|---|---|");
    let rows = [
        ("wall", Some(&report.compute_us)),
        ("thread CPU", report.cpu_us.as_ref()),
    ];
    for (clock, c) in rows {
        if let Some(c) = c {
            println!(
                "| {clock} | {:.1} µs | {:.1} µs | {:.1} µs | {:.1} µs | {:.1} µs | {:.1} µs |",
                c.p50, c.p90, c.p99, c.p999, c.p9999, c.max
            );
        }
    }
    let w = &report.work_max.contact;
    println!(
        "most work in one tick, per kind: {} clearance checks, {} compares, {} look-ups, {} searches, {} near passes, {} solves",
        w.checks, w.compares, w.look_ups, w.searches, w.near_passes, w.solves
    );
    for t in &report.slowest {
        let w = &t.work.contact;
        println!(
            "slow tick {}: {:.1} µs{}, level {}{}: {} checks, {} compares, {} look-ups, {} searches, {} near passes",
            t.tick,
            t.compute_us,
            t.cpu_us
                .map_or(String::new(), |c| format!(" ({c:.1} µs CPU)")),
            t.level,
            if t.in_contact { ", in contact" } else { "" },
            w.checks,
            w.compares,
            w.look_ups,
            w.searches,
            w.near_passes
        );
    }
    if let Some(m) = report.deadline_misses {
        println!(
            "deadline misses: {m} ({:.3} % of ticks)",
            m as f64 / report.ticks.max(1) as f64 * 100.0
        );
    }
    if let Some(p) = &report.planner {
        println!(
            "planner beside the ticks (`planner serve {}`): solved {}, {} nodes, {} iterations, read {:.0} fresh states/s",
            p.args, p.solved, p.nodes, p.iterations, p.state_rate_hz
        );
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)? + "\n")
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}

/// Runs the ticks of `tick` (paced on the wall clock with `--paced`, else back to back)
/// and measures each.
fn run_ticks<G: GuidanceSource, S: StateSink>(
    mut tick: Tick<SimulatedArm, G, S>,
    args: &Args,
    ticks: u64,
    period_ns: u64,
) -> anyhow::Result<Measured> {
    let mut hist = Histogram::<u64>::new_with_bounds(1, 1_000_000_000, 3).context("histogram")?;
    let mut cpu_hist = hist.clone();
    let mut in_contact = 0u64;
    let mut tested_max = 0u32;
    let mut work_max = TickWork::default();
    let mut at_level = [0u64; LEVELS];
    // Held while the ticks run (the CPU latency request lives as long as the report).
    let rt = args.paced.then(|| {
        let r = rt::setup_current_thread(&rt::RtOptions::default());
        for w in &r.warnings {
            eprintln!("tick-budget: {w}");
        }
        println!(
            "paced like the loop: SCHED_FIFO {}, memory locked {}, CPU wake-up latency request {}",
            r.fifo,
            r.memory_locked,
            r.cpu_latency
                .as_ref()
                .map_or("none".to_owned(), |c| format!("{} µs", c.us))
        );
        r
    });
    // Paced ticks are stamped with their wake-up on CLOCK_MONOTONIC and count their
    // deadline misses as the loop's RT thread does (`haptic_loop::runner`): the planner's
    // guidance samples carry that clock and the tick ages them by it.
    let mut deadline_ns = if args.paced { rt::monotonic_ns() } else { 0 } + period_ns;
    let mut misses = 0u64;
    let mut slowest: Vec<SlowTick> = Vec::with_capacity(args.slowest + 1);
    for i in 1..=ticks {
        let now_ns = if args.paced {
            rt::sleep_until(deadline_ns, 0)
        } else {
            deadline_ns
        };
        let c0 = if args.cpu_time {
            rt::thread_cpu_ns()
        } else {
            0
        };
        let t0 = Instant::now();
        let prev = PrevTiming {
            deadline_misses: misses,
            ..PrevTiming::default()
        };
        let s = *tick.step(now_ns, prev);
        let compute_ns = (t0.elapsed().as_nanos() as u64).max(1);
        hist.saturating_record(compute_ns);
        let cpu_ns = args
            .cpu_time
            .then(|| rt::thread_cpu_ns().saturating_sub(c0).max(1));
        if let Some(c) = cpu_ns {
            cpu_hist.saturating_record(c);
        }
        let work = *tick.last_work();
        work_max = work_max.most_of_each(&work);
        let next_ns = deadline_ns + period_ns;
        let end_ns = if args.paced { rt::monotonic_ns() } else { 0 };
        // Overran: skip the deadlines already past, as the loop does.
        let missed = rt::missed_deadlines(end_ns, next_ns, period_ns);
        misses += missed;
        deadline_ns = next_ns + missed * period_ns;
        let touching = s.contact == ContactCode::CONTACT;
        in_contact += u64::from(touching);
        let (level, points_tested) = tick
            .contact()
            .map_or((0, 0), |c| (c.level(), c.last_points_tested()));
        if tick.contact().is_some() {
            tested_max = tested_max.max(points_tested);
            at_level[level] += 1;
        }
        let compute_us = compute_ns as f64 / 1000.0;
        let cpu_us = cpu_ns.map(|c| c as f64 / 1000.0);
        // Ranked by CPU time when it is measured: the wall clock's slowest are mostly the
        // machine's.
        let rank = |t: &SlowTick| t.cpu_us.unwrap_or(t.compute_us);
        let this = SlowTick {
            tick: i,
            compute_us,
            cpu_us,
            work,
            level,
            points_tested,
            in_contact: touching,
        };
        if slowest.len() < args.slowest || slowest.last().is_some_and(|l| rank(&this) > rank(l)) {
            let at = slowest.partition_point(|t| rank(t) >= rank(&this));
            slowest.insert(at, this);
            slowest.truncate(args.slowest);
        }
    }
    drop(rt);
    Ok(Measured {
        slowest,
        misses,
        hist,
        cpu_hist,
        in_contact,
        tested_max,
        work_max,
        at_level,
        max_penetration_m: tick.max_penetration_m(),
    })
}

/// Runs `ticks` with a `planner serve` process beside them, as a live session does: the
/// scene `name` without its route is written into `dir` for it, the ticks get the loop's
/// guidance relay and state writer on a namespace of their own, and the planner's report
/// is read when it has stopped.
fn with_planner<T>(
    args: &Args,
    name: &str,
    planner_args: &str,
    dir: &Path,
    ticks: impl FnOnce(haptic_loop::relay::RelayOutput, services::StateWriter) -> anyhow::Result<T>,
) -> anyhow::Result<(T, PlannerFigures)> {
    let scene_file = lab::live::write_without_route(name, dir)
        .with_context(|| format!("--planner: cannot write {name} without its route"))?;
    let ns = format!("tick_budget_{}", std::process::id());
    let (node, _) = services::create_node(&ns)?;
    let writer = services::state_writer(&node, &ns)?;
    let (relay, guidance) = Relay::spawn(&ns, Relay::LOOP_POLL)?;
    let report = dir.join("planner.json");
    let mut extra = vec![
        "--seed".to_owned(),
        args.seed.to_string(),
        "--json".to_owned(),
        report.display().to_string(),
    ];
    extra.extend(planner_args.split_whitespace().map(str::to_owned));
    let mut child = PlannerChild::spawn_on(&ns, &scene_file.display().to_string(), &extra)?;
    let measured = ticks(guidance, writer);
    child.stop();
    drop(relay);
    let measured = measured?;
    let text = std::fs::read_to_string(&report).with_context(|| {
        format!(
            "the planner wrote no report ({}): check `planner serve {}` on its own",
            report.display(),
            planner_args.trim()
        )
    })?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("the planner's report {}", report.display()))?;
    let figures = PlannerFigures {
        args: planner_args.trim().to_owned(),
        solved: v["solved"].as_bool().unwrap_or(false),
        nodes: v["nodes"].as_u64().unwrap_or(0),
        iterations: v["iterations"].as_u64().unwrap_or(0),
        state_rate_hz: v["state_rate_hz"].as_f64().unwrap_or(0.0),
    };
    Ok((measured, figures))
}
