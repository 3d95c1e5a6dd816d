//! IPC latency across processes, beside bare iceoryx2 with the same payload in the same run.
//!
//! Phases, one after the other (interleaved, so they do not compete for the 2 cores):
//! 1. **bare baselines**, each a writer thread here and a reader in a child process (this
//!    binary re-executed with the hidden `--bare-rx`), plain iceoryx2 on its own service:
//!    `HapticState` over publish-subscribe and over a blackboard at the loop rate, the
//!    reader spinning (the transport alone) and, for the blackboard, polling at the
//!    planner's `--poll-hz` (transport + the wait for the next poll); `Guidance` over
//!    publish-subscribe at the planner's guidance rate, spinning and polling at 1 kHz (the
//!    relay's poll).
//! 2. **ours**: the real haptic loop (simulated arm; contact off unless `--contact`) with a
//!    real `planner serve` process. State: the loop's stamp just before its blackboard
//!    write (`HapticState::published_ns`; the bare writers stamp just before theirs) → the
//!    planner's receiver thread reading the blackboard, phase-locked to the ticks with a
//!    `--state-spin-us` watch after each early wake-up (`ipc_types::pacing`; `state_latency_us` of the planner's
//!    JSON report; from the tick's wake-up instead: `state_age_us`). Guidance: the planner's stamp just before `send_copy` → wake-up of the
//!    first tick rendering it, through the loop's relay thread (woken by the planner's
//!    guidance event) and triple buffer
//!    (`guidance_latency_us` of the loop report).
//!
//! The goal's pair (bare pub/sub spinning, then ours) is run `--rounds` times, one after
//! the other, and the goal ratio is the median of the rounds' ratios: on a shared machine
//! the bare baseline alone moves 4× between runs.
//!
//! Prints a table with the ratios ours / bare and writes JSON with `--json`.
//!
//! `cargo build --release -p planner -p benches && target/release/ipc-latency --seconds 10 --json ipc.json`

use anyhow::{Context, bail};
use benches::harness::{PlannerChild, WallLoop, wall_loop};
use benches::ipc::{self, Bare, Pattern, Poll, Stamped, Writer};
use clap::Parser;
use haptic_loop::rt::RtOptions;
use haptic_loop::stats::Percentiles;
use ipc_types::{Guidance, HapticState, services};
use serde::Serialize;
use std::io::BufRead;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::Duration;

#[global_allocator]
static ALLOC: haptic_loop::alloc_count::CountingAllocator =
    haptic_loop::alloc_count::CountingAllocator;

/// IPC latency of the state and guidance paths versus bare iceoryx2, in one run.
#[derive(Debug, Parser)]
struct Args {
    /// Seconds of each real two-process run.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Rounds of (bare pub/sub spinning baseline, real run), one after the other: the goal
    /// ratio is the median of the rounds' ratios, so that a change of the machine's load
    /// between two phases does not decide it. The tables show the median round.
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// Seconds of each bare baseline (five of them).
    #[arg(long, default_value_t = 4.0)]
    baseline_seconds: f64,
    /// Tick rate = state write rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// The planner's state poll rate before it locks onto the ticks, Hz (`planner serve
    /// --poll-hz`), and the bare polled blackboard's rate.
    #[arg(long, default_value_t = 2000.0)]
    poll_hz: f64,
    /// The planner receiver's longest watch for each predicted state after it wakes, µs
    /// (`planner serve --state-spin-us`; 0: it only sleeps).
    #[arg(long, default_value_t = 100.0)]
    state_spin_us: f64,
    /// SCHED_FIFO priority of the planner's state receiver (`planner serve
    /// --state-priority`) and, for a like-for-like baseline, of the bare state readers
    /// (0 = the normal scheduler).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u8).range(0..=98))]
    state_priority: u8,
    /// The planner's guidance rate, Hz (`planner serve --guidance-rate-hz`).
    #[arg(long, default_value_t = 100.0)]
    guidance_rate_hz: f64,
    /// SCHED_FIFO priority of the RT thread and of the bare writers (0 = normal).
    #[arg(long, default_value_t = 80)]
    priority: u8,
    /// Pin the RT thread and the bare writers to this CPU.
    #[arg(long)]
    cpu: Option<usize>,
    /// Make no 0 µs CPU wake-up latency request (PM QoS) from the writers and the loop: by
    /// default they hold one, as the haptic loop does while it runs.
    #[arg(long)]
    no_cpu_latency_request: bool,
    /// Render contact (1 mm voxels, the S sliding on the wall) during the real run.
    #[arg(long)]
    contact: bool,
    /// Write the figures as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Internal: be the reader of a bare baseline,
    /// `PATTERN:PAYLOAD:POLL_HZ:PRIORITY:NAMESPACE` (POLL_HZ 0 = spin, PRIORITY 0 = the
    /// normal scheduler).
    #[arg(long, hide = true)]
    bare_rx: Option<String>,
}

