//! Latency of the haptic state from the loop's write to a ROS 2 subscriber on the same host,
//! through `hrrtc-ros2 serve` over mutual TLS and over plain TCP, beside bare Zenoh
//! publish-subscribe of the same payload size between two processes, interleaved in one run
//! (one clock, so one-way latencies are exact).
//!
//! Each round starts two real `hrrtc-ros2 serve`, each on its own namespace: one listening
//! on loopback TCP (`--insecure`), one on loopback mutual TLS (`--tls-ca`, `--tls-cert`,
//! `--tls-key`, with certificates made once per run by `hrrtc-bridge certs`; the gateway
//! has no access control of its own to turn on), and:
//!
//! - this process plays the loop for both: a SCHED_FIFO thread (when permitted, as the
//!   loop's RT thread) writes each gateway's state blackboard at `--rate-hz`, each state
//!   stamped just before its write: the TCP gateway's at each period's start and the TLS
//!   gateway's two thirds into it (the other way round in every other round); each
//!   gateway reads its blackboard phase-locked to these writes and publishes the tick's
//!   topics on rmw_zenoh's wire;
//! - a subscriber per gateway in this process, connected to it as an rmw_zenoh node would
//!   be (over TLS with a client certificate of the same lab), takes each `object_pose`
//!   (the tick's first topic) and `/tf` (its last), checks the attachment, decodes the CDR
//!   payload, and records arrival − the tick's stamp (the header's ROS time turned back
//!   into `CLOCK_MONOTONIC` with both clocks read at arrival: exact to a fraction of a
//!   microsecond on one host);
//! - a child process (this executable, `--bare-pub`) puts a payload of `object_pose`'s size,
//!   stamped just before the put, a third of a period after each period's start, to a
//!   subscriber in this process over TCP, from a thread at the gateway's state thread's
//!   priority (SCHED_FIFO 10 when permitted): bare Zenoh between two processes, as the
//!   gateway's path is. Each of the three paths has its own session in this process.
//!
//! The ratios, each the median over rounds: TLS / TCP (`object_pose`) at p50 and p99, with
//! the largest latency of each; and ROS 2 over TCP / bare Zenoh at p50 and p99, as before
//! issue 54. Each gateway's exit summary is read back: a round fails unless the TLS gateway
//! ran over mutual TLS, the TCP one as `--insecure`, and both published.
//!
//! `cargo build --release -p hrrtc-ros2 -p hrrtc-bridge -p benches &&
//! target/release/ros2-latency --seconds 5`

use anyhow::Context;
use benches::across::{Lab, Product};
use benches::across::{
    PathOf, PathSummary, median, print_round_table, print_summary_table, summarize,
};
use clap::Parser;
use hrrtc_ros2::clock::Clocks;
use hrrtc_ros2::msgs::{Message, PoseStamped, TfMessage};
use hrrtc_ros2::rmw::{self, Attachment, Distro, TypeInfo};
use ipc_types::latency::{NsHistogram, Percentiles};
use ipc_types::{HapticState, Header, services};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;
use zenoh::qos::CongestionControl;

/// State latency through the ROS 2 gateway over mutual TLS and over plain TCP, versus bare
/// Zenoh.
#[derive(Debug, Parser)]
struct Args {
    /// The mutually authenticated link measured against plain TCP: `quic` (Zenoh's QUIC,
    /// TLS 1.3 over UDP) or `tls` (Zenoh's TLS over TCP).
    #[arg(long, default_value = "quic")]
    secure_link: String,
    /// Seconds measured per round (after a second of warm-up).
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Rounds (fresh gateways and sessions each).
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// The loop's tick rate, Hz.
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// The `hrrtc-ros2` executable (default: beside this one).
    #[arg(long)]
    gateway: Option<PathBuf>,
    /// The `hrrtc-bridge` executable, which makes the run's certificates (default: beside
    /// this one).
    #[arg(long)]
    bridge: Option<PathBuf>,
    /// More `hrrtc-ros2 serve` options for both gateways, as one string (e.g.
    /// "--state-spin-us 0").
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
    /// Internal: its put's offset into each period, ns.
    #[arg(long, hide = true, default_value_t = 0)]
    bare_offset_ns: u64,
    /// Internal: samples to put.
    #[arg(long, hide = true, default_value_t = 0)]
    bare_count: u64,
    /// Internal: payload bytes.
    #[arg(long, hide = true, default_value_t = 0)]
    bare_bytes: usize,
}

