//! Latency across `hrrtc-bridge`, beside bare Zenoh publish-subscribe of the same payload
//! sizes, in one run on one host (one clock, so one-way latencies are exact).
//!
//! Phases, one after the other (so they do not compete for the cores), `--rounds` times:
//! 1. **bare Zenoh**: two sessions in this process, one listening on loopback TCP, the
//!    other connected to it (peer mode, no multicast), an express publisher with
//!    `CongestionControl::Drop` (as the bridge's) and a callback subscriber. A
//!    `HapticState`-sized payload (552 bytes) at `--rate-hz`, and a `Guidance`-sized one
//!    (152 bytes) at `--guidance-rate-hz` the other way; the stamp is written just before
//!    `put`, read in the callback.
//! 2. **bridge**: two real `hrrtc-bridge` processes on this host, `--side loop` on
//!    namespace A and `--side planner` on namespace B, joined over loopback TCP (same key
//!    namespace). This process plays the loop (writes `HapticState` to A's blackboard at
//!    `--rate-hz`) and the planner (publishes `Guidance` on B and notifies B's guidance
//!    event at `--guidance-rate-hz`); a reader thread spins on B's blackboard (the
//!    transport alone, as a phase-locked planner reading just after the write) and a relay
//!    thread waits on A's guidance event, as the loop's relay does. One direction at a
//!    time, as in phase 1: first the state alone, then the guidance alone (the spinning
//!    reader takes a core of a 2-core machine, which would slow the guidance path beside
//!    it; a real planner spins only around the expected write). Each latency is from
//!    the stamp taken just before the local write to the reading thread's clock, by
//!    sequence number (the bridges re-stamp samples, so their stamps are not used).
//!
//! The goal's ratio is bridge / bare at p50 for each direction, the median over rounds.
//! Both phases run under a 0 µs CPU wake-up latency request, as on a host whose haptic loop
//! is running (`--no-cpu-latency-request` to leave it out).
//!
//! `cargo build --release -p hrrtc-bridge -p benches && target/release/bridge-latency --seconds 5`

use anyhow::{Context, bail};
use clap::Parser;
use ipc_types::latency::{NsHistogram, Percentiles};
use ipc_types::{Guidance, GuidanceMode, HapticState, Header, services};
use serde::Serialize;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;
use zenoh::Wait;
use zenoh::qos::CongestionControl;

/// Latency of the state and guidance paths through two bridges versus bare Zenoh.
#[derive(Debug, Parser)]
struct Args {
    /// Seconds of each phase.
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Rounds of (bare Zenoh, bridge).
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// State rate, Hz (the loop's tick rate).
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// Guidance rate, Hz (the planner's).
    #[arg(long, default_value_t = 100.0)]
    guidance_rate_hz: f64,
    /// The loop-side bridge's state poll period, µs (`hrrtc-bridge --state-poll-us`), used
    /// until it has locked onto the (SCHED_FIFO) writer's ticks.
    #[arg(long, default_value_t = 100)]
    state_poll_us: u64,
    /// The `hrrtc-bridge` executable (default: beside this one).
    #[arg(long)]
    bridge: Option<PathBuf>,
    /// Write the results as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Make no 0 µs CPU wake-up latency request during the run. By default it holds one
    /// (PM QoS), as a host running the haptic loop does while the loop runs; both phases
    /// have it.
    #[arg(long)]
    no_cpu_latency_request: bool,
}

/// One direction's latencies in one phase.
#[derive(Debug, Clone, Copy, Serialize)]
struct Row {
    state_us: Percentiles,
    guidance_us: Percentiles,
}

#[derive(Debug, Serialize)]
struct Round {
    bare: Row,
    bridge: Row,
    state_ratio_p50: f64,
    guidance_ratio_p50: f64,
}

#[derive(Debug, Serialize)]
struct Report {
    rounds: Vec<Round>,
    median_state_ratio_p50: f64,
    median_guidance_ratio_p50: f64,
}

