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
use haptic_loop::contact::ContactStage;
use haptic_loop::contact::{LEVELS, Resolution};
use haptic_loop::relay::Relay;
use haptic_loop::rt;
use haptic_loop::tick::{
    GuidanceSource, NoGuidance, NoSink, PrevTiming, StateSink, Tick, TickConfig,
};
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
    #[arg(long)]
    newcomer: bool,
    /// The generated CAD-like part (20 040 triangles, open, several components,
    /// slivers) passing a hole in a wall (`Scene::cad_like_part_through_wall`) as the
    /// scene, instead of --scene.
    #[arg(long, conflicts_with_all = ["scene", "cube_points"])]
    cad_like: bool,
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
        requires_all = ["newcomer", "paced", "scene"]
    )]
    planner: Option<String>,
    /// Also list the N slowest ticks with what each rendered and did (its work counts),
    /// ranked by the thread's CPU time with --cpu-time, else by the wall clock.
    #[arg(long, default_value_t = 0)]
    slowest: usize,
    /// Before each tick, outside its timing, write this many KiB of a buffer of the
    /// harness's own, so that the tick starts with its data out of the L1 and L2 caches
    /// (2 MiB of L2 per core here), as a live tick does after its sleep on a busy machine.
    #[arg(long, default_value_t = 0)]
    evict_kb: usize,
    /// With --cpu-time: fit each tick's CPU time to its work counts by least squares
    /// (a fixed part plus a cost per clearance check, compare and look-up) and print the
    /// costs, how much of the run they explain, and the largest tick they under-predict.
    #[arg(long, requires = "cpu_time")]
    fit_costs: bool,
    /// With --cpu-time, back to back and without --planner: run the same lockstep
    /// session this many times (it is deterministic: every run does the same work, which is
    /// checked) and also report each tick's least CPU time over the runs. A tick slow by its
    /// work is slow in every run; one the machine slowed (another VM on the host, a cache
    /// emptied) is not, so this is the loop's own cost with the machine's tail taken out.
    #[arg(long, default_value_t = 1, requires = "cpu_time", conflicts_with_all = ["paced", "planner"])]
    replays: u32,
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
    /// Ticks whose caps left contact work on a rendered level for later ticks (the proxy
    /// was held to what keeps that work's points out of the surface).
    deferred_ticks: u64,
    /// The tick's caps (`Tick::caps`).
    caps: haptic_loop::work::WorkCaps,
    /// Ticks that used all of a cap: clearance checks, compares, look-ups (within a
    /// chunk's lanes).
    at_cap: [u64; 3],
    /// The slowest ticks, slowest first (`--slowest`).
    slowest: Vec<SlowTick>,
    /// Each tick's least CPU time over identical runs (`--replays`).
    replayed: Option<Replayed>,
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

/// Each tick's least CPU time over `runs` identical runs (`--replays`).
#[derive(Debug, Serialize)]
struct Replayed {
    runs: u32,
    /// Every run did the same work, tick by tick (the counts agree).
    same_work: bool,
    /// Percentiles over the ticks of each tick's least CPU time, µs.
    cpu_us: Percentiles,
    /// The ticks with the largest least CPU time, largest first (`--slowest`).
    slowest: Vec<ReplayedTick>,
}

/// A tick of the replayed runs: its least CPU time and its work (the same in every run).
#[derive(Debug, Clone, Copy, Serialize)]
struct ReplayedTick {
    /// Tick number from 1.
    tick: u64,
    cpu_us: f64,
    work: TickWork,
}

