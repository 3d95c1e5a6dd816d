//! Latency of the haptic state from the loop's write to a ROS 2 subscriber on the same host,
//! through `hrrtc-ros2 serve`, beside bare Zenoh publish-subscribe of the same payload size
//! between two processes, interleaved in one run (one clock, so one-way latencies are exact).
//!
//! Each round starts a real `hrrtc-ros2 serve` on its own namespace, listening on loopback
//! TCP, and:
//!
//! - this process plays the loop: a SCHED_FIFO thread (when permitted, as the loop's RT
//!   thread) writes the state blackboard at `--rate-hz`, each state stamped just before its
//!   write; the gateway reads it phase-locked to these writes and publishes the tick's topics
//!   on rmw_zenoh's wire;
//! - a subscriber in this process, connected to the gateway as an rmw_zenoh node would be,
//!   takes each `object_pose` (the tick's first topic) and `/tf` (its last), checks the
//!   attachment, decodes the CDR payload, and records arrival − the tick's stamp (the
//!   header's ROS time turned back into `CLOCK_MONOTONIC` with both clocks read at
//!   arrival: exact to a fraction of a microsecond on one host);
//! - a child process (this executable, `--bare-pub`) puts a payload of `object_pose`'s size,
//!   stamped just before the put, half a period after each write, to a subscriber in this
//!   process, from a thread at the gateway's state thread's priority (SCHED_FIFO 10 when
//!   permitted): bare Zenoh between two processes, as the gateway's path is.
//!
//! The goal's ratio is ROS 2 (`object_pose`) / bare Zenoh at p50, the median over rounds.
//!
//! `cargo build --release -p hrrtc-ros2 -p benches && target/release/ros2-latency --seconds 5`

use anyhow::Context;
use clap::Parser;
use hrrtc_ros2::clock::Clocks;
use hrrtc_ros2::msgs::{Message, PoseStamped, TfMessage};
use hrrtc_ros2::rmw::{self, Attachment, Distro, TypeInfo};
use ipc_types::latency::{NsHistogram, Percentiles};
use ipc_types::{HapticState, Header, services};
use serde::Serialize;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;
use zenoh::qos::CongestionControl;

/// State latency through the ROS 2 gateway versus bare Zenoh.
#[derive(Debug, Parser)]
struct Args {
    /// Seconds measured per round (after a second of warm-up).
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Rounds (a fresh gateway and sessions each).
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// The loop's tick rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// The `hrrtc-ros2` executable (default: beside this one).
    #[arg(long)]
    gateway: Option<PathBuf>,
    /// More `hrrtc-ros2 serve` options, as one string (e.g. "--state-spin-us 0").
    #[arg(long, allow_hyphen_values = true)]
    gateway_args: Option<String>,
    /// Write the results as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Make no 0 µs CPU wake-up latency request during the run (by default one is held, as
    /// on a host whose haptic loop runs).
    #[arg(long)]
    no_cpu_latency_request: bool,
    /// Internal: be the bare path's publisher, connected to this port.
    #[arg(long, hide = true)]
    bare_pub: Option<u16>,
    /// Internal: its key.
    #[arg(long, hide = true, default_value = "")]
    bare_key: String,
    /// Internal: `CLOCK_MONOTONIC` of its first period's start, ns.
    #[arg(long, hide = true, default_value_t = 0)]
    bare_start_ns: u64,
    /// Internal: samples to put.
    #[arg(long, hide = true, default_value_t = 0)]
    bare_count: u64,
    /// Internal: payload bytes.
    #[arg(long, hide = true, default_value_t = 0)]
    bare_bytes: usize,
}

