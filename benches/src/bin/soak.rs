//! Soak: the real haptic loop (contact on, the S sliding on the wall) for minutes while its
//! planner is killed (`kill -9`) or hung (`SIGSTOP`, then killed) and restarted every
//! `--restart-s`. Reports the loop's faults, deadline misses and compute percentiles, the
//! largest commanded force, and what a planner sees: the longest gap between two new
//! `HapticState` samples on the blackboard, read by an observer thread polling at 2 kHz.
//!
//! `cargo build --release -p planner -p benches && target/release/soak --minutes 10 --restart-s 30`

use anyhow::{Context, bail};
use benches::harness::{PlannerChild, WallLoop, wall_loop};
use clap::Parser;
use haptic_loop::rt::RtOptions;
use haptic_loop::stats::Percentiles;
use ipc_types::{FaultCode, GuidanceFreshness, services};
use serde::Serialize;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

#[global_allocator]
static ALLOC: haptic_loop::alloc_count::CountingAllocator =
    haptic_loop::alloc_count::CountingAllocator;

/// Soak the haptic loop while its planner is killed and restarted.
#[derive(Debug, Parser)]
struct Args {
    /// How long, minutes.
    #[arg(long, default_value_t = 10.0)]
    minutes: f64,
    /// Kill or hang the planner, then restart it, every this many seconds.
    #[arg(long, default_value_t = 30.0)]
    restart_s: f64,
    /// SCHED_FIFO priority of the RT thread (0 = normal scheduler).
    #[arg(long, default_value_t = 80)]
    priority: u8,
    /// Voxel size, mm.
    #[arg(long, default_value_t = 1.0)]
    voxel_mm: f64,
    /// Write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Debug, Default, Serialize)]
struct Observed {
    /// Longest time between two new states, ms.
    longest_state_gap_ms: f64,
    /// Largest commanded force seen, N.
    max_commanded_force_n: f64,
    /// Times guidance went from fresh to lost.
    guidance_losses: u64,
    /// Times guidance came back (lost to fresh).
    guidance_returns: u64,
    /// Distinct faults seen (code and name), start-up excluded.
    faults: Vec<String>,
}

#[derive(Debug, Serialize)]
struct Report {
    minutes: f64,
    planner_faults_injected: u64,
    ticks: u64,
    deadline_misses: u64,
    loop_faults_latched: u64,
    compute_us: Percentiles,
    wake_latency_us: Percentiles,
    allocations_per_tick: Option<f64>,
    observed: Observed,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !(args.minutes.is_finite() && args.minutes > 0.0 && args.minutes <= 24.0 * 60.0) {
        bail!("--minutes must be within (0, 1440], got {}", args.minutes);
    }
    if !(args.restart_s.is_finite() && args.restart_s >= 2.0) {
        bail!("--restart-s must be at least 2, got {}", args.restart_s);
    }
    if args.priority > 99 {
        bail!("--priority must be 0–99, got {}", args.priority);
    }
    let ns = format!("soak_{}", std::process::id());
    let duration = Duration::from_secs_f64(args.minutes * 60.0);
    let running = wall_loop(
        &ns,
        &WallLoop {
            rate_hz: 1000.0,
            rt: RtOptions {
                fifo_priority: (args.priority > 0).then_some(args.priority),
                cpu: None,
                lock_memory: true,
                cpu_latency_us: Some(0),
            },
            ticks: (duration.as_secs_f64() * 1000.0) as u64,
            voxel_m: Some(args.voxel_mm / 1000.0),
        },
    )?;

    // The planner's view, from another thread of this process.
    let stop = Arc::new(AtomicBool::new(false));
    let observer = {
        let ns = ns.clone();
        let stop = stop.clone();
        std::thread::spawn(move || -> anyhow::Result<Observed> {
            let (node, _) = services::create_node("soak_observer")?;
            let reader = services::state_reader(&node, &ns)?;
            let mut o = Observed::default();
            let (mut last_seq, mut last_new) = (0u64, Instant::now());
            let mut fresh = false;
            while !stop.load(Ordering::Acquire) {
                let s = *reader.get();
                let now = Instant::now();
                if s.header.sequence != last_seq {
                    if last_seq != 0 {
                        let gap = now.duration_since(last_new).as_secs_f64() * 1e3;
                        o.longest_state_gap_ms = o.longest_state_gap_ms.max(gap);
                    }
                    last_seq = s.header.sequence;
                    last_new = now;
                    let f = s.commanded_wrench.force_n;
                    let force = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
                    o.max_commanded_force_n = o.max_commanded_force_n.max(force);
                    if s.fault != FaultCode::NONE && s.fault != FaultCode::STARTUP {
                        let name = format!("{} ({})", s.fault.0, s.fault.name());
                        if !o.faults.contains(&name) {
                            o.faults.push(name);
                        }
                    }
                    match s.guidance_freshness {
                        GuidanceFreshness::FRESH if !fresh => {
                            fresh = true;
                            o.guidance_returns += 1;
                        }
                        GuidanceFreshness::LOST if fresh => {
                            fresh = false;
                            o.guidance_losses += 1;
                        }
                        _ => {}
                    }
                }
                std::thread::sleep(Duration::from_micros(500));
            }
            Ok(o)
        })
    };

    let started = Instant::now();
    let mut injected = 0u64;
    let mut planner = Some(PlannerChild::spawn(&ns)?);
    let mut next = started + Duration::from_secs_f64(args.restart_s);
    while !running.handle.is_finished() {
        if Instant::now() >= next {
            if let Some(p) = planner.take() {
                // Alternate a crash and a hang; the hung one is killed 2 s later.
                if injected.is_multiple_of(2) {
                    p.signal(libc::SIGKILL);
                } else {
                    p.signal(libc::SIGSTOP);
                    std::thread::sleep(Duration::from_secs(2));
                }
                drop(p);
                injected += 1;
            }
            planner = Some(PlannerChild::spawn(&ns)?);
            next += Duration::from_secs_f64(args.restart_s);
            eprintln!(
                "[{:>6.0} s] planner faults injected: {injected}",
                started.elapsed().as_secs_f64()
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    drop(planner);
    let (tick, report) = running.handle.join();
    stop.store(true, Ordering::Release);
    let observed = observer
        .join()
        .map_err(|_| anyhow::anyhow!("observer thread panicked"))??;
    let out = Report {
        minutes: args.minutes,
        planner_faults_injected: injected,
        ticks: report.ticks,
        deadline_misses: report.deadline_misses,
        loop_faults_latched: tick.faults_total(),
        compute_us: report.compute_us,
        wake_latency_us: report.wake_latency_us,
        allocations_per_tick: report.allocations_per_tick,
        observed,
    };
    println!("{}", serde_json::to_string_pretty(&out)?);
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&out)? + "\n")
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}