/// What the ticks measured.
struct Measured {
    /// Each tick's CPU time (ns) and work, with `--replays` above 1.
    per_tick: Vec<(u64, TickWork)>,
    /// The slowest ticks, slowest first (`--slowest`).
    slowest: Vec<SlowTick>,
    /// Deadlines missed (`--paced`).
    misses: u64,
    hist: Histogram<u64>,
    cpu_hist: Histogram<u64>,
    in_contact: u64,
    tested_max: u32,
    work_max: TickWork,
    deferred_ticks: u64,
    caps: haptic_loop::work::WorkCaps,
    at_cap: [u64; 3],
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
    if args.newcomer && args.scene.is_none() && !args.cad_like {
        bail!("--newcomer needs --scene or --cad-like");
    }
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
    let (arm, tick_config, stage, scenario) = set_up(&args)?;
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
    let replayed = if args.replays > 1 {
        let mut least = m.per_tick.clone();
        let mut same_work = true;
        for _ in 1..args.replays {
            let (arm, tick_config, mut stage, _) = set_up(&args)?;
            stage.set_resolution(resolution)?;
            let tick = Tick::new(arm, &tick_config, NoGuidance, NoSink)
                .context("open the simulated arm")?
                .with_contact(stage);
            let again = run_ticks(tick, &args, ticks, period_ns)?;
            for (l, a) in least.iter_mut().zip(&again.per_tick) {
                same_work &= l.1 == a.1;
                l.0 = l.0.min(a.0);
            }
        }
        Some((same_work, least))
    } else {
        None
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
        deferred_ticks: m.deferred_ticks,
        caps: m.caps,
        at_cap: m.at_cap,
        deadline_misses: args.paced.then_some(m.misses),
        slowest: m.slowest,
        replayed: replayed.map(|(same_work, least)| {
            let mut h = Histogram::<u64>::new_with_bounds(1, 1_000_000_000, 3).expect("bounds");
            for (c, _) in &least {
                h.saturating_record((*c).max(1));
            }
            let mut order: Vec<usize> = (0..least.len()).collect();
            order.sort_by_key(|&i| std::cmp::Reverse(least[i].0));
            let slowest = order
                .iter()
                .take(args.slowest)
                .map(|&i| ReplayedTick {
                    tick: i as u64 + 1,
                    cpu_us: least[i].0 as f64 / 1000.0,
                    work: least[i].1,
                })
                .collect();
            Replayed {
                runs: args.replays,
                same_work,
                cpu_us: percentiles(&h),
                slowest,
            }
        }),
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
        "most work in one tick, per kind: {} clearance checks, {} compares, {} look-ups, {} searches, {} near passes, {} solves; {} ticks left work to later ones",
        w.checks,
        w.compares,
        w.look_ups,
        w.searches,
        w.near_passes,
        w.solves,
        report.deferred_ticks
    );
    let c = &report.caps.contact;
    println!(
        "caps: {} clearance checks, {} compares, {} look-ups, {} searches, {} near passes, {} solves; ticks at a cap: {} checks, {} compares, {} look-ups",
        c.checks,
        c.compares,
        c.look_ups,
        c.searches,
        c.near_passes,
        c.solves,
        report.at_cap[0],
        report.at_cap[1],
        report.at_cap[2]
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
    if let Some(r) = &report.replayed {
        let c = &r.cpu_us;
        println!(
            "| least of {} runs{} | {:.1} µs | {:.1} µs | {:.1} µs | {:.1} µs | {:.1} µs | {:.1} µs |",
            r.runs,
            if r.same_work {
                ""
            } else {
                " (the runs' work differed!)"
            },
            c.p50,
            c.p90,
            c.p99,
            c.p999,
            c.p9999,
            c.max
        );
        for t in &r.slowest {
            let w = &t.work.contact;
            println!(
                "least-of-runs slow tick {}: {:.1} µs CPU: {} checks, {} compares, {} look-ups, {} searches, {} near passes",
                t.tick, t.cpu_us, w.checks, w.compares, w.look_ups, w.searches, w.near_passes
            );
        }
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

/// The simulated arm, the tick's configuration, the contact stage and what they do, as
/// `args` choose.
fn set_up(args: &Args) -> anyhow::Result<(SimulatedArm, TickConfig, ContactStage, String)> {
    let voxel_m = args.voxel_mm / 1000.0;
    let scene = match &args.scene {
        _ if args.cad_like => Some(scene::Scene::cad_like_part_through_wall()),
        Some(name) => {
            let mut s =
                scene::Scene::by_name_or_path(name).with_context(|| format!("--scene {name}"))?;
            s.repair_meshes();
            Some(s)
        }
        None => None,
    };
    Ok(match (args.cube_points, scene) {
        (Some(n), _) => {
            let (arm, config, stage) = cube_setup(n, args.rate_hz, args.seconds, voxel_m)?;
            let what = "full tick: cube pressed onto a plate and slid".to_string();
            (arm, config, stage, what)
        }
        (None, Some(scene)) if args.newcomer => {
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
        (None, Some(scene)) => {
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
    })
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
    let mut evict = vec![0u8; args.evict_kb * 1024];
    let caps = tick.caps();
    let mut at_cap = [0u64; 3];
    let mut per_tick = Vec::with_capacity(if args.replays > 1 { ticks as usize } else { 0 });
    let mut fit = args.fit_costs.then(CostFit::default);
    for i in 1..=ticks {
        // A cache line each, so the tick finds its own data evicted.
        for (n, b) in evict.iter_mut().step_by(64).enumerate() {
            *b = b.wrapping_add(n as u8);
        }
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
        let (w, c) = (&work.contact, &caps.contact);
        at_cap[0] += u64::from(w.checks >= c.checks);
        at_cap[1] += u64::from(w.compares >= c.compares);
        at_cap[2] += u64::from(w.look_ups + 8 > c.look_ups);
        if args.replays > 1 {
            per_tick.push((cpu_ns.unwrap_or(0), work));
        }
        if let (Some(fit), Some(c)) = (&mut fit, cpu_ns) {
            fit.add(&work, c as f64 / 1000.0);
        }
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
    std::hint::black_box(&evict);
    if let Some(fit) = &fit {
        fit.print();
    }
    Ok(Measured {
        per_tick,
        slowest,
        misses,
        hist,
        cpu_hist,
        in_contact,
        tested_max,
        work_max,
        deferred_ticks: tick.contact().map_or(0, |c| c.deferred_steps()),
        caps,
        at_cap,
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

/// A least-squares fit of each tick's CPU time (µs) to a fixed part and costs per
/// clearance check, compare and look-up (`--fit-costs`): the normal equations, summed tick
/// by tick, and the ticks kept to find the one the fit under-predicts most.
#[derive(Default)]
struct CostFit {
    ata: nalgebra::Matrix4<f64>,
    atb: nalgebra::Vector4<f64>,
    ticks: Vec<([f64; 4], f64)>,
}

impl CostFit {
    fn row(w: &TickWork) -> [f64; 4] {
        let c = &w.contact;
        [
            1.0,
            f64::from(c.checks),
            f64::from(c.compares),
            f64::from(c.look_ups),
        ]
    }

    fn add(&mut self, w: &TickWork, cpu_us: f64) {
        let x = nalgebra::Vector4::from(Self::row(w));
        self.ata += x * x.transpose();
        self.atb += x * cpu_us;
        self.ticks.push((Self::row(w), cpu_us));
    }

    fn print(&self) {
        let Some(cost) = self.ata.cholesky().map(|c| c.solve(&self.atb)) else {
            println!("cost fit: the work counts do not vary enough to fit");
            return;
        };
        let predict = |x: &[f64; 4]| (0..4).map(|i| x[i] * cost[i]).sum::<f64>();
        let mean = self.ticks.iter().map(|t| t.1).sum::<f64>() / self.ticks.len().max(1) as f64;
        let (mut ss_res, mut ss_tot) = (0.0, 0.0);
        let mut worst = (0.0, 0.0, 0.0);
        for (x, y) in &self.ticks {
            let p = predict(x);
            ss_res += (y - p) * (y - p);
            ss_tot += (y - mean) * (y - mean);
            if y - p > worst.0 {
                worst = (y - p, *y, p);
            }
        }
        println!(
            "cost fit (CPU µs = fixed + checks·a + compares·b + look-ups·c): fixed {:.2} µs, a {:.1} ns a clearance check, b {:.2} ns a compare, c {:.1} ns a look-up; explains {:.0} % of the variance; most under-predicted tick {:.1} µs CPU against {:.1} µs predicted",
            cost[0],
            cost[1] * 1e3,
            cost[2] * 1e3,
            cost[3] * 1e3,
            (1.0 - ss_res / ss_tot.max(1e-12)) * 100.0,
            worst.1,
            worst.2
        );
    }
}