/// One bare baseline's figures.
#[derive(Debug, Serialize)]
struct Baseline {
    pattern: &'static str,
    payload: &'static str,
    /// Reader poll rate, Hz; `null` = spinning.
    poll_hz: Option<f64>,
    write_rate_hz: f64,
    written: u64,
    latency_us: Percentiles,
    /// Duration of the write call itself (part of `latency_us`), µs.
    write_call_us: Percentiles,
}

/// p50, p99 and max of a ratio (ours / baseline) or a difference (µs).
#[derive(Debug, Serialize)]
struct Triple {
    p50: f64,
    p99: f64,
    max: f64,
}

fn ratio(a: &Percentiles, b: &Percentiles) -> Triple {
    let r = |x: f64, y: f64| if y > 0.0 { x / y } else { f64::NAN };
    Triple {
        p50: r(a.p50, b.p50),
        p99: r(a.p99, b.p99),
        max: r(a.max, b.max),
    }
}

#[derive(Debug, Serialize)]
struct StateFigures {
    /// The loop's publish stamp (just before its blackboard write) → planner receiver, µs.
    ours_us: Percentiles,
    /// The tick's wake-up stamp → planner receiver, µs: `ours_us` plus the tick's compute
    /// before publishing.
    ours_from_tick_start_us: Percentiles,
    bare_pubsub_spin: Baseline,
    bare_blackboard_spin: Baseline,
    bare_blackboard_polled: Baseline,
    /// The part a reader polling at `poll_hz` adds: bare polled − bare spinning, µs
    /// (meaningful at p50; the tails of both are preemption).
    poll_part_us: Triple,
    ratio_to_bare_pubsub_spin: Triple,
    ratio_to_bare_blackboard_spin: Triple,
    ratio_to_bare_blackboard_polled: Triple,
    states_received: u64,
    states_skipped: u64,
}

#[derive(Debug, Serialize)]
struct GuidanceFigures {
    /// Planner stamp → first tick rendering it, µs.
    ours_us: Percentiles,
    bare_pubsub_spin: Baseline,
    bare_pubsub_polled: Baseline,
    /// The part a 1 kHz poll adds: bare polled − bare spinning, µs.
    poll_part_us: Triple,
    ratio_to_bare_pubsub_spin: Triple,
    ratio_to_bare_pubsub_polled: Triple,
}

/// One round: the bare pub/sub baseline and the real state path, one after the other.
#[derive(Debug, Serialize)]
struct Round {
    bare_pubsub_spin_p50_us: f64,
    ours_p50_us: f64,
    ratio_p50: f64,
}

#[derive(Debug, Serialize)]
struct Goal {
    statement: &'static str,
    ratio_p50: f64,
    met: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    seconds: f64,
    baseline_seconds: f64,
    /// Sorted by ratio; the tables show the median one.
    rounds: Vec<Round>,
    rate_hz: f64,
    state_poll_hz: f64,
    state_spin_us: f64,
    guidance_rate_hz: f64,
    relay_poll_hz: f64,
    priority: u8,
    contact: bool,
    state: StateFigures,
    guidance: GuidanceFigures,
    goal: Goal,
    loop_compute_us: Percentiles,
    loop_deadline_misses: u64,
    loop_ticks: u64,
    allocations_per_tick: Option<f64>,
}