#[derive(Debug, Serialize)]
struct Round {
    /// The TLS gateway's write came first in each period.
    tls_first: bool,
    /// Bare Zenoh between two processes (TCP), µs.
    bare: Percentiles,
    /// Write → `object_pose` at a ROS 2 subscriber, through the TCP gateway, µs.
    ros2_first: Percentiles,
    /// Write → `/tf` (the tick's last topic), through the TCP gateway, µs.
    ros2_last: Percentiles,
    /// Write → `object_pose`, through the mutual-TLS gateway, µs.
    ros2_first_tls: Percentiles,
    /// Write → `/tf`, through the mutual-TLS gateway, µs.
    ros2_last_tls: Percentiles,
    /// `ros2_first` / `bare` at p50.
    ratio_p50: f64,
    /// `ros2_first` / `bare` at p99.
    ratio_p99: f64,
    /// `ros2_first_tls` / `ros2_first` at p50.
    tls_ratio_p50: f64,
    /// `ros2_first_tls` / `ros2_first` at p99.
    tls_ratio_p99: f64,
    /// `ros2_first_tls` / `bare` at p50.
    tls_bare_ratio_p50: f64,
    /// Whether the writer had SCHED_FIFO (the gateways then phase-lock to it).
    fifo: bool,
    /// What each gateway said at exit (TCP, TLS).
    checks: [String; 2],
}

#[derive(Debug, Serialize)]
struct Report {
    rounds: Vec<Round>,
    paths: Vec<PathSummary>,
    median_ratio_p50: f64,
    median_ratio_p99: f64,
    median_tls_ratio_p50: f64,
    median_tls_ratio_p99: f64,
    median_tls_bare_ratio_p50: f64,
    payload_bytes: usize,
}

/// The lab's hosts: the gateway's (listening on 127.0.0.1) and the ROS 2 node's.
const LAB: [&str; 2] = ["gateway=127.0.0.1", "ros2-node"];

/// Every path, as printed, and where a round keeps it.
const PATHS: [PathOf<Round>; 5] = [
    ("bare Zenoh, two processes (TCP)", |r| r.bare),
    ("loop write → ROS 2 object_pose, TCP", |r| r.ros2_first),
    ("loop write → ROS 2 /tf (last of tick), TCP", |r| {
        r.ros2_last
    }),
    ("loop write → ROS 2 object_pose, TLS", |r| {
        r.ros2_first_tls
    }),
    ("loop write → ROS 2 /tf (last of tick), TLS", |r| {
        r.ros2_last_tls
    }),
];

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    benches::across::set_secure_link(&args.secure_link)?;
    if let Some(port) = args.bare_pub {
        return bare_pub(&args, port);
    }
    println!(
        "TLS below: mutual TLS over {}/ (--secure-link), against plain tcp/ with --insecure",
        benches::across::secure_link()
    );
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
    let bridge = benches::across::sibling_exe(
        args.bridge.as_deref(),
        "hrrtc-bridge",
        "hrrtc-bridge",
        "--bridge",
    )?;
    let lab = Lab::make(&bridge, "ros2-latency", &LAB)?;
    let _cpu_latency = benches::across::cpu_latency_request(args.no_cpu_latency_request);
    let mut rounds = Vec::new();
    let mut payload_bytes = 0;
    for r in 0..args.rounds {
        let (round, bytes) = one_round(&args, &gateway, &lab, r, r % 2 == 1)?;
        payload_bytes = bytes;
        print_round(r, &round);
        rounds.push(round);
    }
    let median = |f: fn(&Round) -> f64| median(&rounds, f);
    let paths = summarize(&rounds, &PATHS);
    let report = Report {
        median_ratio_p50: median(|r| r.ratio_p50),
        median_ratio_p99: median(|r| r.ratio_p99),
        median_tls_ratio_p50: median(|r| r.tls_ratio_p50),
        median_tls_ratio_p99: median(|r| r.tls_ratio_p99),
        median_tls_bare_ratio_p50: median(|r| r.tls_bare_ratio_p50),
        payload_bytes,
        paths,
        rounds,
    };
    print_report(&report);
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

