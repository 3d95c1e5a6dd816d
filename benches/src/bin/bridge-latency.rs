//! Latency across `hrrtc-bridge` over mutual TLS and over plain TCP, beside bare Zenoh
//! publish-subscribe of the same payload sizes, in one run on one host (one clock, so
//! one-way latencies are exact).
//!
//! Each round starts four real `hrrtc-bridge` processes on this host: a pair over plain TCP
//! (`--insecure`, no access control), `--side loop` on namespace A and `--side planner` on
//! namespace B; and a pair over mutual TLS, as the bridges run by default (`--tls-ca`,
//! `--tls-cert`, `--tls-key` with certificates made once per run by `hrrtc-bridge certs`,
//! and `--allow-peer`, so Zenoh's access control runs too), on namespaces A′ and B′. Each
//! pair is joined over loopback on its own port and key namespace. It measures:
//!
//! 1. **State** (`HapticState`, 552 bytes, at `--rate-hz`), one path after the other:
//!    bare Zenoh with publisher and subscriber in this process; bare Zenoh with the
//!    subscriber in a child process (this executable with `--bare-rx`), over TCP and over
//!    mutual TLS; and through each pair of bridges: this process plays the loop, writing
//!    A's (A′'s) blackboard from a SCHED_FIFO thread, and a reader thread spins on B's
//!    (B′'s) blackboard (the transport alone, as a phase-locked planner reading just after
//!    the write). The spinning reader takes a core of a 2-core machine, so the state paths
//!    do not run beside each other; the TCP and TLS twins run one after the other in each
//!    round, TLS first in every other round.
//! 2. **Guidance** (`Guidance`, 152 bytes, each path at `--guidance-rate-hz`), all paths
//!    interleaved in one sequence, each sample an eighth of the period after the previous
//!    one, so that every path sees the same machine (a shared host's load moves the bare
//!    baseline 2–4× between phases a few seconds apart): bare Zenoh in one process and to
//!    a child process (over TCP and over TLS) as above; through each pair of bridges
//!    (published on B with its event notified, as the planner does, received on A by a
//!    thread woken by A's guidance event, as the loop's relay is); from a planner running
//!    the planner side of the bridge in its own process (`hrrtc_bridge::run_in_planner`,
//!    as `planner serve --bridge-connect`: its guidance goes on Zenoh from the planning
//!    thread) to A's relay, over TCP and (with its own certificate, allowing `loop`) over
//!    TLS; and on one host without a bridge (A's service to A's relay: the one hop every
//!    guidance sample takes to reach the loop). Each TLS path sits next to its TCP twin
//!    in the sequence, TLS first in every other round.
//!
//! Latencies through iceoryx2 are from the stamp taken just before the local write to the
//! reading thread's clock, by sequence number (the bridges re-stamp samples, so their
//! stamps are not used); over bare Zenoh from the stamp in the payload to the callback.
//! Before guidance is measured, samples are sent on every bridged path until each has
//! reached its relay (a bridge hands on nothing from a peer before that peer has answered
//! its probes).
//!
//! Ratios, each the median over rounds of the rounds' ratios at p50:
//! - **TLS / TCP** through the bridges, for the state, the guidance through two bridges and
//!   the guidance from the in-planner bridge (the goal of issue 54: ≤ 1.2); p99 and the
//!   largest latency of every path are printed and written beside them;
//! - **bridge / bare Zenoh** through the TCP bridges (`--insecure`), as before issue 54.
//!   Its baseline is bare Zenoh between two processes, as between two hosts and as the
//!   bridges' path is; the ratio against one process (where Zenoh's sessions share a
//!   runtime) is printed beside it.
//!
//! Each bridge's exit summary (its links and counts) is read back: a round fails unless the
//! TLS bridges ran over mutual TLS, the TCP ones as `--insecure`, and both carried state and
//! guidance. Everything runs under a 0 µs CPU wake-up latency request, as on a host whose
//! haptic loop is running (`--no-cpu-latency-request` to leave it out).
//!
//! `cargo build --release -p hrrtc-bridge -p benches && target/release/bridge-latency --seconds 5`

use anyhow::{Context, bail};
use benches::across::{Lab, Product};
use benches::across::{
    PathOf, PathSummary, median, print_round_table, print_summary_table, summarize,
};
use clap::Parser;
use ipc_types::latency::{NsHistogram, Percentiles};
use ipc_types::{Guidance, HapticState, Header, services};
use serde::Serialize;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh::qos::CongestionControl;

/// Latency of the state and guidance paths through two bridges, over mutual TLS and over
/// plain TCP, versus bare Zenoh.
#[derive(Debug, Parser)]
struct Args {
    /// The mutually authenticated link measured against plain TCP: `quic` (Zenoh's QUIC,
    /// TLS 1.3 over UDP) or `tls` (Zenoh's TLS over TCP).
    #[arg(long, default_value = "quic")]
    secure_link: String,
    /// Seconds of each state path, and of the interleaved guidance paths.
    #[arg(long, default_value_t = 5.0)]
    seconds: f64,
    /// Rounds (fresh bridges and sessions each).
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// State rate, Hz (the loop's tick rate).
    #[arg(long, default_value_t = 1000.0)]
    rate_hz: f64,
    /// Guidance rate of each path, Hz (the planner's).
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
    /// (PM QoS), as a host running the haptic loop does while the loop runs.
    #[arg(long)]
    no_cpu_latency_request: bool,
    /// Internal: be a bare path's subscriber process, connected to this port.
    #[arg(long, hide = true)]
    bare_rx: Option<u16>,
    /// Internal: the key the `--bare-rx` process subscribes to.
    #[arg(long, hide = true, default_value = "")]
    bare_rx_key: String,
    /// Internal: the `--bare-rx` process connects over mutual TLS with this lab folder's
    /// `planner` certificate.
    #[arg(long, hide = true)]
    bare_rx_lab: Option<PathBuf>,
}

/// The state paths' latencies in one round, µs.
#[derive(Debug, Clone, Copy, Serialize)]
struct StateRow {
    bare_one_process: Percentiles,
    bare_two_processes: Percentiles,
    /// Bare Zenoh between two processes over mutual TLS.
    bare_two_processes_tls: Percentiles,
    /// Through the TCP bridges (`--insecure`).
    bridged: Percentiles,
    /// Through the mutual-TLS bridges.
    bridged_tls: Percentiles,
}