/// The relay's poll period in `benches::harness::wall_loop`, as a rate.
const RELAY_POLL_HZ: f64 = 1000.0;

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if let Some(spec) = &args.bare_rx {
        return bare_reader(spec);
    }
    for (name, v, lo, hi) in [
        ("seconds", args.seconds, 1.0, 3600.0),
        ("baseline-seconds", args.baseline_seconds, 0.5, 600.0),
        ("rate-hz", args.rate_hz, 500.0, 4000.0),
        ("poll-hz", args.poll_hz, 1.0, 100_000.0),
        ("state-spin-us", args.state_spin_us, 0.0, 500.0),
        ("guidance-rate-hz", args.guidance_rate_hz, 1.0, 10_000.0),
        ("rounds", f64::from(args.rounds), 1.0, 20.0),
    ] {
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            bail!("--{name} must be within {lo}–{hi}, got {v}");
        }
    }
    if args.priority > 99 {
        bail!("--priority must be 0–99, got {}", args.priority);
    }
    let rt = RtOptions {
        fifo_priority: (args.priority > 0).then_some(args.priority),
        cpu: args.cpu,
        lock_memory: true,
        cpu_latency_us: (!args.no_cpu_latency_request).then_some(0),
    };
    let secs = args.baseline_seconds;
    let base = |pattern, rate_hz, poll| Bare {
        pattern,
        rate_hz,
        poll,
        seconds: secs,
    };
    eprintln!("bare baselines: 4 × {secs} s");
    let s_bb = baseline::<HapticState>(
        base(Pattern::Blackboard, args.rate_hz, Poll::Busy),
        rt,
        args.state_priority,
    )?;
    let s_bbp = baseline::<HapticState>(
        base(Pattern::Blackboard, args.rate_hz, Poll::Every(args.poll_hz)),
        rt,
        args.state_priority,
    )?;
    let g_ps = baseline::<Guidance>(
        base(Pattern::PubSub, args.guidance_rate_hz, Poll::Busy),
        rt,
        0,
    )?;
    let g_psp = baseline::<Guidance>(
        base(
            Pattern::PubSub,
            args.guidance_rate_hz,
            Poll::Every(RELAY_POLL_HZ),
        ),
        rt,
        0,
    )?;

    let mut rounds = Vec::new();
    for round in 1..=args.rounds {
        eprintln!(
            "round {round}/{}: bare pub/sub spinning {secs} s, then the haptic loop + planner process {} s",
            args.rounds, args.seconds
        );
        let bare = baseline::<HapticState>(
            base(Pattern::PubSub, args.rate_hz, Poll::Busy),
            rt,
            args.state_priority,
        )?;
        let (report, planner) = run_ours(&args, rt)?;
        let ours = percentiles_from_json(&planner["state_latency_us"])
            .context("the planner's report has no state_latency_us")?;
        rounds.push((
            ratio(&ours, &bare.latency_us).p50,
            bare,
            report,
            planner,
            ours,
        ));
    }
    // The median round by ratio (NaN, an empty baseline, sorts last).
    rounds.sort_by(|a, b| a.0.total_cmp(&b.0));
    let round_figures: Vec<Round> = rounds
        .iter()
        .map(|(ratio_p50, bare, _, _, ours)| Round {
            bare_pubsub_spin_p50_us: bare.latency_us.p50,
            ours_p50_us: ours.p50,
            ratio_p50: *ratio_p50,
        })
        .collect();
    let (goal_ratio, s_ps, report, planner, state_ours) = rounds.swap_remove(rounds.len() / 2);
    let count = |k: &str| planner[k].as_u64().unwrap_or(0);
    let diff = |a: &Percentiles, b: &Percentiles| Triple {
        p50: a.p50 - b.p50,
        p99: a.p99 - b.p99,
        max: a.max - b.max,
    };
    let out = Report {
        seconds: args.seconds,
        baseline_seconds: secs,
        rounds: round_figures,
        rate_hz: args.rate_hz,
        state_poll_hz: args.poll_hz,
        state_spin_us: args.state_spin_us,
        guidance_rate_hz: args.guidance_rate_hz,
        relay_poll_hz: RELAY_POLL_HZ,
        priority: args.priority,
        contact: args.contact,
        state: StateFigures {
            poll_part_us: diff(&s_bbp.latency_us, &s_bb.latency_us),
            ratio_to_bare_pubsub_spin: ratio(&state_ours, &s_ps.latency_us),
            ratio_to_bare_blackboard_spin: ratio(&state_ours, &s_bb.latency_us),
            ratio_to_bare_blackboard_polled: ratio(&state_ours, &s_bbp.latency_us),
            ours_us: state_ours,
            ours_from_tick_start_us: percentiles_from_json(&planner["state_age_us"])
                .context("the planner's report has no state_age_us")?,
            bare_pubsub_spin: s_ps,
            bare_blackboard_spin: s_bb,
            bare_blackboard_polled: s_bbp,
            states_received: count("states_received"),
            states_skipped: count("states_skipped"),
        },
        guidance: GuidanceFigures {
            ours_us: report.guidance_latency_us,
            poll_part_us: diff(&g_psp.latency_us, &g_ps.latency_us),
            ratio_to_bare_pubsub_spin: ratio(&report.guidance_latency_us, &g_ps.latency_us),
            ratio_to_bare_pubsub_polled: ratio(&report.guidance_latency_us, &g_psp.latency_us),
            bare_pubsub_spin: g_ps,
            bare_pubsub_polled: g_psp,
        },
        goal: Goal {
            statement: "HapticState publish → planner receive p50 ≤ 1.5 × bare iceoryx2 \
                        publish-subscribe p50 (spinning subscriber), same payload, same run \
                        (median of the rounds' ratios)",
            ratio_p50: goal_ratio,
            met: goal_ratio <= 1.5,
        },
        loop_compute_us: report.compute_us,
        loop_deadline_misses: report.deadline_misses,
        loop_ticks: report.ticks,
        allocations_per_tick: report.allocations_per_tick,
    };
    print_table(&out);
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&out)? + "\n")
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    Ok(())
}

