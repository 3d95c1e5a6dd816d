//! `planner serve`: next to a haptic loop, over iceoryx2, or on another host with that
//! host's side of the bridge inside (`--bridge-connect`). The options are validated into a
//! [`ShellConfig`]; [`planner_shell::run`] does the work.

use crate::common::{CoreArgs, PortfolioArgs, SamplingArgs, non_negative, positive, positive_opt};
use anyhow::bail;
use clap::Args;
use hrrtc_bridge::clock::HostClock;
use hrrtc_bridge::{BridgeConfig, Side};
use ipc_types::services;
use planner_shell::{self as shell, ShellConfig};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// Options of `planner serve`.
#[derive(Debug, Args, Clone)]
pub struct ServeArgs {
    /// Scene, seed and tree parameters.
    #[command(flatten)]
    pub core: CoreArgs,
    /// IPC namespace; must match the haptic loop's.
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    pub namespace: String,
    /// Guidance publish rate, Hz, independent of iteration speed.
    #[arg(long, default_value_t = 100.0)]
    pub guidance_rate_hz: f64,
    /// k for the force part of F_s = k·F_a, N per scene metre.
    #[arg(long, default_value_t = 20.0)]
    pub gain_n_per_m: f64,
    /// k for the torque part of F_s = k·F_a before a solution, N·m per rad. Default 0: the
    /// orientations of the roadmap's nodes near the operator are mostly uniform draws, and
    /// their barycenter leans towards the goal's orientation (the distance label), which is
    /// not the orientation of the openings on the way; an operator who followed that torque
    /// lost the orientations it had found by touch (bug trap without its route, adaptive
    /// H-RRT-C at α 0.9, the newcomer: at the goal 0 of 5 sessions at 0.05 N·m/rad, 3 of 3
    /// at 0; docs/guide/planner-and-scenes.md). After a solution the lead's torque
    /// (--lead-torque-nm) turns the object to the path's orientation.
    #[arg(long, default_value_t = 0.0)]
    pub gain_nm_per_rad: f64,
    /// Once solved, the guidance leads along the path: a spring towards a carrot ahead on
    /// it whose pull saturates at this force, N (at 5 cm from the carrot; 40 N/m at the
    /// default). Keep it within what the loop renders: 0.4 × the device's maximum force
    /// (3.2 N for the simulated arm).
    #[arg(long, default_value_t = 2.0)]
    pub lead_force_n: f64,
    /// Once solved, the torque towards the path's orientation at the carrot saturates at
    /// this, N·m (at 0.5 rad; 0.2 N·m/rad at the default). The loop renders up to 0.4 ×
    /// the device's maximum torque (0.2 N·m for the simulated arm).
    #[arg(long, default_value_t = 0.1)]
    pub lead_torque_nm: f64,
    /// Time-to-live of each guidance sample, ms; the loop fades it out after that.
    #[arg(long, default_value_t = 100.0)]
    pub ttl_ms: f64,
    /// How the operator's input drives sampling.
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// The narrow-passage methods taking turns with the operator's samples.
    #[command(flatten)]
    pub portfolio: PortfolioArgs,
    /// Memory bound.
    #[command(flatten)]
    pub memory: crate::common::MemoryArgs,
    /// How often to poll the haptic state until the receiver has locked onto the loop's
    /// ticks (then it polls once per tick, just after each state is written) and while no
    /// new state comes, Hz.
    #[arg(long, default_value_t = 2000.0)]
    pub poll_hz: f64,
    /// Longest watch for each state after waking before its predicted write, µs: the
    /// receiver learns to wake before four writes in five and spins until the state comes,
    /// reading it within ~1 µs of its write for about the spread of its own wake-ups in CPU
    /// per tick (this window only bounds a late tick's cost). 0: it only sleeps, reading
    /// each state its wake-up latency after the write (~5–40 µs). It spins only for a loop
    /// with a real-time thread: a loop at normal priority needs that CPU more.
    #[arg(long, default_value_t = 100.0)]
    pub state_spin_us: f64,
    /// SCHED_FIFO priority of the thread that receives the haptic state (below the haptic
    /// loop's, 80 by default), so that it wakes on time on a busy machine and catches each
    /// state as it is written; it sleeps but for the spin window. 0 keeps the normal
    /// scheduler; without permission (see docs/guide/configuration.md, "Without real-time
    /// permissions") it is kept too, with a warning.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u8).range(0..=98))]
    pub state_priority: u8,
    /// Roadmap increments per second for `planner view` (1024 nodes each; a late viewer
    /// gets the whole roadmap from a rolling window); 0 publishes none.
    #[arg(long, default_value_t = 20.0)]
    pub roadmap_rate_hz: f64,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Keep growing the trees while no haptic loop publishes a fresh state (by default
    /// the planner idles then, and resumes when a loop appears).
    #[arg(long)]
    pub plan_without_operator: bool,
    /// Write a JSON report here on exit.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// A planner on another host than the haptic loop, without a bridge process here.
    #[command(flatten)]
    pub bridge: BridgeArgs,
}

/// `--bridge-*`: this host's side of `hrrtc-bridge` run inside the planner.
#[derive(Debug, Args, Clone)]
pub struct BridgeArgs {
    /// Zenoh endpoint of the loop host's `hrrtc-bridge --side loop`, e.g.
    /// `quic/ARM-HOST:7447` (repeatable), with the --bridge-tls-* files and
    /// --bridge-allow-peer naming the loop's certificate. Runs this host's side of the bridge inside this
    /// process instead of `hrrtc-bridge --side planner`: the haptic state arrives in this
    /// host's state blackboard as through that bridge, paths and roadmaps leave through
    /// it, and guidance goes on Zenoh straight from the planning thread (no bridge thread
    /// to wake on its way). Run no other planner-side bridge on this namespace here.
    #[arg(long, value_name = "ENDPOINT")]
    pub bridge_connect: Vec<String>,
    /// Zenoh endpoint for the loop host's bridge to connect to instead (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub bridge_listen: Vec<String>,
    /// Give up when no --bridge-connect endpoint answers within this at start, s.
    #[arg(long, default_value_t = 10.0)]
    pub bridge_connect_timeout_s: f64,
    /// Common name of the loop host's certificate (repeatable): the only peer allowed to put
    /// the state here and to receive this planner's guidance, paths and roadmaps
    /// (as `hrrtc-bridge --allow-peer`).
    #[arg(long, value_name = "CN")]
    pub bridge_allow_peer: Vec<String>,
    /// Zenoh configuration file (JSON5) for the bridge: any Zenoh setting; the flags apply on
    /// top of it (as `hrrtc-bridge --zenoh-config`).
    #[arg(long, value_name = "FILE")]
    pub bridge_zenoh_config: Option<PathBuf>,
    /// The lab's CA certificate (PEM) for the bridge's mutual TLS (as `hrrtc-bridge
    /// --tls-ca`; with --bridge-tls-cert and --bridge-tls-key).
    #[arg(long, value_name = "FILE", requires_all = ["bridge_tls_cert", "bridge_tls_key"])]
    pub bridge_tls_ca: Option<PathBuf>,
    /// This host's certificate (PEM), signed by the lab's CA.
    #[arg(long, value_name = "FILE", requires_all = ["bridge_tls_ca", "bridge_tls_key"])]
    pub bridge_tls_cert: Option<PathBuf>,
    /// This host's private key (PEM).
    #[arg(long, value_name = "FILE", requires_all = ["bridge_tls_ca", "bridge_tls_cert"])]
    pub bridge_tls_key: Option<PathBuf>,
    /// Allow bridge links that are not mutually authenticated TLS (plain tcp/ endpoints):
    /// anyone who reaches them can read the operator's state and push guidance.
    #[arg(long)]
    pub bridge_insecure: bool,
    /// Testing: present this host's clock to the loop's host shifted by this many
    /// seconds (as `hrrtc-bridge --clock-offset-s`).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, hide = true)]
    pub bridge_clock_offset_s: f64,
}

impl BridgeArgs {
    /// The in-process bridge's configuration, if one is asked for.
    fn to_config(&self, namespace: &str, roadmap: bool) -> anyhow::Result<Option<BridgeConfig>> {
        if self.bridge_connect.is_empty() && self.bridge_listen.is_empty() {
            return Ok(None);
        }
        let timeout = non_negative("bridge-connect-timeout-s", self.bridge_connect_timeout_s)?;
        anyhow::ensure!(
            self.bridge_clock_offset_s.is_finite(),
            "--bridge-clock-offset-s {}: must be a finite number",
            self.bridge_clock_offset_s
        );
        let security = hrrtc_bridge::SecurityArgs {
            zenoh_config: self.bridge_zenoh_config.clone(),
            tls_ca: self.bridge_tls_ca.clone(),
            tls_cert: self.bridge_tls_cert.clone(),
            tls_key: self.bridge_tls_key.clone(),
            insecure: self.bridge_insecure,
        }
        .security("bridge-");
        Ok(Some(BridgeConfig {
            listen: self.bridge_listen.clone(),
            connect: self.bridge_connect.clone(),
            security,
            allow_peers: self.bridge_allow_peer.clone(),
            connect_timeout_s: timeout,
            roadmap,
            clock: HostClock::simulated(self.bridge_clock_offset_s, 0.0),
            ..BridgeConfig::new(Side::Planner, namespace)
        }))
    }
}

impl ServeArgs {
    /// Validates the arguments into a [`ShellConfig`] (loads the scene).
    pub fn to_config(&self) -> anyhow::Result<ShellConfig> {
        let (scene, mut params) = self.core.load()?;
        self.sampling.apply(&mut params)?;
        services::validate_namespace(&self.namespace)
            .map_err(|e| anyhow::anyhow!("--namespace: {e}"))?;
        Ok(ShellConfig {
            namespace: self.namespace.clone(),
            scene,
            params,
            seed: self.core.seed,
            guidance_rate_hz: positive("guidance-rate-hz", self.guidance_rate_hz)?,
            gain_n_per_m: non_negative("gain-n-per-m", self.gain_n_per_m)?,
            gain_nm_per_rad: non_negative("gain-nm-per-rad", self.gain_nm_per_rad)?,
            lead_force_n: non_negative("lead-force-n", self.lead_force_n)?,
            lead_torque_nm: non_negative("lead-torque-nm", self.lead_torque_nm)?,
            ttl_s: positive("ttl-ms", self.ttl_ms)? / 1000.0,
            state_poll_hz: positive("poll-hz", self.poll_hz)?,
            state_spin_us: {
                let v = non_negative("state-spin-us", self.state_spin_us)?;
                if v > 500.0 {
                    bail!("--state-spin-us must be at most 500 (half a tick at 1 kHz), got {v}");
                }
                v
            },
            state_priority: self.state_priority,
            state_timeout_s: 0.5,
            plan_without_operator: self.plan_without_operator,
            roadmap_rate_hz: if self.roadmap_rate_hz == 0.0 {
                0.0
            } else {
                positive("roadmap-rate-hz", self.roadmap_rate_hz)?
            },
            duration_s: positive_opt("duration-s", self.duration_s)?,
            portfolio: self
                .portfolio
                .params(SERVE_PORTFOLIO, self.sampling.adaptive_authority()?)?,
            memory: Some(self.memory.bound()?),
        })
    }
}

/// `planner serve`'s --portfolio when none is given: every method. Live, on the built-in
/// scenes without their routes and the newcomer, it solved the bug trap 20 of 20 (median
/// 6.1 s) where the single planner took a median of 40 s, the tunnels, crossing planes and
/// wall-hole in medians under 0.5 s against 4.6–55 s (docs/guide/planner-and-scenes.md,
/// "Narrow passages, live").
pub const SERVE_PORTFOLIO: &str = "all";

/// Runs the command until Ctrl-C / SIGTERM or --duration-s; the exit code is 0.
pub fn run(args: &ServeArgs) -> anyhow::Result<i32> {
    let oom = crate::raise_oom_score_adj();
    let config = args.to_config()?;
    let bridge = args
        .bridge
        .to_config(&config.namespace, config.roadmap_rate_hz > 0.0)?;
    let stop: Arc<AtomicBool> = crate::stop_on_signal()?;
    tracing::info!(
        "planner serving scene '{}' in namespace '{}' (seed {})",
        config.scene.name,
        config.namespace,
        config.seed
    );
    let report = match bridge {
        None => shell::run(&config, stop)?,
        Some(b) => serve_with_bridge(&config, &b, stop)?,
    };
    tracing::info!(
        "planner done: solved {}, {} iterations, {} nodes, states {:.0} Hz; touch: {} operator samples pushed out of a shallow collision, {} reached by a tree, {} on the raw path",
        report.solved,
        report.iterations,
        report.nodes,
        report.state_rate_hz,
        report.touched,
        report.touched_nodes,
        report.touched_on_path
    );
    let t = &report.samples;
    let kind = |name: &str, share: f64, k: &shell::SourceTally| {
        let per = |v: u64| v as f64 / k.iterations.max(1) as f64;
        format!(
            "{name} {:.1} % ({:.3} nodes, {:.3} novel, {:.3} barren a sample)",
            100.0 * share,
            per(k.nodes_added),
            per(k.novel),
            per(k.barren)
        )
    };
    let [m, o, c] = t.shares();
    tracing::info!(
        "planner samples until the solution: {}; {}; {}",
        kind("machine", m, &t.machine),
        kind("operator", o, &t.operator),
        kind("contact", c, &t.contact)
    );
    if let Some(p) = &report.portfolio {
        let methods: Vec<String> = p.methods.iter().map(ToString::to_string).collect();
        tracing::info!(
            "portfolio: {}; solved on a {} turn; longest turn {:.1} ms",
            methods.join("; "),
            p.solved_by.as_deref().unwrap_or("no"),
            report.longest_turn_ms
        );
        if let Some(e) = &p.thinning_error {
            tracing::warn!("portfolio: thinning stopped: {e}");
        }
    }
    if let Some(m) = &report.memory {
        tracing::info!("planner {}", crate::common::memory_line(m));
    }
    if let Some(p) = &args.json {
        crate::write_json(p, &crate::with_oom(&report, &oom))?;
    }
    Ok(0)
}

/// The shell with this host's side of the bridge on a thread of its own; guidance goes to
/// Zenoh from the planning thread.
fn serve_with_bridge(
    config: &ShellConfig,
    bridge: &BridgeConfig,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<shell::ShellReport> {
    let (tx, rx) = std::sync::mpsc::channel();
    let thread = {
        let (bridge, stop) = (bridge.clone(), stop.clone());
        std::thread::Builder::new()
            .name("bridge".into())
            .spawn(move || hrrtc_bridge::run_in_planner(&bridge, stop, tx))?
    };
    let Ok(sender) = rx.recv() else {
        // The bridge ended before it was up: its error says why.
        let ended = thread
            .join()
            .map_err(|_| anyhow::anyhow!("the bridge thread panicked"))?;
        return Err(match ended {
            Err(e) => anyhow::Error::new(e).context(
                "the in-process bridge (--bridge-*; several planners on one host share one \
                 `hrrtc-bridge --side planner` instead)",
            ),
            Ok(_) => anyhow::anyhow!("stopped before the in-process bridge was up"),
        });
    };
    let report = shell::run_with_guidance_out(config, stop.clone(), &|g| {
        sender.send(g);
    });
    stop.store(true, std::sync::atomic::Ordering::Release);
    let bridged = thread
        .join()
        .map_err(|_| anyhow::anyhow!("the bridge thread panicked"))?;
    match bridged {
        Ok(r) => {
            let (state, guidance) = (r.kind("state"), r.kind("guidance"));
            tracing::info!(
                "bridge: {} states received, {} delivered; {} guidance samples sent, {} dropped",
                state.received,
                state.delivered,
                guidance.sent,
                guidance.dropped
            );
        }
        Err(e) => tracing::warn!("the in-process bridge: {e}"),
    }
    Ok(report?)
}