const STATE_BYTES: usize = size_of::<HapticState>();
const GUIDANCE_BYTES: usize = size_of::<Guidance>();
/// Publish times by sequence, for the bridge phase.
const RING: usize = 1 << 14;

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    anyhow::ensure!(
        args.seconds > 0.0 && args.rate_hz > 0.0 && args.guidance_rate_hz > 0.0,
        "--seconds, --rate-hz and --guidance-rate-hz must be positive"
    );
    let bridge = match &args.bridge {
        Some(p) => p.clone(),
        None => std::env::current_exe()?
            .parent()
            .context("this executable's folder")?
            .join("hrrtc-bridge"),
    };
    if !bridge.exists() {
        bail!(
            "{} not found: build it (`cargo build --release -p hrrtc-bridge`) or give --bridge",
            bridge.display()
        );
    }
    let _cpu_latency = if args.no_cpu_latency_request {
        None
    } else {
        match haptic_loop::rt::CpuLatencyRequest::open(0) {
            Ok(r) => Some(r),
            Err(e) => {
                eprintln!("no CPU wake-up latency request (/dev/cpu_dma_latency: {e})");
                None
            }
        }
    };
    let mut rounds = Vec::new();
    for r in 0..args.rounds {
        let bare = bare_zenoh(&args, 17_600 + 2 * r as u16)?;
        let bridged = through_bridges(&args, &bridge, 17_601 + 2 * r as u16, r)?;
        let round = Round {
            state_ratio_p50: bridged.state_us.p50 / bare.state_us.p50,
            guidance_ratio_p50: bridged.guidance_us.p50 / bare.guidance_us.p50,
            bare,
            bridge: bridged,
        };
        print_round(r, &round);
        rounds.push(round);
    }
    let median = |f: fn(&Round) -> f64| {
        let mut v: Vec<f64> = rounds.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let report = Report {
        median_state_ratio_p50: median(|r| r.state_ratio_p50),
        median_guidance_ratio_p50: median(|r| r.guidance_ratio_p50),
        rounds,
    };
    println!(
        "median over {} rounds, bridge / bare Zenoh at p50: state {:.2}, guidance {:.2}",
        report.rounds.len(),
        report.median_state_ratio_p50,
        report.median_guidance_ratio_p50
    );
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

fn print_round(r: u32, round: &Round) {
    println!("round {}:", r + 1);
    println!(
        "  {:<28} {:>8} {:>8} {:>8} {:>8} {:>7}",
        "µs", "p50", "p99", "p99.9", "max", "count"
    );
    let line = |name: &str, p: &Percentiles| {
        println!(
            "  {name:<28} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>7}",
            p.p50, p.p99, p.p999, p.max, p.count
        )
    };
    line("state, bare Zenoh", &round.bare.state_us);
    line("state, loop → bridges → B", &round.bridge.state_us);
    line("guidance, bare Zenoh", &round.bare.guidance_us);
    line("guidance, B → bridges → A", &round.bridge.guidance_us);
    println!(
        "  ratio at p50: state {:.2}, guidance {:.2}",
        round.state_ratio_p50, round.guidance_ratio_p50
    );
}

fn zenoh_session(listen: Option<u16>, connect: Option<u16>) -> anyhow::Result<zenoh::Session> {
    let mut c = zenoh::Config::default();
    let list = |p: Option<u16>| p.map_or("[]".to_owned(), |p| format!("[\"tcp/127.0.0.1:{p}\"]"));
    for (k, v) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", list(listen)),
        ("connect/endpoints", list(connect)),
    ] {
        c.insert_json5(k, &v)
            .map_err(|e| anyhow::anyhow!("{k}: {e}"))?;
    }
    zenoh::open(c)
        .wait()
        .map_err(|e| anyhow::anyhow!("zenoh: {e}"))
}

/// Publishes stamped payloads of `bytes` from `from` to `to` on `key` at `rate_hz` for
/// `seconds`; the latencies the subscriber saw.
fn bare_direction(
    from: &zenoh::Session,
    to: &zenoh::Session,
    key: &str,
    bytes: usize,
    rate_hz: f64,
    seconds: f64,
) -> anyhow::Result<Percentiles> {
    let hist = Arc::new(std::sync::Mutex::new(NsHistogram::new()));
    let sub = {
        let hist = hist.clone();
        to.declare_subscriber(key)
            .callback(move |s| {
                let now = ipc_types::monotonic_ns();
                let b = s.payload().to_bytes();
                if b.len() >= 8 {
                    let mut t = [0u8; 8];
                    t.copy_from_slice(&b[..8]);
                    let sent = u64::from_le_bytes(t);
                    hist.lock().unwrap().record(now.saturating_sub(sent));
                }
            })
            .wait()
            .map_err(|e| anyhow::anyhow!("{e}"))?
    };
    let publisher = from
        .declare_publisher(key.to_owned())
        .congestion_control(CongestionControl::Drop)
        .express(true)
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    // Let the subscription reach the publisher's side.
    std::thread::sleep(Duration::from_millis(500));
    let period = (1e9 / rate_hz) as u64;
    let n = (seconds * rate_hz) as u64;
    let mut next = ipc_types::monotonic_ns();
    let mut payload = vec![0u8; bytes];
    for _ in 0..n {
        next += period;
        ipc_types::sleep_until_ns(next);
        payload[..8].copy_from_slice(&ipc_types::monotonic_ns().to_le_bytes());
        let _ = publisher.put(payload.clone()).wait();
    }
    std::thread::sleep(Duration::from_millis(100));
    drop(sub);
    let p = hist.lock().unwrap().percentiles_us();
    Ok(p)
}

