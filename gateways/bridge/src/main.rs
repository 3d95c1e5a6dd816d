//! `hrrtc-bridge`: carries one namespace's haptic state, guidance, paths and roadmaps
//! between two hosts over Zenoh, so that the planner can run on another machine than the
//! haptic arm. Run one on each host. Exit codes: 0 stopped, 2 an error (printed on stderr)
//! or bad arguments.

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};
use hrrtc_bridge::clock::HostClock;
use hrrtc_bridge::{BridgeConfig, Side};
use std::path::PathBuf;

/// Bridge one namespace of the haptic loop and planner between hosts over Zenoh, mutually
/// authenticated with TLS.
///
/// Once per lab: `hrrtc-bridge certs --out certs --name loop=ARM-HOST --name planner-1`,
/// then copy certs/ca.pem and each host's NAME.pem and NAME.key to that host.
///
/// On the arm's host: `hrrtc-bridge --side loop --listen quic/0.0.0.0:7447 --tls-ca ca.pem
/// --tls-cert loop.pem --tls-key loop.key --allow-peer planner-1`.
/// On the planner's host: `hrrtc-bridge --side planner --connect quic/ARM-HOST:7447 --tls-ca
/// ca.pem --tls-cert planner-1.pem --tls-key planner-1.key --allow-peer loop`, then `planner
/// serve` there as usual (or, for one planner, only `planner serve --bridge-connect ...`
/// with the same options named --bridge-*, which runs this side in its own process).
/// Plain tcp/ endpoints are refused unless --insecure. Stops on Ctrl-C / SIGTERM or after
/// --duration-s.
#[derive(Debug, Parser)]
#[command(
    name = "hrrtc-bridge",
    version,
    about,
    long_about,
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// This host's role: `loop` (the haptic loop runs here: its state goes out, guidance,
    /// paths and roadmaps come in) or `planner` (the reverse).
    #[arg(long, value_enum, required = true)]
    side: Option<SideArg>,
    /// iceoryx2 namespace of the loop and planner (their --namespace); the Zenoh keys are
    /// `hrrtc/<namespace>/...` and must match on both hosts.
    #[arg(long, default_value = ipc_types::services::DEFAULT_NAMESPACE)]
    namespace: String,
    /// Zenoh key namespace, if not the iceoryx2 namespace (both bridges must use the same).
    #[arg(long)]
    key_namespace: Option<String>,
    /// Zenoh endpoint to listen on, e.g. `quic/0.0.0.0:7447` (repeatable). Open this
    /// port in the host's firewall (UDP for quic/, TCP for tls/).
    #[arg(long)]
    listen: Vec<String>,
    /// Zenoh endpoint of the other host's bridge, e.g. `quic/192.168.1.20:7447` (repeatable):
    /// the host as named in its certificate's subject alternative names.
    #[arg(long)]
    connect: Vec<String>,
    /// Common name of a certificate allowed in (repeatable): on the loop's side the
    /// planners' hosts, which may then receive the state and put guidance, paths and
    /// roadmaps; on a planner's side the loop's host, the only one that may put the state.
    #[arg(long, value_name = "CN")]
    allow_peer: Vec<String>,
    #[command(flatten)]
    security: zenoh_session::SecurityArgs,
    /// Give up starting when no --connect endpoint answers within this, s. Once connected,
    /// a lost link is retried for ever (every 0.1–1 s).
    #[arg(long, default_value_t = 10.0)]
    connect_timeout_s: f64,
    /// Loop side: send at most this many states per second (default: every tick).
    #[arg(long)]
    state_rate_hz: Option<f64>,
    /// Loop side: poll period of the state blackboard, µs, until it has locked onto a
    /// real-time loop's ticks (then it reads once per tick, just after the write), and for
    /// a loop without real-time rights.
    #[arg(long, default_value_t = 100)]
    state_poll_us: u64,
    /// Do not carry roadmap increments (they are only for `planner view`: ~90 KB each, up
    /// to 20 per second per planner).
    #[arg(long)]
    no_roadmap: bool,
    /// Stop after this many seconds.
    #[arg(long)]
    duration_s: Option<f64>,
    /// Testing: present this host's clock to the other side shifted by this many seconds,
    /// as a host booted at another time would. The re-stamping on arrival must cancel it.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    clock_offset_s: f64,
    /// Testing: and running this many parts per million fast (negative: slow).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    clock_drift_ppm: f64,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Make a lab's CA and a certificate and key per host, for labs without a PKI: writes
    /// DIR/ca.pem and DIR/ca.key (the CA: keep ca.key on one trusted machine), and
    /// DIR/NAME.pem with DIR/NAME.key per name (keys mode 0600). Run again on the same DIR
    /// to add hosts: its CA signs them.
    Certs {
        /// The folder to write into (made if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// A host's certificate: NAME is its common name (what --allow-peer names), HOSTs
        /// the DNS names or IP addresses others reach it by (subject alternative names,
        /// which TLS checks when connecting), e.g. `loop=192.168.1.10,arm-pc`. Repeatable.
        #[arg(long = "name", value_name = "NAME[=HOST,...]", required = true)]
        names: Vec<hrrtc_bridge::certs::CertName>,
        /// Replace a host's existing certificate and key.
        #[arg(long)]
        force: bool,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum SideArg {
    Loop,
    Planner,
}

/// The bridge's `oom_score_adj`: the kernel's OOM killer takes it after the planner (500)
/// and before the other processes of the host (0) and the loop (-900). A dead bridge costs
/// what a cut link does (the loop fades the guidance out; restarted, it reconnects), but it
/// may carry several planners' guidance, and it holds little memory to free.
const OOM_SCORE_ADJ: i32 = 300;

fn main() -> std::process::ExitCode {
    ipc_types::startup::init_logging_with("info,zenoh=warn", zenoh_session::refusal_counter());
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("hrrtc-bridge: error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

fn run() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let side = match (cli.command, cli.side) {
        (Some(Command::Certs { out, names, force }), _) => return certs(&out, &names, force),
        (None, Some(SideArg::Loop)) => Side::Loop,
        (None, Some(SideArg::Planner)) => Side::Planner,
        (None, None) => anyhow::bail!("give --side loop or --side planner"),
    };
    let oom = ipc_types::startup::raise_oom_score_adj(OOM_SCORE_ADJ);
    tracing::info!("oom_score_adj {oom}");
    if cli.listen.is_empty() && cli.connect.is_empty() && cli.security.zenoh_config.is_none() {
        anyhow::bail!(
            "give --listen, --connect or both (or a --zenoh-config that names endpoints): the \
             other host's bridge must be reachable"
        );
    }
    for (name, v) in [
        ("--connect-timeout-s", cli.connect_timeout_s),
        ("--clock-offset-s", cli.clock_offset_s),
        ("--clock-drift-ppm", cli.clock_drift_ppm),
    ] {
        anyhow::ensure!(v.is_finite(), "{name} {v}: must be a finite number");
    }
    anyhow::ensure!(
        cli.connect_timeout_s >= 0.0,
        "--connect-timeout-s {}: must be ≥ 0",
        cli.connect_timeout_s
    );
    if let Some(d) = cli.duration_s {
        anyhow::ensure!(
            d.is_finite() && d > 0.0,
            "--duration-s {d}: must be positive"
        );
    }
    let config = BridgeConfig {
        listen: cli.listen,
        connect: cli.connect,
        connect_timeout_s: cli.connect_timeout_s,
        state_rate_hz: cli.state_rate_hz,
        state_poll_us: cli.state_poll_us,
        roadmap: !cli.no_roadmap,
        clock: HostClock::simulated(cli.clock_offset_s, cli.clock_drift_ppm),
        duration_s: cli.duration_s,
        key_namespace: cli.key_namespace,
        security: cli.security.security(""),
        allow_peers: cli.allow_peer,
        ..BridgeConfig::new(side, &cli.namespace)
    };
    let stop = ipc_types::startup::stop_on_signal("hrrtc-bridge")
        .context("installing the Ctrl-C / SIGTERM handler")?;
    let report = hrrtc_bridge::run(&config, stop)?;
    println!(
        "bridge ({} side) ran {:.1} s; {} peer(s){}; links: {}",
        side.name(),
        report.seconds,
        report.peers,
        report.min_rtt_us.map_or(String::new(), |r| format!(
            ", smallest round trip {r:.0} µs"
        )),
        config.security.describe()
    );
    println!("  kept out: {}", report.refused);
    println!("  oom_score_adj: {oom}");
    for (name, k) in &report.kinds {
        if k.sent + k.received > 0 {
            println!(
                "  {name}: sent {}, received {}, delivered {}, rejected {}, dropped {}, from \
                 unanswered peers {}",
                k.sent, k.received, k.delivered, k.rejected, k.dropped, k.unverified
            );
        }
    }
    Ok(())
}

/// `hrrtc-bridge certs`: writes the lab's files and says what to copy where.
fn certs(
    out: &std::path::Path,
    names: &[hrrtc_bridge::certs::CertName],
    force: bool,
) -> anyhow::Result<()> {
    let written = hrrtc_bridge::certs::write_lab_certs(out, names, force)?;
    println!(
        "{} the lab's CA {}",
        if written.new_ca {
            "made"
        } else {
            "signed with"
        },
        written.ca_cert.display()
    );
    for f in &written.files {
        println!("  wrote {}", f.display());
    }
    println!(
        "copy ca.pem and a host's NAME.pem and NAME.key to that host only; keep ca.key off \
         the hosts (it signs new certificates)"
    );
    Ok(())
}