fn percentiles_from_json(v: &serde_json::Value) -> Option<Percentiles> {
    let f = |k: &str| v.get(k).and_then(|x| x.as_f64());
    Some(Percentiles {
        p50: f("p50")?,
        p90: f("p90")?,
        p99: f("p99")?,
        p999: f("p999")?,
        max: f("max")?,
        count: v.get("count")?.as_u64()?,
    })
}

fn payload_name<T: 'static>() -> &'static str {
    if std::any::TypeId::of::<T>() == std::any::TypeId::of::<Guidance>() {
        "guidance"
    } else {
        "state"
    }
}

/// One bare baseline: the writer on a thread here (at the RT options), the reader in a child
/// process.
fn baseline<T: Stamped>(
    bare: Bare,
    rt: RtOptions,
    reader_priority: u8,
) -> anyhow::Result<Baseline> {
    let ns = format!("ipcbare_{}_{}", std::process::id(), unique());
    let payload = payload_name::<T>();
    let poll_hz = match bare.poll {
        Poll::Busy => None,
        Poll::Every(hz) => Some(hz),
    };
    eprintln!(
        "  {} {payload}, reader {}",
        bare.pattern.name(),
        poll_hz.map_or("spinning".into(), |hz| format!("polling at {hz} Hz"))
    );
    let exe = std::env::current_exe()?;
    let writer = std::thread::Builder::new()
        .name("bare-writer".into())
        .spawn(move || -> anyhow::Result<(u64, Percentiles, Percentiles)> {
            // iceoryx2 ports are not Send: open them on this thread.
            let (node, _) = services::create_node(&format!("bare_tx_{}", std::process::id()))?;
            let writer = Writer::<T>::create(&node, &ns, bare.pattern)?;
            let mut child = Command::new(&exe)
                .arg("--bare-rx")
                .arg(format!(
                    "{}:{payload}:{}:{reader_priority}:{ns}",
                    bare.pattern.name(),
                    poll_hz.unwrap_or(0.0)
                ))
                .stdout(Stdio::piped())
                .spawn()
                .context("cannot start the bare reader")?;
            let stdout = child.stdout.take().context("no stdout")?;
            let mut lines = std::io::BufReader::new(stdout).lines();
            if lines.next().transpose()?.as_deref() != Some("ready") {
                let _ = child.kill();
                let _ = child.wait();
                bail!("the bare reader did not start");
            }
            let (written, write_ns) = writer.run(&bare, rt)?;
            let result = lines.next().transpose()?.unwrap_or_default();
            let status = child.wait()?;
            if !status.success() {
                bail!("the bare reader failed ({status})");
            }
            let v: serde_json::Value =
                serde_json::from_str(&result).context("the bare reader's output")?;
            let p = percentiles_from_json(&v).context("the bare reader's percentiles")?;
            Ok((written, p, write_ns.percentiles_us()))
        })?;
    let (written, latency_us, write_call_us) = writer
        .join()
        .map_err(|_| anyhow::anyhow!("the bare writer panicked"))??;
    Ok(Baseline {
        pattern: bare.pattern.name(),
        payload,
        poll_hz,
        write_rate_hz: bare.rate_hz,
        written,
        latency_us,
        write_call_us,
    })
}