fn bare_zenoh(args: &Args, port: u16) -> anyhow::Result<Row> {
    let a = zenoh_session(Some(port), None)?;
    let b = zenoh_session(None, Some(port))?;
    let state_us = bare_direction(
        &a,
        &b,
        "bench/bare/state",
        STATE_BYTES,
        args.rate_hz,
        args.seconds,
    )?;
    let guidance_us = bare_direction(
        &b,
        &a,
        "bench/bare/guidance",
        GUIDANCE_BYTES,
        args.guidance_rate_hz,
        args.seconds,
    )?;
    let _ = b.close().wait();
    let _ = a.close().wait();
    Ok(Row {
        state_us,
        guidance_us,
    })
}

struct Kill(Child);

impl Drop for Kill {
    fn drop(&mut self) {
        // SAFETY: kill(2) on our own child, not yet reaped.
        unsafe { libc::kill(self.0.id() as libc::pid_t, libc::SIGTERM) };
        let _ = self.0.wait();
    }
}

/// Publish stamps by sequence number (`RING` slots), shared with a reading thread.
fn sent_stamps() -> Arc<Vec<AtomicU64>> {
    Arc::new((0..RING).map(|_| AtomicU64::new(0)).collect())
}

fn through_bridges(
    args: &Args,
    bridge: &std::path::Path,
    port: u16,
    round: u32,
) -> anyhow::Result<Row> {
    let pid = std::process::id();
    let ns_a = format!("bench_bridge_a_{pid}_{round}");
    let ns_b = format!("bench_bridge_b_{pid}_{round}");
    let keys = format!("bench_bridge_{pid}_{round}");
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let poll = args.state_poll_us.to_string();
    let spawn = |side: &str, ns: &str, how: &str| -> anyhow::Result<Kill> {
        let child = Command::new(bridge)
            .args([
                "--side",
                side,
                "--namespace",
                ns,
                "--key-namespace",
                &keys,
                how,
                &endpoint,
                "--state-poll-us",
                &poll,
                "--no-roadmap",
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .with_context(|| format!("starting {}", bridge.display()))?;
        Ok(Kill(child))
    };
    // The loop side first: the planner side's state writer, and the ports both open,
    // exist before this process opens them.
    let (node, _) = services::create_node("bench_bridge")?;
    let state_writer = services::state_writer(&node, &ns_a)?;
    let guidance_pub = services::publisher::<Guidance>(&node, &ns_b)?;
    let guidance_event = services::guidance_notifier(&node, &ns_b)?;
    let _a = spawn("loop", &ns_a, "--listen")?;
    std::thread::sleep(Duration::from_millis(300));
    let _b = spawn("planner", &ns_b, "--connect")?;
    std::thread::sleep(Duration::from_millis(1500));

    // One direction at a time, as in the bare phase: the state reader spins (a core of
    // this 2-core machine), which would slow the guidance path beside it.
    let state = {
        let sent = sent_stamps();
        let stop = Arc::new(AtomicBool::new(false));
        // Reader of B's state blackboard, spinning.
        let reader = {
            let (stop, sent, ns_b) = (stop.clone(), sent.clone(), ns_b.clone());
            std::thread::spawn(move || -> anyhow::Result<NsHistogram> {
                let (node, _) = services::create_node("bench_bridge_rx")?;
                let mut hist = NsHistogram::new();
                // B's blackboard is the planner-side bridge's: wait until it exists.
                let reader = loop {
                    if let Ok(r) = services::state_reader(&node, &ns_b) {
                        break r;
                    }
                    std::thread::sleep(Duration::from_millis(10));
                };
                let mut last = 0;
                while !stop.load(Ordering::Acquire) {
                    let seq = reader.get().header.sequence;
                    if seq != last && seq != 0 {
                        let now = ipc_types::monotonic_ns();
                        let t = sent[seq as usize % RING].load(Ordering::Acquire);
                        if t != 0 {
                            hist.record(now.saturating_sub(t));
                        }
                        last = seq;
                    }
                    std::hint::spin_loop();
                }
                Ok(hist)
            })
        };
        std::thread::sleep(Duration::from_millis(200));
        // Written from a SCHED_FIFO thread, as the loop's RT thread writes it: the
        // loop-side bridge phase-locks its reads only to a real-time writer.
        let period = (1e9 / args.rate_hz) as u64;
        let n = (args.seconds * args.rate_hz) as u64;
        let writer = {
            let sent = sent.clone();
            std::thread::spawn(move || {
                let fifo = ipc_types::set_thread_fifo_priority(80).is_ok();
                let mut next = ipc_types::monotonic_ns();
                for seq in 1..=n {
                    next += period;
                    ipc_types::sleep_until_ns(next);
                    let mut s = HapticState {
                        header: Header {
                            sequence: seq,
                            timestamp_ns: ipc_types::monotonic_ns(),
                            writer_pid: pid,
                            reserved: 0,
                        },
                        user_pose: ipc_types::Pose::IDENTITY,
                        proxy_pose: ipc_types::Pose::IDENTITY,
                        ..HapticState::default()
                    };
                    let t = ipc_types::monotonic_ns();
                    s.published_ns = t;
                    sent[seq as usize % RING].store(t, Ordering::Release);
                    state_writer.update_with_copy(s);
                }
                fifo
            })
        };
        if !writer
            .join()
            .map_err(|_| anyhow::anyhow!("state writer panicked"))?
        {
            eprintln!(
                "no SCHED_FIFO for the state writer: the loop-side bridge polled every {} µs",
                args.state_poll_us
            );
        }
        std::thread::sleep(Duration::from_millis(100));
        stop.store(true, Ordering::Release);
        reader
            .join()
            .map_err(|_| anyhow::anyhow!("reader panicked"))??
    };
    let guidance = {
        let sent = sent_stamps();
        let stop = Arc::new(AtomicBool::new(false));
        // A's guidance, as the loop's relay receives it.
        let relay = {
            let (stop, sent, ns_a) = (stop.clone(), sent.clone(), ns_a.clone());
            std::thread::spawn(move || -> anyhow::Result<NsHistogram> {
                let (node, _) = services::create_node("bench_bridge_relay")?;
                let sub = services::subscriber::<Guidance>(&node, &ns_a)?;
                let listener = services::guidance_listener(&node, &ns_a)?;
                let mut hist = NsHistogram::new();
                while !stop.load(Ordering::Acquire) {
                    let _ = listener.timed_wait(|_| {}, Duration::from_millis(1));
                    while let Ok(Some(g)) = sub.receive() {
                        let now = ipc_types::monotonic_ns();
                        let t = sent[g.header.sequence as usize % RING].load(Ordering::Acquire);
                        if t != 0 {
                            hist.record(now.saturating_sub(t));
                        }
                    }
                }
                Ok(hist)
            })
        };
        std::thread::sleep(Duration::from_millis(200));
        let period = (1e9 / args.guidance_rate_hz) as u64;
        let n = (args.seconds * args.guidance_rate_hz) as u64;
        let mut next = ipc_types::monotonic_ns();
        for g_seq in 1..=n {
            next += period;
            ipc_types::sleep_until_ns(next);
            let g = Guidance {
                header: Header {
                    sequence: g_seq,
                    timestamp_ns: ipc_types::monotonic_ns(),
                    writer_pid: pid,
                    reserved: 0,
                },
                mode: GuidanceMode::ROADMAP,
                time_to_live_ns: 100_000_000,
                planner_id: 1,
                ..Guidance::default()
            };
            sent[g_seq as usize % RING].store(ipc_types::monotonic_ns(), Ordering::Release);
            let _ = guidance_pub.send_copy(g);
            let _ = guidance_event.notify();
        }
        std::thread::sleep(Duration::from_millis(100));
        stop.store(true, Ordering::Release);
        relay
            .join()
            .map_err(|_| anyhow::anyhow!("relay panicked"))??
    };
    Ok(Row {
        state_us: state.percentiles_us(),
        guidance_us: guidance.percentiles_us(),
    })
}