/// The guidance paths' latencies in one round (interleaved), µs.
#[derive(Debug, Clone, Copy, Serialize)]
struct GuidanceRow {
    bare_one_process: Percentiles,
    bare_two_processes: Percentiles,
    bare_two_processes_tls: Percentiles,
    /// Planner → its host's bridge → the loop's bridge → the loop's relay, over TCP.
    bridged: Percentiles,
    /// The same over mutual TLS.
    bridged_tls: Percentiles,
    /// A planner with the bridge in its process (`planner serve --bridge-connect`) → the
    /// loop's bridge → the loop's relay, over TCP.
    in_process_bridge: Percentiles,
    /// The same over mutual TLS.
    in_process_bridge_tls: Percentiles,
    /// One host, no bridge: planner → the loop's relay.
    local: Percentiles,
}

#[derive(Debug, Serialize)]
struct Round {
    /// The TLS twin of each path went first (state) or sat first in the interleave
    /// (guidance).
    tls_first: bool,
    state: StateRow,
    guidance: GuidanceRow,
    /// Through the TLS bridges / through the TCP bridges, at p50 and p99.
    tls_state_ratio_p50: f64,
    tls_guidance_ratio_p50: f64,
    tls_guidance_in_process_ratio_p50: f64,
    tls_state_ratio_p99: f64,
    tls_guidance_ratio_p99: f64,
    tls_guidance_in_process_ratio_p99: f64,
    /// Bare Zenoh between two processes, TLS / TCP, at p50.
    tls_bare_state_ratio_p50: f64,
    tls_bare_guidance_ratio_p50: f64,
    /// Through the TCP bridges / bare Zenoh (TCP) between two processes, at p50.
    state_ratio_p50: f64,
    guidance_ratio_p50: f64,
    /// Through the TCP in-process bridge / bare Zenoh (TCP) between two processes, at p50.
    guidance_in_process_ratio_p50: f64,
    /// Through the TCP bridges / bare Zenoh within one process, at p50.
    state_ratio_one_process_p50: f64,
    guidance_ratio_one_process_p50: f64,
    /// What the bridges said at exit: their links, and what they carried.
    checks: Checks,
}

#[derive(Debug, Serialize)]
struct Report {
    rounds: Vec<Round>,
    paths: Vec<PathSummary>,
    median_tls_state_ratio_p50: f64,
    median_tls_guidance_ratio_p50: f64,
    median_tls_guidance_in_process_ratio_p50: f64,
    median_tls_state_ratio_p99: f64,
    median_tls_guidance_ratio_p99: f64,
    median_tls_guidance_in_process_ratio_p99: f64,
    median_tls_bare_state_ratio_p50: f64,
    median_tls_bare_guidance_ratio_p50: f64,
    median_state_ratio_p50: f64,
    median_guidance_ratio_p50: f64,
    median_guidance_in_process_ratio_p50: f64,
    median_state_ratio_one_process_p50: f64,
    median_guidance_ratio_one_process_p50: f64,
}

const STATE_BYTES: usize = size_of::<HapticState>();
const GUIDANCE_BYTES: usize = size_of::<Guidance>();
/// Publish times by sequence, for the paths through iceoryx2.
const RING: usize = 1 << 14;
/// The lab's hosts: the loop's (listening on 127.0.0.1), a planner's host running a bridge
/// process, and a planner running the bridge in its process.
const LAB: [&str; 3] = ["loop=127.0.0.1", "planner", "planner-in"];

/// The two links a bridge pair runs over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Link {
    /// Plain TCP, `--insecure`.
    Tcp,
    /// Mutual TLS with access control, the default.
    Tls,
}