fn unique() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// The child side of [`baseline`].
fn bare_reader(spec: &str) -> anyhow::Result<()> {
    let parts: Vec<&str> = spec.splitn(5, ':').collect();
    let [pattern, payload, poll_hz, priority, ns] = parts[..] else {
        bail!("--bare-rx wants PATTERN:PAYLOAD:POLL_HZ:PRIORITY:NAMESPACE, got '{spec}'");
    };
    let priority: u8 = priority.parse().context("--bare-rx priority")?;
    if priority > 0
        && let Err(e) = ipc_types::set_thread_fifo_priority(priority)
    {
        eprintln!("bare reader: {e}; it keeps the normal scheduler");
    }
    let pattern = Pattern::parse(pattern)?;
    let poll_hz: f64 = poll_hz.parse().context("--bare-rx poll rate")?;
    let poll = if poll_hz > 0.0 {
        Poll::Every(poll_hz)
    } else {
        Poll::Busy
    };
    let hist = match payload {
        "state" => ipc::read::<HapticState>(ns, pattern, poll)?,
        "guidance" => ipc::read::<Guidance>(ns, pattern, poll)?,
        _ => bail!("--bare-rx payload must be state or guidance, got '{payload}'"),
    };
    println!("{}", serde_json::to_string(&hist.percentiles_us())?);
    Ok(())
}

/// The real loop with a planner process; returns the loop report and the planner's JSON.
fn run_ours(
    args: &Args,
    rt: RtOptions,
) -> anyhow::Result<(haptic_loop::runner::LoopReport, serde_json::Value)> {
    let ns = format!("ipclat_{}", std::process::id());
    let json = std::env::temp_dir().join(format!("{ns}_planner.json"));
    let mut planner = PlannerChild::spawn_with(
        &ns,
        &[
            "--poll-hz".into(),
            args.poll_hz.to_string(),
            "--state-spin-us".into(),
            args.state_spin_us.to_string(),
            "--state-priority".into(),
            args.state_priority.to_string(),
            "--guidance-rate-hz".into(),
            args.guidance_rate_hz.to_string(),
            "--json".into(),
            json.display().to_string(),
        ],
    )?;
    let running = wall_loop(
        &ns,
        &WallLoop {
            rate_hz: args.rate_hz,
            rt,
            ticks: (args.seconds * args.rate_hz) as u64,
            voxel_m: args.contact.then_some(0.001),
        },
    )?;
    while !running.handle.is_finished() {
        std::thread::sleep(Duration::from_millis(50));
    }
    let (_tick, report) = running.handle.join();
    planner.stop();
    let text = std::fs::read_to_string(&json)
        .with_context(|| format!("the planner wrote no report to {}", json.display()))?;
    let _ = std::fs::remove_file(&json);
    Ok((report, serde_json::from_str(&text)?))
}

