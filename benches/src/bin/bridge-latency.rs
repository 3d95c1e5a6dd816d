//! Latency across `hrrtc-bridge`, beside bare Zenoh publish-subscribe of the same payload
//! sizes, in one run on one host (one clock, so one-way latencies are exact).
//!
//! Each round starts two real `hrrtc-bridge` processes on this host, `--side loop` on
//! namespace A and `--side planner` on namespace B, joined over loopback TCP (same key
//! namespace), and measures:
//!
//! 1. **State** (`HapticState`, 552 bytes, at `--rate-hz`), one path after the other:
//!    bare Zenoh with publisher and subscriber in this process; bare Zenoh with the
//!    subscriber in a child process (this executable with `--bare-rx`); and through the
//!    bridges: this process plays the loop, writing A's blackboard from a SCHED_FIFO thread,
//!    and a reader thread spins on B's blackboard (the transport alone, as a phase-locked
//!    planner reading just after the write). The spinning reader takes a core of a 2-core
//!    machine, so the state paths do not run beside each other.
//! 2. **Guidance** (`Guidance`, 152 bytes, each path at `--guidance-rate-hz`), all paths
//!    interleaved in one sequence, each sample a fifth of the period after the previous
//!    one, so that every path sees the same machine (a shared host's load moves the bare
//!    baseline 2–4× between phases a few seconds apart): bare Zenoh in one process and
//!    to a child process as above; through the bridges (published on B with its event
//!    notified, as the planner does, received on A by a thread woken by A's guidance
//!    event, as the loop's relay is); from a planner running the planner side of the
//!    bridge in its own process (`hrrtc_bridge::run_in_planner`, as `planner serve
//!    --bridge-connect`: its guidance goes on Zenoh from the planning thread) to A's
//!    relay; and on one host without a bridge (A's service to A's relay: the one hop every
//!    guidance sample takes to reach the loop).
//!
//! Latencies through iceoryx2 are from the stamp taken just before the local write to the
//! reading thread's clock, by sequence number (the bridges re-stamp samples, so their
//! stamps are not used); over bare Zenoh from the stamp in the payload to the callback.
//!
//! The goal's ratio is bridge / bare Zenoh at p50 for each direction, the median over
//! rounds. Its baseline is bare Zenoh between two processes, as between two hosts and as
//! the bridges' path is; the ratio against one process (where Zenoh's sessions share a
//! runtime) is printed beside it. Both run under a 0 µs CPU wake-up latency request, as on
//! a host whose haptic loop is running (`--no-cpu-latency-request` to leave it out).
//!
//! `cargo build --release -p hrrtc-bridge -p benches && target/release/bridge-latency --seconds 5`

use anyhow::{Context, bail};
use clap::Parser;
use ipc_types::latency::{NsHistogram, Percentiles};
use ipc_types::{Guidance, HapticState, Header, services};
use serde::Serialize;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;
use zenoh::qos::CongestionControl;

/// Latency of the state and guidance paths through two bridges versus bare Zenoh.
#[derive(Debug, Parser)]
struct Args {
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
}

/// The state paths' latencies in one round, µs.
#[derive(Debug, Clone, Copy, Serialize)]
struct StateRow {
    bare_one_process: Percentiles,
    bare_two_processes: Percentiles,
    bridged: Percentiles,
}

/// The guidance paths' latencies in one round (interleaved), µs.
#[derive(Debug, Clone, Copy, Serialize)]
struct GuidanceRow {
    bare_one_process: Percentiles,
    bare_two_processes: Percentiles,
    /// Planner → its host's bridge → the loop's bridge → the loop's relay.
    bridged: Percentiles,
    /// A planner with the bridge in its process (`planner serve --bridge-connect`) → the
    /// loop's bridge → the loop's relay.
    in_process_bridge: Percentiles,
    /// One host, no bridge: planner → the loop's relay.
    local: Percentiles,
}

#[derive(Debug, Serialize)]
struct Round {
    state: StateRow,
    guidance: GuidanceRow,
    /// Bridged / bare Zenoh between two processes, at p50.
    state_ratio_p50: f64,
    guidance_ratio_p50: f64,
    /// Through the in-process bridge / bare Zenoh between two processes, at p50.
    guidance_in_process_ratio_p50: f64,
    /// Bridged / bare Zenoh within one process, at p50.
    state_ratio_one_process_p50: f64,
    guidance_ratio_one_process_p50: f64,
}