impl Link {
    fn name(self) -> &'static str {
        match self {
            Link::Tcp => "TCP",
            Link::Tls => "TLS",
        }
    }

    /// The two links in the order a round measures them.
    fn order(tls_first: bool) -> [Link; 2] {
        if tls_first {
            [Link::Tls, Link::Tcp]
        } else {
            [Link::Tcp, Link::Tls]
        }
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    benches::across::set_secure_link(&args.secure_link)?;
    if let Some(port) = args.bare_rx {
        return bare_rx(port, &args.bare_rx_key, args.bare_rx_lab.as_deref());
    }
    println!(
        "TLS below: mutual TLS over {}/ (--secure-link), against plain tcp/ with --insecure",
        benches::across::secure_link()
    );
    anyhow::ensure!(
        args.seconds > 0.0 && args.rate_hz > 0.0 && args.guidance_rate_hz > 0.0,
        "--seconds, --rate-hz and --guidance-rate-hz must be positive"
    );
    anyhow::ensure!(args.rounds > 0, "--rounds must be positive");
    let bridge = benches::across::sibling_exe(
        args.bridge.as_deref(),
        "hrrtc-bridge",
        "hrrtc-bridge",
        "--bridge",
    )?;
    let lab = Lab::make(&bridge, "bridge-latency", &LAB)?;
    let _cpu_latency = benches::across::cpu_latency_request(args.no_cpu_latency_request);
    let mut rounds = Vec::new();
    for r in 0..args.rounds {
        let tls_first = r % 2 == 1;
        let (state, guidance, checks) =
            one_round(&args, &bridge, &lab, 17_600 + 8 * r as u16, r, tls_first)?;
        let ratio = |a: &Percentiles, b: &Percentiles| a.p50 / b.p50;
        let ratio99 = |a: &Percentiles, b: &Percentiles| a.p99 / b.p99;
        let (s, g) = (&state, &guidance);
        let round = Round {
            tls_first,
            tls_state_ratio_p50: ratio(&s.bridged_tls, &s.bridged),
            tls_guidance_ratio_p50: ratio(&g.bridged_tls, &g.bridged),
            tls_guidance_in_process_ratio_p50: ratio(
                &g.in_process_bridge_tls,
                &g.in_process_bridge,
            ),
            tls_state_ratio_p99: ratio99(&s.bridged_tls, &s.bridged),
            tls_guidance_ratio_p99: ratio99(&g.bridged_tls, &g.bridged),
            tls_guidance_in_process_ratio_p99: ratio99(
                &g.in_process_bridge_tls,
                &g.in_process_bridge,
            ),
            tls_bare_state_ratio_p50: ratio(&s.bare_two_processes_tls, &s.bare_two_processes),
            tls_bare_guidance_ratio_p50: ratio(&g.bare_two_processes_tls, &g.bare_two_processes),
            state_ratio_p50: ratio(&s.bridged, &s.bare_two_processes),
            guidance_ratio_p50: ratio(&g.bridged, &g.bare_two_processes),
            guidance_in_process_ratio_p50: ratio(&g.in_process_bridge, &g.bare_two_processes),
            state_ratio_one_process_p50: ratio(&s.bridged, &s.bare_one_process),
            guidance_ratio_one_process_p50: ratio(&g.bridged, &g.bare_one_process),
            checks,
            state,
            guidance,
        };
        print_round(r, &round);
        rounds.push(round);
    }
    let median = |f: fn(&Round) -> f64| median(&rounds, f);
    let paths = summarize(&rounds, &PATHS);
    let report = Report {
        median_tls_state_ratio_p50: median(|r| r.tls_state_ratio_p50),
        median_tls_guidance_ratio_p50: median(|r| r.tls_guidance_ratio_p50),
        median_tls_guidance_in_process_ratio_p50: median(|r| r.tls_guidance_in_process_ratio_p50),
        median_tls_state_ratio_p99: median(|r| r.tls_state_ratio_p99),
        median_tls_guidance_ratio_p99: median(|r| r.tls_guidance_ratio_p99),
        median_tls_guidance_in_process_ratio_p99: median(|r| r.tls_guidance_in_process_ratio_p99),
        median_tls_bare_state_ratio_p50: median(|r| r.tls_bare_state_ratio_p50),
        median_tls_bare_guidance_ratio_p50: median(|r| r.tls_bare_guidance_ratio_p50),
        median_state_ratio_p50: median(|r| r.state_ratio_p50),
        median_guidance_ratio_p50: median(|r| r.guidance_ratio_p50),
        median_guidance_in_process_ratio_p50: median(|r| r.guidance_in_process_ratio_p50),
        median_state_ratio_one_process_p50: median(|r| r.state_ratio_one_process_p50),
        median_guidance_ratio_one_process_p50: median(|r| r.guidance_ratio_one_process_p50),
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

/// Every path, as printed, and where a round keeps it.
const PATHS: [PathOf<Round>; 13] = [
    ("state, bare Zenoh, one process", |r| {
        r.state.bare_one_process
    }),
    ("state, bare Zenoh, two processes, TCP", |r| {
        r.state.bare_two_processes
    }),
    ("state, bare Zenoh, two processes, TLS", |r| {
        r.state.bare_two_processes_tls
    }),
    ("state, loop → bridge → bridge → B, TCP", |r| {
        r.state.bridged
    }),
    ("state, loop → bridge → bridge → B, TLS", |r| {
        r.state.bridged_tls
    }),
    ("guidance, bare Zenoh, one process", |r| {
        r.guidance.bare_one_process
    }),
    ("guidance, bare Zenoh, two processes, TCP", |r| {
        r.guidance.bare_two_processes
    }),
    ("guidance, bare Zenoh, two processes, TLS", |r| {
        r.guidance.bare_two_processes_tls
    }),
    ("guidance, B → bridge → bridge → A, TCP", |r| {
        r.guidance.bridged
    }),
    ("guidance, B → bridge → bridge → A, TLS", |r| {
        r.guidance.bridged_tls
    }),
    ("guidance, B (in-process bridge) → A, TCP", |r| {
        r.guidance.in_process_bridge
    }),
    ("guidance, B (in-process bridge) → A, TLS", |r| {
        r.guidance.in_process_bridge_tls
    }),
    ("guidance, A → A (one host, no bridge)", |r| {
        r.guidance.local
    }),
];

fn print_round(r: u32, round: &Round) {
    println!(
        "round {} ({} first):",
        r + 1,
        if round.tls_first { "TLS" } else { "TCP" }
    );
    print_round_table(round, &PATHS);
    println!(
        "  TLS / TCP at p50: state {:.2}, guidance {:.2}, in-process bridge {:.2} \
         (p99: {:.2}, {:.2}, {:.2}; bare Zenoh at p50: {:.2}, {:.2})",
        round.tls_state_ratio_p50,
        round.tls_guidance_ratio_p50,
        round.tls_guidance_in_process_ratio_p50,
        round.tls_state_ratio_p99,
        round.tls_guidance_ratio_p99,
        round.tls_guidance_in_process_ratio_p99,
        round.tls_bare_state_ratio_p50,
        round.tls_bare_guidance_ratio_p50,
    );
    println!(
        "  TCP bridge / bare at p50: state {:.2}, guidance {:.2}, in-process bridge {:.2} \
         (one process: {:.2}, {:.2})",
        round.state_ratio_p50,
        round.guidance_ratio_p50,
        round.guidance_in_process_ratio_p50,
        round.state_ratio_one_process_p50,
        round.guidance_ratio_one_process_p50
    );
    for c in [&round.checks.tcp, &round.checks.tls] {
        println!("  {c}");
    }
}

fn print_report(report: &Report) {
    let n = report.rounds.len();
    print_summary_table(&report.paths, n);
    println!(
        "median over {n} rounds, TLS / TCP bridges at p50: state {:.2}, guidance {:.2}, \
         guidance from a planner with the bridge in its process {:.2} (at p99: {:.2}, {:.2}, \
         {:.2}; bare Zenoh between two processes at p50: state {:.2}, guidance {:.2})",
        report.median_tls_state_ratio_p50,
        report.median_tls_guidance_ratio_p50,
        report.median_tls_guidance_in_process_ratio_p50,
        report.median_tls_state_ratio_p99,
        report.median_tls_guidance_ratio_p99,
        report.median_tls_guidance_in_process_ratio_p99,
        report.median_tls_bare_state_ratio_p50,
        report.median_tls_bare_guidance_ratio_p50,
    );
    println!(
        "median over {n} rounds, TCP bridge / bare Zenoh at p50: state {:.2}, guidance {:.2}, \
         guidance from a planner with the bridge in its process {:.2} \
         (against one process: state {:.2}, guidance {:.2})",
        report.median_state_ratio_p50,
        report.median_guidance_ratio_p50,
        report.median_guidance_in_process_ratio_p50,
        report.median_state_ratio_one_process_p50,
        report.median_guidance_ratio_one_process_p50,
    );
}

fn publisher(
    session: &zenoh::Session,
    key: String,
) -> anyhow::Result<zenoh::pubsub::Publisher<'static>> {
    session
        .declare_publisher(key)
        .congestion_control(CongestionControl::Drop)
        .express(true)
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))
}