fn print_round(r: u32, round: &Round) {
    println!(
        "round {} (writer {}; {} gateway's write first):",
        r + 1,
        if round.fifo {
            "SCHED_FIFO, gateways phase-locked"
        } else {
            "no SCHED_FIFO, gateways polling"
        },
        if round.tls_first { "TLS" } else { "TCP" }
    );
    print_round_table(round, &PATHS);
    println!(
        "  TLS / TCP (object_pose): p50 {:.2}, p99 {:.2}; TLS / bare p50 {:.2}; \
         TCP / bare: p50 {:.2}, p99 {:.2}",
        round.tls_ratio_p50,
        round.tls_ratio_p99,
        round.tls_bare_ratio_p50,
        round.ratio_p50,
        round.ratio_p99
    );
    for c in &round.checks {
        println!("  {c}");
    }
}

fn print_report(report: &Report) {
    let n = report.rounds.len();
    print_summary_table(&report.paths, n);
    println!(
        "median over {n} rounds, object_pose ({} B), TLS / TCP gateway: p50 {:.2}, p99 {:.2} \
         (TLS / bare Zenoh at p50 {:.2}); TCP gateway / bare Zenoh: p50 {:.2}, p99 {:.2}",
        report.payload_bytes,
        report.median_tls_ratio_p50,
        report.median_tls_ratio_p99,
        report.median_tls_bare_ratio_p50,
        report.median_ratio_p50,
        report.median_ratio_p99
    );
}

/// The child: puts `bare_count` stamped payloads, each `bare_offset_ns` into a period.
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
        ipc_types::sleep_until_ns(args.bare_start_ns + i * period + args.bare_offset_ns);
        let mut payload = vec![0u8; args.bare_bytes.max(8)];
        payload[..8].copy_from_slice(&ipc_types::monotonic_ns().to_le_bytes());
        let _ = p.put(payload).wait();
    }
    let _ = s.close().wait();
    Ok(())
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

/// One gateway of a round, its loop's blackboard, and the ROS 2 subscriber connected to it.
struct Gateway {
    tls: bool,
    product: Product,
    first: Arc<Recorder>,
    last: Arc<Recorder>,
}

impl Gateway {
    /// Starts `hrrtc-ros2 serve` on namespace `ns`, listening on `port` over TLS (the lab's
    /// `gateway` certificate) or plain TCP (`--insecure`); with the writer of its loop's
    /// blackboard (made first: the gateway opens it).
    fn start(
        args: &Args,
        gateway: &Path,
        lab: &Lab,
        node: &iceoryx2::node::Node<services::Ipc>,
        (ns, ros_ns): (&str, &str),
        port: u16,
        tls: bool,
    ) -> anyhow::Result<(Self, services::StateWriter)> {
        let writer = services::state_writer(node, ns)?;
        let mut cmd = Command::new(gateway);
        cmd.args(["serve", "--namespace", ns, "--ros-namespace", ros_ns])
            .args(["--no-connect", "--listen"])
            .arg(if tls {
                format!("{}/127.0.0.1:{port}", benches::across::secure_link())
            } else {
                format!("tcp/127.0.0.1:{port}")
            })
            .args(["--scene", "none"]);
        if tls {
            cmd.args(lab.tls_args("gateway"));
        } else {
            cmd.arg("--insecure");
        }
        cmd.args(
            args.gateway_args
                .as_deref()
                .unwrap_or_default()
                .split_whitespace(),
        );
        let product = Product::start(cmd, lab, &format!("{ns}-{}", link(tls)))?;
        let g = Gateway {
            tls,
            product,
            first: Recorder::new(),
            last: Recorder::new(),
        };
        Ok((g, writer))
    }