#[derive(Debug, Serialize)]
struct Report {
    rounds: Vec<Round>,
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

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if let Some(port) = args.bare_rx {
        return bare_rx(port, &args.bare_rx_key);
    }
    anyhow::ensure!(
        args.seconds > 0.0 && args.rate_hz > 0.0 && args.guidance_rate_hz > 0.0,
        "--seconds, --rate-hz and --guidance-rate-hz must be positive"
    );
    let bridge = benches::across::sibling_exe(
        args.bridge.as_deref(),
        "hrrtc-bridge",
        "hrrtc-bridge",
        "--bridge",
    )?;
    let _cpu_latency = benches::across::cpu_latency_request(args.no_cpu_latency_request);
    let mut rounds = Vec::new();
    for r in 0..args.rounds {
        let (state, guidance) = one_round(&args, &bridge, 17_600 + 4 * r as u16, r)?;
        let round = Round {
            state_ratio_p50: state.bridged.p50 / state.bare_two_processes.p50,
            guidance_ratio_p50: guidance.bridged.p50 / guidance.bare_two_processes.p50,
            guidance_in_process_ratio_p50: guidance.in_process_bridge.p50
                / guidance.bare_two_processes.p50,
            state_ratio_one_process_p50: state.bridged.p50 / state.bare_one_process.p50,
            guidance_ratio_one_process_p50: guidance.bridged.p50 / guidance.bare_one_process.p50,
            state,
            guidance,
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
        median_guidance_in_process_ratio_p50: median(|r| r.guidance_in_process_ratio_p50),
        median_state_ratio_one_process_p50: median(|r| r.state_ratio_one_process_p50),
        median_guidance_ratio_one_process_p50: median(|r| r.guidance_ratio_one_process_p50),
        rounds,
    };
    println!(
        "median over {} rounds, bridge / bare Zenoh at p50: state {:.2}, guidance {:.2}, \
         guidance from a planner with the bridge in its process {:.2} \
         (against one process: state {:.2}, guidance {:.2})",
        report.rounds.len(),
        report.median_state_ratio_p50,
        report.median_guidance_ratio_p50,
        report.median_guidance_in_process_ratio_p50,
        report.median_state_ratio_one_process_p50,
        report.median_guidance_ratio_one_process_p50,
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
        "  {:<36} {:>8} {:>8} {:>8} {:>8} {:>7}",
        "µs", "p50", "p99", "p99.9", "max", "count"
    );
    let line = |name: &str, p: &Percentiles| {
        println!(
            "  {name:<36} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>7}",
            p.p50, p.p99, p.p999, p.max, p.count
        )
    };
    let (s, g) = (&round.state, &round.guidance);
    line("state, bare Zenoh, one process", &s.bare_one_process);
    line("state, bare Zenoh, two processes", &s.bare_two_processes);
    line("state, loop → bridge → bridge → B", &s.bridged);
    line("guidance, bare Zenoh, one process", &g.bare_one_process);
    line("guidance, bare Zenoh, two processes", &g.bare_two_processes);
    line("guidance, B → bridge → bridge → A", &g.bridged);
    line("guidance, B (in-process bridge) → A", &g.in_process_bridge);
    line("guidance, A → A (one host, no bridge)", &g.local);
    println!(
        "  bridge / bare at p50: state {:.2}, guidance {:.2}, in-process bridge {:.2} \
         (one process: {:.2}, {:.2})",
        round.state_ratio_p50,
        round.guidance_ratio_p50,
        round.guidance_in_process_ratio_p50,
        round.state_ratio_one_process_p50,
        round.guidance_ratio_one_process_p50
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
/// connected to a listening session of this process.
struct ChildSubscriber {
    child: Child,
    out: std::io::BufReader<std::process::ChildStdout>,
}

impl ChildSubscriber {
    fn start(port: u16, key: &str) -> anyhow::Result<Self> {
        let mut child = Command::new(std::env::current_exe()?)
            .args(["--bare-rx", &port.to_string(), "--bare-rx-key", key])
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
fn bare_rx(port: u16, key: &str) -> anyhow::Result<()> {
    let session = benches::across::zenoh_session(None, Some(port))?;
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

/// One round: the bridges and the bare sessions set up, the state measured on its paths
/// one at a time, then guidance on all its paths interleaved.
fn one_round(
    args: &Args,
    bridge: &std::path::Path,
    port: u16,
    round: u32,
) -> anyhow::Result<(StateRow, GuidanceRow)> {
    let mut rig = Rig::open(bridge, port, round, args.state_poll_us)?;
    let state = rig.measure_state(args)?;
    let guidance = rig.measure_guidance(args)?;
    rig.close();
    Ok((state, guidance))
}

/// What a round measures through: two bridge processes (loop side on namespace A, planner
/// side on B), this process's ports on A, B and a local namespace, and bare Zenoh sessions.
struct Rig {
    round: u32,
    keys: String,
    endpoint: String,
    bare2_port: u16,
    ns_a: String,
    ns_b: String,
    ns_local: String,
    _node: iceoryx2::node::Node<services::Ipc>,
    /// Taken by the state measurement.
    state_writer: Option<services::StateWriter>,
    guidance_b: services::Publisher<Guidance>,
    event_b: services::GuidanceNotifier,
    guidance_local: services::Publisher<Guidance>,
    event_local: services::GuidanceNotifier,
    _bridges: (Kill, Kill),
    bare_tx: zenoh::Session,
    bare_rx: zenoh::Session,
    bare2_tx: zenoh::Session,
}

impl Rig {
    /// Starts the bridges (the loop side first: the planner side's state writer, and the
    /// ports both open, exist before this process opens them) and the bare sessions on
    /// `port`, `port + 1`; the bridges meet on `port + 2`.
    fn open(
        bridge: &std::path::Path,
        port: u16,
        round: u32,
        state_poll_us: u64,
    ) -> anyhow::Result<Self> {
        let pid = std::process::id();
        let ns_a = format!("bench_bridge_a_{pid}_{round}");
        let ns_b = format!("bench_bridge_b_{pid}_{round}");
        let ns_local = format!("bench_local_{pid}_{round}");
        let keys = format!("bench_bridge_{pid}_{round}");
        let (bare_port, bare2_port, bridge_port) = (port, port + 1, port + 2);
        let endpoint = format!("tcp/127.0.0.1:{bridge_port}");
        let poll = state_poll_us.to_string();
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
        let (node, _) = services::create_node("bench_bridge")?;
        let state_writer = services::state_writer(&node, &ns_a)?;
        let guidance_b = services::publisher::<Guidance>(&node, &ns_b)?;
        let event_b = services::guidance_notifier(&node, &ns_b)?;
        let guidance_local = services::publisher::<Guidance>(&node, &ns_local)?;
        let event_local = services::guidance_notifier(&node, &ns_local)?;
        let a = spawn("loop", &ns_a, "--listen")?;
        std::thread::sleep(Duration::from_millis(300));
        let b = spawn("planner", &ns_b, "--connect")?;
        let bare_tx = benches::across::zenoh_session(Some(bare_port), None)?;
        let bare_rx = benches::across::zenoh_session(None, Some(bare_port))?;
        let bare2_tx = benches::across::zenoh_session(Some(bare2_port), None)?;
        std::thread::sleep(Duration::from_millis(1500));
        Ok(Rig {
            round,
            keys,
            endpoint,
            bare2_port,
            ns_a,
            ns_b,
            ns_local,
            _node: node,
            state_writer: Some(state_writer),
            guidance_b,
            event_b,
            guidance_local,
            event_local,
            _bridges: (a, b),
            bare_tx,
            bare_rx,
            bare2_tx,
        })
    }

    /// The state, one path at a time (the bridged path's reader spins on a core): bare
    /// Zenoh in one process, in two, and through the two bridges.
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
        let bare_two = {
            let key = "bench/bare2/state";
            let child = ChildSubscriber::start(self.bare2_port, key)?;
            let p = publisher(&self.bare2_tx, key.to_owned())?;
            std::thread::sleep(Duration::from_millis(500));
            paced(args.rate_hz, args.seconds, |_| put_stamped(&p, STATE_BYTES));
            std::thread::sleep(Duration::from_millis(100));
            child.finish()?
        };
        let writer = self
            .state_writer
            .take()
            .context("the state is measured once a round")?;
        let bridged = state_through_bridges(args, writer, &self.ns_b)?;
        Ok(StateRow {
            bare_one_process: bare_one,
            bare_two_processes: bare_two,
            bridged,
        })
    }

    /// Guidance on every path, interleaved: bare Zenoh in one process and in two, through
    /// the bridges to A's relay, from a planner with the bridge in its process (`planner
    /// serve --bridge-connect`, on its own namespace: started after the state paths, which
    /// it would otherwise receive too) to A's relay, and locally.
    fn measure_guidance(&mut self, args: &Args) -> anyhow::Result<GuidanceRow> {
        let pid = std::process::id();
        let in_process_stop = Arc::new(AtomicBool::new(false));
        let (tx, rx) = std::sync::mpsc::channel();
        let in_process = {
            let mut config = hrrtc_bridge::BridgeConfig::new(
                hrrtc_bridge::Side::Planner,
                &format!("bench_bridge_c_{pid}_{}", self.round),
            );
            config.key_namespace = Some(self.keys.clone());
            config.connect = vec![self.endpoint.clone()];
            config.roadmap = false;
            let stop = in_process_stop.clone();
            std::thread::spawn(move || hrrtc_bridge::run_in_planner(&config, stop, tx))
        };
        let Ok(in_process_sender) = rx.recv() else {
            let e = in_process
                .join()
                .map_err(|_| anyhow::anyhow!("bridge panicked"))?;
            bail!("the in-process bridge did not start: {:?}", e.err());
        };
        std::thread::sleep(Duration::from_millis(500));

        let sent = sent_stamps();
        let stop = Arc::new(AtomicBool::new(false));
        let relay_a = spawn_relay(&self.ns_a, &sent, &stop);
        let relay_local = spawn_relay(&self.ns_local, &sent, &stop);
        let (sub, bare_hist) = stamped_subscriber(&self.bare_rx, "bench/bare/guidance")?;
        let child = ChildSubscriber::start(self.bare2_port, "bench/bare2/guidance")?;
        let bare_pub = publisher(&self.bare_tx, "bench/bare/guidance".to_owned())?;
        let bare2_pub = publisher(&self.bare2_tx, "bench/bare2/guidance".to_owned())?;
        std::thread::sleep(Duration::from_millis(500));
        const PATHS: u64 = 5;
        paced(args.guidance_rate_hz * PATHS as f64, args.seconds, |i| {
            let seq = i + 1;
            // `planner_id` tells the relay of A which path a sample came by.
            let g = |planner_id| Guidance {
                planner_id,
                ..Guidance::roadmap(
                    Header::new(seq, ipc_types::monotonic_ns(), pid),
                    [0.0; 6],
                    0.0,
                    0.0,
                    100_000_000,
                )
            };
            let stamp =
                || sent[seq as usize % RING].store(ipc_types::monotonic_ns(), Ordering::Release);
            match i % PATHS {
                0 => put_stamped(&bare_pub, GUIDANCE_BYTES),
                1 => put_stamped(&bare2_pub, GUIDANCE_BYTES),
                2 => {
                    let g = g(BRIDGED);
                    stamp();
                    let _ = self.guidance_b.send_copy(g);
                    let _ = self.event_b.notify();
                }
                3 => {
                    let g = g(IN_PROCESS);
                    stamp();
                    in_process_sender.send(&g);
                }
                _ => {
                    let g = g(LOCAL);
                    stamp();
                    let _ = self.guidance_local.send_copy(g);
                    let _ = self.event_local.notify();
                }
            }
        });
        std::thread::sleep(Duration::from_millis(100));
        stop.store(true, Ordering::Release);
        let a = relay_a
            .join()
            .map_err(|_| anyhow::anyhow!("relay panicked"))??;
        let local = relay_local
            .join()
            .map_err(|_| anyhow::anyhow!("relay panicked"))??;
        drop(sub);
        let row = GuidanceRow {
            bare_one_process: bare_hist.lock().unwrap().percentiles_us(),
            bare_two_processes: child.finish()?,
            bridged: a[BRIDGED as usize].percentiles_us(),
            in_process_bridge: a[IN_PROCESS as usize].percentiles_us(),
            local: local[LOCAL as usize].percentiles_us(),
        };
        in_process_stop.store(true, Ordering::Release);
        in_process
            .join()
            .map_err(|_| anyhow::anyhow!("bridge panicked"))??;
        Ok(row)
    }

    /// Closes the bare sessions; the bridges stop when dropped.
    fn close(self) {
        for s in [self.bare_tx, self.bare_rx, self.bare2_tx] {
            let _ = s.close().wait();
        }
    }
}

/// `planner_id`s marking the guidance paths that end at a relay.
const BRIDGED: u32 = 0;
const IN_PROCESS: u32 = 1;
const LOCAL: u32 = 2;

/// A thread receiving guidance on `ns` as the loop's relay does (woken by the guidance
/// event), recording each sample's latency by its `planner_id`.
fn spawn_relay(
    ns: &str,
    sent: &Arc<Vec<AtomicU64>>,
    stop: &Arc<AtomicBool>,
) -> std::thread::JoinHandle<anyhow::Result<[NsHistogram; 3]>> {
    let (stop, sent, ns) = (stop.clone(), sent.clone(), ns.to_owned());
    std::thread::spawn(move || {
        let (node, _) = services::create_node("bench_bridge_relay")?;
        let sub = services::subscriber::<Guidance>(&node, &ns)?;
        let listener = services::guidance_listener(&node, &ns)?;
        let mut hist: [NsHistogram; 3] = Default::default();
        while !stop.load(Ordering::Acquire) {
            let _ = listener.timed_wait(|_| {}, Duration::from_millis(1));
            while let Ok(Some(g)) = sub.receive() {
                let now = ipc_types::monotonic_ns();
                let t = sent[g.header.sequence as usize % RING].load(Ordering::Acquire);
                if let Some(h) = hist.get_mut(g.planner_id as usize)
                    && t != 0
                {
                    h.record(now.saturating_sub(t));
                }
            }
        }
        Ok(hist)
    })
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