/// A subscriber on `key` recording the latency of each stamped payload (its first 8 bytes:
/// the publisher's `monotonic_ns` just before `put`).
fn stamped_subscriber(
    session: &zenoh::Session,
    key: &str,
) -> anyhow::Result<(zenoh::pubsub::Subscriber<()>, Arc<Mutex<NsHistogram>>)> {
    let hist = Arc::new(Mutex::new(NsHistogram::new()));
    let h = hist.clone();
    let sub = session
        .declare_subscriber(key)
        .callback(move |s| {
            let now = ipc_types::monotonic_ns();
            let b = s.payload().to_bytes();
            if b.len() >= 8 {
                let mut t = [0u8; 8];
                t.copy_from_slice(&b[..8]);
                let sent = u64::from_le_bytes(t);
                h.lock().unwrap().record(now.saturating_sub(sent));
            }
        })
        .wait()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    Ok((sub, hist))
}

/// Puts a payload of `bytes` stamped with the time just before `put`.
fn put_stamped(publisher: &zenoh::pubsub::Publisher<'_>, bytes: usize) {
    let mut payload = vec![0u8; bytes];
    payload[..8].copy_from_slice(&ipc_types::monotonic_ns().to_le_bytes());
    let _ = publisher.put(payload).wait();
}

/// Calls `send` at `rate_hz` for `seconds` (absolute deadlines).
fn paced(rate_hz: f64, seconds: f64, mut send: impl FnMut(u64)) {
    let period = (1e9 / rate_hz) as u64;
    let n = (seconds * rate_hz) as u64;
    let mut next = ipc_types::monotonic_ns();
    for i in 0..n {
        next += period;
        ipc_types::sleep_until_ns(next);
        send(i);
    }
}

/// A bare path's subscriber in a child process: this executable with `--bare-rx`,
/// connected to a listening session of this process (over mutual TLS with `lab`).
struct ChildSubscriber {
    child: Child,
    out: std::io::BufReader<std::process::ChildStdout>,
}

impl ChildSubscriber {
    fn start(port: u16, key: &str, lab: Option<&Lab>) -> anyhow::Result<Self> {
        let mut cmd = Command::new(std::env::current_exe()?);
        cmd.args(["--bare-rx", &port.to_string(), "--bare-rx-key", key])
            .args(["--secure-link", benches::across::secure_link()]);
        if let Some(lab) = lab {
            cmd.arg("--bare-rx-lab").arg(lab.dir());
        }
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .context("starting the bare subscriber (this executable, --bare-rx)")?;
        let stdout = child
            .stdout
            .take()
            .context("the bare subscriber's stdout")?;
        let mut s = ChildSubscriber {
            child,
            out: std::io::BufReader::new(stdout),
        };
        let mut line = String::new();
        s.out.read_line(&mut line)?;
        if line.trim() != "ready" {
            bail!("the bare subscriber did not start: {line:?}");
        }
        Ok(s)
    }

    /// Ends the child (closes its input) and reads the latencies it saw.
    fn finish(mut self) -> anyhow::Result<Percentiles> {
        drop(self.child.stdin.take());
        let mut line = String::new();
        self.out.read_line(&mut line)?;
        serde_json::from_str(&line)
            .with_context(|| format!("the bare subscriber's report {line:?}"))
    }
}

impl Drop for ChildSubscriber {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The child of [`ChildSubscriber`]: subscribes, says `ready`, and prints its latencies as
/// JSON once its standard input closes.
fn bare_rx(port: u16, key: &str, lab: Option<&Path>) -> anyhow::Result<()> {
    let session = match lab {
        Some(dir) => benches::across::zenoh_session_tls(
            None,
            Some(port),
            &benches::across::lab_tls(dir, "planner"),
        )?,
        None => benches::across::zenoh_session(None, Some(port))?,
    };
    let (sub, hist) = stamped_subscriber(&session, key)?;
    println!("ready");
    std::io::stdout().flush()?;
    std::io::copy(&mut std::io::stdin(), &mut std::io::sink())?;
    drop(sub);
    let p = hist.lock().unwrap().percentiles_us();
    println!("{}", serde_json::to_string(&p)?);
    let _ = session.close().wait();
    Ok(())
}

/// One round: the bridges and the bare sessions set up, the state measured on its paths
/// one at a time, then guidance on all its paths interleaved, then the bridges stopped and
/// their summaries checked.
fn one_round(
    args: &Args,
    bridge: &Path,
    lab: &Lab,
    port: u16,
    round: u32,
    tls_first: bool,
) -> anyhow::Result<(StateRow, GuidanceRow, Checks)> {
    let mut rig = Rig::open(args, bridge, lab, port, round, tls_first)?;
    // A bridge that died says why.
    let measured = rig
        .measure_state(args)
        .and_then(|s| Ok((s, rig.measure_guidance(args)?)));
    let (state, (guidance, in_planner)) = match measured {
        Ok(m) => m,
        Err(e) => {
            rig.check_running()?;
            return Err(e);
        }
    };
    let checks = rig.close(in_planner)?;
    Ok((state, guidance, checks))
}

/// What each link's bridges said at exit (their links and counts), one line per link.
#[derive(Debug, Serialize)]
struct Checks {
    tcp: String,
    tls: String,
}

/// A pair of bridge processes over one link: the loop side on `ns_a`, the planner side on
/// `ns_b`, joined on `endpoint` under the key namespace `keys`.
struct Pair {
    link: Link,
    keys: String,
    endpoint: String,
    ns_a: String,
    ns_b: String,
    loop_side: Product,
    planner_side: Product,
}

impl Pair {
    /// The pair's iceoryx2 namespaces (A, B) and key namespace over `link` in `round`.
    fn names(link: Link, round: u32) -> (String, String, String) {
        let pid = std::process::id();
        let tag = match link {
            Link::Tcp => "",
            Link::Tls => "t",
        };
        (
            format!("bench_bridge_a{tag}_{pid}_{round}"),
            format!("bench_bridge_b{tag}_{pid}_{round}"),
            format!("bench_bridge{tag}_{pid}_{round}"),
        )
    }