fn print_table(r: &Report) {
    let row = |name: &str, p: &Percentiles| {
        println!(
            "| {name} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} | {} |",
            p.p50, p.p90, p.p99, p.p999, p.max, p.count
        )
    };
    let ratios = |name: &str, q: &Triple| {
        println!(
            "| ours / {name} | {:.2} | | {:.2} | | {:.2} | |",
            q.p50, q.p99, q.max
        )
    };
    let s = &r.state;
    println!(
        "HapticState at {} Hz, loop publish → planner receiver phase-locked to the ticks, waking before each write and spinning for it (at most {} µs) ({} received, {} skipped)",
        r.rate_hz, r.state_spin_us, s.states_received, s.states_skipped
    );
    println!("| µs | p50 | p90 | p99 | p99.9 | max | n |");
    println!("|---|---|---|---|---|---|---|");
    row("ours: loop publish → planner", &s.ours_us);
    row("ours: tick start → planner", &s.ours_from_tick_start_us);
    row(
        &format!("bare blackboard, reader polling at {} Hz", r.state_poll_hz),
        &s.bare_blackboard_polled.latency_us,
    );
    row(
        "bare blackboard, reader spinning",
        &s.bare_blackboard_spin.latency_us,
    );
    row(
        "bare pub/sub, subscriber spinning",
        &s.bare_pubsub_spin.latency_us,
    );
    ratios("bare blackboard polled", &s.ratio_to_bare_blackboard_polled);
    ratios("bare blackboard spinning", &s.ratio_to_bare_blackboard_spin);
    ratios("bare pub/sub spinning", &s.ratio_to_bare_pubsub_spin);
    // Only the median is meaningful: the tails of the two readers are preemption.
    println!(
        "poll part (bare polled − bare spinning), p50: {:.1} µs",
        s.poll_part_us.p50
    );
    println!(
        "bare write calls, p50 / p99 µs: pub/sub send_copy {:.1} / {:.1}, blackboard update_with_copy {:.1} / {:.1}",
        s.bare_pubsub_spin.write_call_us.p50,
        s.bare_pubsub_spin.write_call_us.p99,
        s.bare_blackboard_spin.write_call_us.p50,
        s.bare_blackboard_spin.write_call_us.p99
    );
    let g = &r.guidance;
    println!();
    println!(
        "Guidance at {} Hz, planner stamp → first tick rendering it (relay woken by the planner's event, else polling at {} Hz)",
        r.guidance_rate_hz, r.relay_poll_hz
    );
    println!("| µs | p50 | p90 | p99 | p99.9 | max | n |");
    println!("|---|---|---|---|---|---|---|");
    row("ours: planner → tick", &g.ours_us);
    row(
        &format!("bare pub/sub, subscriber polling at {} Hz", r.relay_poll_hz),
        &g.bare_pubsub_polled.latency_us,
    );
    row(
        "bare pub/sub, subscriber spinning",
        &g.bare_pubsub_spin.latency_us,
    );
    ratios("bare pub/sub polled", &g.ratio_to_bare_pubsub_polled);
    ratios("bare pub/sub spinning", &g.ratio_to_bare_pubsub_spin);
    println!();
    for (i, round) in r.rounds.iter().enumerate() {
        println!(
            "round (sorted) {}: state p50 {:.1} µs vs bare pub/sub spinning {:.1} µs: ratio {:.2}",
            i + 1,
            round.ours_p50_us,
            round.bare_pubsub_spin_p50_us,
            round.ratio_p50
        );
    }
    println!(
        "goal: {}: ratio {:.2} → {}",
        r.goal.statement,
        r.goal.ratio_p50,
        if r.goal.met { "met" } else { "NOT met" }
    );
    println!(
        "same transport as ours (bare blackboard, spinning reader): ratio {:.2} (the RT writer cannot use publish-subscribe: one allocation per send)",
        r.state.ratio_to_bare_blackboard_spin.p50
    );
    println!(
        "loop: {} ticks, {} deadline misses, compute p50 {:.1} µs, p99 {:.1} µs, allocations/tick {}",
        r.loop_ticks,
        r.loop_deadline_misses,
        r.loop_compute_us.p50,
        r.loop_compute_us.p99,
        r.allocations_per_tick
            .map_or("n/a".into(), |a| a.to_string())
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_round_trip_through_json() {
        let p = Percentiles {
            p50: 1.5,
            p90: 2.0,
            p99: 3.0,
            p999: 4.0,
            max: 9.0,
            count: 12,
        };
        let v = serde_json::to_value(p).unwrap();
        assert_eq!(percentiles_from_json(&v), Some(p));
        assert_eq!(
            percentiles_from_json(&serde_json::json!({"p50": 1.0})),
            None
        );
    }

    #[test]
    fn ratios_are_per_percentile_and_nan_on_empty_baseline() {
        let a = Percentiles {
            p50: 3.0,
            p99: 8.0,
            max: 10.0,
            ..Percentiles::default()
        };
        let b = Percentiles {
            p50: 2.0,
            p99: 4.0,
            max: 5.0,
            ..Percentiles::default()
        };
        let r = ratio(&a, &b);
        assert_eq!((r.p50, r.p99, r.max), (1.5, 2.0, 2.0));
        assert!(ratio(&a, &Percentiles::default()).p50.is_nan());
    }
}