    /// This gateway's subscribers on `z`, for ROS namespace `ros_ns`.
    fn subscribe(
        &self,
        z: &zenoh::Session,
        ros_ns: &str,
    ) -> anyhow::Result<[zenoh::pubsub::Subscriber<()>; 2]> {
        let key = |topic: &str, ty| rmw::topic_key(0, topic, &TypeInfo::of(ty, Distro::Jazzy));
        Ok([
            ros2_subscriber::<PoseStamped>(
                z,
                key(&format!("{ros_ns}/object_pose"), PoseStamped::TYPE),
                self.first.clone(),
                |m| Some(m.header.stamp),
            )?,
            ros2_subscriber::<TfMessage>(z, key("/tf", TfMessage::TYPE), self.last.clone(), |m| {
                m.transforms.first().map(|t| t.header.stamp)
            })?,
        ])
    }

    /// Stops the gateway and checks its summary: the link it ran over, and that it
    /// published. One line saying so.
    fn stop(self) -> anyhow::Result<String> {
        let name = link(self.tls);
        let ended = self.product.stop()?;
        let summary = ended
            .stdout
            .lines()
            .find(|l| l.starts_with("hrrtc-ros2 serve ran"))
            .with_context(|| format!("the {name} gateway's summary: {:?}", ended.stdout))?;
        let links = summary.split_once("links: ").map_or("", |(_, l)| l);
        let published: u64 = summary
            .split_once(" ticks seen, ")
            .and_then(|(_, rest)| rest.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or(0);
        let ok = if self.tls {
            links.starts_with("mutual TLS") && ended.stderr.contains("links: mutual TLS, CA ")
        } else {
            links.contains("INSECURE")
        };
        anyhow::ensure!(ok, "the {name} gateway ran with links: {links}");
        anyhow::ensure!(
            published > 0,
            "the {name} gateway published nothing: {summary}"
        );
        Ok(format!(
            "{name} gateway: {published} ticks published; links: {links}"
        ))
    }
}

fn link(tls: bool) -> &'static str {
    if tls { "TLS" } else { "TCP" }
}