    /// Starts the pair over `link` (the loop side first, listening on `port`).
    fn start(
        args: &Args,
        bridge: &Path,
        lab: &Lab,
        link: Link,
        port: u16,
        round: u32,
    ) -> anyhow::Result<Self> {
        let (ns_a, ns_b, keys) = Pair::names(link, round);
        let endpoint = match link {
            Link::Tcp => format!("tcp/127.0.0.1:{port}"),
            Link::Tls => format!("{}/127.0.0.1:{port}", benches::across::secure_link()),
        };
        let poll = args.state_poll_us.to_string();
        let spawn = |side: &str, ns: &str, how: &str, cert: &str, peers: &[&str]| {
            let mut cmd = Command::new(bridge);
            cmd.args(["--side", side, "--namespace", ns, "--key-namespace", &keys])
                .args([how, &endpoint, "--state-poll-us", &poll, "--no-roadmap"]);
            match link {
                Link::Tcp => {
                    cmd.arg("--insecure");
                }
                Link::Tls => {
                    cmd.args(lab.tls_args(cert));
                    for p in peers {
                        cmd.args(["--allow-peer", p]);
                    }
                }
            }
            let name = format!("round{round}-{}-{side}", link.name());
            Product::start(cmd, lab, &name)
        };
        let loop_side = spawn(
            "loop",
            &ns_a,
            "--listen",
            "loop",
            &["planner", "planner-in"],
        )?;
        std::thread::sleep(Duration::from_millis(300));
        let planner_side = spawn("planner", &ns_b, "--connect", "planner", &["loop"])?;
        Ok(Pair {
            link,
            keys,
            endpoint,
            ns_a,
            ns_b,
            loop_side,
            planner_side,
        })
    }

    /// The in-planner bridge's configuration for this pair, on namespace `ns`.
    fn in_planner_config(&self, lab: &Lab, ns: &str) -> hrrtc_bridge::BridgeConfig {
        let mut config = hrrtc_bridge::BridgeConfig::new(hrrtc_bridge::Side::Planner, ns);
        config.key_namespace = Some(self.keys.clone());
        config.connect = vec![self.endpoint.clone()];
        config.roadmap = false;
        match self.link {
            Link::Tcp => config.security.insecure = true,
            Link::Tls => {
                config.security = hrrtc_bridge::Security {
                    tls: Some(lab.tls("planner-in")),
                    flag_prefix: "bridge-",
                    ..hrrtc_bridge::Security::default()
                };
                config.allow_peers = vec!["loop".to_owned()];
            }
        }
        config
    }

    /// Stops both bridges and checks what they said at exit against `link` and what was
    /// sent; one line saying so.
    fn stop(self, in_planner: &hrrtc_bridge::BridgeReport) -> anyhow::Result<String> {
        let link = self.link.name();
        let a = self.loop_side.stop()?;
        let b = self.planner_side.stop()?;
        let links = |e: &benches::across::Ended, side: &str| -> anyhow::Result<String> {
            let first = e.stdout.lines().next().unwrap_or_default();
            let l = first
                .split_once("links: ")
                .map(|(_, l)| l.to_owned())
                .with_context(|| format!("the {link} {side} bridge's summary: {first:?}"))?;
            let ok = match self.link {
                Link::Tcp => l.contains("INSECURE"),
                Link::Tls => {
                    l.starts_with("mutual TLS") && e.stderr.contains("links: mutual TLS, CA ")
                }
            };
            anyhow::ensure!(ok, "the {link} {side} bridge ran with links: {l}");
            Ok(l)
        };
        let links_a = links(&a, "loop")?;
        links(&b, "planner")?;
        let state_out = KindCounts::parse(&a.stdout, "state");
        let state_in = KindCounts::parse(&b.stdout, "state");
        let guidance_out = KindCounts::parse(&b.stdout, "guidance");
        let guidance_in = KindCounts::parse(&a.stdout, "guidance");
        let (state_sent, state_delivered) = (state_out.sent, state_in.delivered);
        let (guidance_sent, guidance_delivered) = (guidance_out.sent, guidance_in.delivered);
        let in_planner_sent = in_planner.kind("guidance").sent;
        anyhow::ensure!(
            state_delivered > 0 && guidance_delivered > 0 && in_planner_sent > 0,
            "the {link} bridges carried nothing: state sent {state_sent}, delivered \
             {state_delivered}; guidance delivered {guidance_delivered}, sent from the \
             in-planner bridge {in_planner_sent}\n{}\n{}",
            a.stdout,
            b.stdout
        );
        Ok(format!(
            "{link} bridges (links: {links_a}): state sent {state_sent}, delivered \
             {state_delivered}{}; guidance sent {guidance_sent} + {in_planner_sent} from the \
             in-planner bridge, delivered {guidance_delivered}{}",
            state_in.lost(),
            guidance_in.lost()
        ))
    }
}

/// The counts of an `hrrtc-bridge` exit summary's line for a kind (`  state: sent N,
/// received N, delivered N, rejected N, dropped N, from unanswered peers N`).
#[derive(Debug, Clone, Copy, Default)]
struct KindCounts {
    sent: u64,
    delivered: u64,
    rejected: u64,
    dropped: u64,
    unanswered: u64,
}

impl KindCounts {
    /// `kind`'s counts in the summary `stdout`; all 0 when the kind is not listed (a bridge
    /// lists only kinds it sent or received).
    fn parse(stdout: &str, kind: &str) -> Self {
        let prefix = format!("  {kind}: ");
        let Some(line) = stdout.lines().find_map(|l| l.strip_prefix(&prefix)) else {
            return KindCounts::default();
        };
        let n: Vec<u64> = line
            .split(", ")
            .map(|f| {
                f.rsplit(' ')
                    .next()
                    .and_then(|n| n.parse().ok())
                    .unwrap_or(0)
            })
            .collect();
        let at = |i: usize| n.get(i).copied().unwrap_or(0);
        KindCounts {
            sent: at(0),
            delivered: at(2),
            rejected: at(3),
            dropped: at(4),
            unanswered: at(5),
        }
    }