#[derive(Debug, Clone, Copy, Serialize)]
struct Round {
    /// Bare Zenoh between two processes, µs.
    bare: Percentiles,
    /// Write → `object_pose` at a ROS 2 subscriber, µs.
    ros2_first: Percentiles,
    /// Write → `/tf` (the tick's last topic), µs.
    ros2_last: Percentiles,
    /// `ros2_first` / `bare` at p50.
    ratio_p50: f64,
    /// `ros2_first` / `bare` at p99.
    ratio_p99: f64,
    /// Whether the writer had SCHED_FIFO (the gateway then phase-locks to it).
    fifo: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    rounds: Vec<Round>,
    median_ratio_p50: f64,
    median_ratio_p99: f64,
    payload_bytes: usize,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if let Some(port) = args.bare_pub {
        return bare_pub(&args, port);
    }
    anyhow::ensure!(
        args.seconds > 0.0 && args.rate_hz > 0.0 && args.rounds > 0,
        "--seconds, --rate-hz and --rounds must be positive"
    );
    let gateway = benches::across::sibling_exe(
        args.gateway.as_deref(),
        "hrrtc-ros2",
        "hrrtc-ros2",
        "--gateway",
    )?;
    let _cpu_latency = benches::across::cpu_latency_request(args.no_cpu_latency_request);
    let mut rounds = Vec::new();
    let mut payload_bytes = 0;
    for r in 0..args.rounds {
        let (round, bytes) = one_round(&args, &gateway, r)?;
        payload_bytes = bytes;
        print_round(r, &round);
        rounds.push(round);
    }
    let median = |f: fn(&Round) -> f64| {
        let mut v: Vec<f64> = rounds.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let report = Report {
        median_ratio_p50: median(|r| r.ratio_p50),
        median_ratio_p99: median(|r| r.ratio_p99),
        payload_bytes,
        rounds,
    };
    println!(
        "median over {} rounds, ROS 2 (object_pose, {} B) / bare Zenoh: p50 {:.2}, p99 {:.2}",
        report.rounds.len(),
        report.payload_bytes,
        report.median_ratio_p50,
        report.median_ratio_p99
    );
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

fn print_round(r: u32, round: &Round) {
    println!(
        "round {} (writer {}):",
        r + 1,
        if round.fifo {
            "SCHED_FIFO, gateway phase-locked"
        } else {
            "no SCHED_FIFO, gateway polling"
        }
    );
    println!(
        "  {:<40} {:>8} {:>8} {:>8} {:>8} {:>7}",
        "µs", "p50", "p99", "p99.9", "max", "count"
    );
    let line = |name: &str, p: &Percentiles| {
        println!(
            "  {name:<40} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>7}",
            p.p50, p.p99, p.p999, p.max, p.count
        )
    };
    line("bare Zenoh, two processes", &round.bare);
    line("loop write → ROS 2 object_pose", &round.ros2_first);
    line("loop write → ROS 2 /tf (last of tick)", &round.ros2_last);
    println!(
        "  ROS 2 / bare: p50 {:.2}, p99 {:.2}",
        round.ratio_p50, round.ratio_p99
    );
}

/// The child: puts `bare_count` stamped payloads, each half a period after a write.
fn bare_pub(args: &Args, port: u16) -> anyhow::Result<()> {
    let s = benches::across::zenoh_session(None, Some(port))?;
    let p = s
        .declare_publisher(args.bare_key.clone())
        .congestion_control(CongestionControl::Drop)
        .express(true)
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    // As the gateway's state thread: SCHED_FIFO 10 when permitted, 1 µs timer slack.
    let _ = ipc_types::set_thread_fifo_priority(10);
    ipc_types::set_thread_timer_slack_ns(1_000);
    let period = (1e9 / args.rate_hz) as u64;
    for i in 0..args.bare_count {
        ipc_types::sleep_until_ns(args.bare_start_ns + i * period + period / 2);
        let mut payload = vec![0u8; args.bare_bytes.max(8)];
        payload[..8].copy_from_slice(&ipc_types::monotonic_ns().to_le_bytes());
        let _ = p.put(payload).wait();
    }
    let _ = s.close().wait();
    Ok(())
}

struct Kill(Child);

impl Drop for Kill {
    fn drop(&mut self) {
        // SAFETY: kill(2) on our own child, not yet reaped.
        unsafe { libc::kill(self.0.id() as libc::pid_t, libc::SIGTERM) };
        let _ = self.0.wait();
    }
}

/// Whether latencies are being recorded (off during warm-up).
struct Recorder {
    on: AtomicBool,
    hist: Mutex<NsHistogram>,
}

impl Recorder {
    fn new() -> Arc<Self> {
        Arc::new(Recorder {
            on: AtomicBool::new(false),
            hist: Mutex::new(NsHistogram::new()),
        })
    }

    fn record(&self, ns: u64) {
        if self.on.load(Ordering::Acquire) {
            self.hist.lock().unwrap().record(ns);
        }
    }
}

/// A ROS 2 subscriber of `M` on `key`: checks the attachment, decodes, and records arrival −
/// the header stamp `stamp(msg)` turned back into `CLOCK_MONOTONIC`.
fn ros2_subscriber<M: Message + 'static>(
    z: &zenoh::Session,
    key: String,
    rec: Arc<Recorder>,
    stamp: fn(&M) -> Option<hrrtc_ros2::msgs::Time>,
) -> anyhow::Result<zenoh::pubsub::Subscriber<()>> {
    z.declare_subscriber(key)
        .callback(move |s| {
            let now = Clocks::now();
            let attachment = s.attachment().map(|a| a.to_bytes());
            if Attachment::decode(attachment.as_deref()).is_err() {
                return;
            }
            if let Ok(m) = M::decode(&s.payload().to_bytes())
                && let Some(t) = stamp(&m)
            {
                let sent = now.to_monotonic_ns(t);
                rec.record((now.monotonic_ns as i64 - sent).max(0) as u64);
            }
        })
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))
}