fn one_round(
    args: &Args,
    gateway: &Path,
    lab: &Lab,
    round: u32,
    tls_first: bool,
) -> anyhow::Result<(Round, usize)> {
    let pid = std::process::id();
    let base = 17_700 + 4 * round as u16;
    let (tcp_port, bare_port, tls_port) = (base, base + 1, base + 2);
    let names = |tag: &str| {
        (
            format!("bench_ros2{tag}_{pid}_{round}"),
            format!("/bench_ros2{tag}_{pid}_{round}"),
        )
    };
    let (ns_tcp, ros_ns_tcp) = names("");
    let (ns_tls, ros_ns_tls) = names("_tls");
    let (node, _) = services::create_node("bench_ros2")?;
    let (mut tcp, tcp_writer) = Gateway::start(
        args,
        gateway,
        lab,
        &node,
        (&ns_tcp, &ros_ns_tcp),
        tcp_port,
        false,
    )?;
    let (mut tls, tls_writer) = Gateway::start(
        args,
        gateway,
        lab,
        &node,
        (&ns_tls, &ros_ns_tls),
        tls_port,
        true,
    )?;
    std::thread::sleep(Duration::from_millis(500));
    tcp.product.check_running()?;
    tls.product.check_running()?;
    // A session per path, so that no path's samples wait behind another's in one session.
    let z_tcp = benches::across::zenoh_session(None, Some(tcp_port))?;
    let z_tls = benches::across::zenoh_session_tls(None, Some(tls_port), &lab.tls("ros2-node"))?;
    let _subs_tcp = tcp.subscribe(&z_tcp, &ros_ns_tcp)?;
    let _subs_tls = tls.subscribe(&z_tls, &ros_ns_tls)?;
    let z_bare = benches::across::zenoh_session(Some(bare_port), None)?;
    let bare = Recorder::new();
    let bare_key = format!("bench/ros2/bare/{pid}/{round}");
    let _bare = {
        let bare = bare.clone();
        z_bare
            .declare_subscriber(bare_key.clone())
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
            frame_id: format!("{}/scene", ros_ns_tcp.trim_start_matches('/')),
            ..Default::default()
        },
        ..Default::default()
    };
    let bytes = sample.encode().len();
    // Each period: the first gateway's write, the bare put a third in, the second
    // gateway's write two thirds in.
    let period = (1e9 / args.rate_hz) as u64;
    let warm = (args.rate_hz) as u64;
    let n = warm + (args.seconds * args.rate_hz) as u64;
    let start = ipc_types::monotonic_ns() + 1_000_000_000;
    let mut child = Command::new(std::env::current_exe()?);
    child
        .args([
            "--bare-pub",
            &bare_port.to_string(),
            "--bare-key",
            &bare_key,
        ])
        .args(["--bare-start-ns", &start.to_string()])
        .args(["--bare-offset-ns", &(period / 3).to_string()])
        .args(["--bare-count", &n.to_string()])
        .args(["--bare-bytes", &bytes.to_string()])
        .args(["--rate-hz", &args.rate_hz.to_string()]);
    let _child = Product::start(child, lab, &format!("bare-pub-{round}"))?;
    let recorders = [&tcp.first, &tcp.last, &tls.first, &tls.last, &bare];
    let (first, second) = if tls_first {
        (tls_writer, tcp_writer)
    } else {
        (tcp_writer, tls_writer)
    };
    let writer_thread = std::thread::spawn(move || {
        let fifo = ipc_types::set_thread_fifo_priority(80).is_ok();
        let write = |w: &services::StateWriter, seq| {
            let t = ipc_types::monotonic_ns();
            w.update_with_copy(HapticState {
                header: Header::new(seq, t, pid),
                published_ns: t,
                ..HapticState::default()
            });
        };
        for seq in 1..=n {
            let at = start + (seq - 1) * period;
            ipc_types::sleep_until_ns(at);
            write(&first, seq);
            ipc_types::sleep_until_ns(at + 2 * period / 3);
            write(&second, seq);
        }
        fifo
    });
    // Record after the warm-up second.
    ipc_types::sleep_until_ns(start + warm * period);
    for r in recorders {
        r.on.store(true, Ordering::Release);
    }
    let fifo = writer_thread
        .join()
        .map_err(|_| anyhow::anyhow!("the state writer panicked"))?;
    std::thread::sleep(Duration::from_millis(200));
    for r in recorders {
        r.on.store(false, Ordering::Release);
    }
    let p = |r: &Recorder| r.hist.lock().unwrap().percentiles_us();
    let (b, f, l, ft, lt) = (
        p(&bare),
        p(&tcp.first),
        p(&tcp.last),
        p(&tls.first),
        p(&tls.last),
    );
    if f.count == 0 || ft.count == 0 {
        tcp.product.check_running()?;
        tls.product.check_running()?;
    }
    anyhow::ensure!(
        b.count > 0 && f.count > 0 && ft.count > 0,
        "no samples (bare {}, ROS 2 over TCP {}, over TLS {}): did hrrtc-ros2 start?",
        b.count,
        f.count,
        ft.count
    );
    for z in [z_tcp, z_tls, z_bare] {
        let _ = z.close().wait();
    }
    let checks = [tcp.stop()?, tls.stop()?];
    Ok((
        Round {
            tls_first,
            bare: b,
            ros2_first: f,
            ros2_last: l,
            ros2_first_tls: ft,
            ros2_last_tls: lt,
            ratio_p50: f.p50 / b.p50,
            ratio_p99: f.p99 / b.p99,
            tls_ratio_p50: ft.p50 / f.p50,
            tls_ratio_p99: ft.p99 / f.p99,
            tls_bare_ratio_p50: ft.p50 / b.p50,
            fifo,
            checks,
        },
        bytes,
    ))
}