    /// What arrived but was not handed on, when anything was.
    fn lost(&self) -> String {
        if self.rejected + self.dropped + self.unanswered == 0 {
            String::new()
        } else {
            format!(
                " (not handed on: rejected {}, dropped {}, from unanswered peers {})",
                self.rejected, self.dropped, self.unanswered
            )
        }
    }
}

/// What a round measures through: two bridge pairs (TCP and TLS), this process's ports on
/// A, B (of each pair) and a local namespace, and bare Zenoh sessions.
struct Rig<'a> {
    lab: &'a Lab,
    round: u32,
    tls_first: bool,
    tcp: Pair,
    tls: Pair,
    bare2_port: u16,
    bare2_tls_port: u16,
    ns_local: String,
    _node: iceoryx2::node::Node<services::Ipc>,
    /// Taken by the state measurement: A's and A′'s.
    state_writers: Option<(services::StateWriter, services::StateWriter)>,
    guidance_b: [(services::Publisher<Guidance>, services::GuidanceNotifier); 2],
    guidance_local: services::Publisher<Guidance>,
    event_local: services::GuidanceNotifier,
    bare_tx: zenoh::Session,
    bare_rx: zenoh::Session,
    bare2_tx: zenoh::Session,
    bare2_tls_tx: zenoh::Session,
}

impl<'a> Rig<'a> {
    /// Starts the bridges (the loop sides first: the planner sides' state writers, and the
    /// ports both open, exist before this process opens them) and the bare sessions on
    /// `port` (one process), `port + 1` (two, TCP), `port + 2` (two, TLS); the TCP bridges
    /// meet on `port + 3`, the TLS ones on `port + 4`.
    fn open(
        args: &Args,
        bridge: &Path,
        lab: &'a Lab,
        port: u16,
        round: u32,
        tls_first: bool,
    ) -> anyhow::Result<Self> {
        let pid = std::process::id();
        let ns_local = format!("bench_local_{pid}_{round}");
        let (bare_port, bare2_port, bare2_tls_port) = (port, port + 1, port + 2);
        let (node, _) = services::create_node("bench_bridge")?;
        let state_writers = (
            services::state_writer(&node, &Pair::names(Link::Tcp, round).0)?,
            services::state_writer(&node, &Pair::names(Link::Tls, round).0)?,
        );
        let guidance_local = services::publisher::<Guidance>(&node, &ns_local)?;
        let event_local = services::guidance_notifier(&node, &ns_local)?;
        let mut pairs = Vec::new();
        for link in Link::order(tls_first) {
            let p = match link {
                Link::Tcp => port + 3,
                Link::Tls => port + 4,
            };
            pairs.push(Pair::start(args, bridge, lab, link, p, round)?);
        }
        let (tcp, tls) = {
            let mut it = pairs.into_iter();
            let (x, y) = (it.next().context("pair")?, it.next().context("pair")?);
            if x.link == Link::Tcp { (x, y) } else { (y, x) }
        };
        let guidance_b = [
            (
                services::publisher::<Guidance>(&node, &tcp.ns_b)?,
                services::guidance_notifier(&node, &tcp.ns_b)?,
            ),
            (
                services::publisher::<Guidance>(&node, &tls.ns_b)?,
                services::guidance_notifier(&node, &tls.ns_b)?,
            ),
        ];
        let bare_tx = benches::across::zenoh_session(Some(bare_port), None)?;
        let bare_rx = benches::across::zenoh_session(None, Some(bare_port))?;
        let bare2_tx = benches::across::zenoh_session(Some(bare2_port), None)?;
        let bare2_tls_tx =
            benches::across::zenoh_session_tls(Some(bare2_tls_port), None, &lab.tls("loop"))?;
        std::thread::sleep(Duration::from_millis(1500));
        let rig = Rig {
            lab,
            round,
            tls_first,
            tcp,
            tls,
            bare2_port,
            bare2_tls_port,
            ns_local,
            _node: node,
            state_writers: Some(state_writers),
            guidance_b,
            guidance_local,
            event_local,
            bare_tx,
            bare_rx,
            bare2_tx,
            bare2_tls_tx,
        };
        let mut rig = rig;
        rig.check_running()?;
        Ok(rig)
    }

    /// `Err` with its log if a bridge has exited.
    fn check_running(&mut self) -> anyhow::Result<()> {
        for p in [&mut self.tcp, &mut self.tls] {
            p.loop_side.check_running()?;
            p.planner_side.check_running()?;
        }
        Ok(())
    }

    /// The state, one path at a time (the bridged paths' reader spins on a core): bare
    /// Zenoh in one process, in two (TCP and TLS), and through each pair of bridges; each
    /// TLS twin first in every other round.
    fn measure_state(&mut self, args: &Args) -> anyhow::Result<StateRow> {
        let bare_one = {
            let key = "bench/bare/state";
            let (sub, hist) = stamped_subscriber(&self.bare_rx, key)?;
            let p = publisher(&self.bare_tx, key.to_owned())?;
            std::thread::sleep(Duration::from_millis(500));
            paced(args.rate_hz, args.seconds, |_| put_stamped(&p, STATE_BYTES));
            std::thread::sleep(Duration::from_millis(100));
            drop(sub);
            hist.lock().unwrap().percentiles_us()
        };
        let bare_two = |link: Link| -> anyhow::Result<Percentiles> {
            let (key, port, tx, lab) = match link {
                Link::Tcp => ("bench/bare2/state", self.bare2_port, &self.bare2_tx, None),
                Link::Tls => (
                    "bench/bare2tls/state",
                    self.bare2_tls_port,
                    &self.bare2_tls_tx,
                    Some(self.lab),
                ),
            };
            let child = ChildSubscriber::start(port, key, lab)?;
            let p = publisher(tx, key.to_owned())?;
            std::thread::sleep(Duration::from_millis(500));
            paced(args.rate_hz, args.seconds, |_| put_stamped(&p, STATE_BYTES));
            std::thread::sleep(Duration::from_millis(100));
            child.finish()
        };
        let mut bare = [None, None];
        for link in Link::order(self.tls_first) {
            bare[link as usize] = Some(bare_two(link)?);
        }
        let (writer_tcp, writer_tls) = self
            .state_writers
            .take()
            .context("the state is measured once a round")?;
        let mut writers = [Some(writer_tcp), Some(writer_tls)];
        let mut bridged = [None, None];
        for link in Link::order(self.tls_first) {
            let writer = writers[link as usize].take().context("one writer a link")?;
            let ns_b = match link {
                Link::Tcp => &self.tcp.ns_b,
                Link::Tls => &self.tls.ns_b,
            };
            let p = state_through_bridges(args, writer, ns_b)?;
            anyhow::ensure!(
                p.count > 0,
                "no state came through the {} bridges",
                link.name()
            );
            bridged[link as usize] = Some(p);
        }
        let got = |v: [Option<Percentiles>; 2], link: Link| v[link as usize].context("measured");
        Ok(StateRow {
            bare_one_process: bare_one,
            bare_two_processes: got(bare, Link::Tcp)?,
            bare_two_processes_tls: got(bare, Link::Tls)?,
            bridged: got(bridged, Link::Tcp)?,
            bridged_tls: got(bridged, Link::Tls)?,
        })
    }