fn one_round(args: &Args, gateway: &std::path::Path, round: u32) -> anyhow::Result<(Round, usize)> {
    let pid = std::process::id();
    let ns = format!("bench_ros2_{pid}_{round}");
    let ros_ns = format!("/bench_ros2_{pid}_{round}");
    let (ros_port, bare_port) = (17_700 + 2 * round as u16, 17_701 + 2 * round as u16);
    let (node, _) = services::create_node("bench_ros2")?;
    let writer = services::state_writer(&node, &ns)?;
    let _gw = Kill(
        Command::new(gateway)
            .args(["serve", "--namespace", &ns, "--ros-namespace", &ros_ns])
            .args([
                "--no-connect",
                "--listen",
                &format!("tcp/127.0.0.1:{ros_port}"),
            ])
            .args(["--scene", "none"])
            .args(
                args.gateway_args
                    .as_deref()
                    .unwrap_or_default()
                    .split_whitespace(),
            )
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .with_context(|| format!("starting {}", gateway.display()))?,
    );
    std::thread::sleep(Duration::from_millis(500));
    let z = benches::across::zenoh_session(Some(bare_port), Some(ros_port))?;
    let key = |topic: &str, ty| rmw::topic_key(0, topic, &TypeInfo::of(ty, Distro::Jazzy));
    let first = Recorder::new();
    let last = Recorder::new();
    let bare = Recorder::new();
    let _first = ros2_subscriber::<PoseStamped>(
        &z,
        key(&format!("{ros_ns}/object_pose"), PoseStamped::TYPE),
        first.clone(),
        |m| Some(m.header.stamp),
    )?;
    let _last = ros2_subscriber::<TfMessage>(&z, key("/tf", TfMessage::TYPE), last.clone(), |m| {
        m.transforms.first().map(|t| t.header.stamp)
    })?;
    let bare_key = format!("bench/ros2/bare/{pid}/{round}");
    let _bare = {
        let bare = bare.clone();
        z.declare_subscriber(bare_key.clone())
            .callback(move |s| {
                let now = ipc_types::monotonic_ns();
                let b = s.payload().to_bytes();
                if b.len() >= 8 {
                    let mut t = [0u8; 8];
                    t.copy_from_slice(&b[..8]);
                    bare.record(now.saturating_sub(u64::from_le_bytes(t)));
                }
            })
            .wait()
            .map_err(|e| anyhow::anyhow!("{e}"))?
    };
    // The bare payload has object_pose's size (frame id included).
    let sample = PoseStamped {
        header: hrrtc_ros2::msgs::Header {
            frame_id: format!("{}/scene", ros_ns.trim_start_matches('/')),
            ..Default::default()
        },
        ..Default::default()
    };
    let bytes = sample.encode().len();
    let period = (1e9 / args.rate_hz) as u64;
    let warm = (args.rate_hz) as u64;
    let n = warm + (args.seconds * args.rate_hz) as u64;
    let start = ipc_types::monotonic_ns() + 1_000_000_000;
    let _child = Kill(
        Command::new(std::env::current_exe()?)
            .args([
                "--bare-pub",
                &bare_port.to_string(),
                "--bare-key",
                &bare_key,
            ])
            .args(["--bare-start-ns", &start.to_string()])
            .args(["--bare-count", &n.to_string()])
            .args(["--bare-bytes", &bytes.to_string()])
            .args(["--rate-hz", &args.rate_hz.to_string()])
            .stdin(Stdio::null())
            .spawn()
            .context("starting the bare publisher (this executable, --bare-pub)")?,
    );
    let writer_thread = std::thread::spawn(move || {
        let fifo = ipc_types::set_thread_fifo_priority(80).is_ok();
        for seq in 1..=n {
            ipc_types::sleep_until_ns(start + (seq - 1) * period);
            let t = ipc_types::monotonic_ns();
            writer.update_with_copy(HapticState {
                header: Header::new(seq, t, pid),
                published_ns: t,
                ..HapticState::default()
            });
        }
        fifo
    });
    // Record after the warm-up second.
    ipc_types::sleep_until_ns(start + warm * period);
    for r in [&first, &last, &bare] {
        r.on.store(true, Ordering::Release);
    }
    let fifo = writer_thread
        .join()
        .map_err(|_| anyhow::anyhow!("the state writer panicked"))?;
    std::thread::sleep(Duration::from_millis(200));
    for r in [&first, &last, &bare] {
        r.on.store(false, Ordering::Release);
    }
    let p = |r: &Recorder| r.hist.lock().unwrap().percentiles_us();
    let (b, f, l) = (p(&bare), p(&first), p(&last));
    anyhow::ensure!(
        b.count > 0 && f.count > 0,
        "no samples (bare {}, ROS 2 {}): did hrrtc-ros2 start?",
        b.count,
        f.count
    );
    let _ = z.close().wait();
    Ok((
        Round {
            bare: b,
            ros2_first: f,
            ros2_last: l,
            ratio_p50: f.p50 / b.p50,
            ratio_p99: f.p99 / b.p99,
            fifo,
        },
        bytes,
    ))
}