    /// Starts an in-planner bridge joined to `pair`'s loop side, on its own namespace.
    fn start_in_planner(&self, pair: &Pair) -> anyhow::Result<InPlanner> {
        let pid = std::process::id();
        let tag = match pair.link {
            Link::Tcp => "",
            Link::Tls => "t",
        };
        let ns = format!("bench_bridge_c{tag}_{pid}_{}", self.round);
        let config = pair.in_planner_config(self.lab, &ns);
        let stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let thread = {
            let stop = stop.clone();
            std::thread::spawn(move || hrrtc_bridge::run_in_planner(&config, stop, tx))
        };
        let Ok(sender) = rx.recv() else {
            let e = thread
                .join()
                .map_err(|_| anyhow::anyhow!("bridge panicked"))?;
            bail!(
                "the in-planner bridge over {} did not start: {:?}",
                pair.link.name(),
                e.err()
            );
        };
        Ok(InPlanner {
            stop,
            thread,
            sender,
        })
    }

    /// Guidance on every path, interleaved: bare Zenoh in one process and in two (TCP and
    /// TLS), through each pair of bridges to its A's relay, from a planner with the bridge
    /// in its process (`planner serve --bridge-connect`, on its own namespace: started
    /// after the state paths, which it would otherwise receive too) over each link to A's
    /// relay, and locally. Returns the in-planner bridges' reports too (TCP, TLS).
    fn measure_guidance(
        &mut self,
        args: &Args,
    ) -> anyhow::Result<(GuidanceRow, [hrrtc_bridge::BridgeReport; 2])> {
        let pid = std::process::id();
        let in_planner = [
            self.start_in_planner(&self.tcp)?,
            self.start_in_planner(&self.tls)?,
        ];
        let shared = Arc::new(RelayShared::new());
        let relays = [
            spawn_relay(&self.tcp.ns_a, &shared),
            spawn_relay(&self.tls.ns_a, &shared),
            spawn_relay(&self.ns_local, &shared),
        ];
        let guidance = |seq: u64, planner_id: u32| Guidance {
            planner_id,
            ..Guidance::roadmap(
                Header::new(seq, ipc_types::monotonic_ns(), pid),
                [0.0; 6],
                0.0,
                0.0,
                100_000_000,
            )
        };
        // Every relayed path once per step (sent stamps unrecorded) until each arrived.
        let send = |path: GuidancePath, g: Guidance| match path {
            GuidancePath::Bridged(link) => {
                let (p, e) = &self.guidance_b[link as usize];
                let _ = p.send_copy(g);
                let _ = e.notify();
            }
            GuidancePath::InPlanner(link) => {
                in_planner[link as usize].sender.send(&g);
            }
            _ => {
                let _ = self.guidance_local.send_copy(g);
                let _ = self.event_local.notify();
            }
        };
        let relayed = RELAYED.map(|(path, _)| path);
        let mut seq = 0;
        let deadline = Instant::now() + Duration::from_secs(20);
        while !shared.all_seen() {
            if Instant::now() > deadline {
                shared.stop.store(true, Ordering::Release);
                for b in &in_planner {
                    b.stop.store(true, Ordering::Release);
                }
                bail!(
                    "guidance did not reach the relays within 20 s (arrived by path {:?}: {:?})",
                    relayed,
                    shared.seen.each_ref().map(|s| s.load(Ordering::Acquire))
                );
            }
            for path in relayed {
                seq += 1;
                send(path, guidance(seq, path.planner_id()));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let (sub, bare_hist) = stamped_subscriber(&self.bare_rx, "bench/bare/guidance")?;
        let child = ChildSubscriber::start(self.bare2_port, "bench/bare2/guidance", None)?;
        let child_tls = ChildSubscriber::start(
            self.bare2_tls_port,
            "bench/bare2tls/guidance",
            Some(self.lab),
        )?;
        let bare_pub = publisher(&self.bare_tx, "bench/bare/guidance".to_owned())?;
        let bare2_pub = publisher(&self.bare2_tx, "bench/bare2/guidance".to_owned())?;
        let bare2_tls_pub = publisher(&self.bare2_tls_tx, "bench/bare2tls/guidance".to_owned())?;
        std::thread::sleep(Duration::from_millis(500));
        shared.recording.store(true, Ordering::Release);
        let order = GuidancePath::order(self.tls_first);
        let first = seq + 1;
        paced(
            args.guidance_rate_hz * order.len() as f64,
            args.seconds,
            |i| {
                let path = order[i as usize % order.len()];
                match path {
                    GuidancePath::BareOne => put_stamped(&bare_pub, GUIDANCE_BYTES),
                    GuidancePath::BareTwo(Link::Tcp) => put_stamped(&bare2_pub, GUIDANCE_BYTES),
                    GuidancePath::BareTwo(Link::Tls) => put_stamped(&bare2_tls_pub, GUIDANCE_BYTES),
                    _ => {
                        let seq = first + i;
                        let g = guidance(seq, path.planner_id());
                        shared.sent[seq as usize % RING]
                            .store(ipc_types::monotonic_ns(), Ordering::Release);
                        send(path, g);
                    }
                }
            },
        );
        std::thread::sleep(Duration::from_millis(100));
        shared.stop.store(true, Ordering::Release);
        let mut hists = Vec::new();
        for r in relays {
            hists.push(r.join().map_err(|_| anyhow::anyhow!("relay panicked"))??);
        }
        drop(sub);
        let relayed_p = |path: GuidancePath| {
            let id = path.planner_id() as usize;
            hists[RELAYED[id].1][id].percentiles_us()
        };
        let row = GuidanceRow {
            bare_one_process: bare_hist.lock().unwrap().percentiles_us(),
            bare_two_processes: child.finish()?,
            bare_two_processes_tls: child_tls.finish()?,
            bridged: relayed_p(GuidancePath::Bridged(Link::Tcp)),
            bridged_tls: relayed_p(GuidancePath::Bridged(Link::Tls)),
            in_process_bridge: relayed_p(GuidancePath::InPlanner(Link::Tcp)),
            in_process_bridge_tls: relayed_p(GuidancePath::InPlanner(Link::Tls)),
            local: relayed_p(GuidancePath::Local),
        };
        let mut reports = Vec::new();
        for b in in_planner {
            b.stop.store(true, Ordering::Release);
            reports.push(
                b.thread
                    .join()
                    .map_err(|_| anyhow::anyhow!("bridge panicked"))??,
            );
        }
        let reports: [hrrtc_bridge::BridgeReport; 2] = reports
            .try_into()
            .map_err(|_| anyhow::anyhow!("two in-planner bridges"))?;
        Ok((row, reports))
    }

    /// Closes the bare sessions, stops the bridges and checks their summaries (with the
    /// in-planner bridges' reports, TCP and TLS).
    fn close(self, in_planner: [hrrtc_bridge::BridgeReport; 2]) -> anyhow::Result<Checks> {
        for s in [self.bare_tx, self.bare_rx, self.bare2_tx, self.bare2_tls_tx] {
            let _ = s.close().wait();
        }
        let [tcp_report, tls_report] = in_planner;
        Ok(Checks {
            tcp: self.tcp.stop(&tcp_report)?,
            tls: self.tls.stop(&tls_report)?,
        })
    }
}

/// A planner side of a bridge in this process ([`hrrtc_bridge::run_in_planner`]).
struct InPlanner {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<Result<hrrtc_bridge::BridgeReport, hrrtc_bridge::BridgeError>>,
    sender: hrrtc_bridge::GuidanceSender,
}

/// The guidance paths of the interleave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum GuidancePath {
    BareOne,
    BareTwo(Link),
    /// Through a pair of bridge processes to A's relay.
    Bridged(Link),
    /// From the in-planner bridge to A's relay.
    InPlanner(Link),
    /// A's service to A's relay.
    Local,
}

/// The paths ending at a relay, by `planner_id` (which tells a relay the path a sample came
/// by), with the relay that receives them (0: A over TCP, 1: A′ over TLS, 2: local).
const RELAYED: [(GuidancePath, usize); 5] = [
    (GuidancePath::Bridged(Link::Tcp), 0),
    (GuidancePath::Bridged(Link::Tls), 1),
    (GuidancePath::InPlanner(Link::Tcp), 0),
    (GuidancePath::InPlanner(Link::Tls), 1),
    (GuidancePath::Local, 2),
];

impl GuidancePath {
    fn planner_id(self) -> u32 {
        RELAYED
            .iter()
            .position(|(p, _)| *p == self)
            .map_or(u32::MAX, |i| i as u32)
    }

    /// The interleave: each TLS path beside its TCP twin, TLS first when `tls_first`.
    fn order(tls_first: bool) -> [GuidancePath; 8] {
        let [x, y] = Link::order(tls_first);
        [
            GuidancePath::BareOne,
            GuidancePath::BareTwo(x),
            GuidancePath::BareTwo(y),
            GuidancePath::Bridged(x),
            GuidancePath::Bridged(y),
            GuidancePath::InPlanner(x),
            GuidancePath::InPlanner(y),
            GuidancePath::Local,
        ]
    }
}

/// What the relay threads share: publish stamps by sequence number (`RING` slots), the
/// paths seen (during the warm-up), whether to record, and when to stop.
struct RelayShared {
    sent: Vec<AtomicU64>,
    seen: [AtomicBool; RELAYED.len()],
    recording: AtomicBool,
    stop: AtomicBool,
}

impl RelayShared {
    fn new() -> Self {
        RelayShared {
            sent: (0..RING).map(|_| AtomicU64::new(0)).collect(),
            seen: Default::default(),
            recording: AtomicBool::new(false),
            stop: AtomicBool::new(false),
        }
    }

    fn all_seen(&self) -> bool {
        self.seen.iter().all(|s| s.load(Ordering::Acquire))
    }
}

/// A thread receiving guidance on `ns` as the loop's relay does (woken by the guidance
/// event), recording each sample's latency by its `planner_id` once recording is on.
fn spawn_relay(
    ns: &str,
    shared: &Arc<RelayShared>,
) -> std::thread::JoinHandle<anyhow::Result<[NsHistogram; RELAYED.len()]>> {
    let (shared, ns) = (shared.clone(), ns.to_owned());
    std::thread::spawn(move || {
        let (node, _) = services::create_node("bench_bridge_relay")?;
        let sub = services::subscriber::<Guidance>(&node, &ns)?;
        let listener = services::guidance_listener(&node, &ns)?;
        let mut hist: [NsHistogram; RELAYED.len()] = Default::default();
        while !shared.stop.load(Ordering::Acquire) {
            let _ = listener.timed_wait(|_| {}, Duration::from_millis(1));
            while let Ok(Some(g)) = sub.receive() {
                let now = ipc_types::monotonic_ns();
                let id = g.planner_id as usize;
                if let Some(s) = shared.seen.get(id) {
                    s.store(true, Ordering::Release);
                }
                if !shared.recording.load(Ordering::Acquire) {
                    continue;
                }
                let t = shared.sent[g.header.sequence as usize % RING].load(Ordering::Acquire);
                if let Some(h) = hist.get_mut(id)
                    && t != 0
                {
                    h.record(now.saturating_sub(t));
                }
            }
        }
        Ok(hist)
    })
}

/// Publish stamps by sequence number (`RING` slots), shared with a reading thread.
fn sent_stamps() -> Arc<Vec<AtomicU64>> {
    Arc::new((0..RING).map(|_| AtomicU64::new(0)).collect())
}

/// The bridged state path: this process writes A's blackboard at the loop's rate from a
/// SCHED_FIFO thread, a reader thread spins on B's.
fn state_through_bridges(
    args: &Args,
    state_writer: services::StateWriter,
    ns_b: &str,
) -> anyhow::Result<Percentiles> {
    let pid = std::process::id();
    let sent = sent_stamps();
    let stop = Arc::new(AtomicBool::new(false));
    // Reader of B's state blackboard, spinning.
    let reader = {
        let (stop, sent, ns_b) = (stop.clone(), sent.clone(), ns_b.to_owned());
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
                    header: Header::new(seq, ipc_types::monotonic_ns(), pid),
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
    Ok(reader
        .join()
        .map_err(|_| anyhow::anyhow!("reader panicked"))??
        .percentiles_us())
}
